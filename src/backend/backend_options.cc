#include "mcvo/backend/backend_options.h"

#include "mcvo/util/option_checks.h"

namespace mcvo {

void BackendOptions::Check() const {
  CheckAtLeast("/backend/window_size", window_size, 2);
  CheckAtLeast("/backend/max_iterations", max_iterations, 1);
  CheckAtLeast("/backend/max_solver_time_s", max_solver_time_s, 0.0);
  CheckPositive("/backend/loss_scale", loss_scale);
  CheckPositive("/backend/reprojection_sigma_px", reprojection_sigma_px);
  CheckPositive("/backend/virtual_focal_px", virtual_focal_px);
  CheckPositive("/backend/init_depth_m", init_depth_m);
  CheckAtLeast("/backend/min_observations", min_observations, 2);
  CheckAtLeast("/backend/keyframe_parallax_px", keyframe_parallax_px, 0.0);
  CheckAtLeast("/backend/keyframe_min_tracked", keyframe_min_tracked, 0);
  CheckPositive("/backend/outlier_threshold_px", outlier_threshold_px);
  CheckInRange("/backend/cross_camera_min_angle_deg", cross_camera_min_angle_deg, 0.0, 90.0);
  CheckPositive("/backend/pnp_threshold_px", pnp_threshold_px);
  CheckAtLeast("/backend/min_pnp_inliers", min_pnp_inliers, 6);
  CheckAtLeast("/backend/scale_correction_period", scale_correction_period, 0);
  CheckAtLeast("/backend/scale_correction_min_change", scale_correction_min_change, 0.0);
  CheckAtLeast("/backend/scale_drift_per_100m", scale_drift_per_100m, 0.0);
  CheckPositive("/backend/scale_correction_max_sigma", scale_correction_max_sigma);
  CheckAtLeast("/backend/scale_correction_sigma_factor", scale_correction_sigma_factor, 1.0);
  CheckAtLeast("/backend/scale_correction_min_rotation_deg", scale_correction_min_rotation_deg, 0.0);
  CheckAtLeast("/backend/scale_correction_min_travel_m", scale_correction_min_travel_m, 0.0);
  CheckAtLeast("/backend/reverse_pass_overlap_frames", reverse_pass_overlap_frames, 10);
}

}  // namespace mcvo
