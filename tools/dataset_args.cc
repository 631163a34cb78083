#include "dataset_args.h"

#include <string_view>

#include "mcvo/util/strings.h"

namespace mcvo::tools {

void AddDatasetArgs(ArgParser* args, DatasetArgs* values, bool dataset_required) {
  args->AddString("dataset", &values->root, "DIR", "dataset folder (any layout, docs/datasets.md)",
                  dataset_required);
  args->AddString("format", &values->format, "F", "dataset layout: auto, generic, kitti360, kitti, euroc, kalibr");
  args->AddString("sequence", &values->sequence, "S", "sequence of a multi-sequence dataset (kitti360; kitti: NN)");
  args->AddString("cameras", &values->cameras, "A,B",
                  "subset and order of the cameras (names); default: all");
  args->AddFlag("skip-incomplete", &values->skip_incomplete,
                "drop frames where a camera has no image (default: keep them, that camera marked missing)");
}

DatasetOptions MakeDatasetOptions(const DatasetArgs& values) {
  DatasetOptions options;
  options.root = values.root;
  options.format = values.format;
  options.sequence = values.sequence;
  if (!values.cameras.empty()) {
    for (const std::string_view field : SplitFields(values.cameras, ',')) options.cameras.emplace_back(field);
  }
  options.missing_images =
      values.skip_incomplete ? MissingImagePolicy::kSkipFrame : MissingImagePolicy::kMarkMissing;
  return options;
}

}  // namespace mcvo::tools
