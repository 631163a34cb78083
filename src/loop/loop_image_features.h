// LoopImageFeatures (loop_closer.h): what of a keyframe's loop-closure
// features its images give, private to loop/.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "mcvo/loop/loop_closer.h"

namespace mcvo {

// What of a keyframe's features its images give (LoopCloser::
// ExtractImageFeatures), and the points they were extracted at.
struct LoopImageFeatures {
  // One camera's ORB detections and descriptors at the landmark pixels.
  struct CameraFeatures {
    std::vector<cv::Point2f> detections;  // full-resolution pixels
    cv::Mat detection_descriptors;
    std::vector<int> point_index;  // of landmark keypoints kept by ORB (border)
    cv::Mat point_descriptors;
    // With cross-camera links: oriented level-0 descriptors at the landmark
    // pixels (the cameras' roll differs), whatever the loop closer's own
    // landmark descriptors are (kept by ORB: indices into keyframe.points).
    std::vector<int> link_point_index;
    cv::Mat link_point_descriptors;
  };
  std::vector<CameraFeatures> cameras;
  // The keyframe's points' cameras and pixels, in order: the indices above
  // refer to them.
  std::vector<int> point_camera;
  std::vector<Eigen::Vector2d> point_pixel;

  size_t Bytes() const {
    size_t bytes = point_camera.size() * sizeof(int) + point_pixel.size() * sizeof(Eigen::Vector2d);
    for (const CameraFeatures& c : cameras) {
      bytes += c.detections.size() * sizeof(cv::Point2f) + c.point_index.size() * sizeof(int) +
               c.link_point_index.size() * sizeof(int);
      for (const cv::Mat* m : {&c.detection_descriptors, &c.point_descriptors, &c.link_point_descriptors}) {
        bytes += m->total() * m->elemSize();
      }
    }
    return bytes;
  }

  bool Fits(const LoopKeyframe& keyframe) const {
    if (keyframe.points.size() != point_camera.size()) return false;
    for (size_t k = 0; k < point_camera.size(); ++k) {
      const LoopKeyframe::Point& p = keyframe.points[k];
      if (p.camera != point_camera[k] || p.pixel != point_pixel[k]) return false;
    }
    return true;
  }
};

}  // namespace mcvo
