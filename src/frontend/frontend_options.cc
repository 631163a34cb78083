#include "mcvo/frontend/frontend_options.h"

#include <algorithm>
#include <cmath>

#include "mcvo/util/error.h"
#include "mcvo/util/option_checks.h"

namespace mcvo {

void FrontendOptions::Check() const {
  if (IsLearnedDetector(detector) && model_path.empty()) {
    MCVO_THROW_INPUT("/frontend/model_path: required for detector \"",
                     EnumToName(kDetectorTypeNames, detector), "\" (an ONNX model file)");
  }
  CheckPositive("/frontend/max_features_pinhole", max_features_pinhole);
  CheckPositive("/frontend/max_features_fisheye", max_features_fisheye);
  CheckAtLeast("/frontend/max_features_pinhole_megapixels", max_features_pinhole_megapixels, 0.0);
  CheckAtLeast("/frontend/min_distance_px", min_distance_px, 0);
  CheckAtLeast("/frontend/pixel_scale_reference_px", pixel_scale_reference_px, 0.0);
  CheckAtLeast("/frontend/candidate_factor", candidate_factor, 1);
  CheckAtLeast("/frontend/detection_max_megapixels", detection_max_megapixels, 0.0);
  CheckInRange("/frontend/detect_missing_fraction", detect_missing_fraction, 0.0, 1.0);
  CheckPositive("/frontend/ransac_threshold_px", ransac_threshold_px);
  CheckPositive("/frontend/ransac_focal_px", ransac_focal_px);
  CheckPositive("/frontend/clahe/clip_limit", clahe.clip_limit);
  CheckAtLeast("/frontend/clahe/tile_grid", clahe.tile_grid, 1);
  CheckAtLeast("/frontend/texture/min_gradient", texture.min_gradient, 0.0);
  CheckAtLeast("/frontend/texture/noise_factor", texture.noise_factor, 0.0);
  CheckAtLeast("/frontend/lk/window_px", lk.window_px, 3);
  CheckAtLeast("/frontend/lk/pyramid_levels", lk.pyramid_levels, 0);
  CheckAtLeast("/frontend/lk/max_iterations", lk.max_iterations, 1);
  CheckPositive("/frontend/lk/forward_backward_threshold_px", lk.forward_backward_threshold_px);
  CheckAtLeast("/frontend/lk/predict_rotation_min_px", lk.predict_rotation_min_px, 0.0);
  CheckAtLeast("/frontend/lk/predict_motion_min_px", lk.predict_motion_min_px, 0.0);
  CheckAtLeast("/frontend/lk/predict_motion_min_points", lk.predict_motion_min_points, 3);
  CheckAtLeast("/frontend/anchor/half_size_px", anchor.half_size_px, 2);
  CheckAtLeast("/frontend/anchor/weight_sigma_px", anchor.weight_sigma_px, 0.0);
  CheckAtLeast("/frontend/anchor/max_iterations", anchor.max_iterations, 1);
  CheckInRange("/frontend/anchor/min_zncc", anchor.min_zncc, -1.0, 1.0);
  CheckPositive("/frontend/anchor/max_shift_px", anchor.max_shift_px);
  CheckAtLeast("/frontend/anchor/max_warp_change", anchor.max_warp_change, 1.0);
  CheckAtLeast("/frontend/anchor/reanchor_scale", anchor.reanchor_scale, 1.0);
  CheckAtLeast("/frontend/superpoint/downscale", superpoint.downscale, 1);
  CheckInRange("/frontend/superpoint/confidence_threshold", superpoint.confidence_threshold, 0.0, 1.0);
  CheckAtLeast("/frontend/superpoint/nms_radius_px", superpoint.nms_radius_px, 0);
  CheckAtLeast("/frontend/superpoint/border_px", superpoint.border_px, 0);
  CheckInRange("/frontend/superpoint/detect_missing_fraction", superpoint.detect_missing_fraction, 0.0, 1.0);
  CheckInRange("/frontend/cross_camera/min_view_overlap", cross_camera.min_view_overlap, 0.0, 1.0);
  CheckPositive("/frontend/cross_camera/init_distance_m", cross_camera.init_distance_m);
  CheckAtLeast("/frontend/cross_camera/near_distance_m", cross_camera.near_distance_m, 0.0);
  CheckAtLeast("/frontend/cross_camera/normalise_sigma_px", cross_camera.normalise_sigma_px, 0.0);
  CheckPositive("/frontend/cross_camera/epipolar_threshold_px", cross_camera.epipolar_threshold_px);
  CheckInRange("/frontend/cross_camera/min_angle_deg", cross_camera.min_angle_deg, 0.0, 90.0);
  CheckAtLeast("/frontend/cross_camera/max_matches_per_pair", cross_camera.max_matches_per_pair, 0);
  CheckAtLeast("/frontend/cross_camera/rematch_every", cross_camera.rematch_every, 1);
  CheckInRange("/frontend/cross_camera/rematch_below_fraction", cross_camera.rematch_below_fraction, 0.0, 1.0);
}

double PixelScaleForCamera(const FrontendOptions& options, int width, int height) {
  if (!(options.pixel_scale_reference_px > 0.0) || width <= 0 || height <= 0) return 1.0;
  const double size = std::sqrt(static_cast<double>(width) * static_cast<double>(height));
  return std::min(1.0, size / options.pixel_scale_reference_px);
}

int PinholeFeatureBudget(const FrontendOptions& options, int width, int height) {
  const int base = options.max_features_pinhole;
  if (!(options.max_features_pinhole_megapixels > 0.0) || width <= 0 || height <= 0) return base;
  const double ratio = static_cast<double>(width) * static_cast<double>(height) /
                       (options.max_features_pinhole_megapixels * 1e6);
  if (!(ratio > 1.0)) return base;
  constexpr double kMaxBudget = 20000.0;  // the bound of max_features_pinhole itself
  return std::max(base, static_cast<int>(std::lround(std::min(kMaxBudget, base * ratio))));
}

FrontendOptions ScalePixelParameters(const FrontendOptions& options, double scale) {
  if (!(scale < 1.0) || !(scale > 0.0)) return options;
  FrontendOptions scaled = options;
  const auto scaled_int = [scale](int value, int floor) {
    return std::min(value, std::max(floor, static_cast<int>(std::lround(value * scale))));
  };
  scaled.min_distance_px = scaled_int(options.min_distance_px, 1);
  scaled.anchor.half_size_px = scaled_int(options.anchor.half_size_px, 3);
  scaled.clahe.tile_grid = scaled_int(options.clahe.tile_grid, 2);
  // The odd size nearest to window x scale: 2 floor(window x scale / 2) + 1.
  const int window = 2 * static_cast<int>(std::floor(options.lk.window_px * scale / 2.0)) + 1;
  scaled.lk.window_px = std::min(options.lk.window_px, std::max(5, window));
  return scaled;
}

}  // namespace mcvo
