// OptionBounds, CheckOptionBounds and CheckOptionsAgainstRig
// (mcvo/config/option_bounds.h). The maxima: docs/config.md, beside each key.
#include "mcvo/config/option_bounds.h"

#include <algorithm>

#include "mcvo/frontend/frontend_options.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

// Sizes that allocate (pixels of a window, a grid, a feature budget) are
// bounded for 4K images and thousands of features; iteration counts at 10 to
// 100 times their defaults; counts and thresholds that only gate a decision
// (a minimum number of inliers, a period in frames) far above any use, so
// that no arithmetic on them overflows.
constexpr int64_t kManyFeatures = 20000;
constexpr int64_t kThreshold = 100000;
constexpr int64_t kPeriod = 1000000;

void AddFrontend(const FrontendOptions& f, std::vector<OptionBound>* b) {
  b->push_back({"/frontend/max_features_pinhole", f.max_features_pinhole, kManyFeatures});
  b->push_back({"/frontend/max_features_fisheye", f.max_features_fisheye, kManyFeatures});
  b->push_back({"/frontend/min_distance_px", f.min_distance_px, 1000});
  b->push_back({"/frontend/candidate_factor", f.candidate_factor, 100});
  b->push_back({"/frontend/clahe/tile_grid", f.clahe.tile_grid, 256});
  b->push_back({"/frontend/lk/window_px", f.lk.window_px, 255});
  b->push_back({"/frontend/lk/pyramid_levels", f.lk.pyramid_levels, 10});
  b->push_back({"/frontend/lk/max_iterations", f.lk.max_iterations, 1000});
  b->push_back({"/frontend/lk/predict_motion_min_points", f.lk.predict_motion_min_points, 10000});
  b->push_back({"/frontend/anchor/half_size_px", f.anchor.half_size_px, 127});
  b->push_back({"/frontend/anchor/max_iterations", f.anchor.max_iterations, 1000});
  b->push_back({"/frontend/superpoint/downscale", f.superpoint.downscale, 16});
  b->push_back({"/frontend/superpoint/nms_radius_px", f.superpoint.nms_radius_px, 64});
  b->push_back({"/frontend/superpoint/border_px", f.superpoint.border_px, 1000});
  b->push_back({"/frontend/cross_camera/max_matches_per_pair", f.cross_camera.max_matches_per_pair, kThreshold});
  b->push_back({"/frontend/cross_camera/rematch_every", f.cross_camera.rematch_every, kPeriod});
}

void AddInitializer(const InitializerOptions& i, std::vector<OptionBound>* b) {
  b->push_back({"/initializer/window_size", i.window_size, 200});
  b->push_back({"/initializer/min_correspondences", i.min_correspondences, kThreshold});
  b->push_back({"/initializer/min_cameras_passing", i.min_cameras_passing, 1000});
  b->push_back({"/initializer/relax_required_after_windows", i.relax_required_after_windows, kPeriod});
  b->push_back({"/initializer/min_cross_camera_matches", i.min_cross_camera_matches, kThreshold});
  b->push_back({"/initializer/max_skipped_windows", i.max_skipped_windows, kPeriod});
  b->push_back({"/initializer/max_rig_ba_iterations", i.max_rig_ba_iterations, 1000});
  b->push_back({"/initializer/sfm/ransac_max_iterations", i.sfm.ransac_max_iterations, 10000});
  b->push_back({"/initializer/sfm/min_correspondences", i.sfm.min_correspondences, kThreshold});
  b->push_back({"/initializer/sfm/min_inliers", i.sfm.min_inliers, kThreshold});
  b->push_back({"/initializer/sfm/min_points_for_pnp", i.sfm.min_points_for_pnp, kThreshold});
  b->push_back({"/initializer/sfm/max_ba_iterations", i.sfm.max_ba_iterations, 1000});
  b->push_back({"/initializer/consistency/min_landmarks", i.consistency.min_landmarks, kThreshold});
  b->push_back({"/initializer/overlap_start/after_failed_windows", i.overlap_start.after_failed_windows, kPeriod});
  b->push_back({"/initializer/overlap_start/min_points", i.overlap_start.min_points, kThreshold});
  b->push_back({"/initializer/overlap_start/min_frame_inliers", i.overlap_start.min_frame_inliers, kThreshold});
}

void AddBackend(const BackendOptions& o, std::vector<OptionBound>* b) {
  b->push_back({"/backend/window_size", o.window_size, 200});
  b->push_back({"/backend/max_iterations", o.max_iterations, 1000});
  b->push_back({"/backend/min_observations", o.min_observations, 1000});
  b->push_back({"/backend/keyframe_min_tracked", o.keyframe_min_tracked, kThreshold});
  b->push_back({"/backend/min_pnp_inliers", o.min_pnp_inliers, kThreshold});
  b->push_back({"/backend/scale_correction_period", o.scale_correction_period, kPeriod});
  b->push_back({"/backend/reverse_pass_overlap_frames", o.reverse_pass_overlap_frames, 10000});
}

void AddLoop(const LoopOptions& l, std::vector<OptionBound>* b) {
  const LoopClosureOptions& c = l.closure;
  b->push_back({"/loop/relocalise_map_keyframes", l.relocalise_map_keyframes, 1000});
  b->push_back({"/loop/relocalise_query_keyframes", l.relocalise_query_keyframes, 1000});
  b->push_back({"/loop/frontend_cache_mb", l.frontend_cache_mb, 65536});
  b->push_back({"/loop/features_per_camera", c.features_per_camera, kManyFeatures});
  b->push_back({"/loop/exclude_recent_keyframes", c.exclude_recent_keyframes, kPeriod});
  b->push_back({"/loop/max_candidates", c.max_candidates, 100});
  b->push_back({"/loop/landmark_levels", c.landmark_levels, 8});
  b->push_back({"/loop/max_match_distance", c.max_match_distance, 256});
  b->push_back({"/loop/pnp_max_iterations", c.pnp_max_iterations, 10000});
  b->push_back({"/loop/min_inliers", c.min_inliers, kThreshold});
  b->push_back({"/loop/min_camera_inliers", c.min_camera_inliers, kThreshold});
  b->push_back({"/loop/consistency_window", c.consistency_window, 1000});
  b->push_back({"/loop/candidate_neighbours", c.candidate_neighbours, 1000});
  b->push_back({"/loop/cross_camera/window_keyframes", c.cross_camera.window_keyframes, 1000});
  b->push_back({"/loop/cross_camera/max_distance", c.cross_camera.max_distance, 256});
  b->push_back({"/loop/pose_graph/loop_loss_stages", l.pose_graph.loop_loss_stages, 100});
  b->push_back({"/loop/pose_graph/max_iterations", l.pose_graph.max_iterations, 10000});
}

void AddRest(const PipelineOptions& o, std::vector<OptionBound>* b) {
  const GlobalBaOptions& r = o.refine;
  b->push_back({"/refine/max_iterations", r.max_iterations, 1000});
  b->push_back({"/refine/outlier_rounds", r.outlier_rounds, 100});
  b->push_back({"/refine/min_observations", r.min_observations, 1000});
  b->push_back({"/refine/thin_tracks_longer_than", r.thin_tracks_longer_than, kPeriod});
  b->push_back({"/refine/thin_track_stride", r.thin_track_stride, kPeriod});
  b->push_back({"/refine/straight_window_keyframes", r.straight_window_keyframes, 10000});
  b->push_back({"/refine/straight_overlap_min_landmarks", r.straight_overlap_min_landmarks, kPeriod});
  b->push_back({"/colmap/fit_grid", o.colmap.export_options.fit_grid, 1024});
  b->push_back({"/colmap/min_track_length", o.colmap.export_options.min_track_length, kPeriod});
  b->push_back({"/runtime/threads", o.runtime.threads, 1024});
  b->push_back({"/eval/align_num_poses", o.eval.align_num_poses, 100000000});
  b->push_back({"/eval/local_scale_window", o.eval.local_scale_window, kPeriod});
}

}  // namespace

std::vector<OptionBound> OptionBounds(const PipelineOptions& options) {
  std::vector<OptionBound> bounds;
  AddFrontend(options.frontend, &bounds);
  AddInitializer(options.initializer, &bounds);
  AddBackend(options.backend, &bounds);
  AddLoop(options.loop, &bounds);
  AddRest(options, &bounds);
  return bounds;
}

void CheckOptionBounds(const PipelineOptions& options) {
  for (const OptionBound& bound : OptionBounds(options)) {
    if (bound.value > bound.max) MCVO_THROW_INPUT(bound.pointer, ": ", bound.value, " is above the maximum ", bound.max);
  }
}

void CheckOptionsAgainstRig(const PipelineOptions& options, const Rig& rig, const std::string& config_source) {
  const FrontendOptions& frontend = options.frontend;
  for (const Camera& camera : rig.cameras) {
    const FrontendOptions scaled =
        ScalePixelParameters(frontend, PixelScaleForCamera(frontend, camera.width, camera.height));
    const int side = std::min(camera.width, camera.height);
    const auto fail = [&](const char* pointer, int given, int used, const std::string& what) {
      const std::string value =
          used == given ? std::to_string(given) : StrCat(given, " (", used, " on this camera, scaled)");
      MCVO_THROW_INPUT(config_source, ": ", pointer, ": ", value, " ", what, " of camera ", camera.name, " (",
                       camera.width, " x ", camera.height, " px)");
    };
    if (scaled.lk.window_px >= side) {
      fail("/frontend/lk/window_px", frontend.lk.window_px, scaled.lk.window_px,
           "is not smaller than the smaller side of the image");
    }
    if (frontend.clahe.enabled && scaled.clahe.tile_grid > side) {
      fail("/frontend/clahe/tile_grid", frontend.clahe.tile_grid, scaled.clahe.tile_grid,
           "tiles is more than the pixels on the smaller side of the image");
    }
    if (frontend.anchor.enabled && 2 * scaled.anchor.half_size_px + 1 > side) {
      fail("/frontend/anchor/half_size_px", frontend.anchor.half_size_px, scaled.anchor.half_size_px,
           "gives a template (2 h + 1 px) larger than the smaller side of the image");
    }
  }
}

}  // namespace mcvo
