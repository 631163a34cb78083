#include <set>
#include <string>

#include "mcvo/initializer/initializer.h"
#include "mcvo/util/error.h"
#include "mcvo/util/option_checks.h"

namespace mcvo {

void InitializerOptions::Check() const {
  CheckAtLeast("/initializer/window_size", window_size, 2);
  // The 5-point RANSAC needs some redundancy over its minimal sample.
  CheckAtLeast("/initializer/min_correspondences", min_correspondences, 8);
  CheckAtLeast("/initializer/min_parallax_px", min_parallax_px, 0.0);
  CheckPositive("/initializer/virtual_focal_px", virtual_focal_px);
  CheckAtLeast("/initializer/min_cameras_passing", min_cameras_passing, 1);
  std::set<std::string> seen;
  for (size_t i = 0; i < required_cameras.size(); ++i) {
    if (required_cameras[i].empty())
      MCVO_THROW_INPUT("/initializer/required_cameras/", i, ": empty camera name");
    if (!seen.insert(required_cameras[i]).second) {
      MCVO_THROW_INPUT("/initializer/required_cameras/", i, ": camera \"", required_cameras[i],
                       "\" listed twice");
    }
  }
  CheckAtLeast("/initializer/relax_required_after_windows", relax_required_after_windows, -1);
  CheckAtLeast("/initializer/min_cross_camera_matches", min_cross_camera_matches, 1);
  CheckAtLeast("/initializer/min_cross_camera_angle_deg", min_cross_camera_angle_deg, 0.0);
  CheckInRange("/initializer/min_singular_value_ratio", min_singular_value_ratio, 0.0, 1.0);
  CheckPositive("/initializer/max_rms_residual_m", max_rms_residual_m);
  CheckPositive("/initializer/max_relative_scale_sigma", max_relative_scale_sigma);
  CheckAtLeast("/initializer/max_relative_scale_sigma_fallback", max_relative_scale_sigma_fallback, 0.0);
  CheckAtLeast("/initializer/max_skipped_windows", max_skipped_windows, 0);
  CheckAtLeast("/initializer/max_rig_ba_iterations", max_rig_ba_iterations, 0);
  CheckPositive("/initializer/sfm/ransac_threshold_px", sfm.ransac_threshold_px);
  CheckPositive("/initializer/sfm/focal_px", sfm.focal_px);
  CheckAtLeast("/initializer/sfm/ransac_max_iterations", sfm.ransac_max_iterations, 1);
  CheckAtLeast("/initializer/sfm/min_correspondences", sfm.min_correspondences, 8);
  CheckAtLeast("/initializer/sfm/min_inliers", sfm.min_inliers, 5);
  CheckAtLeast("/initializer/sfm/min_triangulation_angle_deg", sfm.min_triangulation_angle_deg, 0.0);
  CheckAtLeast("/initializer/sfm/min_points_for_pnp", sfm.min_points_for_pnp, 4);
  CheckPositive("/initializer/sfm/max_reprojection_px", sfm.max_reprojection_px);
  CheckAtLeast("/initializer/sfm/max_ba_iterations", sfm.max_ba_iterations, 0);
  CheckAtLeast("/initializer/consistency/min_landmarks", consistency.min_landmarks, 0);
  CheckPositive("/initializer/consistency/disagreement_sigmas", consistency.disagreement_sigmas);
  CheckAtLeast("/initializer/consistency/min_disagreement", consistency.min_disagreement, 0.0);
  CheckPositive("/initializer/consistency/max_shape_residual", consistency.max_shape_residual);
  CheckPositive("/initializer/sfm/ba_huber_px", sfm.ba_huber_px);
  CheckAtLeast("/initializer/overlap_start/after_failed_windows", overlap_start.after_failed_windows, 0);
  CheckAtLeast("/initializer/overlap_start/min_points", overlap_start.min_points, 6);
  CheckInRange("/initializer/overlap_start/min_angle_deg", overlap_start.min_angle_deg, 0.0, 90.0);
  CheckPositive("/initializer/overlap_start/max_depth_m", overlap_start.max_depth_m);
  CheckAtLeast("/initializer/overlap_start/min_frame_inliers", overlap_start.min_frame_inliers, 6);
  CheckPositive("/initializer/overlap_start/max_relative_scale_sigma", overlap_start.max_relative_scale_sigma);
}

}  // namespace mcvo
