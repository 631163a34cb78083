#include "mcvo/frontend/bearing_ransac.h"

#include <cmath>
#include <memory>

#include <Eigen/SVD>
#include <opengv/relative_pose/CentralRelativeAdapter.hpp>
#include <opengv/sac/Ransac.hpp>
#include <opengv/sac_problems/relative_pose/CentralRelativePoseSacProblem.hpp>
#include <opengv/sac_problems/relative_pose/RotationOnlySacProblem.hpp>

#include "mcvo/util/error.h"

namespace mcvo {
namespace {

// Runs one OpenGV RANSAC problem and returns its inlier flags (all false when
// no model was found). Scores that are not finite (degenerate triangulation)
// compare false against the threshold, so they count as outliers.
template <typename Problem>
std::vector<bool> RunRansac(const std::shared_ptr<Problem>& problem, size_t n,
                            const BearingRansacOptions& options) {
  opengv::sac::Ransac<Problem> ransac;
  ransac.sac_model_ = problem;
  ransac.threshold_ = options.threshold;
  ransac.max_iterations_ = options.max_iterations;
  ransac.probability_ = 0.99;
  std::vector<bool> inliers(n, false);
  if (!ransac.computeModel(0)) return inliers;
  // The hypothesis comes from a minimal, noisy sample: refine it on its
  // inliers (OpenGV: nonlinear least squares for the 5-point model, Arun for
  // the rotation) and re-select; keep the refinement only if it keeps more.
  std::vector<int> selected = ransac.inliers_;
  if (selected.size() > 5) {
    typename Problem::model_t refined;
    problem->optimizeModelCoefficients(selected, ransac.model_coefficients_, refined);
    std::vector<int> refined_inliers;
    if (refined.allFinite()) problem->selectWithinDistance(refined, options.threshold, refined_inliers);
    if (refined_inliers.size() > selected.size()) selected.swap(refined_inliers);
  }
  for (int index : selected) {
    if (index >= 0 && static_cast<size_t>(index) < n) inliers[static_cast<size_t>(index)] = true;
  }
  return inliers;
}

int Count(const std::vector<bool>& flags) {
  int count = 0;
  for (bool flag : flags) count += flag ? 1 : 0;
  return count;
}

}  // namespace

double BearingThresholdFromPixels(double threshold_px, double focal_px) {
  return 1.0 - std::cos(std::atan(threshold_px / focal_px));
}

std::vector<bool> RansacRelativePoseInliers(const std::vector<Eigen::Vector3d>& bearings_prev,
                                            const std::vector<Eigen::Vector3d>& bearings_cur,
                                            const BearingRansacOptions& options) {
  MCVO_CHECK(bearings_prev.size() == bearings_cur.size());
  const size_t n = bearings_prev.size();
  if (static_cast<int>(n) < options.min_correspondences) return std::vector<bool>(n, true);

  opengv::bearingVectors_t prev(bearings_prev.begin(), bearings_prev.end());
  opengv::bearingVectors_t cur(bearings_cur.begin(), bearings_cur.end());
  // OpenGV's view 1 is the previous frame, view 2 the current one.
  opengv::relative_pose::CentralRelativeAdapter adapter(prev, cur);

  using EssentialProblem = opengv::sac_problems::relative_pose::CentralRelativePoseSacProblem;
  using RotationProblem = opengv::sac_problems::relative_pose::RotationOnlySacProblem;
  const auto essential =
      std::make_shared<EssentialProblem>(adapter, EssentialProblem::STEWENIUS, /*randomSeed=*/false);
  std::vector<bool> inliers = RunRansac(essential, n, options);
  const auto rotation = std::make_shared<RotationProblem>(adapter, /*randomSeed=*/false);
  std::vector<bool> rotation_inliers = RunRansac(rotation, n, options);
  if (Count(rotation_inliers) > Count(inliers)) inliers.swap(rotation_inliers);
  return inliers;
}

std::vector<bool> RansacRelativePoseInliers(const std::vector<Eigen::Vector3d>& bearings_prev,
                                            const std::vector<Eigen::Vector3d>& bearings_cur,
                                            double threshold_angle_rad, int max_iterations) {
  BearingRansacOptions options;
  options.threshold = 1.0 - std::cos(threshold_angle_rad);
  options.max_iterations = max_iterations;
  return RansacRelativePoseInliers(bearings_prev, bearings_cur, options);
}

std::optional<Eigen::Matrix3d> FitBearingRotation(const std::vector<Eigen::Vector3d>& prev,
                                                  const std::vector<Eigen::Vector3d>& cur) {
  MCVO_CHECK_MSG(prev.size() == cur.size(), "FitBearingRotation: ", prev.size(), " vs ", cur.size(), " bearings");
  if (prev.size() < 3) return std::nullopt;
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < prev.size(); ++i) sum += cur[i] * prev[i].transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d& sigma = svd.singularValues();
  if (!(sigma(1) > 1e-9 * sigma(0))) return std::nullopt;
  Eigen::Vector3d d(1.0, 1.0, 1.0);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) d(2) = -1.0;
  const Eigen::Matrix3d rotation = svd.matrixU() * d.asDiagonal() * svd.matrixV().transpose();
  if (!rotation.allFinite()) return std::nullopt;
  return rotation;
}

}  // namespace mcvo
