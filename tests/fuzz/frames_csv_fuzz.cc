// libFuzzer target: frames.csv text -> ParseFrameTable (src/io/frame_table.cc),
// the frame table of the generic dataset layout. Contract (docs/fuzzing.md):
// returns a table or throws InputError naming the source; a table that
// parses has one path per camera in every row and increasing times.
#include <cstdlib>
#include <string>

#include "fuzz/fuzz_util.h"
#include "mcvo/io/frame_table.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mcvo::fuzz::ExpectOnlyInputErrors("fuzz/frames.csv", [&] {
    const mcvo::FrameTable table = mcvo::ParseFrameTable(text, "fuzz/frames.csv");
    for (size_t i = 0; i < table.rows.size(); ++i) {
      if (table.rows[i].image_paths.size() != table.camera_names.size()) std::abort();
      if (i > 0 && table.rows[i].t_ns <= table.rows[i - 1].t_ns) std::abort();
    }
  });
  return 0;
}
