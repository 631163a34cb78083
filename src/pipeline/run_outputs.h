// The output stage of `mcvo run` (private to pipeline/): from the odometry,
// relocalisation and loop closure results, every file of a run
// (docs/run-outputs.md) written into the staging folder: trajectories
// (final; the odometry's and the pose graph's when loop closure or the
// global bundle adjustment changed them), keyframes,
// scale_log.csv, frame_stats.csv, timing.csv, loops.csv, the evaluation
// against ground truth, the COLMAP model, report.html/md and run.json (with
// the SHA-256 of every other output).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "loop_stage.h"
#include "mcvo/config/pipeline_options.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/map/sparse_map.h"
#include "mcvo/pipeline/frame_source.h"
#include "mcvo/pipeline/run.h"
#include "odometry_stage.h"
#include "refine_stage.h"
#include "relocalise_segments.h"

namespace mcvo::pipeline_internal {

// The run's sparse map: keyframes in frame order with their images and the
// observations of landmarks that have a final position and lie within
// twice the back end's outlier threshold of it (*dropped counts the
// others), the landmarks they observe in id order.
SparseMap BuildSparseMap(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                         const std::map<int64_t, Eigen::Vector3d>& landmarks, const BackendOptions& backend,
                         int* dropped);

// What the output stage reads. Pointers: owned by RunPipeline, not null.
struct RunOutputsInput {
  const RunRequest* request = nullptr;
  const DatasetIndex* index = nullptr;   // as posed (after the monocular fallback: its one camera)
  const DatasetIndex* opened = nullptr;  // as opened: the inputs hashed in run.json (index when null)
  int threads = 1;
  int total_frames = 0;
  std::filesystem::path vocabulary_path;  // empty: loop closure off
  std::filesystem::path final_dir;        // where the staging folder will be moved (named in logs)
  const OdometryOutput* odometry = nullptr;
  const LoopOutcome* loops = nullptr;  // when loop closure ran
  const OdometryBeforeLoops* before_loops = nullptr;
  const RefineOutcome* refine = nullptr;  // the global bundle adjustment stage
  const SparseMap* map = nullptr;
  int map_observations_dropped = 0;
  double odometry_seconds = 0.0;
  // The frontend's stages when images were tracked (null for a track file).
  const FrontendStageSeconds* frontend_stages = nullptr;
  // run.json's "inputs" (HashRunInputs of `opened`), hashed before the run
  // read anything.
  const std::vector<std::pair<std::string, std::string>>* inputs = nullptr;
};

// Writes every output into `dir` and sets summary's evaluation fields
// (frames, poses, warning and timing must be set already).
void WriteRunOutputs(const RunOutputsInput& in, const std::filesystem::path& dir, RunSummary* summary);

}  // namespace mcvo::pipeline_internal
