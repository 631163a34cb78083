// The sparse reconstruction a run leaves behind: keyframe rig poses, the 2-D
// observations of every camera of each keyframe, and the landmarks they
// observe, in one world frame. The estimator produces it (keyframes and
// landmarks as they leave the window, or at the end), the COLMAP exporter
// (colmap/colmap_model.h) and loop closure read it. Data only (module
// map, below backend, colmap and loop).
//
// Conventions: poses are world_from_rig (the rig frame of rig.json), pixel
// coordinates are OpenCV's (the centre of the top-left pixel is (0, 0));
// the COLMAP writer converts to COLMAP's (0.5, 0.5).
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

struct MapObservation {
  int camera = 0;            // index into Rig::cameras
  int64_t landmark_id = 0;   // MapLandmark::id
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

struct MapKeyframe {
  int frame_index = 0;  // position in the dataset's frame list
  int64_t t_ns = 0;
  int segment = 0;       // tracking segment (a re-initialisation starts a new one)
  Rigid3d world_from_rig;
  // Image of each rig camera at this frame (as the dataset lists it: absolute,
  // or relative to the dataset root); an empty path: the camera had no image.
  // May be empty altogether (a run from a track file without the dataset).
  std::vector<std::filesystem::path> images;
  // Observations of landmarks in SparseMap::landmarks, in camera then
  // landmark-id order. Only landmarks the bundle adjustment used.
  std::vector<MapObservation> observations;
};

struct MapLandmark {
  int64_t id = 0;  // unique over the run; ascending in SparseMap::landmarks
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
};

struct SparseMap {
  std::vector<MapKeyframe> keyframes;  // ascending frame_index
  std::vector<MapLandmark> landmarks;  // ascending id
};

}  // namespace mcvo
