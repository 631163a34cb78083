// Private: synchronisation of per-camera image time stamps into rig frames,
// shared by the EuRoC and Kalibr readers.
//
// The first camera leads: every one of its images proposes a frame at its
// time. For each other camera, the image nearest in time is taken when
// |dt| <= tolerance and the match is mutual (that image's nearest lead time
// is this frame), so one image never serves two frames. A frame where some
// camera has no match is kept with that camera's path empty
// (MissingImagePolicy::kMarkMissing) or dropped (kSkipFrame). Images of the
// other cameras that match no lead time are counted and reported.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mcvo/dataset/dataset.h"

namespace mcvo::dataset_internal {

struct CameraImages {
  std::string name;
  std::vector<int64_t> t_ns;                  // strictly increasing
  std::vector<std::filesystem::path> images;  // same size as t_ns
};

struct SyncResult {
  std::vector<DatasetFrame> frames;
  std::vector<std::string> log;  // one line per camera and a summary
};

// cameras[0] leads. Needs at least one camera.
SyncResult SynchronizeCameras(const std::vector<CameraImages>& cameras, double tolerance_s,
                              MissingImagePolicy policy);

}  // namespace mcvo::dataset_internal
