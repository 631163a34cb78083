// The dataset flags shared by the subcommands that open a dataset (`mcvo
// info`, `mcvo track`, ...): --dataset, --format, --sequence, --cameras,
// --skip-incomplete, and for ROS bags --calib, --topics, --gt-topic, --gt,
// parsed into DatasetOptions the same way everywhere.
#pragma once

#include <string>

#include "mcvo/dataset/dataset.h"
#include "mcvo/util/args.h"

namespace mcvo::tools {

struct DatasetArgs {
  std::string root;
  std::string format = "auto";
  std::string sequence;
  std::string cameras;  // comma-separated names; empty: all
  bool skip_incomplete = false;
  std::string calib;     // rosbag: camchain.yaml or rig.json
  std::string topics;    // rosbag: camera=topic,...
  std::string gt_topic;  // rosbag: ground-truth pose topic
  std::string gt;        // rosbag: ground-truth trajectory file
};

// The flags besides --dataset, for commands that reject them without it.
inline constexpr const char* kDatasetDetailFlags[] = {"format", "sequence", "cameras",  "skip-incomplete",
                                                      "calib",  "topics",   "gt-topic", "gt"};

// Adds the dataset flags to `args`, writing into *values.
void AddDatasetArgs(ArgParser* args, DatasetArgs* values, bool dataset_required);

// DatasetOptions from the parsed flags (the other fields keep their defaults).
DatasetOptions MakeDatasetOptions(const DatasetArgs& values);

}  // namespace mcvo::tools
