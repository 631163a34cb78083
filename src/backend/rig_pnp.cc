#include "mcvo/backend/rig_pnp.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include <ceres/ceres.h>
#include <opengv/absolute_pose/NoncentralAbsoluteAdapter.hpp>
#include <opengv/sac/Ransac.hpp>
#include <opengv/sac_problems/absolute_pose/AbsolutePoseSacProblem.hpp>

#include "mcvo/backend/factors.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

using SacProblem = opengv::sac_problems::absolute_pose::AbsolutePoseSacProblem;

// Tangent-plane bearing residual of a known world point, in pixels at the
// focal f (factors.h): r = f B(b) (u - b), u the unit direction of
// cam_from_rig * rig_from_world * point_in_world, rig_from_world the inverse
// of the pose block world_from_rig {t, q}.
struct PnpResidual {
  Eigen::Vector3d bearing;
  Eigen::Matrix<double, 2, 3> basis;
  Eigen::Vector3d point_in_world;
  Eigen::Quaterniond cam_from_rig_rotation;
  Eigen::Vector3d cam_from_rig_translation;
  double focal = 1.0;

  template <typename T>
  bool operator()(const T* world_from_rig, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(world_from_rig + 3);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(world_from_rig);
    const Eigen::Matrix<T, 3, 1> point_in_rig = q.conjugate() * (point_in_world.cast<T>() - t);
    const Eigen::Matrix<T, 3, 1> point_in_cam =
        cam_from_rig_rotation.cast<T>() * point_in_rig + cam_from_rig_translation.cast<T>();
    return TangentResidual(point_in_cam, bearing, basis, focal, residuals);
  }
};

// 1 - cos(angle) between the observed bearing and the predicted direction
// (OpenGV's score); 2 (the largest) when the point sits on the camera centre.
double AngularScore(const Rigid3d& cam_from_world, const RigPnpCorrespondence& c) {
  const Eigen::Vector3d p = cam_from_world * c.point_in_world;
  const double norm = p.norm();
  if (!(norm > 0.0)) return 2.0;
  return 1.0 - p.dot(c.bearing) / norm;
}

// focal * tan(angle), from the cross and dot products (accurate for small
// angles, unlike 1 - cos); infinite at or beyond 90 deg.
double ErrorPixels(const Rigid3d& cam_from_world, const RigPnpCorrespondence& c, double focal) {
  const Eigen::Vector3d p = cam_from_world * c.point_in_world;
  const double dot = p.dot(c.bearing);
  if (!(dot > 0.0)) return std::numeric_limits<double>::infinity();
  return focal * p.cross(c.bearing).norm() / dot;
}

struct Classification {
  std::vector<bool> inliers;
  int num_inliers = 0;
  double msac = 0.0;  // sum of min(score, threshold) over usable correspondences
};

Classification Classify(const Rigid3d& world_from_rig, const std::vector<Rigid3d>& cam_from_rig,
                        const std::vector<RigPnpCorrespondence>& correspondences,
                        const std::vector<int>& usable, double threshold) {
  Classification out;
  out.inliers.assign(correspondences.size(), false);
  const Rigid3d rig_from_world = world_from_rig.Inverse();
  std::vector<Rigid3d> cam_from_world(cam_from_rig.size());
  for (size_t c = 0; c < cam_from_rig.size(); ++c) cam_from_world[c] = cam_from_rig[c] * rig_from_world;
  for (int k : usable) {
    const RigPnpCorrespondence& c = correspondences[static_cast<size_t>(k)];
    const double score = AngularScore(cam_from_world[static_cast<size_t>(c.camera)], c);
    const bool inlier = score < threshold;
    out.inliers[static_cast<size_t>(k)] = inlier;
    out.num_inliers += inlier ? 1 : 0;
    out.msac += std::min(score, threshold);
  }
  return out;
}

// Ceres refinement of world_from_rig on the inliers.
Rigid3d Refine(const Rigid3d& world_from_rig, const std::vector<Rigid3d>& cam_from_rig,
               const std::vector<RigPnpCorrespondence>& correspondences, const std::vector<bool>& inliers,
               const RigPnpOptions& options) {
  double pose[kPoseParamSize];
  PoseToParams(world_from_rig, pose);
  ceres::Problem problem;
  for (size_t k = 0; k < correspondences.size(); ++k) {
    if (!inliers[k]) continue;
    const RigPnpCorrespondence& c = correspondences[k];
    const Rigid3d& extrinsic = cam_from_rig[static_cast<size_t>(c.camera)];
    auto* functor = new PnpResidual{c.bearing,          TangentBasis(c.bearing), c.point_in_world,
                                    extrinsic.rotation, extrinsic.translation,   options.focal_px};
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PnpResidual, 2, kPoseParamSize>(functor),
                             new ceres::HuberLoss(options.threshold_px), pose);
  }
  if (problem.NumResidualBlocks() == 0) return world_from_rig;
  problem.SetManifold(pose, NewPoseManifold());
  ceres::Solver::Options solver_options;
  solver_options.max_num_iterations = options.max_refine_iterations;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  Rigid3d refined = PoseFromParams(pose);
  if (!refined.translation.allFinite() || !refined.rotation.coeffs().allFinite()) return world_from_rig;
  return refined;
}

}  // namespace

int MinInlierIterations(int min_inliers, int num_correspondences, int sample_size, double confidence) {
  if (num_correspondences <= 0 || min_inliers <= 0 || sample_size <= 0) return 1;
  const double w = std::min(1.0, static_cast<double>(min_inliers) / num_correspondences);
  const double miss = 1.0 - std::pow(w, sample_size);  // one sample is not all inliers
  if (!(miss > 0.0)) return 1;
  if (!(confidence > 0.0 && confidence < 1.0)) return std::numeric_limits<int>::max();
  const double k = std::ceil(std::log(1.0 - confidence) / std::log(miss));
  return k >= static_cast<double>(std::numeric_limits<int>::max()) ? std::numeric_limits<int>::max()
                                                                     : std::max(1, static_cast<int>(k));
}

RigPnpResult SolveRigPnp(const std::vector<Rigid3d>& cam_from_rig,
                         const std::vector<RigPnpCorrespondence>& correspondences,
                         const RigPnpOptions& options, const Rigid3d* prior) {
  MCVO_CHECK_MSG(!cam_from_rig.empty(), "rig PnP needs at least one camera");
  MCVO_CHECK_MSG(options.threshold_px > 0.0 && options.focal_px > 0.0, "threshold_px ", options.threshold_px,
                 " and focal_px ", options.focal_px, " must be > 0");
  MCVO_CHECK(options.max_iterations >= 1 && options.max_refine_iterations >= 0);
  const int num_cameras = static_cast<int>(cam_from_rig.size());

  RigPnpResult result;
  result.inliers.assign(correspondences.size(), false);
  result.inliers_per_camera.assign(cam_from_rig.size(), 0);
  if (prior != nullptr) result.world_from_rig = *prior;

  // Usable correspondences, with unit bearings.
  std::vector<RigPnpCorrespondence> normalized = correspondences;
  std::vector<int> usable;
  for (size_t k = 0; k < normalized.size(); ++k) {
    RigPnpCorrespondence& c = normalized[k];
    MCVO_CHECK_MSG(c.camera >= 0 && c.camera < num_cameras, "correspondence ", k, ": camera ", c.camera,
                   " is not one of the ", num_cameras, " rig cameras");
    const double norm = c.bearing.norm();
    if (!c.bearing.allFinite() || !c.point_in_world.allFinite() || !(norm > 0.0)) continue;
    c.bearing /= norm;
    usable.push_back(static_cast<int>(k));
  }
  constexpr int kSampleSize = 4;  // GP3P and a fourth point to choose among its solutions
  const int needed = std::max(options.min_inliers, kSampleSize);
  if (static_cast<int>(usable.size()) < needed) {
    result.reason = StrCat("too few correspondences: ", usable.size(), " usable of ", correspondences.size(),
                           ", need ", needed);
    return result;
  }

  // OpenGV: cameras are given as rig_from_cam (offset = camera centre in the
  // rig, rotation = rig_from_cam); the model is world_from_rig as [R | t].
  opengv::bearingVectors_t bearings;
  opengv::points_t points;
  std::vector<int> cam_of;
  for (const RigPnpCorrespondence& c : normalized) {
    bearings.push_back(c.bearing);
    points.push_back(c.point_in_world);
    cam_of.push_back(c.camera);
  }
  opengv::translations_t cam_offsets;
  opengv::rotations_t cam_rotations;
  for (const Rigid3d& extrinsic : cam_from_rig) {
    const Rigid3d rig_from_cam = extrinsic.Inverse();
    cam_offsets.push_back(rig_from_cam.translation);
    cam_rotations.push_back(rig_from_cam.RotationMatrix());
  }
  opengv::absolute_pose::NoncentralAbsoluteAdapter adapter(bearings, cam_of, points, cam_offsets,
                                                           cam_rotations);
  const double threshold = 1.0 - std::cos(std::atan(options.threshold_px / options.focal_px));
  const auto problem = std::make_shared<SacProblem>(adapter, SacProblem::GP3P, usable, /*randomSeed=*/false);
  opengv::sac::Ransac<SacProblem> ransac;
  ransac.sac_model_ = problem;
  ransac.threshold_ = threshold;
  ransac.max_iterations_ = options.max_iterations;
  if (options.min_inlier_confidence > 0.0) {
    ransac.max_iterations_ =
        std::min(options.max_iterations, MinInlierIterations(options.min_inliers, static_cast<int>(usable.size()),
                                                             kSampleSize, options.min_inlier_confidence));
  }
  ransac.probability_ = 0.99;

  bool found = false;
  Rigid3d hypothesis;
  Classification best;
  if (ransac.computeModel(0) && ransac.model_coefficients_.allFinite()) {
    const opengv::transformation_t& m = ransac.model_coefficients_;
    hypothesis = Rigid3d(Eigen::Matrix3d(m.leftCols<3>()), Eigen::Vector3d(m.col(3)));
    best = Classify(hypothesis, cam_from_rig, normalized, usable, threshold);
    found = true;
  }
  if (prior != nullptr && prior->translation.allFinite() && prior->rotation.coeffs().allFinite()) {
    Classification prior_class = Classify(*prior, cam_from_rig, normalized, usable, threshold);
    if (!found || prior_class.num_inliers > best.num_inliers) {
      hypothesis = *prior;
      best = std::move(prior_class);
      found = true;
    }
  }
  if (!found || best.num_inliers < kSampleSize) {
    result.reason = StrCat("RANSAC found no pose with at least ", kSampleSize, " inliers among ",
                           usable.size(), " correspondences");
    return result;
  }

  // Refine on the inliers and re-classify, until the inlier set is stable
  // (at most three rounds); keep a refinement only if its MSAC score is not
  // worse, so a refinement that diverges never replaces a good hypothesis.
  Rigid3d world_from_rig = hypothesis;
  for (int round = 0; round < 3; ++round) {
    const Rigid3d refined = Refine(world_from_rig, cam_from_rig, normalized, best.inliers, options);
    Classification refined_class = Classify(refined, cam_from_rig, normalized, usable, threshold);
    if (refined_class.msac > best.msac) break;
    const bool same = refined_class.inliers == best.inliers;
    world_from_rig = refined;
    best = std::move(refined_class);
    if (same) break;
  }

  result.world_from_rig = world_from_rig;
  result.inliers = best.inliers;
  result.num_inliers = best.num_inliers;
  const Rigid3d rig_from_world = world_from_rig.Inverse();
  double sum_sq = 0.0;
  for (size_t k = 0; k < normalized.size(); ++k) {
    if (!best.inliers[k]) continue;
    const RigPnpCorrespondence& c = normalized[k];
    ++result.inliers_per_camera[static_cast<size_t>(c.camera)];
    const double px =
        ErrorPixels(cam_from_rig[static_cast<size_t>(c.camera)] * rig_from_world, c, options.focal_px);
    sum_sq += px * px;
  }
  result.rms_error_px = best.num_inliers > 0 ? std::sqrt(sum_sq / best.num_inliers) : 0.0;
  result.ok = best.num_inliers >= options.min_inliers;
  if (!result.ok) {
    result.reason =
        StrCat("too few inliers: ", best.num_inliers, " of ", usable.size(), ", need ", options.min_inliers);
  }
  return result;
}

}  // namespace mcvo
