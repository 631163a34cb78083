// `mcvo config [--config FILE] [--out FILE]`: validates a config and prints
// (or writes) the resolved config, every key with its value (docs/config.md).
#include <iostream>
#include <string>

#include "command.h"
#include "mcvo/config/config.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"

namespace mcvo::tools {
namespace {

int RunConfig(int argc, const char* const* argv) {
  std::string config_path;
  std::string out_path;
  ArgParser args(
      "mcvo config",
      "Validates a config file and prints the resolved config (the defaults overlaid with the file).");
  args.AddString("config", &config_path, "FILE", "config to validate; without it the defaults are printed");
  args.AddString("out", &out_path, "FILE", "write the resolved config here instead of printing it");
  args.AddEpilog("example: mcvo config --config my.json --out resolved.json\n");
  if (!args.Parse(argc, argv)) return kExitOk;
  const PipelineOptions options = config_path.empty() ? PipelineOptions() : ReadPipelineOptions(config_path);
  if (config_path.empty()) options.Check();
  if (out_path.empty()) {
    std::cout << PipelineOptionsToJson(options);
  } else {
    WritePipelineOptions(out_path, options);
  }
  return kExitOk;
}

const CommandRegistrar kRegistrar("config", {"validate a config and print the resolved options", RunConfig});

}  // namespace
}  // namespace mcvo::tools
