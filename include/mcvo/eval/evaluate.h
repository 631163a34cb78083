// Trajectory evaluation: association, alignment, ATE, RPE, scale and
// start-end discrepancy. The definitions (and every choice the literature
// leaves open) are in docs/eval.md; the short form is next to each field.
//
//   EvalOptions options;                     // defaults: time, 0.01 s, se3, 10..50 %
//   options.align = AlignmentMode::kSim3;
//   EvalResult result = EvaluateTrajectory(gt, est, options, "gt.txt", "est.txt");
//   std::string json = EvalResultToJson(result);   // eval/report.h
//
// Conventions: every pose is world_from_body. The alignment is
// gt_world_from_est_world (a Sim3d, scale 1 unless sim3) estimated with
// Umeyama on the positions of the matched poses (geometry/umeyama.h).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mcvo/eval/associate.h"
#include "mcvo/eval/stats.h"
#include "mcvo/geometry/sim3d.h"
#include "mcvo/io/trajectory_io.h"

namespace mcvo {

enum class AlignmentMode {
  kNone,    // identity: the estimate is compared in its own world frame
  kSe3,     // rotation + translation (metric methods)
  kSim3,    // rotation + translation + scale (monocular)
  kPosYaw,  // rotation about world z + translation (visual-inertial)
};

// "none", "se3", "sim3", "posyaw".
std::optional<AlignmentMode> AlignmentModeFromName(std::string_view name);
std::string_view AlignmentModeName(AlignmentMode mode);
// Matched poses an alignment needs: 3 for se3/sim3, 2 for posyaw, 0 for none.
size_t MinPosesForAlignment(AlignmentMode mode);

struct EvalOptions {
  AssociationOptions association;
  // se3 by default: mcvo is a metric method, its scale is part of what is measured.
  AlignmentMode align = AlignmentMode::kSe3;
  // Align on the first N matched poses (in est order); 0 = all matched
  // poses. N larger than the number of matches uses all of them. The
  // scale report's Sim3 uses the same poses.
  int align_num_poses = 0;
  // RPE sub-trajectory lengths in metres. When empty, the lengths are
  // rpe_length_percents of the ground-truth path length (over the matched poses).
  std::vector<double> rpe_lengths_m;
  std::vector<double> rpe_length_percents = {10.0, 20.0, 30.0, 40.0, 50.0};
  // An RPE segment of nominal length d is accepted when its travelled
  // ground-truth distance is within rpe_length_tolerance * d of d.
  double rpe_length_tolerance = 0.2;
  // Local scale: consecutive, non-overlapping windows of this many matched
  // poses; a window counts when its ground-truth ends are at least
  // local_scale_min_distance_m apart (docs/eval.md, "Local scale").
  int local_scale_window = 50;
  double local_scale_min_distance_m = 1.0;

  // Throws UsageError naming the bad field.
  void Check() const;
};

// Error of one matched pose after alignment.
struct PoseError {
  size_t gt_index = 0;
  size_t est_index = 0;
  double translation_m = 0.0;  // |p_gt - (s R p_est + t)|
  double rotation_deg = 0.0;   // |Log((R_align R_est)^T R_gt)| in degrees
};

struct RpeLengthResult {
  double length_m = 0.0;                   // nominal length d
  std::optional<double> length_percent;    // d as % of the gt path, when lengths are given that way
  ErrorStats translation_m;                // |t(E)|
  ErrorStats translation_percent;          // 100 |t(E)| / d
  ErrorStats rotation_deg;                 // angle(E) in degrees
  ErrorStats rotation_deg_per_m;           // angle(E) / d
  ErrorStats scale_ratio;                  // est / gt travelled distance, est unscaled (1 = metric)
  ErrorStats scale_ratio_sim3_normalized;  // scale_ratio * sim3 scale (1 = no drift); count 0 without sim3
};

struct RpeAverage {
  size_t num_lengths = 0;  // lengths with at least one segment
  // Unweighted means over those lengths of the per-length mean values.
  double translation_m = 0.0;
  double translation_percent = 0.0;
  double rotation_deg = 0.0;
  double rotation_deg_per_m = 0.0;
};

// Between consecutive matched poses (k, k+1 in pair order: one frame apart
// when every frame is matched), whatever the lengths: the frame-to-frame
// error E = (T_gt,k^-1 T_gt,k+1)^-1 (T_est,k^-1 T_est,k+1) of the aligned
// estimate, the TUM benchmark's RPE with a delta of one frame. What a jump
// of the estimate between two frames costs, which the length-based RPE
// averages away. Computed with at least 2 matched poses.
struct RpeStepResult {
  ErrorStats translation_m;  // |t(E)|
  ErrorStats rotation_deg;   // angle(E)
};

struct RpeResult {
  RpeStepResult step;
  bool computed = false;
  std::string skipped_reason;  // when !computed
  std::vector<RpeLengthResult> lengths;
  RpeAverage average;
};

struct ScaleResult {
  bool available = false;
  std::string unavailable_reason;           // when !available
  size_t num_poses = 0;                     // poses the Sim3 was estimated on
  double sim3_scale = 1.0;                  // s of the Sim3 alignment est -> gt (gt = s R est + t)
  double est_scale_factor = 1.0;            // 1 / s: size of the estimate relative to the truth
  double scale_error_percent = 0.0;         // 100 |1/s - 1|
  double scale_error_signed_percent = 0.0;  // 100 (1/s - 1): > 0 estimate too large
};

// How far the scale wanders along the trajectory: per window of
// options.local_scale_window matched poses, ratio = |est_b - est_a| /
// |gt_b - gt_a| between the window's end poses, the estimate aligned (so
// metric for se3, the global scale removed for sim3).
struct LocalScaleResult {
  int window_poses = 0;
  size_t windows_skipped = 0;  // windows whose gt ends were closer than the minimum distance
  std::vector<double> ratios;  // one per counted window, in order
  ErrorStats ratio;            // over `ratios`
  // 100 max |ratio - 1| and 100 median |ratio - 1|; 0 when no window counts.
  double worst_deviation_percent = 0.0;
  double median_deviation_percent = 0.0;
};

struct StartEndResult {
  // Over all poses of each trajectory (not only the matched ones), in the
  // trajectory's own units (the estimate is not aligned or scaled).
  double est_distance_m = 0.0;  // |p_last - p_first|
  double est_path_length_m = 0.0;
  std::optional<double> est_percent;  // 100 distance / path length; none for a zero path
  double gt_distance_m = 0.0;
  double gt_path_length_m = 0.0;
  std::optional<double> gt_percent;
};

struct EvalResult {
  std::string gt_name;
  std::string est_name;
  EvalOptions options;
  size_t num_gt_poses = 0;
  size_t num_est_poses = 0;
  Association association;

  Sim3d gt_world_from_est_world;     // the alignment applied (identity for none)
  size_t num_alignment_poses = 0;    // poses it was estimated on (0 for none)
  bool alignment_collinear = false;  // positions collinear: rotation about the line unobservable

  double gt_matched_path_length_m = 0.0;  // along the matched gt poses, in pair order
  std::vector<PoseError> pose_errors;     // one per pair, in pair order
  ErrorStats ate_translation_m;
  ErrorStats ate_rotation_deg;
  RpeResult rpe;
  ScaleResult scale;
  LocalScaleResult local_scale;
  StartEndResult start_end;
  std::vector<std::string> notes;  // conditions worth a reader's attention

  // All estimated poses mapped by gt_world_from_est_world (time stamps and
  // frame indices kept).
  Trajectory est_aligned;
};

// Throws InputError naming the file (gt_name / est_name) on: an empty
// trajectory, a non-finite pose, no matched poses, fewer matched poses than
// the alignment needs, or an undetermined alignment (all positions equal;
// no horizontal extent for posyaw). Throws UsageError when options.Check()
// fails. A zero-length gt path skips RPE with a note instead.
EvalResult EvaluateTrajectory(const Trajectory& gt, const Trajectory& est, const EvalOptions& options,
                              const std::string& gt_name = "ground truth",
                              const std::string& est_name = "estimate");

// Sum of the distances between consecutive positions.
double PathLength(const std::vector<Eigen::Vector3d>& positions);

}  // namespace mcvo
