#include "mcvo/pipeline/batch.h"

#include <sched.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <set>
#include <thread>
#include <utility>

#include <nlohmann/json.hpp>

#include "mcvo/config/config.h"
#include "mcvo/io/json_util.h"
#include "mcvo/pipeline/run.h"
#include "mcvo/pipeline/run_manifest.h"
#include "mcvo/util/blas.h"
#include "mcvo/util/cancel.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/output_folder.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/sha256.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
using io_internal::JoinPath;
using io_internal::Json;
using io_internal::JsonReader;

constexpr size_t kMaxNameLength = 100;
const char* const kSummaryNames[] = {"summary.csv", "summary.md"};

// Folder of the batch's own records inside the output folder.
fs::path BatchDir(const fs::path& out_dir) { return out_dir / ".batch"; }
fs::path RecordPath(const fs::path& out_dir, const std::string& name) {
  return BatchDir(out_dir) / "runs" / (name + ".json");
}

fs::path Resolve(const fs::path& base_dir, const std::string& path) {
  const fs::path p(path);
  return p.is_absolute() ? p : (base_dir / p).lexically_normal();
}

// Why `name` is not a safe folder name, or empty.
std::string NameProblem(const std::string& name) {
  if (name.empty()) return "must not be empty";
  if (name.size() > kMaxNameLength) return StrCat("must be at most ", kMaxNameLength, " characters");
  if (name[0] == '.' || name[0] == '-') return "must not start with '.' or '-'";
  for (char c : name) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-' || c == '.';
    if (!ok)
      return StrCat("character '", std::string(1, c), "' not allowed (letters, digits, '_', '-', '.')");
  }
  for (const char* reserved : kSummaryNames) {
    if (name == reserved) return "is reserved for the summary";
  }
  return "";
}

std::string Lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

// One line: newlines and tabs become spaces.
std::string OneLine(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  }
  return std::string(Trim(text));
}

// The first JSON pointer where a and b differ, or nullopt.
std::optional<std::string> FirstDifference(const Json& a, const Json& b, const std::string& path) {
  if (a.is_object() && b.is_object()) {
    for (const auto& item : a.items()) {
      if (!b.contains(item.key())) return JoinPath(path, item.key());
      if (auto d = FirstDifference(item.value(), b[item.key()], JoinPath(path, item.key()))) return d;
    }
    for (const auto& item : b.items()) {
      if (!a.contains(item.key())) return JoinPath(path, item.key());
    }
    return std::nullopt;
  }
  if (a.is_array() && b.is_array() && a.size() == b.size()) {
    for (size_t i = 0; i < a.size(); ++i) {
      if (auto d = FirstDifference(a[i], b[i], JoinPath(path, i))) return d;
    }
    return std::nullopt;
  }
  if (a == b) return std::nullopt;
  return path.empty() ? std::string("/") : path;
}

// The config as run.json records it, without the thread count.
Json ComparableConfig(Json config) {
  if (config.is_object() && config.contains("runtime") && config["runtime"].is_object()) {
    config["runtime"].erase("threads");
  }
  return config;
}

std::optional<RunManifest> ReadRunManifest(const fs::path& run_dir) {
  const fs::path path = run_dir / "run.json";
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  try {
    return RunManifest::Read(path);
  } catch (const InputError&) {
  }
  return std::nullopt;
}

std::optional<std::string> ConfigDifference(const RunManifest& run, const PipelineOptions& options) {
  if (!run.Has("config")) return std::string("run.json has no config");
  const Json current = ComparableConfig(Json::parse(PipelineOptionsToJson(options)));
  if (auto d = FirstDifference(current, ComparableConfig(Json(run.config)), "")) {
    return "config changed at " + *d;
  }
  return std::nullopt;
}

DatasetOptions RunDataset(const BatchRunSpec& spec, const PipelineOptions& options) {
  DatasetOptions dataset = spec.dataset;
  // As RunPipeline: the config's camera selection when the run names none.
  if (dataset.cameras.empty()) dataset.cameras = options.dataset.cameras;
  return dataset;
}

// Numbers of the summary from a finished run folder.
void ReadRunNumbers(const fs::path& run_dir, BatchRunResult* result) {
  const std::optional<RunManifest> run = ReadRunManifest(run_dir);
  if (!run || !run->Has("result")) return;
  const RunHeadline h = run->Headline();
  result->has_result = true;
  result->frames = h.frames;
  result->posed_frames = h.posed_frames;
  result->segments = h.segments;
  if (h.warning) result->warning = *h.warning;
  result->evaluated = h.ate_rmse_m.has_value();
  result->ate_rmse_m = h.ate_rmse_m.value_or(result->ate_rmse_m);
  result->ate_percent_of_path = h.ate_percent_of_path.value_or(result->ate_percent_of_path);
  result->scale_arbitrary = h.scale_arbitrary;
  result->scale_error_percent = h.scale_error_percent.value_or(result->scale_error_percent);
  result->frames_per_second = h.frames_per_second.value_or(result->frames_per_second);
  // RPE: run.json's result when it carries it, else the run's eval/eval.json.
  if (h.rpe_translation_percent && h.rpe_rotation_deg_per_100m) {
    result->rpe_translation_percent = *h.rpe_translation_percent;
    result->rpe_rotation_deg_per_100m = *h.rpe_rotation_deg_per_100m;
    result->has_rpe = true;
    return;
  }
  std::error_code ec;
  if (!fs::is_regular_file(run_dir / "eval" / "eval.json", ec)) return;
  auto number = [](const Json& object, const char* key, double* value) {
    if (!object.is_object() || !object.contains(key) || !object[key].is_number()) return false;
    *value = object[key].get<double>();
    return true;
  };
  try {
    const Json eval = io_internal::ReadJsonFile(run_dir / "eval" / "eval.json");
    if (!eval.contains("rpe") || !eval["rpe"].contains("average")) return;
    const Json& average = eval["rpe"]["average"];
    double per_m = 0.0;
    if (number(average, "translation_percent", &result->rpe_translation_percent) &&
        number(average, "rotation_deg_per_m", &per_m)) {
      result->rpe_rotation_deg_per_100m = 100.0 * per_m;
      result->has_rpe = true;
    }
  } catch (const InputError&) {
  }
}

void WriteRecord(const fs::path& out_dir, const BatchRunResult& result) {
  nlohmann::ordered_json record;
  record["name"] = result.name;
  record["status"] = BatchRunStatusName(result.status);
  record["note"] = result.note;
  WriteFileAtomic(RecordPath(out_dir, result.name), io_internal::PrettyJson(record));
}

std::optional<BatchRunResult> ReadRecord(const fs::path& out_dir, const std::string& name) {
  const fs::path path = RecordPath(out_dir, name);
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  try {
    const Json record = io_internal::ReadJsonFile(path);
    BatchRunResult result;
    result.name = name;
    const std::string status = record.value("status", "");
    for (BatchRunStatus s :
         {BatchRunStatus::kOk, BatchRunStatus::kSkipped, BatchRunStatus::kFailed, BatchRunStatus::kNotRun}) {
      if (status == BatchRunStatusName(s)) {
        result.status = s;
        result.note = record.value("note", "");
        return result;
      }
    }
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

// Runs (or skips) one run; never throws.
BatchRunResult ExecuteRun(const BatchRunSpec& spec, const BatchOptions& options,
                          const std::string& command_line, const std::string& position) {
  BatchRunResult result;
  result.name = spec.name;
  const fs::path run_dir = options.out_dir / spec.name;
  try {
    const PipelineOptions pipeline = BatchRunOptions(spec, options.jobs);
    std::error_code ec;
    if (fs::exists(run_dir, ec) && !fs::is_directory(run_dir, ec)) {
      MCVO_THROW_INPUT(run_dir.string(), ": exists and is not a folder");
    }
    if (fs::is_directory(run_dir, ec) && !fs::is_empty(run_dir, ec) &&
        !fs::is_regular_file(fs::symlink_status(run_dir / kOutputMarkerName, ec))) {
      // Not a folder mcvo wrote (util/output_folder.h): never replaced, with --force or without.
      MCVO_THROW_INPUT(run_dir.string(), ": folder exists, is not empty and holds no ", kOutputMarkerName,
                       " marker: mcvo replaces only folders it wrote (move it away or rename the run)");
    }
    if (!options.force && fs::is_directory(run_dir, ec) && !fs::is_empty(run_dir, ec)) {
      MCVO_LOG(kInfo, "batch: ", spec.name, ": checking whether it is up to date (", position, ")");
      const std::optional<std::string> reason = RunOutOfDateReason(run_dir, spec, pipeline);
      if (!reason) {
        result.status = BatchRunStatus::kSkipped;
        result.note = "up to date";
        ReadRunNumbers(run_dir, &result);
        return result;
      }
      result.note = "ran again: " + *reason;
      MCVO_LOG(kInfo, "batch: ", spec.name, ": ", result.note);
    }
    RunRequest request;
    request.dataset = spec.dataset;
    request.tracks = spec.tracks;
    request.out_dir = run_dir;
    request.force = true;  // the folder is empty or a run of ours (its marker, checked again by the run)
    request.options = pipeline;
    request.config_source = spec.config.empty() ? "built-in defaults" : spec.config.string();
    request.config_path = spec.config;
    request.max_frames = spec.max_frames;
    request.command_line = command_line;
    request.version = options.version;
    MCVO_LOG(kInfo, "batch: ", spec.name, ": started (", position, ")");
    RunPipeline(request);
    result.status = BatchRunStatus::kOk;
    ReadRunNumbers(run_dir, &result);
  } catch (const Cancelled&) {
    throw;  // the whole batch stops (util/cancel.h)
  } catch (const std::bad_alloc& e) {
    // Out of memory: the run fails, named with its stage (util/stage.h); the others go on.
    const std::string stage = FailedStage();
    result = BatchRunResult();
    result.name = spec.name;
    result.status = BatchRunStatus::kFailed;
    result.note =
        OneLine(StrCat("out of memory", stage.empty() ? std::string() : " in " + stage, " (", e.what(), ")"));
  } catch (const std::exception& e) {
    // An error on the way out of a cancelled run (a read interrupted by the signal).
    if (const int signal_number = CancelSignal(); signal_number != 0) throw Cancelled(signal_number);
    result = BatchRunResult();
    result.name = spec.name;
    result.status = BatchRunStatus::kFailed;
    result.note = OneLine(e.what());
    // Another process (a second submission of the same batch, another shard
    // of an overlapping manifest) holds the run folder's lock
    // (util/output_folder.h): said first, so that the log and the summary
    // name it.
    if (result.note.find(": is being written by another mcvo") != std::string::npos) {
      result.being_written_elsewhere = true;
      result.note = "being written by another mcvo: " + result.note;
    }
  }
  return result;
}

// Summary only: what <out> says about one run.
BatchRunResult GatherRun(const BatchRunSpec& spec, const BatchOptions& options) {
  const fs::path run_dir = options.out_dir / spec.name;
  std::error_code ec;
  const bool has_run = fs::is_regular_file(run_dir / "run.json", ec);
  BatchRunResult result;
  result.name = spec.name;
  if (std::optional<BatchRunResult> record = ReadRecord(options.out_dir, spec.name)) {
    result = *record;
  } else if (has_run) {
    result.status = BatchRunStatus::kOk;
    result.note = "no batch record";
  } else {
    result.note = "no run folder";
    return result;
  }
  if (result.status == BatchRunStatus::kFailed || result.status == BatchRunStatus::kNotRun) return result;
  if (!has_run) {
    result.status = BatchRunStatus::kNotRun;
    result.note = "run folder missing";
    return result;
  }
  try {
    const std::optional<RunManifest> run = ReadRunManifest(run_dir);
    if (!run) MCVO_THROW_INPUT((run_dir / "run.json").string(), ": does not parse");
    if (std::optional<std::string> reason = ConfigDifference(*run, BatchRunOptions(spec, options.jobs))) {
      result.status = BatchRunStatus::kStale;
      result.note = *reason;
    }
  } catch (const std::exception& e) {
    result.status = BatchRunStatus::kFailed;
    result.note = OneLine(e.what());
    return result;
  }
  ReadRunNumbers(run_dir, &result);
  return result;
}

// Where WriteBatchSummary writes the CSV (the Markdown beside it, .md).
fs::path SummaryCsvPath(const fs::path& out_dir, const BatchShard& shard, bool summary_only) {
  if (shard.count > 1 && !summary_only) {
    return BatchDir(out_dir) / StrCat("summary_shard_", shard.index, "_of_", shard.count, ".csv");
  }
  return out_dir / "summary.csv";
}

std::string MarkdownCell(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}

std::string StatusText(const BatchRunResult& r) {
  switch (r.status) {
    case BatchRunStatus::kOk:
      return r.note.empty() ? "ok" : "ok (" + r.note + ")";
    case BatchRunStatus::kSkipped:
      return "skipped (up to date)";
    case BatchRunStatus::kFailed:
      return "failed: " + r.note;
    case BatchRunStatus::kNotRun:
      return r.note.empty() ? "not run" : "not run (" + r.note + ")";
    case BatchRunStatus::kStale:
      return "stale: " + r.note;
  }
  return "";
}

std::string CountsLine(const BatchReport& report) {
  return StrCat(report.runs.size(), " runs: ", report.Count(BatchRunStatus::kOk), " ok, ",
                report.Count(BatchRunStatus::kSkipped), " skipped (up to date), ",
                report.Count(BatchRunStatus::kFailed), " failed, ", report.Count(BatchRunStatus::kNotRun),
                " not run, ", report.Count(BatchRunStatus::kStale), " stale");
}

}  // namespace

const char* BatchRunStatusName(BatchRunStatus status) {
  switch (status) {
    case BatchRunStatus::kOk:
      return "ok";
    case BatchRunStatus::kSkipped:
      return "skipped";
    case BatchRunStatus::kFailed:
      return "failed";
    case BatchRunStatus::kNotRun:
      return "not run";
    case BatchRunStatus::kStale:
      return "stale";
  }
  return "";
}

BatchCancelled::BatchCancelled(int signal_number, BatchReport report)
    : Cancelled(signal_number), report_(std::move(report)) {}

int BatchReport::Count(BatchRunStatus status) const {
  return static_cast<int>(
      std::count_if(runs.begin(), runs.end(), [&](const BatchRunResult& r) { return r.status == status; }));
}

BatchManifest ParseBatchManifest(const std::string& json_text, const std::string& source,
                                 const fs::path& base_dir) {
  const JsonReader reader(source);
  const Json root = io_internal::ParseJson(json_text, source);
  reader.CheckKeys(root, "", {"runs"}, {"runs"});
  reader.ExpectArray(root["runs"], "/runs");
  if (root["runs"].empty()) reader.Fail("/runs", "no runs: expected at least one");
  BatchManifest manifest;
  manifest.path = source;
  std::set<std::string> names;  // lower case: folders must differ on case-insensitive file systems
  for (size_t i = 0; i < root["runs"].size(); ++i) {
    const Json& run = root["runs"][i];
    const std::string path = JoinPath("/runs", i);
    reader.CheckKeys(run, path, {"name", "dataset", "config", "tracks", "max_frames", "threads"},
                     {"name", "dataset"});
    BatchRunSpec spec;
    spec.name = reader.String(run["name"], JoinPath(path, "name"));
    if (const std::string problem = NameProblem(spec.name); !problem.empty()) {
      reader.Fail(JoinPath(path, "name"), "\"" + spec.name + "\": " + problem);
    }
    if (!names.insert(Lower(spec.name)).second) {
      reader.Fail(JoinPath(path, "name"), "\"" + spec.name + "\": duplicate run name");
    }
    const Json& dataset = run["dataset"];
    const std::string dpath = JoinPath(path, "dataset");
    reader.CheckKeys(dataset, dpath, {"root", "format", "sequence", "cameras", "skip_incomplete"}, {"root"});
    const std::string root_text = reader.String(dataset["root"], JoinPath(dpath, "root"));
    if (root_text.empty()) reader.Fail(JoinPath(dpath, "root"), "must not be empty");
    spec.dataset.root = Resolve(base_dir, root_text);
    if (dataset.contains("format")) {
      spec.dataset.format = reader.String(dataset["format"], JoinPath(dpath, "format"));
      const std::vector<std::string> formats = {"auto", "generic", "kitti360", "kitti", "euroc", "kalibr"};
      if (std::find(formats.begin(), formats.end(), spec.dataset.format) == formats.end()) {
        reader.Fail(JoinPath(dpath, "format"),
                    "unknown format \"" + spec.dataset.format +
                        "\" (known: auto, generic, kitti360, kitti, euroc, kalibr)");
      }
    }
    if (dataset.contains("sequence")) {
      spec.dataset.sequence = reader.String(dataset["sequence"], JoinPath(dpath, "sequence"));
    }
    if (dataset.contains("cameras")) {
      const std::string cpath = JoinPath(dpath, "cameras");
      reader.ExpectArray(dataset["cameras"], cpath);
      for (size_t c = 0; c < dataset["cameras"].size(); ++c) {
        const std::string camera = reader.String(dataset["cameras"][c], JoinPath(cpath, c));
        if (camera.empty()) reader.Fail(JoinPath(cpath, c), "must not be empty");
        spec.dataset.cameras.push_back(camera);
      }
    }
    if (dataset.contains("skip_incomplete") &&
        reader.Bool(dataset["skip_incomplete"], JoinPath(dpath, "skip_incomplete"))) {
      spec.dataset.missing_images = MissingImagePolicy::kSkipFrame;
    }
    for (const char* key : {"config", "tracks"}) {
      if (!run.contains(key)) continue;
      const std::string text = reader.String(run[key], JoinPath(path, key));
      if (text.empty()) reader.Fail(JoinPath(path, key), "must not be empty (leave the key out instead)");
      (std::string(key) == "config" ? spec.config : spec.tracks) = Resolve(base_dir, text);
    }
    if (run.contains("max_frames")) {
      spec.max_frames =
          static_cast<int>(reader.Integer(run["max_frames"], JoinPath(path, "max_frames"), 0, 1 << 30));
    }
    if (run.contains("threads")) {
      spec.threads = static_cast<int>(reader.Integer(run["threads"], JoinPath(path, "threads"), 0, 1024));
    }
    manifest.runs.push_back(std::move(spec));
  }
  return manifest;
}

BatchManifest ReadBatchManifest(const fs::path& path) {
  BatchManifest manifest =
      ParseBatchManifest(ReadFileToString(path), path.string(), fs::absolute(path).parent_path());
  manifest.path = path;
  return manifest;
}

BatchShard ParseBatchShard(const std::string& text) {
  const size_t slash = text.find('/');
  const std::optional<int64_t> k = ParseInt64(text.substr(0, slash));
  const std::optional<int64_t> n =
      slash == std::string::npos ? std::nullopt : ParseInt64(std::string_view(text).substr(slash + 1));
  if (!k || !n || *n < 1 || *n > 1000000 || *k < 0 || *k >= *n) {
    throw UsageError(
        StrCat("--shard: expected K/N with 0 <= K < N (0-based, as $SLURM_ARRAY_TASK_ID), got '", text, "'"));
  }
  return {static_cast<int>(*k), static_cast<int>(*n)};
}

int BatchCpus() {
  const int affinity = AvailableCores();
  const char* slurm = std::getenv("SLURM_CPUS_PER_TASK");
  if (slurm == nullptr) return affinity;
  const std::optional<int64_t> cpus = ParseInt64(Trim(slurm));
  if (!cpus || *cpus < 1) return affinity;
  // Under task/none (no binding) the affinity mask is the whole node: the
  // allocation is what Slurm says. Under task/affinity or cgroup the mask
  // is the allocation itself; never more than the mask.
  return static_cast<int>(std::min<int64_t>(*cpus, affinity));
}

PipelineOptions BatchRunOptions(const BatchRunSpec& spec, int jobs) {
  PipelineOptions options = spec.config.empty() ? PipelineOptions() : ReadPipelineOptions(spec.config);
  if (spec.threads >= 0) {
    options.runtime.threads = spec.threads;
  } else if (options.runtime.threads == 0) {
    // The CPUs this process may use (a Slurm task's allocation), not the machine's.
    options.runtime.threads = std::max(1, BatchCpus() / std::max(1, jobs));
  }
  options.Check();
  return options;
}

std::optional<std::string> RunOutOfDateReason(const fs::path& run_dir, const BatchRunSpec& spec,
                                              const PipelineOptions& options) {
  const std::optional<RunManifest> run = ReadRunManifest(run_dir);
  if (!run) return std::string("no readable run.json");
  if (std::optional<std::string> reason = ConfigDifference(*run, options)) return reason;
  if (run->executable_sha256 != ExecutableSha256()) {
    return std::string("made by another mcvo build (run.json build.executable_sha256)");
  }
  if (run->blas != BlasLibrary()) return std::string("made with another BLAS (run.json build.blas)");
  if (!run->Has("outputs_sha256")) return std::string("run.json lists no outputs");
  for (const auto& [name, hash] : run->outputs_sha256) {
    const fs::path file = run_dir / name;
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) return "output " + name + " is missing";
    if (Sha256File(file) != hash) return "output " + name + " was changed";
  }
  const DatasetIndex index = OpenRunDataset(RunDataset(spec, options));
  const int dataset_frames = static_cast<int>(index.frames.size());
  const int frames = spec.max_frames > 0 ? std::min(spec.max_frames, dataset_frames) : dataset_frames;
  if (run->dataset.frames != frames) return StrCat("frame count changed (now ", frames, ")");
  if (!run->Has("inputs")) return std::string("run.json lists no inputs");
  const auto current =
      HashRunInputs(index, spec.tracks, frames, RunVocabularyPath(options), options.runtime.threads);
  if (run->inputs.size() != current.size()) return std::string("inputs changed");
  for (const auto& [key, hash] : current) {
    auto it = run->inputs.find(key);
    if (it == run->inputs.end() || it->second != hash) return "inputs changed (" + key + ")";
  }
  return std::nullopt;
}

BatchReport RunBatch(const BatchManifest& manifest, const BatchOptions& options) {
  if (options.jobs < 1) throw UsageError("--jobs: must be >= 1");
  BatchReport report;
  report.shard = options.shard;
  report.summary_only = options.summary_only;
  if (options.summary_only) {
    for (const BatchRunSpec& spec : manifest.runs) report.runs.push_back(GatherRun(spec, options));
    return report;
  }
  CreateDirectories(BatchDir(options.out_dir) / "runs");
  {
    // The summary this batch will write, removed first: a batch killed before
    // it writes one (SIGKILL, a node lost) leaves none rather than a stale one.
    fs::path path = SummaryCsvPath(options.out_dir, options.shard, false);
    std::error_code ec;
    fs::remove(path, ec);
    fs::remove(path.replace_extension(".md"), ec);
  }
  std::vector<int> selected;
  for (int i = 0; i < static_cast<int>(manifest.runs.size()); ++i) {
    if (options.shard.Contains(i)) selected.push_back(i);
  }
  report.runs.resize(selected.size());
  for (size_t k = 0; k < selected.size(); ++k) {
    report.runs[k].name = manifest.runs[selected[k]].name;
    report.runs[k].note = "cancelled before it started";
  }
  std::atomic<int> finished{0};
  // Runs in manifest order to `jobs` workers (util/parallel.h); each writes
  // its own slot of report.runs.
  auto record = [&](const BatchRunResult& result) {
    try {
      WriteRecord(options.out_dir, result);
    } catch (const std::exception& e) {
      MCVO_LOG(kWarning, "batch: ", result.name, ": cannot write its status record: ", OneLine(e.what()));
    }
  };
  try {
    ParallelFor(static_cast<int>(selected.size()), std::max(1, options.jobs), [&](int run) {
      const size_t k = static_cast<size_t>(run);
      const BatchRunSpec& spec = manifest.runs[selected[k]];
      const std::string position =
          StrCat("run ", selected[k] + 1, " of the manifest's ", manifest.runs.size());
      const std::string command_line =
          StrCat(options.command_line.empty() ? std::string("mcvo batch") : options.command_line, " [run ",
                 spec.name, "]");
      BatchRunResult result;
      try {
        result = ExecuteRun(spec, options, command_line, position);
      } catch (const Cancelled& e) {
        // The attempt did not finish: its record says so (not a stale "ok"
        // or "failed" of an earlier attempt); the folder, if any, is the
        // earlier run's, untouched (the staging folder is gone).
        result.name = spec.name;
        result.status = BatchRunStatus::kNotRun;
        result.note = StrCat("cancelled by signal ", e.signal_number(), " while running");
        record(result);
        report.runs[k] = std::move(result);
        throw;
      }
      // A run another process is writing is that process's to record.
      if (!result.being_written_elsewhere) record(result);
      const std::string line =
          StrCat("batch: [", ++finished, "/", selected.size(), "] ", spec.name, ": ", StatusText(result));
      if (result.status == BatchRunStatus::kFailed) {
        MCVO_LOG(kError, line);
      } else {
        MCVO_LOG(kInfo, line);
      }
      report.runs[k] = std::move(result);
    });
  } catch (const Cancelled& e) {
    throw BatchCancelled(e.signal_number(), std::move(report));
  }
  return report;
}

std::string BatchSummaryCsv(const BatchReport& report) {
  std::string csv =
      "name,status,note,frames,posed_frames,segments,warning,ate_rmse_m,ate_percent_of_path,rpe_translation_"
      "percent,"
      "rpe_rotation_deg_per_100m,scale_error_percent,frames_per_second\n";
  for (const BatchRunResult& r : report.runs) {
    csv += StrCat(r.name, ",", BatchRunStatusName(r.status), ",", CsvQuote(r.note));
    if (r.has_result) {
      csv += StrCat(",", r.frames, ",", r.posed_frames, ",", r.segments, ",", CsvQuote(r.warning));
    } else {
      csv += ",,,,";
    }
    for (double value : {r.ate_rmse_m, r.ate_percent_of_path})
      csv += "," + (r.evaluated ? FormatDouble(value) : "");
    for (double value : {r.rpe_translation_percent, r.rpe_rotation_deg_per_100m}) {
      csv += "," + (r.has_rpe ? FormatDouble(value) : "");
    }
    csv += "," + (r.evaluated
                      ? (r.scale_arbitrary ? std::string("arbitrary") : FormatDouble(r.scale_error_percent))
                      : std::string());
    csv += "," + (r.has_result ? FormatFixed(r.frames_per_second, 2) : "");
    csv += "\n";
  }
  return csv;
}

std::string BatchSummaryMarkdown(const BatchReport& report) {
  std::string md = "# mcvo batch summary";
  if (report.shard.count > 1 && !report.summary_only) {
    md += StrCat(" (shard ", report.shard.index, "/", report.shard.count, ")");
  }
  md +=
      "\n\n| run | status | frames | posed | segments | ATE RMSE (m) | ATE (% of path) | RPE (%) | RPE "
      "(deg/100 m) | "
      "scale error (%) | frames/s | warning |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const BatchRunResult& r : report.runs) {
    md += StrCat("| ", r.name, " | ", MarkdownCell(StatusText(r)), " | ");
    md += r.has_result ? StrCat(r.frames, " | ", r.posed_frames, " | ", r.segments, " | ")
                       : std::string(" |  |  | ");
    md += r.evaluated ? FormatFixed(r.ate_rmse_m, 4) + " | " + FormatFixed(r.ate_percent_of_path, 3) + " | "
                      : std::string(" |  | ");
    md += r.has_rpe ? FormatFixed(r.rpe_translation_percent, 3) + " | " +
                          FormatFixed(r.rpe_rotation_deg_per_100m, 3) + " | "
                    : std::string(" |  | ");
    md += r.evaluated
              ? (r.scale_arbitrary ? std::string("arbitrary") : FormatFixed(r.scale_error_percent, 3)) + " | "
              : std::string(" | ");
    md += r.has_result ? FormatFixed(r.frames_per_second, 2) + " | " : std::string(" | ");
    md += MarkdownCell(r.warning) + " |\n";
  }
  md += "\n" + CountsLine(report) +
        ". ATE with the config's eval alignment; RPE: mean over the lengths; "
        "frames/s is wall clock.\n";
  return md;
}

fs::path WriteBatchSummary(const fs::path& out_dir, const BatchReport& report) {
  const fs::path csv = SummaryCsvPath(out_dir, report.shard, report.summary_only);
  CreateDirectories(csv.parent_path());
  fs::path md = csv;
  WriteFileAtomic(md.replace_extension(".md"), BatchSummaryMarkdown(report));
  WriteFileAtomic(csv, BatchSummaryCsv(report));
  return csv;
}

}  // namespace mcvo
