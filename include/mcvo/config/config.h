// JSON config files of the pipeline options tree (mcvo/config/pipeline_options.h).
// This is the only place that knows the config's JSON form; docs/config.md
// lists every key.
#pragma once

#include <filesystem>
#include <string>

#include "mcvo/config/pipeline_options.h"

namespace mcvo {

// Reads a config: keys that are missing keep their defaults; unknown keys
// (at any depth; the message lists the valid keys there), values of the
// wrong type and values that fail Check() throw InputError
// "<path>: <JSON path>: <what is wrong>".
PipelineOptions ReadPipelineOptions(const std::filesystem::path& path);
// As ReadPipelineOptions, from JSON text; `source` names it in errors.
PipelineOptions ParsePipelineOptions(const std::string& json_text, const std::string& source);

// The resolved config: every key, in a fixed order, pretty printed, ending
// with a newline. ParsePipelineOptions(PipelineOptionsToJson(o)) == o.
std::string PipelineOptionsToJson(const PipelineOptions& options);
// Writes PipelineOptionsToJson atomically.
void WritePipelineOptions(const std::filesystem::path& path, const PipelineOptions& options);

}  // namespace mcvo
