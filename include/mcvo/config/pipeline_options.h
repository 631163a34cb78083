// The pipeline options tree: one struct per component, defaults in code, a
// Check() that throws InputError naming the bad field by its JSON path in the
// config file ("/frontend/max_features_pinhole: must be > 0, got -3").
//
// A component that exists owns its options struct (eval: EvalOptions in
// eval/evaluate.h); the structs of components still to be built live here
// and move next to their component when it lands, so that this header then
// only composes them. JSON parsing and writing is in config/config.h, the
// only place that knows config JSON; the config module sits above the
// components so that it can read every component's own struct. Every key, its default and
// its meaning: docs/config.md. Defaults follow the published implementation
// (../shared/reference/mcvo-reference-notes.md) unless said otherwise.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "mcvo/backend/backend_options.h"
#include "mcvo/colmap/colmap_model.h"
#include "mcvo/eval/evaluate.h"
#include "mcvo/frontend/frontend_options.h"
#include "mcvo/initializer/initializer.h"
#include "mcvo/loop/loop_closer.h"
#include "mcvo/loop/pose_graph.h"
#include "mcvo/refine/global_ba.h"
#include "mcvo/util/enum_names.h"

namespace mcvo {

inline constexpr EnumName<AlignmentMode> kAlignmentModeNames[] = {{AlignmentMode::kSe3, "se3"},
                                                                  {AlignmentMode::kSim3, "sim3"},
                                                                  {AlignmentMode::kPosYaw, "posyaw"},
                                                                  {AlignmentMode::kNone, "none"}};

// Which cameras of the dataset's rig the pipeline uses (a preset for the
// 3-camera KITTI-360 rig names them); `--cameras` on the command line wins.
struct DatasetSelectionOptions {
  std::vector<std::string> cameras;  // names, in the order to use; empty ("all" in JSON): every camera

  void Check() const;
};

// Loop closure (loop/loop_closer.h, loop/pose_graph.h): the component's own
// options, and where its vocabulary comes from.
struct LoopOptions {
  bool enabled = true;
  std::string vocabulary_path;  // empty: the built-in vocabulary (DefaultVocabularyPath())
  // Relocalisation after a tracking loss (pipeline/relocalise_segments.h;
  // needs `enabled`, it uses the same vocabulary, features and rig PnP):
  // each later segment's first `relocalise_query_keyframes` keyframes are
  // located in the map of the previous segment's last
  // `relocalise_map_keyframes` keyframes; otherwise the constant-velocity
  // link stays.
  bool relocalise = true;
  int relocalise_map_keyframes = 10;
  int relocalise_query_keyframes = 5;
  // Memory for the keyframes `mcvo run` describes from the frontend's
  // decode during the odometry (pipeline/loop_image_cache.h: ORB features
  // and colours, about 0.1-0.2 MB per keyframe of 4 cameras); keyframes
  // beyond it are read from their files again by the loop stage. The
  // outputs are the same either way. 0: every keyframe is read again.
  int frontend_cache_mb = 1024;
  LoopClosureOptions closure;   // keys directly under /loop
  PoseGraphOptions pose_graph;  // /loop/pose_graph

  void Check() const;
};

// config/vocabulary_orb.bin of the source tree (docs/loop-closure.md).
std::string DefaultVocabularyPath();

// What `mcvo run` writes besides the trajectories, logs and run.json
// (docs/run-outputs.md).
struct OutputOptions {
  bool report = true;  // report.html and report.md
  void Check() const {}
};

// The COLMAP model of a run's keyframes and landmarks (colmap/ in the run
// folder; docs/colmap-export.md). The export's own options; its threads
// come from /runtime/threads and the run replaces its own folder.
struct ColmapOutputOptions {
  bool enabled = true;
  ColmapExportOptions export_options;
  void Check() const;
};

struct RuntimeOptions {
  int threads = 0;  // 0: hardware concurrency
  int64_t seed = 0;
  bool deterministic = true;

  void Check() const;
};

struct PipelineOptions {
  DatasetSelectionOptions dataset;
  FrontendOptions frontend;
  InitializerOptions initializer;
  BackendOptions backend;
  LoopOptions loop;
  GlobalBaOptions refine;  // the component's own options (refine/global_ba.h)
  OutputOptions output;
  ColmapOutputOptions colmap;
  RuntimeOptions runtime;
  EvalOptions eval;  // the component's own options (eval/evaluate.h)

  // Checks every section and the constraints between sections.
  void Check() const;
};

}  // namespace mcvo
