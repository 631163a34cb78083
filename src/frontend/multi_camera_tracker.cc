// Cameras are tracked on worker threads (util/parallel.h, threads per Track() call; a
// frame's work per camera is milliseconds to tens of milliseconds, so thread
// start-up is negligible), each camera into its own pre-sized slot. After the
// join, new feature ids are assigned in camera order, so ids and every output
// are independent of the thread count and of scheduling.
//
// OpenCV's own parallel loops (LK over points, pyramid and corner response
// over rows) compute each output element independently of how the work is
// split, so their results do not depend on cv::getNumThreads();
// multi_camera_tracker_test checks threads 1 vs 2 bit for bit.
//
// Cross-camera matching runs after the ids are assigned (a match names its
// feature by id), the same way: pairs on worker threads into pre-sized slots,
// concatenated in pair order, which is the (camera_a, camera_b) order.
// With cross_camera.rematch_every > 1 a pair is matched through its warps
// only every rematch_every-th frame (or when too few matches could be
// followed); on the frames between, the last matches are followed in b's
// images (CrossCameraMatcher::Follow). Each pair's state is its own, so
// pairs stay independent work items.
#include "mcvo/frontend/multi_camera_tracker.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <string>
#include <thread>

#include "mcvo/frontend/cross_camera.h"
#include "mcvo/frontend/detector.h"
#include "mcvo/util/error.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"
#include "motion_predictor.h"

namespace mcvo {
namespace {

// Per camera: PixelScaleForCamera.
std::vector<double> PixelScales(const Rig& rig, const FrontendOptions& options) {
  std::vector<double> scales;
  for (const Camera& camera : rig.cameras) scales.push_back(PixelScaleForCamera(options, camera.width, camera.height));
  return scales;
}

// Says which cameras PixelScales scaled, one line per image size (once the
// trackers exist: a start-up error stays the only line).
void LogScaledCameras(const Rig& rig, const FrontendOptions& options, const std::vector<double>& scales) {
  struct SizeGroup {
    int width = 0, height = 0;
    double scale = 1.0;  // the same for every camera of this size
    std::string names;
  };
  std::vector<SizeGroup> groups;
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    if (scales[c] >= 1.0) continue;
    const Camera& camera = rig.cameras[c];
    const auto same = std::find_if(groups.begin(), groups.end(), [&](const SizeGroup& g) {
      return g.width == camera.width && g.height == camera.height;
    });
    if (same == groups.end()) {
      groups.push_back({camera.width, camera.height, scales[c], camera.name});
    } else {
      same->names += ", " + camera.name;
    }
  }
  for (const SizeGroup& g : groups) {
    const FrontendOptions scaled = ScalePixelParameters(options, g.scale);
    MCVO_LOG(kInfo, "frontend: ", g.names, " (", g.width, "x", g.height, " px): pixel parameters scaled by ",
             FormatFixed(g.scale, 2), " (frontend.pixel_scale_reference_px ",
             FormatFixed(options.pixel_scale_reference_px, 0), "): min distance ", scaled.min_distance_px,
             " px, LK window ", scaled.lk.window_px, " px, anchor half size ", scaled.anchor.half_size_px,
             " px, CLAHE ", scaled.clahe.tile_grid, "x", scaled.clahe.tile_grid, " tiles");
  }
}

// Says which pinhole cameras PinholeFeatureBudget gave more features than
// max_features_pinhole, one line per image size.
void LogFeatureBudgets(const Rig& rig, const FrontendOptions& options) {
  std::vector<std::pair<std::pair<int, int>, std::string>> groups;  // (width, height), names
  for (const Camera& camera : rig.cameras) {
    if (IsFisheyeModel(camera.model)) continue;
    if (PinholeFeatureBudget(options, camera.width, camera.height) == options.max_features_pinhole) continue;
    const std::pair<int, int> size{camera.width, camera.height};
    const auto same = std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return g.first == size; });
    if (same == groups.end()) {
      groups.emplace_back(size, camera.name);
    } else {
      same->second += ", " + camera.name;
    }
  }
  for (const auto& [size, names] : groups) {
    MCVO_LOG(kInfo, "frontend: ", names, " (", size.first, "x", size.second, " px): ",
             PinholeFeatureBudget(options, size.first, size.second), " features per image (max_features_pinhole ",
             options.max_features_pinhole, " per ", FormatFixed(options.max_features_pinhole_megapixels, 2),
             " Mpx, frontend.max_features_pinhole_megapixels)");
  }
}

}  // namespace

int CountCrossCameraMatches(const MultiCameraFrame& frame, int camera_a) {
  return static_cast<int>(std::count_if(frame.cross_matches.begin(), frame.cross_matches.end(),
                                        [&](const CrossCameraMatch& m) { return m.camera_a == camera_a; }));
}

struct MultiCameraTracker::Impl {
  std::vector<std::unique_ptr<CameraTracker>> trackers;
  std::vector<std::pair<int, int>> pairs;
  std::vector<std::unique_ptr<CrossCameraMatcher>> matchers;  // one per pair
  // Per pair, for cross_camera.rematch_every > 1: the last frame's matches,
  // frames since the last full match (0: none yet), its number of matches.
  std::vector<std::vector<CrossCameraMatch>> last_matches;
  std::vector<int> frames_since_full;
  std::vector<int> full_matches;
  int rematch_every = 1;
  double rematch_below_fraction = 0.5;
  int threads = 1;
  uint64_t next_id = 1;  // 0 means "not assigned yet"
  // With lk.predict_motion and matched pairs: LK's starts from the rig's motion.
  std::unique_ptr<frontend_internal::RigMotionPredictor> predictor;
};

MultiCameraTracker::MultiCameraTracker(const Rig& rig, const std::vector<cv::Mat>& masks,
                                       const FrontendOptions& options, int threads)
    : impl_(std::make_unique<Impl>()) {
  if (!masks.empty() && static_cast<int>(masks.size()) != rig.NumCameras()) {
    MCVO_THROW_INPUT("frontend: ", masks.size(), " masks for a rig of ", rig.NumCameras(), " cameras");
  }
  impl_->threads = std::max(1, threads);
  const std::vector<double> scales = PixelScales(rig, options);
  for (int c = 0; c < rig.NumCameras(); ++c) {
    const cv::Mat mask = masks.empty() ? cv::Mat() : masks[static_cast<size_t>(c)];
    const Camera& camera = rig.cameras[static_cast<size_t>(c)];
    FrontendOptions camera_options = ScalePixelParameters(options, scales[static_cast<size_t>(c)]);
    camera_options.max_features_pinhole = PinholeFeatureBudget(options, camera.width, camera.height);
    impl_->trackers.push_back(
        std::make_unique<CameraTracker>(camera, mask, camera_options, CreateDetector(camera_options)));
  }
  impl_->pairs = SelectCrossCameraPairs(rig, masks, options.cross_camera);
  // Each matcher computes its warp maps (a Project per pixel of camera a
  // and warp distance) on all threads, row blocks in parallel (pairs in
  // parallel would leave a thread idle when one pair has a fisheye of 2 Mpx
  // and the others small pinholes). Camera a's bearing grid (an iterative
  // undistortion per pixel: most of the cost) is computed once for all its
  // pairs; pairs are ordered by a, so one grid is alive at a time.
  std::vector<Eigen::Vector3d> bearings_a;
  int bearings_camera = -1;
  for (const auto& [a, b] : impl_->pairs) {
    const Camera& camera_a = rig.cameras[static_cast<size_t>(a)];
    if (a != bearings_camera) {
      bearings_a = UnitBearingGrid(camera_a, impl_->threads);
      bearings_camera = a;
    }
    const cv::Mat mask_b = masks.empty() ? cv::Mat() : masks[static_cast<size_t>(b)];
    const double pair_scale = std::min(scales[static_cast<size_t>(a)], scales[static_cast<size_t>(b)]);
    impl_->matchers.push_back(std::make_unique<CrossCameraMatcher>(a, b, camera_a, rig.cameras[static_cast<size_t>(b)],
                                                                   mask_b, ScalePixelParameters(options, pair_scale),
                                                                   impl_->threads, &bearings_a));
  }
  impl_->rematch_every = options.cross_camera.rematch_every;
  impl_->rematch_below_fraction = options.cross_camera.rematch_below_fraction;
  impl_->last_matches.resize(impl_->pairs.size());
  impl_->frames_since_full.assign(impl_->pairs.size(), 0);
  impl_->full_matches.assign(impl_->pairs.size(), 0);
  if (options.lk.predict_motion && !impl_->pairs.empty()) {
    impl_->predictor = std::make_unique<frontend_internal::RigMotionPredictor>(rig, options.ransac_focal_px,
                                                                               options.lk.predict_motion_min_points);
  }
  LogScaledCameras(rig, options, scales);
  LogFeatureBudgets(rig, options);
}

MultiCameraTracker::~MultiCameraTracker() = default;

MultiCameraFrame MultiCameraTracker::Track(int frame_index, int64_t t_ns,
                                           const std::vector<cv::Mat>& images) {
  const size_t n = impl_->trackers.size();
  if (images.size() != n) {
    MCVO_THROW_INPUT("frontend: frame ", frame_index, " has ", images.size(), " images for ", n, " cameras");
  }
  MultiCameraFrame frame;
  frame.frame_index = frame_index;
  frame.t_ns = t_ns;
  frame.cameras.resize(n);
  const std::vector<FeaturePredictions> predictions =
      impl_->predictor ? impl_->predictor->Predict(t_ns) : std::vector<FeaturePredictions>();
  // An exception: the first failing camera's, in camera order.
  ParallelFor(static_cast<int>(n), impl_->threads,
              [&](size_t c) {
                const ScopedStage stage(StrCat("camera ", c));
                frame.cameras[c] = impl_->trackers[c]->Track(images[c], predictions.empty() ? nullptr : &predictions[c]);
              });
  for (size_t c = 0; c < n; ++c) impl_->trackers[c]->AssignNewIds(&impl_->next_id, &frame.cameras[c]);

  const size_t p = impl_->matchers.size();
  std::vector<std::vector<CrossCameraMatch>> matches(p);
  frame.cross_pair_stats.resize(p);
  ParallelFor(static_cast<int>(p), impl_->threads, [&](size_t i) {
    const CrossCameraMatcher& matcher = *impl_->matchers[i];
    const size_t a = static_cast<size_t>(matcher.camera_a());
    const size_t b = static_cast<size_t>(matcher.camera_b());
    const CameraTracker& tracker_b = *impl_->trackers[b];
    // Between full frames: follow the last frame's matches; matched in full
    // all the same when too few survive (a decision on counts only, so the
    // same at any thread count).
    int& since_full = impl_->frames_since_full[i];
    if (since_full > 0 && since_full < impl_->rematch_every && impl_->full_matches[i] > 0) {
      matches[i] = matcher.Follow(frame.cameras[a].features, impl_->last_matches[i],
                                  tracker_b.PreviousCrossCameraPyramid(), tracker_b.CrossCameraPyramid(),
                                  &frame.cross_pair_stats[i]);
      if (static_cast<double>(matches[i].size()) >=
          impl_->rematch_below_fraction * static_cast<double>(impl_->full_matches[i])) {
        ++since_full;
        impl_->last_matches[i] = matches[i];  // only reached with rematch_every > 1
        return;
      }
    }
    matches[i] = matcher.Match(frame.cameras[a].features, impl_->trackers[a]->CrossCameraPyramid(),
                               tracker_b.CrossCameraPyramid(), &frame.cross_pair_stats[i]);
    since_full = 1;
    impl_->full_matches[i] = static_cast<int>(matches[i].size());
    if (impl_->rematch_every > 1) impl_->last_matches[i] = matches[i];
  });
  for (const std::vector<CrossCameraMatch>& pair_matches : matches) {
    frame.cross_matches.insert(frame.cross_matches.end(), pair_matches.begin(), pair_matches.end());
  }
  if (impl_->predictor) impl_->predictor->Update(frame);
  return frame;
}

const std::vector<std::pair<int, int>>& MultiCameraTracker::CrossCameraPairs() const { return impl_->pairs; }

int MultiCameraTracker::DescriptorSize() const {
  return impl_->trackers.empty() ? 0 : impl_->trackers.front()->DescriptorSize();
}
int MultiCameraTracker::DescriptorType() const {
  return impl_->trackers.empty() ? CV_32F : impl_->trackers.front()->DescriptorType();
}

}  // namespace mcvo
