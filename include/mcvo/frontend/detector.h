// Keypoint detectors behind one interface: Shi-Tomasi, ORB/FAST (classic,
// src/frontend/classic_detectors.cc) and ONNX keypoint networks (XFeat,
// SuperPoint layout; src/frontend/keypoint_net.cc).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "mcvo/frontend/frontend_options.h"

namespace mcvo {

// Detections in one image, sorted by decreasing score (ties: smaller y, then
// smaller x), pixel coordinates in OpenCV's convention.
struct Detections {
  std::vector<Eigen::Vector2f> pixels;
  std::vector<float> scores;
  // One row per detection (CV_32F, L2-normalised) for detectors with
  // descriptors (ORB: CV_8U rows of 32 bytes); empty otherwise.
  cv::Mat descriptors;

  size_t size() const { return pixels.size(); }
};

class Detector {
 public:
  virtual ~Detector() = default;
  virtual std::string Name() const = 0;
  // Detections in a CV_8UC1 image, none where `mask` (CV_8UC1, same size,
  // may be empty) is 0 nor within border_px of the image border: the best
  // max_candidates by score and, for Shi-Tomasi and the networks, up to
  // max_candidates more spread over the image (regions the best left
  // without candidates; ORB returns none). Sorted by score, so the first
  // max_candidates are the best. Deterministic. Not thread-safe: one
  // detector per camera.
  virtual Detections Detect(const cv::Mat& image, const cv::Mat& mask, int max_candidates, int border_px) = 0;
  // Descriptor length (floats or bytes), 0 without descriptors.
  virtual int DescriptorSize() const = 0;
  // OpenCV depth of a descriptor element: CV_32F (networks), CV_8U (ORB);
  // meaningless when DescriptorSize() is 0.
  virtual int DescriptorType() const = 0;
};

// Builds the detector the options ask for. Network models are loaded and
// their input/output layout is checked here, at start-up: a missing file or
// an incompatible model throws InputError naming the file and what is wrong.
std::unique_ptr<Detector> CreateDetector(const FrontendOptions& options);

}  // namespace mcvo
