// Per-camera tracking: pyramidal LK with a forward-backward check, outlier
// rejection by RANSAC on bearing vectors (5-point essential, OpenGV; works for
// fisheyes beyond 90 degrees), borders and masks respected, optional CLAHE,
// then detection and selection of new features.
#pragma once

#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/frontend/detector.h"
#include "mcvo/frontend/frontend_options.h"

namespace mcvo {

struct TrackedFeature {
  uint64_t id = 0;  // 0 until assigned (new features of the current frame)
  Eigen::Vector2f pixel = Eigen::Vector2f::Zero();
  float score = 0.0f;
  int track_length = 1;  // frames this feature has been seen in, this one included
};

struct CameraFrameStats {
  bool image_missing = false;
  int tracked = 0;  // features carried over from the previous frame (after all checks)
  int lost_lk = 0;  // LK failed or left the image / mask
  int lost_forward_backward = 0;
  int lost_anchor = 0;  // the anchor patch no longer matches (FrontendOptions::anchor)
  // New detections the texture gate turned away (FrontendOptions::texture;
  // not in the track file).
  int untextured = 0;
  int ransac_inliers = 0;
  int ransac_outliers = 0;
  int new_features = 0;
  double mean_track_length = 0.0;  // over the features of this frame
  double sfd = 0.0;                // ComputeSfd over this frame's features
  // Wall time per stage in seconds: for logs and benchmarks only, never
  // written to deterministic outputs.
  // seconds_clahe: the contrast equalisation (FrontendOptions::clahe; 0 when
  // off); seconds_pyramid: the LK pyramid(s) after it.
  double seconds_clahe = 0.0, seconds_pyramid = 0.0, seconds_lk = 0.0, seconds_ransac = 0.0,
         seconds_anchor = 0.0, seconds_detect = 0.0, seconds_select = 0.0;
};

struct CameraFrameResult {
  std::vector<TrackedFeature> features;  // tracked first (previous order), then new ones
  // Descriptor of each feature, one row per feature, from the frame it was
  // detected in (empty when the detector has none).
  cv::Mat descriptors;
  CameraFrameStats stats;
};

// Starting pixels for LK by feature id (frontend.lk.predict_motion).
using FeaturePredictions = std::unordered_map<uint64_t, Eigen::Vector2f>;

class CameraTracker {
 public:
  CameraTracker(const Camera& camera, const cv::Mat& mask, const FrontendOptions& options,
                std::unique_ptr<Detector> detector);
  ~CameraTracker();
  CameraTracker(const CameraTracker&) = delete;
  CameraTracker& operator=(const CameraTracker&) = delete;

  // Tracks into the next image (CV_8UC1; an empty Mat means this camera has
  // no image in this frame: every track ends). New features have id 0.
  // predictions (optional): where some of the previous frame's features are
  // expected, by id; LK starts there (forward) and at the forward result
  // shifted back by the predicted move (backward) for those that land
  // inside the usable image, and as without predictions for the others.
  CameraFrameResult Track(const cv::Mat& image, const FeaturePredictions* predictions = nullptr);
  // Gives the id-0 features of `result` (the last Track()) consecutive ids
  // from *next_id on, advancing it, and records them for the next frame.
  void AssignNewIds(uint64_t* next_id, CameraFrameResult* result);
  // The LK pyramid of the last Track()'s image (after CLAHE), as
  // cv::buildOpticalFlowPyramid made it (window lk.window_px, lk.pyramid_levels,
  // with derivatives); empty when that image was missing. Valid until the
  // next Track(). The cross-camera matcher reuses it.
  const std::vector<cv::Mat>& Pyramid() const;
  // The pyramid cross-camera matching reads: Pyramid(), or that of the
  // unequalised image where CLAHE is on and cross_camera.equalised off.
  const std::vector<cv::Mat>& CrossCameraPyramid() const;
  // CrossCameraPyramid() of the Track() before the last one: kept only with
  // cross_camera.rematch_every > 1 (matches are followed from it); empty
  // otherwise, on the first frame and after a missing image.
  const std::vector<cv::Mat>& PreviousCrossCameraPyramid() const;
  // The detector's descriptor layout (Detector::DescriptorSize / DescriptorType).
  int DescriptorSize() const;
  int DescriptorType() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
