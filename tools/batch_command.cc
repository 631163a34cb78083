// `mcvo batch`: the runs of a manifest, N at a time, resumable, shardable
// over a Slurm job array, with a summary table (pipeline/batch.h;
// docs/batch-and-regress.md).
#include <iostream>
#include <string>

#include "command.h"
#include "mcvo/pipeline/batch.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"
#include "mcvo/util/logging.h"

namespace mcvo::tools {
namespace {

// Exit code when the batch itself worked but some run failed (or, with
// --summary-only, some run failed, was not run or is stale).
constexpr int kExitRunsFailed = 4;

int RunBatchCommand(int argc, const char* const* argv) {
  std::string manifest_path, out_path, shard_text;
  int jobs = 1;
  bool force = false, summary_only = false;
  ArgParser args("mcvo batch",
                 "Runs every run of a manifest through the pipeline (as `mcvo run`), N at a time, into\n"
                 "<out>/<name>/, and writes summary.csv and summary.md. Runs that are up to date (same\n"
                 "config, frame count and input hashes as their finished run.json) are skipped; a failing\n"
                 "run is reported and the others go on.");
  args.AddString("manifest", &manifest_path, "FILE", "the runs (JSON; docs/batch-and-regress.md)", true);
  args.AddInt("jobs", &jobs,
              "runs at the same time (in this process), each on max(1, cores / N) threads; N = cores is "
              "fastest where memory allows");
  args.AddString("shard", &shard_text, "K/N",
                 "take only the runs whose 0-based manifest index i has i % N == K (0 <= K < N)");
  args.AddString("out", &out_path, "DIR", "output folder; default: the manifest's path without .json");
  args.AddFlag("force", &force, "run again even when up to date; replace folders that hold no finished run");
  args.AddFlag("summary-only", &summary_only,
               "run nothing: gather the status of every run from DIR (after the shards of a job array)");
  args.AddEpilog(
      "Exit codes: 0 every run ok or up to date, 4 some run failed (--summary-only: failed, not run\n"
      "or stale), 2 usage, 3 bad manifest or output folder.\n"
      "example: mcvo batch --manifest runs.json --jobs 2 --out runs\n"
      "         mcvo batch --manifest runs.json --shard $SLURM_ARRAY_TASK_ID/8 --out runs\n"
      "         mcvo batch --manifest runs.json --summary-only --out runs\n");
  if (!args.Parse(argc, argv)) return kExitOk;
  if (jobs < 1) throw UsageError("--jobs: must be >= 1");
  if (summary_only && (force || args.WasGiven("shard"))) {
    throw UsageError("--summary-only: runs nothing, so --force and --shard do not apply");
  }

  BatchOptions options;
  options.jobs = jobs;
  options.force = force;
  options.summary_only = summary_only;
  if (!shard_text.empty()) options.shard = ParseBatchShard(shard_text);
  options.version = MCVO_VERSION;
  options.command_line = "mcvo batch";
  for (int i = 0; i < argc; ++i) options.command_line += " " + std::string(argv[i]);
  const BatchManifest manifest = ReadBatchManifest(manifest_path);
  if (out_path.empty()) {
    std::filesystem::path out = manifest_path;
    out_path = out.replace_extension().string();
    if (out_path == manifest_path) out_path += ".out";
  }
  options.out_dir = out_path;

  BatchReport report;
  try {
    report = RunBatch(manifest, options);
  } catch (const BatchCancelled& e) {
    // Cancelled (SIGTERM from scancel or a time limit, Ctrl-C): the summary
    // still says what finished and what did not, then the exit is 128 + signal.
    try {
      const std::filesystem::path summary = WriteBatchSummary(options.out_dir, e.report());
      MCVO_LOG(kWarning, "batch: cancelled; wrote ", summary.string());
    } catch (const std::exception& write_error) {
      MCVO_LOG(kWarning, "batch: cancelled; cannot write the summary: ", write_error.what());
    }
    throw;
  }
  const std::filesystem::path summary = WriteBatchSummary(options.out_dir, report);
  std::cout << BatchSummaryMarkdown(report);
  MCVO_LOG(kInfo, "batch: wrote ", summary.string(), " and ", summary.parent_path().string(), "/",
           summary.stem().string(), ".md");
  int bad = report.Count(BatchRunStatus::kFailed);
  // A run that posed no frame counts as bad too (mcvo run exits with 5 for it).
  for (const BatchRunResult& r : report.runs) bad += r.has_result && r.posed_frames == 0 ? 1 : 0;
  if (summary_only) bad += report.Count(BatchRunStatus::kNotRun) + report.Count(BatchRunStatus::kStale);
  return bad > 0 ? kExitRunsFailed : kExitOk;
}

const CommandRegistrar kRegistrar("batch",
                                  {"run the runs of a manifest (resumable, shardable) with a summary table",
                                   RunBatchCommand});

}  // namespace
}  // namespace mcvo::tools
