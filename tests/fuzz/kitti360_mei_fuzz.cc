// libFuzzer target: the KITTI-360 fisheye calibration image_02.yaml /
// image_03.yaml (OpenCV-style YAML, MEI model) -> ReadMeiYaml
// (src/dataset/kitti360_calib.cc, yaml-cpp through src/dataset/yaml_util.cc).
// Contract (docs/fuzzing.md): a camera with usable parameters or an
// InputError naming the file; no yaml-cpp exception escapes.
#include <cstdlib>
#include <string>

#include "fuzz/fuzz_util.h"
#include "kitti360_calib.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::filesystem::path path = mcvo::fuzz::ScratchDir("kitti360_mei") / "image_02.yaml";
  mcvo::fuzz::WriteBytes(path, data, size);
  mcvo::fuzz::ExpectOnlyInputErrors(path.string(), [&] {
    const mcvo::Camera camera = mcvo::kitti360::ReadMeiYaml(path, "image_02");
    if (camera.params.size() != 9 || camera.width < 1 || camera.height < 1) std::abort();
  });
  return 0;
}
