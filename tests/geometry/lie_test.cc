#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "mcvo/geometry/se3.h"
#include "mcvo/geometry/so3.h"

namespace mcvo {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Matrix3d ExpMatrixSeries(const Eigen::Vector3d& phi) {
  // exp(hat(phi)) by its power series: an independent reference.
  Eigen::Matrix3d sum = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d term = Eigen::Matrix3d::Identity();
  for (int k = 1; k < 40; ++k) {
    term = term * Hat(phi) / static_cast<double>(k);
    sum += term;
  }
  return sum;
}

TEST(So3, HatIsCrossProduct) {
  const Eigen::Vector3d a(1.0, -2.0, 0.5);
  const Eigen::Vector3d b(0.3, 0.7, -1.1);
  EXPECT_LT((Hat(a) * b - a.cross(b)).norm(), 1e-15);
}

TEST(So3, ExpMatchesMatrixExponential) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-2.0, 2.0);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d phi(uni(rng), uni(rng), uni(rng));
    EXPECT_LT((So3Exp(phi).toRotationMatrix() - ExpMatrixSeries(phi)).norm(), 1e-12);
  }
}

TEST(So3, ExpLogRoundTripGeneric) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::uniform_real_distribution<double> angle(0.0, kPi - 1e-3);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d axis = Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).normalized();
    const Eigen::Vector3d phi = angle(rng) * axis;
    EXPECT_LT((So3Log(So3Exp(phi)) - phi).norm(), 1e-12) << phi.transpose();
  }
}

TEST(So3, ExpLogRoundTripNearZero) {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, -0.5, 0.8).normalized();
  for (double theta : {0.0, 1e-15, 1e-12, 1e-9, 1e-6, 5e-5, 9.99e-5, 1e-4, 1.01e-4, 1e-3}) {
    const Eigen::Vector3d phi = theta * axis;
    const Eigen::Vector3d back = So3Log(So3Exp(phi));
    // Relative accuracy holds at tiny angles as well.
    EXPECT_LE((back - phi).norm(), 1e-15 + 1e-13 * theta) << theta;
    EXPECT_NEAR(RotationAngle(So3Exp(phi)), theta, 1e-16 + 1e-13 * theta);
  }
}

TEST(So3, ExpLogRoundTripNearPi) {
  const Eigen::Vector3d axis = Eigen::Vector3d(-0.3, 0.4, 0.866).normalized();
  for (double eps : {1e-3, 1e-6, 1e-9, 1e-12}) {
    const Eigen::Vector3d phi = (kPi - eps) * axis;
    EXPECT_LT((So3Log(So3Exp(phi)) - phi).norm(), 1e-12) << eps;
    // Through the rotation matrix (the path a KITTI pose takes).
    EXPECT_LT((So3Log(So3Exp(phi).toRotationMatrix()) - phi).norm(), 1e-9) << eps;
    EXPECT_NEAR(RotationAngle(So3Exp(phi)), kPi - eps, 1e-12);
  }
  // Exactly pi: either sign of the axis is a valid logarithm.
  const Eigen::Vector3d log_pi = So3Log(So3Exp(kPi * axis));
  EXPECT_NEAR(log_pi.norm(), kPi, 1e-12);
  EXPECT_NEAR(std::abs(log_pi.normalized().dot(axis)), 1.0, 1e-12);
  // Just beyond pi wraps to the shortest rotation about the opposite axis.
  const Eigen::Vector3d beyond = So3Log(So3Exp((kPi + 1e-6) * axis));
  EXPECT_LT((beyond + (kPi - 1e-6) * axis).norm(), 1e-12);
}

TEST(So3, RotationAngleIgnoresSignAndNorm) {
  const Eigen::Quaterniond q = So3Exp(Eigen::Vector3d(0.0, 0.0, 0.7));
  Eigen::Quaterniond minus_q = q;
  minus_q.coeffs() = -q.coeffs();
  Eigen::Quaterniond scaled_q = q;
  scaled_q.coeffs() *= 1.0 + 1e-9;
  EXPECT_NEAR(RotationAngle(q), 0.7, 1e-15);
  EXPECT_NEAR(RotationAngle(minus_q), 0.7, 1e-15);
  EXPECT_NEAR(RotationAngle(scaled_q), 0.7, 1e-15);
  EXPECT_EQ(RotationAngle(Eigen::Quaterniond::Identity()), 0.0);
}

TEST(So3, LeftJacobianTimesInverseIsIdentity) {
  for (double theta : {0.0, 1e-8, 5e-5, 1e-3, 0.5, 2.0, 3.0, kPi}) {
    const Eigen::Vector3d phi = theta * Eigen::Vector3d(1.0, 2.0, -2.0).normalized();
    EXPECT_LT((So3LeftJacobian(phi) * So3LeftJacobianInverse(phi) - Eigen::Matrix3d::Identity()).norm(),
              1e-12)
        << theta;
  }
}

TEST(So3, LeftJacobianMatchesFiniteDifference) {
  // Exp(phi + d) ~= Exp(J d) Exp(phi)  =>  J d ~= Log(Exp(phi + d) Exp(phi)^-1).
  const Eigen::Vector3d phi(0.4, -1.2, 0.9);
  const Eigen::Matrix3d jac = So3LeftJacobian(phi);
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(k);
    const Eigen::Vector3d numeric = (So3Log(So3Exp(phi + d) * So3Exp(phi).conjugate()) -
                                     So3Log(So3Exp(phi - d) * So3Exp(phi).conjugate())) /
                                    (2.0 * h);
    EXPECT_LT((numeric - jac.col(k)).norm(), 1e-8);
  }
}

TEST(Se3, ExpLogRoundTrip) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (double theta : {0.0, 1e-10, 1e-5, 0.3, 1.5, 3.0, kPi - 1e-6}) {
    const Eigen::Vector3d axis = Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).normalized();
    Vector6d xi;
    xi << 5.0 * uni(rng), 5.0 * uni(rng), 5.0 * uni(rng), theta * axis;
    const Vector6d back = Se3Log(Se3Exp(xi));
    EXPECT_LT((back - xi).norm(), 1e-9) << theta;
  }
}

TEST(Se3, PureTranslationAndAgainstMatrixExponential) {
  Vector6d xi = Vector6d::Zero();
  xi.head<3>() = Eigen::Vector3d(1.0, 2.0, 3.0);
  const Rigid3d t = Se3Exp(xi);
  EXPECT_LT((t.translation - Eigen::Vector3d(1.0, 2.0, 3.0)).norm(), 1e-15);
  EXPECT_EQ(RotationAngle(t.rotation), 0.0);

  // exp of the 4x4 twist matrix [hat(phi) rho; 0 0] by its series.
  xi << 0.5, -1.0, 2.0, 0.3, -0.2, 1.1;
  Eigen::Matrix4d twist = Eigen::Matrix4d::Zero();
  twist.topLeftCorner<3, 3>() = Hat(xi.tail<3>());
  twist.topRightCorner<3, 1>() = xi.head<3>();
  Eigen::Matrix4d sum = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d term = Eigen::Matrix4d::Identity();
  for (int k = 1; k < 40; ++k) {
    term = term * twist / static_cast<double>(k);
    sum += term;
  }
  EXPECT_LT((Se3Exp(xi).ToMatrix4() - sum).norm(), 1e-12);
}

// The derivative of Eigen's q * v (and q^* * v) with respect to (x, y, z, w)
// against central differences of the product itself, for quaternions of any
// norm near 1 (the formula is differentiated as written, not as a rotation).
TEST(So3, QuaternionRotateJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0.0;
  for (int i = 0; i < 200; ++i) {
    Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
    q.coeffs() *= (1.0 + 0.1 * u(rng)) / q.coeffs().norm();
    const Eigen::Vector3d v(5.0 * u(rng), 5.0 * u(rng), 5.0 * u(rng));
    for (const bool inverse : {false, true}) {
      const Eigen::Matrix<double, 3, 4> analytic =
          inverse ? QuaternionInverseRotateJacobian(q, v) : QuaternionRotateJacobian(q, v);
      const auto rotate = [&](const Eigen::Quaterniond& p) -> Eigen::Vector3d {
        return inverse ? Eigen::Vector3d(p.conjugate() * v) : Eigen::Vector3d(p * v);
      };
      const double h = 1e-6;
      for (int k = 0; k < 4; ++k) {
        Eigen::Quaterniond plus = q, minus = q;
        plus.coeffs()[k] += h;
        minus.coeffs()[k] -= h;
        const Eigen::Vector3d numeric = (rotate(plus) - rotate(minus)) / (2.0 * h);
        worst = std::max(worst, (analytic.col(k) - numeric).norm() / std::max(1.0, numeric.norm()));
      }
    }
  }
  EXPECT_LT(worst, 1e-8);
}

}  // namespace
}  // namespace mcvo
