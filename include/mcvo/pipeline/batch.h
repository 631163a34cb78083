// `mcvo batch`: many runs of `mcvo run` from one manifest, in-process, N at a
// time, resumable, shardable over machines, with one summary table.
//
//   const BatchManifest manifest = ReadBatchManifest("runs.json");
//   BatchOptions options;  options.out_dir = "runs";  options.jobs = 2;
//   const BatchReport report = RunBatch(manifest, options);  // never throws for one bad run
//   WriteBatchSummary(options.out_dir, report);                // summary.csv, summary.md
//
// Layout of the output folder (docs/batch-and-regress.md):
//   <out>/<name>/                the run's folder, as `mcvo run --out` writes it
//   <out>/summary.csv, summary.md one row per run of the manifest, in manifest order
//   <out>/.batch/runs/<name>.json the status of the last attempt at that run
//                                 (ok, skipped, failed and why, not run when
//                                 it was cancelled): what a later
//                                 `--summary-only` gathers from all shards
//   <out>/.batch/summary_shard_K_of_N.{csv,md}  the summary of one shard
//
// Resuming: a run whose folder holds a finished run.json with the same
// resolved config (the thread count aside), frame count and input hashes
// (HashRunInputs: rig, images or track file) and whose listed outputs are all
// there with their recorded SHA-256, is skipped. Computing the input hashes
// reads the input files once; nothing is decoded or run.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mcvo/config/pipeline_options.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/util/cancel.h"

namespace mcvo {

// One run of the manifest. Paths are already resolved against the manifest's
// folder (absolute paths are kept).
struct BatchRunSpec {
  std::string name;              // unique; a safe folder name
  DatasetOptions dataset;        // root, format, sequence, cameras, missing-image policy
  std::filesystem::path config;  // pipeline config; empty: built-in defaults
  std::filesystem::path tracks;  // optional track file of `mcvo track`
  int max_frames = 0;            // 0: all
  int threads = -1;              // -1: not given (the config's runtime.threads)
};

struct BatchManifest {
  std::filesystem::path path;  // the manifest file (for messages)
  std::vector<BatchRunSpec> runs;
};

// Reads and validates a manifest (format in docs/batch-and-regress.md).
// Every error is one InputError line "<file>: <JSON path>: <what is wrong>".
BatchManifest ReadBatchManifest(const std::filesystem::path& path);
// As ReadBatchManifest from text; relative paths are resolved against base_dir.
BatchManifest ParseBatchManifest(const std::string& json_text, const std::string& source,
                                 const std::filesystem::path& base_dir);

// `--shard K/N`: this process takes the runs whose 0-based manifest index i
// has i % N == K (K in [0, N), as $SLURM_ARRAY_TASK_ID with --array=0-(N-1)).
struct BatchShard {
  int index = 0;
  int count = 1;
  bool Contains(int run_index) const { return run_index % count == index; }
};
// Parses "K/N"; throws UsageError naming `--shard`.
BatchShard ParseBatchShard(const std::string& text);

struct BatchOptions {
  std::filesystem::path out_dir;
  int jobs = 1;               // runs at the same time
  BatchShard shard;           // which runs this process takes
  bool force = false;         // run again even when up to date; replace folders that are not runs
  bool summary_only = false;  // run nothing: gather the status of every run from <out>
  std::string version;        // for run.json
  std::string command_line;   // for run.json (each run's own: "batch <manifest> <name>")
};

enum class BatchRunStatus {
  kOk,       // ran and finished
  kSkipped,  // up to date: not run again
  kFailed,   // bad input or an exception; `error` says why
  kNotRun,   // another shard's run, cancelled, or (summary only) no trace of it in <out>
  kStale,    // summary only: the folder's run.json is from another config
};
// "ok", "skipped", "failed", "not run", "stale".
const char* BatchRunStatusName(BatchRunStatus status);

// The outcome of one run, with the numbers of its run.json (and
// eval/eval.json for RPE) when the run folder has one.
struct BatchRunResult {
  std::string name;
  BatchRunStatus status = BatchRunStatus::kNotRun;
  std::string note;         // one line: why it failed, why it ran again, or "up to date"
  bool has_result = false;  // the numbers below come from a run.json
  int frames = 0;
  int posed_frames = 0;
  int segments = 0;
  std::string warning;  // run.json "result"/"warning": fewer than half of the frames posed
  bool evaluated = false;
  double ate_rmse_m = 0.0;
  double ate_percent_of_path = 0.0;
  double scale_error_percent = 0.0;
  bool scale_arbitrary = false;  // run.json result "scale": "arbitrary" (one camera): no scale error
  bool has_rpe = false;
  double rpe_translation_percent = 0.0;    // mean over the RPE lengths
  double rpe_rotation_deg_per_100m = 0.0;  // mean over the RPE lengths
  double frames_per_second = 0.0;          // wall clock: not deterministic
  // Failed because another process holds the run folder's lock
  // (util/output_folder.h): that process records the run, this one does not.
  bool being_written_elsewhere = false;
};

struct BatchReport {
  std::vector<BatchRunResult> runs;  // every run of the manifest, manifest order
  BatchShard shard;
  bool summary_only = false;
  int Count(BatchRunStatus status) const;
};

// Thrown by RunBatch when SIGINT / SIGTERM stopped it (util/cancel.h): a
// Cancelled that carries the report so far, the runs that did not finish
// (the one cancelled while running, those not started) as kNotRun with a
// note, so that the caller can still write the (shard's) summary.
class BatchCancelled : public Cancelled {
 public:
  BatchCancelled(int signal_number, BatchReport report);
  const BatchReport& report() const { return report_; }

 private:
  BatchReport report_;
};

// Runs the manifest's runs of options.shard, options.jobs at a time, each into
// <out>/<name> through RunPipeline. A run that fails is recorded with its
// one-line error and the others go on; a run whose folder another process is
// writing (it holds the folder's lock) fails at once with the note "being
// written by another mcvo: ..." and leaves that process's record alone.
// Logs "<name>: checking whether it is up to date" before the check of a run
// that has a folder, "<name>: started" only when the run really runs, and one
// line with the outcome. Throws for a bad output folder, and BatchCancelled
// when cancelled (the run being cancelled is recorded "not run").
BatchReport RunBatch(const BatchManifest& manifest, const BatchOptions& options);

// The CPUs a batch shares among its runs: $SLURM_CPUS_PER_TASK when set (a
// positive integer; a Slurm task's allocation, also under task/none where
// the task's affinity mask is the whole node), capped by the CPUs this
// process may run on (its affinity mask); else that mask.
int BatchCpus();

// The options a run uses: its config file (or the defaults) with the run's
// thread count; without one, a config that says 0 (all cores) gets
// max(1, BatchCpus() / jobs), so that `jobs` runs share the CPUs.
// Outputs do not depend on the thread count. Throws InputError for a bad
// config.
PipelineOptions BatchRunOptions(const BatchRunSpec& spec, int jobs);

// Why the finished run in `run_dir` does not match `spec` run with `options`,
// or nullopt when it is up to date: its run.json must have the same config
// (thread count aside), frame count and input hashes (HashRunInputs), and
// every output it lists must be there with its recorded SHA-256. Opens the
// dataset and hashes the inputs only when everything else matches; throws
// InputError when the dataset cannot be opened.
std::optional<std::string> RunOutOfDateReason(const std::filesystem::path& run_dir, const BatchRunSpec& spec,
                                              const PipelineOptions& options);

// The summary table: CSV (name,status,note,frames,posed_frames,segments,
// warning,ate_rmse_m,ate_percent_of_path,rpe_translation_percent,
// rpe_rotation_deg_per_100m,scale_error_percent,frames_per_second; empty
// cells where there is no value) and Markdown.
std::string BatchSummaryCsv(const BatchReport& report);
std::string BatchSummaryMarkdown(const BatchReport& report);
// Writes summary.csv and summary.md into out_dir (shard runs:
// .batch/summary_shard_K_of_N.{csv,md}) atomically; returns the CSV path.
std::filesystem::path WriteBatchSummary(const std::filesystem::path& out_dir, const BatchReport& report);

}  // namespace mcvo
