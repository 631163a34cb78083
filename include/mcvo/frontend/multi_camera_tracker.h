// Tracks all cameras of a rig frame by frame: cameras in parallel (one
// CameraTracker each, worker threads over cameras), results merged in camera
// order, so feature ids and every output are identical at any thread count.
// Then, for camera pairs with overlapping views, finds each camera's features
// in the other camera of the same frame (cross_camera.h), pairs in parallel.
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mcvo/camera/camera.h"
#include "mcvo/frontend/camera_tracker.h"
#include "mcvo/frontend/frontend_options.h"

namespace mcvo {

// Feature `id_a` of camera `camera_a` (in cameras[camera_a].features of the
// same frame) seen by camera `camera_b` (camera_a < camera_b) at pixel_b.
struct CrossCameraMatch {
  int camera_a = 0;
  uint64_t id_a = 0;
  int camera_b = 0;
  Eigen::Vector2f pixel_b = Eigen::Vector2f::Zero();
};

// What happened to camera a's features in one frame of one matched pair.
// features = outside_view + lost_lk + lost_forward_backward + lost_epipolar
//          + lost_triangulation + over_limit + matches.
struct CrossCameraPairStats {
  int camera_a = 0;
  int camera_b = 0;
  int features = 0;      // camera a's features of this frame (0 when a or b has no image)
  int outside_view = 0;  // the initial guess does not project into b's image / mask
  int lost_lk = 0;       // LK failed or left b's image / mask, or a bearing is undefined
  int lost_forward_backward = 0;
  int lost_epipolar = 0;       // b's bearing too far from the epipolar plane
  int lost_triangulation = 0;  // behind a camera, or the rays nearly parallel
  int over_limit = 0;          // beyond cross_camera.max_matches_per_pair
  int matches = 0;
  // Wall time in seconds: logs and benchmarks only, never written to
  // deterministic outputs.
  double seconds = 0.0;
};

struct MultiCameraFrame {
  int frame_index = 0;
  int64_t t_ns = 0;
  std::vector<CameraFrameResult> cameras;  // one per rig camera, in rig order
  // Sorted by (camera_a, camera_b, id_a).
  std::vector<CrossCameraMatch> cross_matches;
  // One per matched pair (MultiCameraTracker::CrossCameraPairs), in that order.
  std::vector<CrossCameraPairStats> cross_pair_stats;
};

// Number of matches of `frame` with this camera as camera_a (its features
// found in other cameras).
int CountCrossCameraMatches(const MultiCameraFrame& frame, int camera_a);

class MultiCameraTracker {
 public:
  // masks: one per camera (empty Mat: no mask), or none at all. Detectors are created per
  // camera with CreateDetector (so model errors surface here, at start-up).
  // Fisheye cameras (kannala_brandt, mei, double_sphere) get
  // max_features_fisheye, the others max_features_pinhole, or more on a
  // pinhole camera larger than max_features_pinhole_megapixels
  // (PinholeFeatureBudget: the same density).
  MultiCameraTracker(const Rig& rig, const std::vector<cv::Mat>& masks, const FrontendOptions& options,
                     int threads);
  ~MultiCameraTracker();
  MultiCameraTracker(const MultiCameraTracker&) = delete;
  MultiCameraTracker& operator=(const MultiCameraTracker&) = delete;

  // images: one CV_8UC1 per camera, empty = missing.
  MultiCameraFrame Track(int frame_index, int64_t t_ns, const std::vector<cv::Mat>& images);
  // The camera pairs (a, b), a < b, in increasing order, that are matched
  // across cameras: ViewOverlap(a, b, kViewOverlapDepthM, masks) >=
  // cross_camera.min_view_overlap (none when cross_camera.enabled is false).
  const std::vector<std::pair<int, int>>& CrossCameraPairs() const;
  // Descriptor layout of every camera's features (one detector type per rig).
  int DescriptorSize() const;
  int DescriptorType() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
