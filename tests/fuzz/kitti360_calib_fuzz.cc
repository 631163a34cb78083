// libFuzzer target: the KITTI-360 "KEY: values" calibration files
// (calib_cam_to_pose.txt, perspective.txt) and timestamps.txt, through the
// helpers the reader uses (src/dataset/kitti360_calib.cc): every input is
// read as each of them. Contract (docs/fuzzing.md): only InputError naming
// the file; every rotation that is read is orthonormal.
#include <cmath>
#include <cstdlib>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fuzz/fuzz_util.h"
#include "kitti360_calib.h"

namespace {

void CheckRotation(const Eigen::Matrix3d& r) {
  if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-9)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace kitti360 = mcvo::kitti360;
  const std::filesystem::path& dir = mcvo::fuzz::ScratchDir("kitti360_calib");
  const std::filesystem::path path = dir / "calib.txt";
  mcvo::fuzz::WriteBytes(path, data, size);
  std::optional<kitti360::KeyValueFile> file;
  mcvo::fuzz::ExpectOnlyInputErrors(path.string(), [&] { file.emplace(path); });
  if (file) {
    // calib_cam_to_pose.txt
    for (const std::string& camera : kitti360::kCameraNames) {
      mcvo::fuzz::ExpectOnlyInputErrors(path.string(), [&] {
        CheckRotation(kitti360::ReadPoseFromCam(*file, camera).rotation.toRotationMatrix());
      });
    }
    // perspective.txt
    for (const char* key : {"R_rect_00", "R_rect_01"}) {
      mcvo::fuzz::ExpectOnlyInputErrors(path.string(),
                                        [&] { CheckRotation(kitti360::ReadRectRotation(*file, key)); });
    }
    for (const auto& entry : {std::pair<const char*, size_t>{"S_rect_00", 2},
                              {"P_rect_00", 12},
                              {"S_rect_01", 2},
                              {"P_rect_01", 12}}) {
      mcvo::fuzz::ExpectOnlyInputErrors(path.string(), [&] {
        if (file->Has(entry.first) && file->Numbers(entry.first, entry.second).size() != entry.second)
          std::abort();
      });
    }
  }
  // timestamps.txt
  mcvo::fuzz::ExpectOnlyInputErrors(path.string(), [&] {
    const std::vector<int64_t> times = kitti360::ReadTimestamps(path);
    for (size_t i = 1; i < times.size(); ++i) {
      if (times[i] <= times[i - 1]) std::abort();
    }
  });
  return 0;
}
