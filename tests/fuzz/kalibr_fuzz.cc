// libFuzzer target: Kalibr camchain.yaml -> ReadKalibrDataset
// (src/dataset/kalibr_reader.cc, YAML helpers in src/dataset/yaml_util.cc).
// The input is the camchain.yaml of a dataset folder that has no images, so
// a camchain that parses ends in "image folder missing" (an InputError too).
// Contract (docs/fuzzing.md): only InputError / UsageError naming the file
// (no yaml-cpp exception escapes).
#include <string>

#include "fuzz/fuzz_util.h"
#include "mcvo/dataset/dataset.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::filesystem::path& root = mcvo::fuzz::ScratchDir("kalibr");
  mcvo::fuzz::WriteBytes(root / "camchain.yaml", data, size);
  mcvo::DatasetOptions options;
  options.root = root;
  options.format = "kalibr";
  mcvo::fuzz::ExpectOnlyInputErrors(root.string(), [&] { mcvo::ReadKalibrDataset(options); });
  return 0;
}
