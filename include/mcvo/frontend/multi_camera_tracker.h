// Tracks all cameras of a rig frame by frame: cameras in parallel (one
// CameraTracker each, worker threads over cameras), results merged in camera
// order, so feature ids and every output are identical at any thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "mcvo/camera/camera.h"
#include "mcvo/frontend/camera_tracker.h"
#include "mcvo/frontend/frontend_options.h"

namespace mcvo {

struct MultiCameraFrame {
  int frame_index = 0;
  int64_t t_ns = 0;
  std::vector<CameraFrameResult> cameras;  // one per rig camera, in rig order
};

class MultiCameraTracker {
 public:
  // masks: one per camera (empty Mat: no mask). Detectors are created per
  // camera with CreateDetector (so model errors surface here, at start-up).
  // Fisheye cameras (kannala_brandt, mei, double_sphere) get
  // max_features_fisheye, the others max_features_pinhole.
  MultiCameraTracker(const Rig& rig, const std::vector<cv::Mat>& masks, const FrontendOptions& options,
                     int threads);
  ~MultiCameraTracker();
  MultiCameraTracker(const MultiCameraTracker&) = delete;
  MultiCameraTracker& operator=(const MultiCameraTracker&) = delete;

  // images: one CV_8UC1 per camera, empty = missing.
  MultiCameraFrame Track(int frame_index, int64_t t_ns, const std::vector<cv::Mat>& images);
  // Descriptor layout of every camera's features (one detector type per rig).
  int DescriptorSize() const;
  int DescriptorType() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
