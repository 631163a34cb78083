#include "mcvo/geometry/so3.h"

#include <cmath>

namespace mcvo {
namespace {
// Below this angle the closed forms lose digits to cancellation; the series
// used instead are accurate to O(t^4) relative, far below double precision.
constexpr double kSmallAngle = 1e-4;
}  // namespace

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Quaterniond So3Exp(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  double w;
  double k;  // sin(theta / 2) / theta
  if (theta < kSmallAngle) {
    const double theta2 = theta * theta;
    w = 1.0 - theta2 / 8.0;
    k = 0.5 - theta2 / 48.0;
  } else {
    w = std::cos(0.5 * theta);
    k = std::sin(0.5 * theta) / theta;
  }
  Eigen::Quaterniond q(w, k * phi.x(), k * phi.y(), k * phi.z());
  return q.normalized();
}

Eigen::Vector3d So3Log(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  // q and -q are the same rotation; w >= 0 gives the angle in [0, pi].
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d v = q.vec();
  const double n = v.norm();
  const double w = q.w();
  // theta = 2 atan2(n, w); phi = theta * v / n.
  double k;
  if (n < kSmallAngle * 0.5) {
    // 2 atan(n / w) / n = (2 / w) (1 - n^2 / (3 w^2) + ...), w ~ 1 here.
    k = 2.0 / w * (1.0 - n * n / (3.0 * w * w));
  } else {
    k = 2.0 * std::atan2(n, w) / n;
  }
  return k * v;
}

Eigen::Vector3d So3Log(const Eigen::Matrix3d& rotation) {
  // Eigen's matrix -> quaternion conversion picks the largest diagonal pivot
  // (Shepperd), so it stays accurate near pi.
  return So3Log(Eigen::Quaterniond(rotation));
}

double RotationAngle(const Eigen::Quaterniond& q) {
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w()));
}

Eigen::Matrix3d So3LeftJacobian(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d hat = Hat(phi);
  const Eigen::Matrix3d hat2 = hat * hat;
  double a;  // (1 - cos t) / t^2
  double b;  // (t - sin t) / t^3
  if (theta < kSmallAngle) {
    const double theta2 = theta * theta;
    a = 0.5 - theta2 / 24.0;
    b = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    const double theta2 = theta * theta;
    a = (1.0 - std::cos(theta)) / theta2;
    b = (theta - std::sin(theta)) / (theta2 * theta);
  }
  return Eigen::Matrix3d::Identity() + a * hat + b * hat2;
}

Eigen::Matrix3d So3LeftJacobianInverse(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d hat = Hat(phi);
  const Eigen::Matrix3d hat2 = hat * hat;
  double c;  // 1 / t^2 - cot(t / 2) / (2 t)
  if (theta < kSmallAngle) {
    c = 1.0 / 12.0 + theta * theta / 720.0;
  } else {
    const double half = 0.5 * theta;
    c = 1.0 / (theta * theta) - std::cos(half) / (2.0 * theta * std::sin(half));
  }
  return Eigen::Matrix3d::Identity() - 0.5 * hat + c * hat2;
}

Eigen::Matrix<double, 3, 4> QuaternionRotateJacobian(const Eigen::Quaterniond& q, const Eigen::Vector3d& v) {
  const Eigen::Vector3d qv = q.vec();
  Eigen::Matrix<double, 3, 4> jacobian;
  jacobian.leftCols<3>() =
      2.0 * (-q.w() * Hat(v) + qv.dot(v) * Eigen::Matrix3d::Identity() + qv * v.transpose() - 2.0 * v * qv.transpose());
  jacobian.col(3) = 2.0 * qv.cross(v);
  return jacobian;
}

Eigen::Matrix<double, 3, 4> QuaternionInverseRotateJacobian(const Eigen::Quaterniond& q, const Eigen::Vector3d& v) {
  Eigen::Matrix<double, 3, 4> jacobian = QuaternionRotateJacobian(q.conjugate(), v);
  jacobian.leftCols<3>() = -jacobian.leftCols<3>();
  return jacobian;
}

}  // namespace mcvo
