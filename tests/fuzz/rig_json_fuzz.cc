// libFuzzer target: rig.json text -> ParseRigJson (src/io/rig_io.cc).
// Contract (docs/fuzzing.md): returns a rig or throws InputError naming the
// source; a rig that parses writes back (RigToJson) to text that parses to
// the same text again (docs/rig-json.md: the round trip is exact).
#include <cstdio>
#include <cstdlib>
#include <string>

#include "fuzz/fuzz_util.h"
#include "mcvo/io/rig_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  // Relative mask paths resolve against a folder that does not exist.
  const std::filesystem::path base_dir = "/nonexistent/mcvo_fuzz";
  mcvo::fuzz::ExpectOnlyInputErrors("fuzz/rig.json", [&] {
    const mcvo::Rig rig = mcvo::ParseRigJson(text, "fuzz/rig.json", base_dir);
    const std::string written = mcvo::RigToJson(rig, base_dir);
    const mcvo::Rig again = mcvo::ParseRigJson(written, "fuzz/rig.json", base_dir);
    if (mcvo::RigToJson(again, base_dir) != written) {
      std::fprintf(stderr, "rig.json round trip changed the rig:\n%s\n", written.c_str());
      std::abort();
    }
  });
  return 0;
}
