// `mcvo run`: dataset (or track file) -> metric trajectory, scale log, stats,
// evaluation (pipeline/run.h; outputs: docs/run-outputs.md).
#include <optional>
#include <string>

#include "command.h"
#include "dataset_args.h"
#include "mcvo/config/config.h"
#include "mcvo/pipeline/run.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"

namespace mcvo::tools {
namespace {

int RunRun(int argc, const char* const* argv) {
  DatasetArgs dataset;
  std::string config_path, tracks_path, out_path, model_path, detector_name;
  int threads = -1;
  int max_frames = 0;
  bool force = false;
  ArgParser args(
      "mcvo run",
      "Runs the whole pipeline on a dataset: frontend, metric initialisation, sliding-window bundle\n"
      "adjustment with scale correction. Writes trajectories, the scale log, per-frame statistics,\n"
      "run.json and, when the dataset has ground truth, the evaluation.");
  AddDatasetArgs(&args, &dataset, /*dataset_required=*/true);
  args.AddString("config", &config_path, "FILE",
                 "pipeline config (docs/config.md; presets in config/); default: built-in defaults");
  args.AddString("tracks", &tracks_path, "FILE",
                 "replay a track file of `mcvo track` instead of tracking the images");
  args.AddString("detector", &detector_name, "NAME",
                 "shi_tomasi | orb | xfeat | superpoint (overrides the config)");
  args.AddString("model", &model_path, "FILE", "ONNX model of xfeat / superpoint (overrides the config)");
  args.AddInt("threads", &threads,
              "worker threads; 0: all cores (overrides the config; results do not depend on it)");
  args.AddInt("frames", &max_frames, "run the first N frames only; 0: all");
  args.AddString("out", &out_path, "DIR", "output folder (must not exist or be empty, unless --force)", true);
  args.AddFlag("force", &force, "replace a non-empty output folder");
  args.AddEpilog(
      "Outputs (docs/run-outputs.md) are complete or absent, and identical at any thread count\n"
      "(except timing.csv and the timing section of run.json).\n"
      "example: mcvo run --dataset seq/kitti360 --config config/kitti360_4cam.json --out runs/k360\n");
  if (!args.Parse(argc, argv)) return kExitOk;
  if (args.WasGiven("threads") && threads < 0) throw UsageError("--threads: must be >= 0");
  if (max_frames < 0) throw UsageError("--frames: must be >= 0");

  RunRequest request;
  request.options = config_path.empty() ? PipelineOptions() : ReadPipelineOptions(config_path);
  request.config_source = config_path.empty() ? "built-in defaults" : config_path;
  request.config_path = config_path;
  if (!detector_name.empty()) {
    const std::optional<DetectorType> detector = EnumFromName(kDetectorTypeNames, detector_name);
    if (!detector) {
      throw UsageError(StrCat("--detector: unknown value '", detector_name,
                              "' (known: ", EnumNameList(kDetectorTypeNames), ")"));
    }
    request.options.frontend.detector = *detector;
  }
  if (!model_path.empty()) request.options.frontend.model_path = model_path;
  if (threads >= 0) request.options.runtime.threads = threads;
  request.options.Check();
  request.dataset = MakeDatasetOptions(dataset);
  request.tracks = tracks_path;
  request.out_dir = out_path;
  request.force = force;
  request.max_frames = max_frames;
  request.version = MCVO_VERSION;
  for (int i = 0; i < argc; ++i) request.command_line += (i > 0 ? " " : "") + std::string(argv[i]);
  const ScopedStage stage("run --out " + out_path);
  const RunSummary summary = RunPipeline(request);
  return summary.posed_frames > 0 ? kExitOk : kExitNothingPosed;
}

const CommandRegistrar kRegistrar("run", {"run the pipeline on a dataset: trajectory, scale log, evaluation",
                                          RunRun});

}  // namespace
}  // namespace mcvo::tools
