// Relative pose error and scale drift over sub-trajectories (docs/eval.md,
// "RPE" and "Scale drift").
//
// Inputs are the matched poses in pair order: gt[k] <-> est[k]. For a
// nominal length d and every start k = i, the end j > i is the pose whose
// travelled gt distance D(i, j) = dist[j] - dist[i] is closest to d (ties:
// smallest j); the segment counts when |D(i, j) - d| <= tolerance * d. Its
// error is
//   E = (gt_i^-1 gt_j)^-1 (est_i^-1 est_j)
// with est already aligned (so scaled by s when the alignment is sim3).
// translation |t(E)| m and 100 |t(E)| / d %; rotation angle(E) deg and
// angle(E) / d deg/m: the denominators are the nominal d, as the KITTI
// odometry benchmark does.
//
// Scale drift: per segment, ratio = est travelled distance / gt travelled
// distance between i and j, both summed along the matched poses, the
// estimate UNSCALED (est_raw_positions), whatever the alignment. The same
// ratio multiplied by the Sim3 scale removes the global scale and leaves the
// drift.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "mcvo/eval/evaluate.h"
#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

// Per-segment values of one length (exposed for tests).
struct RpeSegment {
  size_t start = 0;  // k of the start pose
  size_t end = 0;    // k of the end pose
  double gt_distance_m = 0.0;
  double translation_m = 0.0;
  double rotation_deg = 0.0;
  double scale_ratio = 0.0;  // est raw / gt travelled distance
};

// Segments of nominal length length_m. gt_poses, est_aligned_poses and
// est_raw_positions have the same size.
std::vector<RpeSegment> ComputeRpeSegments(const std::vector<Rigid3d>& gt_poses,
                                           const std::vector<Rigid3d>& est_aligned_poses,
                                           const std::vector<Eigen::Vector3d>& est_raw_positions,
                                           double length_m, double tolerance);

// All lengths, their stats and the average. `lengths_m` and (optionally)
// the percent each came from; `sim3_scale` normalises the scale ratio when set.
RpeResult ComputeRpe(const std::vector<Rigid3d>& gt_poses, const std::vector<Rigid3d>& est_aligned_poses,
                     const std::vector<Eigen::Vector3d>& est_raw_positions,
                     const std::vector<double>& lengths_m,
                     const std::vector<std::optional<double>>& length_percents, double tolerance,
                     std::optional<double> sim3_scale);

// The error between consecutive matched poses (EvalResult's rpe.step;
// RpeStepResult); gt_poses and est_aligned_poses have the same size.
RpeStepResult ComputeRpeStep(const std::vector<Rigid3d>& gt_poses, const std::vector<Rigid3d>& est_aligned_poses);

// Local scale over windows of `window` poses (0, window, 2 window, ...):
// gt_positions and est_aligned_positions have the same size.
LocalScaleResult ComputeLocalScale(const std::vector<Eigen::Vector3d>& gt_positions,
                                   const std::vector<Eigen::Vector3d>& est_aligned_positions, int window,
                                   double min_distance_m);

}  // namespace mcvo
