// `mcvo run`: one command from a dataset (images, or a track file made by
// `mcvo track`) to a metric trajectory and everything needed to trust it.
//
// Stages: images are decoded in background threads (FrameStream), the
// frontend tracks all cameras of a frame in parallel (MultiCameraTracker),
// and the estimator (backend/estimator.h) runs on its own thread, one frame
// behind the frontend. Each stage is deterministic and frames pass between
// them in order, so the outputs are identical at any thread count.
//
// Outputs (docs/run-outputs.md): written into "<out>.tmp-<pid>" and renamed
// to <out> when complete, so a run that fails leaves no output folder that
// looks finished.
//   trajectory.tum / trajectory_kitti.txt / trajectory_euroc.csv  every posed frame
//   keyframes.tum        keyframe poses when they left the window
//   scale_log.csv        initialisations, scale corrections, tracking losses
//   frame_stats.csv      per frame: state, features and landmarks per camera, BA
//   timing.csv           per frame wall time of each stage (NOT deterministic)
//   run.json             resolved config, version, input and output hashes, timings
//   eval/                `mcvo eval` outputs when the dataset has ground truth
// Every file except timing.csv and run.json's "timing" section is
// byte-identical for the same inputs and config, at any thread count.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "mcvo/config/pipeline_options.h"
#include "mcvo/dataset/dataset.h"

namespace mcvo {

struct RunRequest {
  DatasetOptions dataset;
  std::filesystem::path tracks;  // optional: a track file of the same dataset (no image is decoded)
  std::filesystem::path out_dir;
  bool force = false;         // replace a non-empty output folder
  PipelineOptions options;    // checked
  std::string config_source;  // config file path, or "built-in defaults"
  std::filesystem::path config_path;  // the config file read, empty for the built-in defaults
  int max_frames = 0;         // 0: all
  std::string command_line;   // for run.json
  std::string version;        // program version, for run.json
};

struct RunSummary {
  int frames = 0;
  int posed_frames = 0;
  int keyframes = 0;
  int segments = 1;
  // Segments after the first located in the previous one's map
  // (loop.relocalise); the others are linked by constant velocity.
  int segments_relocalised = 0;
  double seconds = 0.0;
  double frames_per_second = 0.0;
  bool evaluated = false;
  double ate_rmse_m = 0.0;
  double ate_percent_of_path = 0.0;
  double scale_error_percent = 0.0;
  double gt_path_length_m = 0.0;
  // A one-camera rig: the trajectory's unit is arbitrary (estimator.h
  // "Monocular"); the evaluation then aligns with a similarity (alignment),
  // scale_error_percent is not an error, and unit_m is the metres in one
  // unit (the Sim3 scale).
  bool scale_arbitrary = false;
  AlignmentMode alignment = AlignmentMode::kSe3;  // of the evaluation
  double unit_m = 0.0;
  int loops_accepted = 0;
  // Set when fewer than half of the frames are posed: one line with the
  // reason (RunPosingWarning). Logged, in run.json ("result"/"warning") and
  // the report; `mcvo run` exits with kExitNothingPosed when no frame is posed.
  std::string warning;
};

// The warning for a run that posed `posed` of
// `frames` frames (empty when at least half are posed), naming the most
// frequent reason the unposed frames waited for: the rig never moved, never
// turned without overlapping views, tracking lost, too few features or cameras.
std::string RunPosingWarning(int frames, int posed, const std::vector<std::string>& unposed_reasons);
// The category of one waiting reason that a user can act on ("tracking
// lost", kScaleNeverObservable, ...), and the most frequent category of a
// list ("unknown" for an empty one).
inline constexpr const char* kScaleNeverObservable =
    "the metric scale was never observable (the rig did not turn, and no overlapping cameras matched enough "
    "features)";
std::string PosingFailureCategory(const std::string& reason);
std::string MostFrequentPosingFailure(const std::vector<std::string>& unposed_reasons);

// The dataset as `mcvo run` uses it (OpenDataset; a one-camera rig's origin
// moved to the camera's centre, the ground truth with it: run.cc
// MonocularIndex). Its rig is what run.json's input hash covers.
DatasetIndex OpenRunDataset(const DatasetOptions& options);

// Runs the pipeline. Bad input throws InputError / UsageError naming the file
// and field; nothing is left at out_dir then.
RunSummary RunPipeline(const RunRequest& request);

// The "inputs" section of run.json as (key, SHA-256 hex) pairs in the order
// written: "rig_sha256" (the rig as used), then "tracks_sha256" (the track
// file) or "images_sha256" (one hash over the per-image hashes of the first
// `frames` frames, in frame and camera order; "missing" for a missing image).
// Reads the input files but decodes nothing, so `mcvo batch` can tell
// whether a finished run is up to date without running it again.
// Then "dataset_sha256": everything else of the dataset that changes a
// result, as read (HashDatasetContent). Then "vocabulary_sha256" when
// `vocabulary` is not empty (loop closure's bag-of-words vocabulary:
// RunVocabularyPath). The images are hashed on `threads` threads (0: all
// cores); the hashes do not depend on it.
std::vector<std::pair<std::string, std::string>> HashRunInputs(const DatasetIndex& index,
                                                               const std::filesystem::path& tracks,
                                                               int frames,
                                                               const std::filesystem::path& vocabulary = {},
                                                               int threads = 1);

// One hash over what a dataset gives a run besides its rig and its image
// files: the frame times and which images are missing (of the first
// `frames` frames), the ground truth (every time and pose, at full
// precision) and the camera masks (their pixels). Editing groundtruth.tum,
// shifting times in frames.csv or editing a mask changes it.
std::string HashDatasetContent(const DatasetIndex& index, int frames);

// The vocabulary file a run with these options reads: empty when loop
// closure is off, the built-in one when none is configured.
std::filesystem::path RunVocabularyPath(const PipelineOptions& options);

}  // namespace mcvo
