// The initializer's analytic tangent-plane bearing cost
// (src/initializer/bearing_residual.h TangentBearingCost) against its
// AutoDiff reference: the same residual and the same ambient Jacobians
// (quaternion x, y, z, w, then the position; the point), for cameras in any
// direction, points beyond 90 degrees, and quaternions off the unit sphere
// by rounding-size amounts as Ceres' manifold leaves them.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "../../src/initializer/bearing_residual.h"
#include "mcvo/geometry/so3.h"

namespace mcvo {
namespace {

using initializer_internal::PoseBlock;
using initializer_internal::TangentBearingCost;
using initializer_internal::TangentBearingResidual;
using initializer_internal::ToPoseBlock;
using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

Eigen::Vector3d RandomUnit(std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector3d v(normal(*rng), normal(*rng), normal(*rng));
  return v.normalized();
}

Eigen::Quaterniond RandomRotation(std::mt19937* rng) {
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  return So3Exp(angle(*rng) * RandomUnit(rng));
}

struct Evaluation {
  bool ok = false;
  Eigen::Vector2d residual = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::array<RowMajor, 2> jacobians{RowMajor(2, 7), RowMajor(2, 3)};
};

Evaluation Evaluate(const ceres::CostFunction& cost, const double* pose, const double* point) {
  Evaluation e;
  for (RowMajor& j : e.jacobians) j.setConstant(std::numeric_limits<double>::quiet_NaN());
  const double* params[2] = {pose, point};
  double* jacobians[2] = {e.jacobians[0].data(), e.jacobians[1].data()};
  e.ok = cost.Evaluate(params, e.residual.data(), jacobians);
  return e;
}

double RelativeDifference(const RowMajor& a, const RowMajor& reference) {
  const double scale = std::max(reference.cwiseAbs().maxCoeff(), 1e-300);
  return (a - reference).cwiseAbs().maxCoeff() / scale;
}

TEST(TangentBearingCost, MatchesTheAutoDiffReference) {
  std::mt19937 rng(71);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  double worst_truth = 0.0, worst_residual = 0.0, worst_jacobian = 0.0;
  for (int i = 0; i < 3000; ++i) {
    const Rigid3d world_from_body(RandomRotation(&rng), 20.0 * uniform(rng) * RandomUnit(&rng));
    // Half the cases carry a camera off the body (the rig BA), half are the
    // camera itself (the per-camera SfM).
    const Rigid3d cam_from_body =
        i % 2 == 0 ? Rigid3d() : Rigid3d(RandomRotation(&rng), 1.5 * uniform(rng) * RandomUnit(&rng));
    const Eigen::Vector3d in_cam = (0.3 + 60.0 * uniform(rng)) * RandomUnit(&rng);
    const Eigen::Vector3d point = world_from_body * (cam_from_body.Inverse() * in_cam);
    const double focal = 200.0 + 800.0 * uniform(rng);
    PoseBlock pose = ToPoseBlock(world_from_body);
    {
      const TangentBearingCost at_truth(in_cam.normalized(), focal, cam_from_body);
      const Evaluation e = Evaluate(at_truth, pose.data(), point.data());
      ASSERT_TRUE(e.ok);
      worst_truth = std::max(worst_truth, e.residual.norm());
    }
    // Off the truth: the observed bearing up to 0.5 rad away; on a quarter of
    // the cases the quaternion 1e-9 relative off the unit sphere.
    const Eigen::Vector3d axis = in_cam.normalized().cross(RandomUnit(&rng)).normalized();
    const Eigen::Vector3d observed = Eigen::AngleAxisd(0.5 * uniform(rng), axis) * in_cam.normalized();
    if (i % 4 == 1) pose.head<4>() *= 1.0 + 1e-9 * (2.0 * uniform(rng) - 1.0);
    const TangentBearingCost analytic(observed, focal, cam_from_body);
    const ceres::AutoDiffCostFunction<TangentBearingResidual, 2, 7, 3> autodiff(
        new TangentBearingResidual(observed, focal, cam_from_body));
    const Evaluation ea = Evaluate(analytic, pose.data(), point.data());
    const Evaluation ed = Evaluate(autodiff, pose.data(), point.data());
    ASSERT_TRUE(ea.ok && ed.ok);
    worst_residual = std::max(worst_residual, (ea.residual - ed.residual).norm() / std::max(ed.residual.norm(), 1e-3));
    for (size_t b = 0; b < ea.jacobians.size(); ++b) {
      ASSERT_TRUE(ea.jacobians[b].allFinite());
      worst_jacobian = std::max(worst_jacobian, RelativeDifference(ea.jacobians[b], ed.jacobians[b]));
    }
  }
  std::printf("tangent bearing cost: residual at truth %.3g px; analytic vs autodiff: residual %.3g, Jacobian %.3g\n",
              worst_truth, worst_residual, worst_jacobian);
  EXPECT_LT(worst_truth, 1e-9);
  EXPECT_LT(worst_residual, 1e-9);
  EXPECT_LT(worst_jacobian, 1e-8);
}

// A point at the camera centre has no bearing: both refuse to evaluate.
TEST(TangentBearingCost, RefusesAPointAtTheCameraCentre) {
  const Rigid3d world_from_body(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1.0, 2.0, 3.0));
  const PoseBlock pose = ToPoseBlock(world_from_body);
  const Eigen::Vector3d point = world_from_body.translation;
  const TangentBearingCost analytic(Eigen::Vector3d::UnitZ(), 500.0);
  const ceres::AutoDiffCostFunction<TangentBearingResidual, 2, 7, 3> autodiff(
      new TangentBearingResidual(Eigen::Vector3d::UnitZ(), 500.0));
  EXPECT_FALSE(Evaluate(analytic, pose.data(), point.data()).ok);
  EXPECT_FALSE(Evaluate(autodiff, pose.data(), point.data()).ok);
}

}  // namespace
}  // namespace mcvo
