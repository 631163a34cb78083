#include "dataset_args.h"

#include <string_view>

#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::tools {

void AddDatasetArgs(ArgParser* args, DatasetArgs* values, bool dataset_required) {
  args->AddString("dataset", &values->root, "DIR",
                  "dataset folder (any layout, docs/datasets.md) or ROS bag (*.bag)", dataset_required);
  args->AddString("format", &values->format, "F",
                  "dataset layout: auto, generic, kitti360, kitti, euroc, kalibr, rosbag");
  args->AddString("sequence", &values->sequence, "S",
                  "sequence of a multi-sequence dataset (kitti360; kitti: NN)");
  args->AddString("cameras", &values->cameras, "A,B",
                  "subset and order of the cameras (names); default: all");
  args->AddFlag("skip-incomplete", &values->skip_incomplete,
                "drop frames where a camera has no image (default: keep them, that camera marked missing)");
  args->AddString("calib", &values->calib, "FILE",
                  "ROS bag: its calibration, a Kalibr camchain.yaml or a rig.json");
  args->AddString("topics", &values->topics, "CAM=TOPIC,...",
                  "ROS bag: image topic per camera (default: the camchain's rostopic, else /CAM/image_raw)");
  args->AddString("gt-topic", &values->gt_topic, "TOPIC",
                  "ROS bag: ground truth from a PoseStamped, TransformStamped or Odometry topic");
  args->AddString("gt", &values->gt, "FILE",
                  "ROS bag: ground truth from a trajectory file (TUM, EuRoC CSV, ...)");
}

DatasetOptions MakeDatasetOptions(const DatasetArgs& values) {
  DatasetOptions options;
  options.root = values.root;
  options.format = values.format;
  options.sequence = values.sequence;
  if (!values.cameras.empty()) {
    for (const std::string_view field : SplitFields(values.cameras, ',')) options.cameras.emplace_back(field);
  }
  options.calib = values.calib;
  options.gt_topic = values.gt_topic;
  options.gt_file = values.gt;
  if (!values.topics.empty()) {
    for (const std::string_view field : SplitFields(values.topics, ',')) {
      const size_t eq = field.find('=');
      if (eq == std::string_view::npos || eq == 0 || eq + 1 == field.size())
        throw UsageError(StrCat("--topics: expected CAM=TOPIC, got '", field, "'"));
      options.topics.emplace_back(std::string(field.substr(0, eq)), std::string(field.substr(eq + 1)));
    }
  }
  options.missing_images =
      values.skip_incomplete ? MissingImagePolicy::kSkipFrame : MissingImagePolicy::kMarkMissing;
  return options;
}

}  // namespace mcvo::tools
