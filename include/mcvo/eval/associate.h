// Association of estimated poses with ground-truth poses (docs/eval.md,
// "Association").
//
// time:  candidate pairs are all (gt i, est j) with |t_gt(i) - t_est(j)| <=
//        max_dt (inclusive). They are taken greedily in order of increasing
//        |dt| (ties: smaller est index, then smaller gt index), skipping a
//        pair when either pose is already used: a one-to-one matching in
//        which every pose gets its nearest free partner; deterministic.
// index: pairs (gt i, est j) with equal frame index. A trajectory without
//        frame indices (has_frame_index false: TUM, EuRoC) uses its pose
//        order 0, 1, 2, ... instead. A frame index that appears twice in one
//        trajectory is an InputError.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mcvo/io/trajectory_io.h"

namespace mcvo {

enum class AssociationMode { kTime, kIndex };

// "time", "index".
std::optional<AssociationMode> AssociationModeFromName(std::string_view name);
std::string_view AssociationModeName(AssociationMode mode);

struct AssociationOptions {
  AssociationMode mode = AssociationMode::kTime;
  // Largest accepted |t_gt - t_est| in seconds for mode time. 0.01 s as
  // evo's default t_max_diff: half a frame period at 50 Hz, so a 20-30 Hz
  // estimate never reaches a neighbouring frame's ground truth.
  double max_dt_s = 0.01;

  // Throws UsageError naming the bad field.
  void Check() const;
  // max_dt_s rounded to integer nanoseconds.
  int64_t MaxDtNs() const;
};

struct PosePair {
  size_t gt_index = 0;   // into gt.poses
  size_t est_index = 0;  // into est.poses
};

struct Association {
  std::vector<PosePair> pairs;  // sorted by est_index
  size_t num_gt_unmatched = 0;
  size_t num_est_unmatched = 0;
  int64_t max_abs_dt_ns = 0;  // largest |t_gt - t_est| over the pairs (mode time; 0 otherwise)
};

// Throws InputError (naming gt_name / est_name) when mode is time and a
// trajectory has no time stamps, or mode is index and a frame index repeats.
// An empty result is not an error here (the evaluation reports it).
Association AssociatePoses(const Trajectory& gt, const Trajectory& est, const AssociationOptions& options,
                           const std::string& gt_name, const std::string& est_name);

}  // namespace mcvo
