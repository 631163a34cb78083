// See absolute_pose_refine.h.
#include "absolute_pose_refine.h"

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>

#include "bearing_residual.h"
#include "mcvo/util/error.h"

namespace mcvo::initializer_internal {
namespace {

// The bearing cost of one observation of a fixed point: the pose block only.
class FixedPointBearingCost final : public ceres::SizedCostFunction<2, 7> {
 public:
  FixedPointBearingCost(const Eigen::Vector3d& bearing, const Eigen::Vector3d& point, double focal)
      : cost_(bearing, focal), point_(point) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* params[2] = {parameters[0], point_.data()};
    double* blocks[2] = {jacobians != nullptr ? jacobians[0] : nullptr, nullptr};
    return cost_.Evaluate(params, residuals, jacobians != nullptr ? blocks : nullptr);
  }

 private:
  TangentBearingCost cost_;
  Eigen::Vector3d point_;
};

}  // namespace

Rigid3d RefineAbsolutePose(const opengv::bearingVectors_t& bearings, const opengv::points_t& points,
                           const std::vector<int>& rows, double focal, const Rigid3d& start,
                           int max_iterations) {
  MCVO_CHECK(bearings.size() == points.size());
  if (rows.empty()) return start;
  PoseBlock block = ToPoseBlock(start);
  ceres::Problem problem;
  for (const int i : rows) {
    MCVO_CHECK(i >= 0 && static_cast<size_t>(i) < points.size());
    problem.AddResidualBlock(
        new FixedPointBearingCost(bearings[static_cast<size_t>(i)], points[static_cast<size_t>(i)], focal),
        nullptr, block.data());
  }
  problem.SetManifold(
      block.data(),
      new ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>());
  ceres::Solver::Options options = DeterministicBaOptions(max_iterations);
  options.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return FromPoseBlock(block);
}

}  // namespace mcvo::initializer_internal
