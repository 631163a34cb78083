// LoopClosureOptions::Check (loop_closer.h).
#include "mcvo/loop/loop_closer.h"
#include "mcvo/util/option_checks.h"

namespace mcvo {

void LoopClosureOptions::Check() const {
  CheckAtLeast("/loop/features_per_camera", features_per_camera, 1);
  CheckAtLeast("/loop/exclude_recent_keyframes", exclude_recent_keyframes, 0);
  CheckAtLeast("/loop/feature_max_megapixels", feature_max_megapixels, 0.0);
  CheckInRange("/loop/min_score", min_score, 0.0, 1.0);
  CheckAtLeast("/loop/min_normalized_score", min_normalized_score, 0.0);
  CheckAtLeast("/loop/max_candidates", max_candidates, 1);
  CheckInRange("/loop/match_ratio", match_ratio, 0.0, 1.0);
  CheckAtLeast("/loop/max_match_distance", max_match_distance, 1);
  CheckPositive("/loop/pnp_threshold_px", pnp_threshold_px);
  CheckAtLeast("/loop/pnp_max_iterations", pnp_max_iterations, 1);
  CheckAtLeast("/loop/min_inliers", min_inliers, 6);
  CheckAtLeast("/loop/min_camera_inliers", min_camera_inliers, 1);
  CheckInRange("/loop/min_camera_fraction", min_camera_fraction, 0.0, 1.0);
  CheckAtLeast("/loop/consistency_window", consistency_window, 0);
  CheckAtLeast("/loop/candidate_neighbours", candidate_neighbours, 0);
  CheckInRange("/loop/landmark_levels", landmark_levels, 1, 8);
  CheckAtLeast("/loop/max_correction_fraction", max_correction_fraction, 0.0);
  CheckAtLeast("/loop/max_correction_floor_m", max_correction_floor_m, 0.0);
  cross_camera.Check();
}

}  // namespace mcvo
