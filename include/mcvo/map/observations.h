// What the estimator (initializer and back end) sees of one rig frame: per
// camera, the tracked features as pixels and unit bearing vectors
// (Camera::Unproject), plus features of one camera found again in another
// camera of the same frame (overlapping views). Built from the frontend's
// MultiCameraFrame by the pipeline; the estimator never touches images or
// camera models, so every camera model (fisheyes beyond 90 deg included)
// is handled the same way. Data only, in module map (below initializer,
// backend, loop and pipeline, which share it).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace mcvo {

struct FeatureObservation {
  uint64_t id = 0;  // the frontend's feature id: unique over all cameras and frames
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();  // unit vector in the camera frame
};

// Feature `id` of camera `camera_a` (listed in cameras[camera_a] of the same
// frame) seen by camera `camera_b` at `bearing_b`.
struct CrossCameraObservation {
  int camera_a = 0;
  uint64_t id = 0;
  int camera_b = 0;
  Eigen::Vector2d pixel_b = Eigen::Vector2d::Zero();
  Eigen::Vector3d bearing_b = Eigen::Vector3d::UnitZ();
};

struct RigFrameObservations {
  int frame_index = 0;  // position in the input sequence
  int64_t t_ns = 0;
  // One entry per rig camera, in rig order; a camera with no image has an
  // empty list and camera_missing[c] = true.
  std::vector<std::vector<FeatureObservation>> cameras;
  std::vector<bool> camera_missing;
  std::vector<CrossCameraObservation> cross_camera;
};

}  // namespace mcvo
