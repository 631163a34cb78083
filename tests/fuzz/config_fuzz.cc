// libFuzzer target: pipeline config JSON text -> ParsePipelineOptions
// (src/config/config.cc). Contract (docs/fuzzing.md): returns options or
// throws InputError (UsageError) naming the source; options that parse
// write back (PipelineOptionsToJson) to text that parses to the same text.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "fuzz/fuzz_util.h"
#include "mcvo/config/config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mcvo::fuzz::ExpectOnlyInputErrors("fuzz/config.json", [&] {
    const mcvo::PipelineOptions options = mcvo::ParsePipelineOptions(text, "fuzz/config.json");
    const std::string written = mcvo::PipelineOptionsToJson(options);
    const mcvo::PipelineOptions again = mcvo::ParsePipelineOptions(written, "fuzz/config.json");
    if (mcvo::PipelineOptionsToJson(again) != written) {
      std::fprintf(stderr, "config round trip changed the options:\n%s\n", written.c_str());
      std::abort();
    }
  });
  return 0;
}
