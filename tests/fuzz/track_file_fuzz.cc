// libFuzzer target: binary track file -> TrackFileReader (header and every
// frame; src/frontend/track_file.cc). Contract (docs/fuzzing.md): frames or
// an InputError naming the file and the byte offset; a frame has one block
// per header camera.
#include <cstdlib>
#include <optional>
#include <string>

#include "fuzz/fuzz_util.h"
#include "mcvo/frontend/track_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::filesystem::path path = mcvo::fuzz::ScratchDir("track_file") / "tracks.bin";
  mcvo::fuzz::WriteBytes(path, data, size);
  mcvo::fuzz::ExpectOnlyInputErrors(path.string(), [&] {
    mcvo::TrackFileReader reader(path);
    const size_t cameras = reader.header().camera_names.size();
    while (const std::optional<mcvo::MultiCameraFrame> frame = reader.Next()) {
      if (frame->cameras.size() != cameras) std::abort();
    }
  });
  return 0;
}
