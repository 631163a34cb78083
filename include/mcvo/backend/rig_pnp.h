// Absolute pose of a multi-camera rig from 2D-3D correspondences in all of its
// cameras at once (a generalized, non-central camera): OpenGV's
// NoncentralAbsoluteAdapter with the GP3P minimal solver in RANSAC (fixed
// seed: deterministic), then a Ceres refinement of world_from_rig on the
// inliers (tangent-plane bearing residuals as in factors.h, in pixels at
// focal_px, Huber at threshold_px), and a re-classification of every
// correspondence with the refined pose. Used to track each new frame against
// the window's landmarks and to verify loop candidates.
//
// Inlier test (OpenGV's): 1 - cos(angle(bearing, predicted)) below
// 1 - cos(atan(threshold_px / focal_px)); any bearing direction is allowed
// (fisheye bearings beyond 90 deg). The error of a correspondence in pixels
// is focal_px * tan(angle).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

struct RigPnpCorrespondence {
  int camera = 0;                                      // rig camera that observed it
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();  // unit, camera frame
  Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();
};

struct RigPnpOptions {
  double threshold_px = 2.0;  // inlier angle as pixels at focal_px
  double focal_px = 460.0;
  int max_iterations = 300;        // RANSAC (stops earlier at 99 % confidence)
  int min_inliers = 12;            // fewer: ok = false (at least 4, GP3P's sample)
  // RANSAC also stops after the number of samples that finds, with this
  // confidence, an outlier-free sample of any pose with min_inliers inliers
  // (MinInlierIterations): a pose with fewer would be rejected anyway, so
  // further samples could only find what the caller refuses. 0: no such cap.
  double min_inlier_confidence = 0.9999;
  int max_refine_iterations = 20;  // Ceres iterations per refinement round
};

struct RigPnpResult {
  bool ok = false;
  std::string reason;
  Rigid3d world_from_rig;
  std::vector<bool> inliers;  // per correspondence
  int num_inliers = 0;
  std::vector<int> inliers_per_camera;  // size = number of rig cameras
  double rms_error_px = 0.0;            // inliers, after refinement, at focal_px
};

// Samples after which RANSAC has drawn, with probability >= confidence, at
// least one sample of sample_size correspondences that are all inliers of a
// pose with min_inliers inliers among num_correspondences:
// ceil(log(1 - confidence) / log(1 - w^sample_size)), w = min_inliers /
// num_correspondences; at least 1. (Loop verification needs 40 inliers:
// among 60 matches that is 42 samples at 0.9999, among 100 it is 356, not
// the 1000 of its cap.)
int MinInlierIterations(int min_inliers, int num_correspondences, int sample_size, double confidence);

// cam_from_rig: one extrinsic per rig camera; every correspondence's camera
// must index it (checked). Correspondences with a non-finite or zero bearing
// or point are never inliers. With a prior pose (prior != nullptr) RANSAC also
// scores the prior as a hypothesis, so a good prediction is never lost to an
// unlucky sample; the refined pose is kept when its truncated quadratic
// (MSAC) score over all correspondences is not worse than the hypothesis's.
// ok = false with a reason when there are fewer than max(min_inliers, 4)
// usable correspondences, RANSAC finds no model, or fewer than min_inliers
// inliers remain (world_from_rig and inliers are still filled then, for
// diagnostics, when a model was found).
RigPnpResult SolveRigPnp(const std::vector<Rigid3d>& cam_from_rig,
                         const std::vector<RigPnpCorrespondence>& correspondences,
                         const RigPnpOptions& options, const Rigid3d* prior = nullptr);

}  // namespace mcvo
