// Properties of every camera model on every fixture camera: round trips over
// the whole valid field of view, Jacobians against finite differences and
// against autodiff, Jets through parameters and through Unproject, and no NaN
// at the singular points.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include "mcvo/camera/models.h"
#include "test_cameras.h"

namespace mcvo {
namespace {

using test::AngleBetween;
using test::Direction;
using test::DomainEdgeAngle;

class CameraModelTest : public ::testing::TestWithParam<Camera> {};

// Principal point and focal lengths in the parameter vector of each model.
struct Intrinsics {
  double fx, fy, cx, cy;
};
Intrinsics GetIntrinsics(const Camera& camera) {
  const std::vector<double>& p = camera.params;
  if (camera.model == CameraModelId::kMei) return {p[5], p[6], p[7], p[8]};
  return {p[0], p[1], p[2], p[3]};
}

// Normalised radius of a pixel and of the image of the domain edge along the
// same azimuth (the models are radially symmetric up to tangential terms).
void PixelAndEdgeRadius(const Camera& camera, const Eigen::Vector2d& pixel, double* pixel_radius,
                        double* edge_radius) {
  const Intrinsics in = GetIntrinsics(camera);
  const double mx = (pixel.x() - in.cx) / in.fx;
  const double my = (pixel.y() - in.cy) / in.fy;
  const double phi = std::atan2(my, mx);
  *pixel_radius = std::hypot(mx, my);
  const auto edge_pixel = camera.Project(Direction(DomainEdgeAngle(camera, phi) * (1.0 - 1e-9), phi));
  EXPECT_TRUE(edge_pixel.has_value());
  *edge_radius = edge_pixel ? std::hypot((edge_pixel->x() - in.cx) / in.fx, (edge_pixel->y() - in.cy) / in.fy)
                            : std::numeric_limits<double>::infinity();
}

// Random points in the domain, at most `edge_fraction` of the edge angle off
// axis, at depths 0.5 .. 20.
std::vector<Eigen::Vector3d> RandomDomainPoints(const Camera& camera, int count, double edge_fraction,
                                                uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Eigen::Vector3d> points;
  while (static_cast<int>(points.size()) < count) {
    const double phi = 2.0 * M_PI * unit(rng);
    const double theta = edge_fraction * DomainEdgeAngle(camera, phi) * std::sqrt(unit(rng));
    points.push_back((0.5 + 19.5 * unit(rng)) * Direction(theta, phi));
  }
  return points;
}

TEST_P(CameraModelTest, BearingRoundTripOverFieldOfView) {
  const Camera& camera = GetParam();
  double worst_angle = 0.0, worst_norm = 0.0, max_edge = 0.0;
  for (int ip = 0; ip < 72; ++ip) {
    const double phi = 2.0 * M_PI * ip / 72 + 0.01;
    const double edge = DomainEdgeAngle(camera, phi);
    max_edge = std::max(max_edge, edge);
    for (int it = 0; it <= 200; ++it) {
      const double theta = 0.999 * edge * it / 200;
      const Eigen::Vector3d bearing = Direction(theta, phi);
      const auto pixel = camera.Project((0.3 + it * 0.1) * bearing);
      ASSERT_TRUE(pixel) << "theta " << theta << " phi " << phi;
      const auto back = camera.Unproject(*pixel);
      ASSERT_TRUE(back) << "theta " << theta << " phi " << phi << " pixel " << pixel->transpose();
      worst_norm = std::max(worst_norm, std::abs(back->norm() - 1.0));
      worst_angle = std::max(worst_angle, AngleBetween(*back, bearing));
    }
  }
  std::printf("[ %s ] max edge angle %.4f deg, worst bearing error %.3g rad, worst |norm - 1| %.3g\n",
              camera.name.c_str(), max_edge * 180.0 / M_PI, worst_angle, worst_norm);
  EXPECT_LT(worst_angle, 1e-9);
  EXPECT_LT(worst_norm, 1e-14);
}

TEST_P(CameraModelTest, PixelRoundTripOverImage) {
  const Camera& camera = GetParam();
  int failures = 0;
  double worst = 0.0;
  constexpr int kSteps = 60;
  for (int iy = 0; iy <= kSteps; ++iy) {
    for (int ix = 0; ix <= kSteps; ++ix) {
      const Eigen::Vector2d pixel(-0.5 + camera.width * ix / double(kSteps),
                                  -0.5 + camera.height * iy / double(kSteps));
      const auto bearing = camera.Unproject(pixel);
      if (!bearing) {
        // Only pixels outside the image of the domain may fail.
        double pixel_radius, edge_radius;
        PixelAndEdgeRadius(camera, pixel, &pixel_radius, &edge_radius);
        EXPECT_GT(pixel_radius, (1.0 - 1e-3) * edge_radius) << pixel.transpose();
        ++failures;
        continue;
      }
      const auto reprojected = camera.Project(2.5 * *bearing);
      ASSERT_TRUE(reprojected) << pixel.transpose();
      worst = std::max(worst, (*reprojected - pixel).norm());
    }
  }
  std::printf("[ %s ] %d of %d grid pixels outside the image of the domain, worst round trip %.3g px\n",
              camera.name.c_str(), failures, (kSteps + 1) * (kSteps + 1), worst);
  EXPECT_LT(worst, 1e-8);
}

TEST_P(CameraModelTest, AnalyticJacobianMatchesFiniteDifferencesAndAutodiff) {
  const Camera& camera = GetParam();
  double worst_fd = 0.0, worst_autodiff = 0.0;
  for (const Eigen::Vector3d& point : RandomDomainPoints(camera, 300, 0.98, 7)) {
    Eigen::Matrix<double, 2, 3> jacobian;
    const auto pixel = camera.Project(point, &jacobian);
    ASSERT_TRUE(pixel);
    EXPECT_LT((*pixel - *camera.Project(point)).norm(), 1e-12);
    Eigen::Matrix<double, 2, 3> numeric;
    const double h = 1e-6 * point.norm();
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d step = h * Eigen::Vector3d::Unit(c);
      const auto plus = camera.Project(point + step);
      const auto minus = camera.Project(point - step);
      ASSERT_TRUE(plus && minus);
      numeric.col(c) = (*plus - *minus) / (2.0 * h);
    }
    worst_fd = std::max(worst_fd, (jacobian - numeric).norm() / jacobian.norm());
    // Autodiff through the templated Project with Jets on the point.
    VisitCameraModel(camera.model, [&](auto m) {
      using Jet = ceres::Jet<double, 3>;
      using Model = decltype(m);
      Jet params[Model::kNumParams], point_jet[3], pixel_jet[2];
      for (int i = 0; i < Model::kNumParams; ++i) params[i] = Jet(camera.params[i]);
      for (int i = 0; i < 3; ++i) point_jet[i] = Jet(point[i], i);
      ASSERT_TRUE(Model::Project(params, point_jet, pixel_jet));
      for (int r = 0; r < 2; ++r) {
        EXPECT_NEAR(pixel_jet[r].a, (*pixel)[r], 1e-12 * std::max(1.0, std::abs((*pixel)[r])));
        worst_autodiff =
            std::max(worst_autodiff, (jacobian.row(r).transpose() - pixel_jet[r].v).norm() / jacobian.norm());
      }
    });
  }
  std::printf("[ %s ] Jacobian relative error: finite differences %.3g, autodiff %.3g\n", camera.name.c_str(),
              worst_fd, worst_autodiff);
  EXPECT_LT(worst_fd, 1e-6);
  EXPECT_LT(worst_autodiff, 1e-12);
}

// Central difference of f at 0 with Richardson extrapolation (truncation
// error O(h^4)): (4 D(h/2) - D(h)) / 3.
template <typename Func>
Eigen::VectorXd RichardsonDerivative(const Func& f, double h) {
  const Eigen::VectorXd d_h = (f(h) - f(-h)) / (2.0 * h);
  const Eigen::VectorXd d_half = (f(0.5 * h) - f(-0.5 * h)) / h;
  return (4.0 * d_half - d_h) / 3.0;
}

// Relative error of one derivative column. The floor is the size of a
// finite-difference error from rounding the function values, 1e-16 |f| / h,
// times 1e7: columns that are (nearly) zero at this point, e.g. d pixel / d k3
// near the axis, are then compared in absolute terms.
double ColumnError(const Eigen::VectorXd& jet, const Eigen::VectorXd& numeric, double value_norm, double h) {
  return (jet - numeric).norm() / (numeric.norm() + 1e-9 * (1.0 + value_norm) / h);
}

// Jets on the parameters (intrinsics refinement) and through Unproject (the
// implicit-function derivative of the Newton inverses).
TEST_P(CameraModelTest, JetDerivativesOfParamsAndUnprojectMatchFiniteDifferences) {
  const Camera& camera = GetParam();
  double worst_params = 0.0, worst_unproject = 0.0;
  VisitCameraModel(camera.model, [&](auto m) {
    using Model = decltype(m);
    constexpr int kN = Model::kNumParams;
    using Jet = ceres::Jet<double, kN + 2>;
    for (const Eigen::Vector3d& point : RandomDomainPoints(camera, 100, 0.95, 11)) {
      Jet params[kN], point_jet[3], pixel_jet[2], bearing_jet[3];
      for (int i = 0; i < kN; ++i) params[i] = Jet(camera.params[i], i);
      for (int i = 0; i < 3; ++i) point_jet[i] = Jet(point[i]);
      ASSERT_TRUE(Model::Project(params, point_jet, pixel_jet));
      const Eigen::Vector2d pixel(pixel_jet[0].a, pixel_jet[1].a);
      Jet pixel_in[2] = {Jet(pixel.x(), kN), Jet(pixel.y(), kN + 1)};
      ASSERT_TRUE(Model::Unproject(params, pixel_in, bearing_jet));
      // Variable i: parameter i (i < kN) or pixel coordinate i - kN.
      for (int i = 0; i < kN + 2; ++i) {
        // Steps: 1e-7 relative for parameters (theta(k4) is strongly curved at
        // 170 degrees for kb_tumvi), 1e-5 px for pixels.
        const double h = i < kN ? 1e-7 * std::max(1.0, std::abs(camera.params[i])) : 1e-5;
        auto perturbed = [&](double delta, std::vector<double>* params_out, Eigen::Vector2d* pixel_out) {
          *params_out = camera.params;
          *pixel_out = pixel;
          (i < kN ? (*params_out)[i] : (*pixel_out)[i - kN]) += delta;
        };
        if (i < kN) {
          const Eigen::VectorXd numeric = RichardsonDerivative(
              [&](double delta) {
                std::vector<double> p;
                Eigen::Vector2d unused;
                perturbed(delta, &p, &unused);
                Eigen::Vector2d out = Eigen::Vector2d::Zero();
                EXPECT_TRUE(Model::Project(p.data(), point.data(), out.data()));
                return Eigen::VectorXd(out);
              },
              h);
          worst_params = std::max(
              worst_params,
              ColumnError(Eigen::Vector2d(pixel_jet[0].v[i], pixel_jet[1].v[i]), numeric, pixel.norm(), h));
        }
        const Eigen::VectorXd numeric = RichardsonDerivative(
            [&](double delta) {
              std::vector<double> p;
              Eigen::Vector2d q;
              perturbed(delta, &p, &q);
              Eigen::Vector3d out = Eigen::Vector3d::Zero();
              EXPECT_TRUE(Model::Unproject(p.data(), q.data(), out.data()));
              return Eigen::VectorXd(out);
            },
            h);
        worst_unproject = std::max(
            worst_unproject,
            ColumnError(Eigen::Vector3d(bearing_jet[0].v[i], bearing_jet[1].v[i], bearing_jet[2].v[i]),
                        numeric, 1.0, h));
      }
    }
  });
  std::printf(
      "[ %s ] Jet vs finite differences (relative): d pixel/d params %.3g, d bearing/d (params, pixel) "
      "%.3g\n",
      camera.name.c_str(), worst_params, worst_unproject);
  EXPECT_LT(worst_params, 1e-5);
  EXPECT_LT(worst_unproject, 1e-5);
}

TEST_P(CameraModelTest, SingularPointsGiveFalseOrFiniteValues) {
  const Camera& camera = GetParam();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& bad :
       {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, -2), Eigen::Vector3d(nan, 0, 1),
        Eigen::Vector3d(0, inf, 1), Eigen::Vector3d(1e-300, 0, -1)}) {
    EXPECT_FALSE(camera.Project(bad)) << bad.transpose();
  }
  EXPECT_FALSE(camera.Unproject(Eigen::Vector2d(nan, 10.0)));
  EXPECT_FALSE(camera.Unproject(Eigen::Vector2d(10.0, inf)));
  // On the optical axis: the principal point, finite Jacobians, also as Jets.
  const Intrinsics in = GetIntrinsics(camera);
  for (const Eigen::Vector3d& axis : {Eigen::Vector3d(0, 0, 2), Eigen::Vector3d(1e-200, -1e-200, 2)}) {
    Eigen::Matrix<double, 2, 3> jacobian;
    const auto pixel = camera.Project(axis, &jacobian);
    ASSERT_TRUE(pixel);
    EXPECT_NEAR(pixel->x(), in.cx, 1e-9);
    EXPECT_NEAR(pixel->y(), in.cy, 1e-9);
    EXPECT_TRUE(jacobian.allFinite());
    VisitCameraModel(camera.model, [&](auto m) {
      using Model = decltype(m);
      using Jet = ceres::Jet<double, Model::kNumParams + 3>;
      Jet params[Model::kNumParams], point[3], pixel_jet[2], bearing[3];
      for (int i = 0; i < Model::kNumParams; ++i) params[i] = Jet(camera.params[i], i);
      for (int i = 0; i < 3; ++i) point[i] = Jet(axis[i], Model::kNumParams + i);
      ASSERT_TRUE(Model::Project(params, point, pixel_jet));
      for (int r = 0; r < 2; ++r) {
        EXPECT_TRUE(pixel_jet[r].v.allFinite());
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(pixel_jet[r].v[Model::kNumParams + c], jacobian(r, c), 1e-9);
      }
      ASSERT_TRUE(Model::Unproject(params, pixel_jet, bearing));
      for (int r = 0; r < 3; ++r) EXPECT_TRUE(bearing[r].v.allFinite() && std::isfinite(bearing[r].a));
      EXPECT_NEAR(bearing[2].a, 1.0, 1e-15);
    });
  }
  // Just inside and just outside the edge of the domain.
  for (double phi : {0.3, 2.0, 4.0}) {
    const double edge = DomainEdgeAngle(camera, phi);
    Eigen::Matrix<double, 2, 3> jacobian;
    const auto pixel = camera.Project(Direction(edge * (1.0 - 1e-12), phi), &jacobian);
    ASSERT_TRUE(pixel);
    EXPECT_TRUE(pixel->allFinite() && jacobian.allFinite());
    EXPECT_FALSE(camera.Project(Direction(std::min(M_PI, edge * (1.0 + 1e-9)), phi)));
    const auto bearing = camera.Unproject(*pixel);
    if (bearing) {
      EXPECT_TRUE(bearing->allFinite());
    }
  }
}

TEST_P(CameraModelTest, FarOutsidePixelRejectedExactlyWhenTheDomainImageIsBounded) {
  const Camera& camera = GetParam();
  const Intrinsics in = GetIntrinsics(camera);
  for (double phi : {0.0, 1.0, 2.5, 4.0}) {
    const Eigen::Vector2d far(in.cx + 1e5 * std::cos(phi), in.cy + 1e5 * std::sin(phi));
    double pixel_radius, edge_radius;
    PixelAndEdgeRadius(camera, far, &pixel_radius, &edge_radius);
    const auto bearing = camera.Unproject(far);
    EXPECT_EQ(bearing.has_value(), pixel_radius < edge_radius) << phi;
    if (bearing) {
      EXPECT_LT((*camera.Project(*bearing) - far).norm(), 1e-6);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllModels, CameraModelTest, ::testing::ValuesIn(test::AllTestCameras()),
                         [](const ::testing::TestParamInfo<Camera>& param_info) {
                           return param_info.param.name;
                         });

}  // namespace
}  // namespace mcvo
