// mcvo batch (pipeline/batch.h): manifest validation, shards that partition
// the runs, resuming (a second batch skips what is up to date; a changed
// config, frame count or output runs again), failure isolation, the summary,
// and identical outputs at any --jobs. Runs are short (12-20 frames of a
// small stereo sequence, about 0.2 s each).
#include "mcvo/pipeline/batch.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <nlohmann/json.hpp>

#include "mcvo/synth/synthesize.h"
#include "mcvo/util/blas.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/sha256.h"
#include "mcvo/util/strings.h"
#include "test_temp_dir.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

fs::path Root() { return mcvo::testing::TestTempDir("batch_test"); }

// 20 frames of the stereo preset at 0.35 scale: every frame gets a pose.
const fs::path& Dataset() {
  static const fs::path dir = [] {
    const fs::path out = Root() / "seq";
    synth::SynthOptions options;
    options.preset = "stereo";
    options.frames = 20;
    options.image_scale = 0.35;
    options.seed = 3;
    options.render.samples_per_axis = 1;
    options.render.threads = 2;
    synth::Synthesize(options, out);
    return out;
  }();
  return dir;
}

fs::path WriteConfig(const std::string& name, const std::string& text) {
  const fs::path path = Root() / name;
  WriteFileAtomic(path, text);
  return path;
}

const char* const kConfig = R"({"frontend": {"max_features_pinhole": 100}, "eval": {"align": "se3"}})";

BatchRunSpec Spec(const std::string& name, const fs::path& config, int max_frames) {
  BatchRunSpec spec;
  spec.name = name;
  spec.dataset.root = Dataset();
  spec.config = config;
  spec.max_frames = max_frames;
  spec.threads = 1;
  return spec;
}

nlohmann::json RunJson(const fs::path& run_dir) {
  return nlohmann::json::parse(ReadFileToString(run_dir / "run.json"));
}

// The message of the InputError that parsing `text` throws ("" when none).
std::string ManifestError(const std::string& text) {
  try {
    ParseBatchManifest(text, "m.json", "/base");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(BatchManifest, ParsesAndResolvesPathsAgainstTheManifestFolder) {
  const BatchManifest manifest = ParseBatchManifest(R"({
    // comments are allowed
    "runs": [
      {"name": "a_1", "dataset": {"root": "seq/a", "format": "generic", "cameras": ["image_00", "image_01"],
       "skip_incomplete": true}, "config": "../cfg.json", "tracks": "t.bin", "max_frames": 30, "threads": 2},
      {"name": "B.2", "dataset": {"root": "/data/kitti", "format": "kitti360", "sequence": "s0"}}
    ]})",
                                                    "m.json", "/base/dir");
  ASSERT_EQ(manifest.runs.size(), 2u);
  const BatchRunSpec& a = manifest.runs[0];
  EXPECT_EQ(a.name, "a_1");
  EXPECT_EQ(a.dataset.root, fs::path("/base/dir/seq/a"));
  EXPECT_EQ(a.dataset.format, "generic");
  EXPECT_EQ(a.dataset.cameras, (std::vector<std::string>{"image_00", "image_01"}));
  EXPECT_EQ(a.dataset.missing_images, MissingImagePolicy::kSkipFrame);
  EXPECT_EQ(a.config, fs::path("/base/cfg.json"));
  EXPECT_EQ(a.tracks, fs::path("/base/dir/t.bin"));
  EXPECT_EQ(a.max_frames, 30);
  EXPECT_EQ(a.threads, 2);
  const BatchRunSpec& b = manifest.runs[1];
  EXPECT_EQ(b.dataset.root, fs::path("/data/kitti"));
  EXPECT_EQ(b.dataset.sequence, "s0");
  EXPECT_EQ(b.dataset.missing_images, MissingImagePolicy::kMarkMissing);
  EXPECT_TRUE(b.config.empty());
  EXPECT_TRUE(b.tracks.empty());
  EXPECT_EQ(b.max_frames, 0);
  EXPECT_EQ(b.threads, -1);
}

TEST(BatchManifest, ErrorsNameTheFileAndTheJsonPath) {
  const std::string ok = R"({"name": "a", "dataset": {"root": "x"}})";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"runs": []})", "m.json: /runs: no runs"},
      {R"({"run": []})", "m.json: /run: unknown key"},
      {R"({})", "m.json: /runs: missing required key"},
      {R"({"runs": {}})", "m.json: /runs: expected an array"},
      {R"({"runs": [)" + ok + R"(, {"name": "A", "dataset": {"root": "y"}}]})",
       "m.json: /runs/1/name: \"A\": duplicate"},
      {R"({"runs": [{"name": "../up", "dataset": {"root": "x"}}]})",
       "m.json: /runs/0/name: \"../up\": must not start"},
      {R"({"runs": [{"name": "a/b", "dataset": {"root": "x"}}]})",
       "m.json: /runs/0/name: \"a/b\": character '/'"},
      {R"({"runs": [{"name": "", "dataset": {"root": "x"}}]})",
       "m.json: /runs/0/name: \"\": must not be empty"},
      {R"({"runs": [{"name": "summary.csv", "dataset": {"root": "x"}}]})",
       "/runs/0/name: \"summary.csv\": is reserved"},
      {R"({"runs": [{"name": "a"}]})", "m.json: /runs/0/dataset: missing required key"},
      {R"({"runs": [{"name": "a", "dataset": {}}]})", "m.json: /runs/0/dataset/root: missing required key"},
      {R"({"runs": [{"name": "a", "dataset": {"root": "x", "format": "rosbag"}}]})",
       "m.json: /runs/0/dataset/format: unknown format \"rosbag\""},
      {R"({"runs": [{"name": "a", "dataset": {"root": "x", "cameras": "image_00"}}]})",
       "m.json: /runs/0/dataset/cameras: expected an array"},
      {R"({"runs": [{"name": "a", "dataset": {"root": "x", "fps": 10}}]})",
       "m.json: /runs/0/dataset/fps: unknown key"},
      {R"({"runs": [{"name": "a", "dataset": {"root": "x"}, "max_frames": -1}]})",
       "m.json: /runs/0/max_frames: must be >= 0"},
      {R"({"runs": [{"name": "a", "dataset": {"root": "x"}, "threads": "2"}]})",
       "m.json: /runs/0/threads: expected an integer"},
      {R"({"runs": [{"name": "a", "dataset": {"root": "x"}, "config": ""}]})",
       "m.json: /runs/0/config: must not be empty"},
      {R"({"runs": [{"name": "a", "dataset": {"root": "x"}, "confg": "c.json"}]})",
       "m.json: /runs/0/confg: unknown key"},
      {R"({"runs": [)", "m.json"},
  };
  for (const auto& [text, expected] : cases) {
    const std::string error = ManifestError(text);
    EXPECT_NE(error.find(expected), std::string::npos) << text << "\n -> " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
  // A file that is not there names the file.
  try {
    ReadBatchManifest(Root() / "nothing.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("nothing.json"), std::string::npos) << e.what();
  }
}

TEST(BatchShard, ParsesAndPartitionsTheRuns) {
  EXPECT_EQ(ParseBatchShard("0/1").count, 1);
  EXPECT_EQ(ParseBatchShard("3/8").index, 3);
  EXPECT_EQ(ParseBatchShard("3/8").count, 8);
  for (const char* bad : {"", "1", "2/2", "-1/2", "1/0", "a/b", "1/2/3", "0/x"}) {
    EXPECT_THROW(ParseBatchShard(bad), UsageError) << bad;
  }
  // Every run in exactly one shard, for any shard count.
  for (int n = 1; n <= 7; ++n) {
    for (int run = 0; run < 23; ++run) {
      int owners = 0;
      for (int k = 0; k < n; ++k)
        owners += ParseBatchShard(std::to_string(k) + "/" + std::to_string(n)).Contains(run);
      EXPECT_EQ(owners, 1) << run << " of " << n;
    }
  }
}

// A Slurm task's allocation comes from SLURM_CPUS_PER_TASK (under task/none
// the affinity mask is the whole node), never more than the mask.
TEST(BatchRun, CpusPreferSlurmCpusPerTask) {
  const char* saved = std::getenv("SLURM_CPUS_PER_TASK");
  const std::string saved_value = saved ? saved : "";
  ::unsetenv("SLURM_CPUS_PER_TASK");
  EXPECT_EQ(BatchCpus(), AvailableCores());
  ::setenv("SLURM_CPUS_PER_TASK", "1", 1);
  EXPECT_EQ(BatchCpus(), 1);
  BatchRunSpec spec;
  EXPECT_EQ(BatchRunOptions(spec, 1).runtime.threads, 1);  // the defaults say 0: all CPUs of the task
  ::setenv("SLURM_CPUS_PER_TASK", "100000", 1);
  EXPECT_EQ(BatchCpus(), AvailableCores());
  ::setenv("SLURM_CPUS_PER_TASK", "two", 1);
  EXPECT_EQ(BatchCpus(), AvailableCores());
  if (saved) {
    ::setenv("SLURM_CPUS_PER_TASK", saved_value.c_str(), 1);
  } else {
    ::unsetenv("SLURM_CPUS_PER_TASK");
  }
}

TEST(BatchRun, ShardsRunDisjointRunsAndSummaryOnlyGathersThemAll) {
  // Runs on datasets that do not exist fail at once: enough to see who ran what.
  BatchManifest manifest;
  for (int i = 0; i < 5; ++i) {
    BatchRunSpec spec;
    spec.name = "r" + std::to_string(i);
    spec.dataset.root = Root() / ("missing_" + std::to_string(i));
    manifest.runs.push_back(spec);
  }
  BatchOptions options;
  options.out_dir = Root() / "shards";
  std::multiset<std::string> seen;
  for (int k = 0; k < 2; ++k) {
    options.shard = ParseBatchShard(std::to_string(k) + "/2");
    const BatchReport report = RunBatch(manifest, options);
    for (const BatchRunResult& r : report.runs) {
      seen.insert(r.name);
      EXPECT_EQ(r.status, BatchRunStatus::kFailed);
      EXPECT_NE(r.note.find("missing_"), std::string::npos) << r.note;
    }
    EXPECT_EQ(report.runs.size(), k == 0 ? 3u : 2u);
    const fs::path summary = WriteBatchSummary(options.out_dir, report);
    EXPECT_EQ(summary, options.out_dir / ".batch" / ("summary_shard_" + std::to_string(k) + "_of_2.csv"));
    EXPECT_TRUE(fs::is_regular_file(summary));
  }
  EXPECT_EQ(seen, (std::multiset<std::string>{"r0", "r1", "r2", "r3", "r4"}));
  EXPECT_FALSE(fs::exists(options.out_dir / "summary.csv"));

  options.shard = BatchShard();
  options.summary_only = true;
  const BatchReport all = RunBatch(manifest, options);
  ASSERT_EQ(all.runs.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(all.runs[i].name, "r" + std::to_string(i));
    EXPECT_EQ(all.runs[i].status, BatchRunStatus::kFailed);
    EXPECT_NE(all.runs[i].note.find("missing_" + std::to_string(i)), std::string::npos) << all.runs[i].note;
  }
  EXPECT_EQ(WriteBatchSummary(options.out_dir, all), options.out_dir / "summary.csv");
}

TEST(BatchRun, SkipsRunsThatAreUpToDateAndRerunsChangedOnes) {
  const fs::path config_a = WriteConfig("a.json", kConfig), config_b = WriteConfig("b.json", kConfig);
  BatchManifest manifest;
  manifest.runs = {Spec("a", config_a, 12), Spec("b", config_b, 12)};
  BatchOptions options;
  options.out_dir = Root() / "resume";
  BatchReport report = RunBatch(manifest, options);
  ASSERT_EQ(report.runs.size(), 2u);
  for (const BatchRunResult& r : report.runs) ASSERT_EQ(r.status, BatchRunStatus::kOk) << r.note;
  // The deterministic outputs' hashes (timing.csv is wall clock).
  auto hashes = [&](const std::string& name) {
    nlohmann::json h = RunJson(options.out_dir / name)["outputs_sha256"];
    h.erase("timing.csv");
    return h.dump();
  };
  const std::string hashes_a = hashes("a");

  // Nothing changed: both skipped, nothing rewritten.
  const auto written = fs::last_write_time(options.out_dir / "a" / "run.json");
  report = RunBatch(manifest, options);
  for (const BatchRunResult& r : report.runs) {
    EXPECT_EQ(r.status, BatchRunStatus::kSkipped) << r.name << ": " << r.note;
    EXPECT_TRUE(r.has_result);
    EXPECT_EQ(r.frames, 12);
  }
  EXPECT_EQ(fs::last_write_time(options.out_dir / "a" / "run.json"), written);
  // A different thread count does not make a run out of date (outputs do not depend on it).
  manifest.runs[0].threads = 2;
  EXPECT_EQ(RunBatch(manifest, options).runs[0].status, BatchRunStatus::kSkipped);

  // The config of b changes: b runs again and says why, a is skipped.
  WriteConfig("b.json", R"({"frontend": {"max_features_pinhole": 90}, "eval": {"align": "se3"}})");
  report = RunBatch(manifest, options);
  EXPECT_EQ(report.runs[0].status, BatchRunStatus::kSkipped);
  EXPECT_EQ(report.runs[1].status, BatchRunStatus::kOk);
  EXPECT_NE(report.runs[1].note.find("config changed at /frontend/max_features_pinhole"), std::string::npos)
      << report.runs[1].note;
  EXPECT_EQ(RunJson(options.out_dir / "b")["config"]["frontend"]["max_features_pinhole"], 90);

  // The frame count of a changes: a runs again.
  manifest.runs[0].max_frames = 14;
  report = RunBatch(manifest, options);
  EXPECT_EQ(report.runs[0].status, BatchRunStatus::kOk);
  EXPECT_NE(report.runs[0].note.find("frame count changed"), std::string::npos) << report.runs[0].note;
  EXPECT_EQ(report.runs[0].frames, 14);
  EXPECT_EQ(report.runs[1].status, BatchRunStatus::kSkipped);

  // Made by another build (another executable): runs again.
  nlohmann::json run_b = RunJson(options.out_dir / "b");
  ASSERT_EQ(run_b["build"]["executable_sha256"], ExecutableSha256());
  run_b["build"]["executable_sha256"] = std::string(64, '0');
  WriteFileAtomic(options.out_dir / "b" / "run.json", run_b.dump(2));
  report = RunBatch(manifest, options);
  EXPECT_EQ(report.runs[0].status, BatchRunStatus::kSkipped);
  EXPECT_EQ(report.runs[1].status, BatchRunStatus::kOk);
  EXPECT_NE(report.runs[1].note.find("made by another mcvo build"), std::string::npos) << report.runs[1].note;

  // Made with another BLAS (the same executable, another libblas.so.3): runs again.
  run_b = RunJson(options.out_dir / "b");
  ASSERT_EQ(run_b["build"]["blas"], BlasLibrary());
  run_b["build"]["blas"] = "/usr/lib/x86_64-linux-gnu/blas/libblas.so.3.11.0";
  WriteFileAtomic(options.out_dir / "b" / "run.json", run_b.dump(2));
  report = RunBatch(manifest, options);
  EXPECT_EQ(report.runs[0].status, BatchRunStatus::kSkipped);
  EXPECT_EQ(report.runs[1].status, BatchRunStatus::kOk);
  EXPECT_NE(report.runs[1].note.find("made with another BLAS"), std::string::npos) << report.runs[1].note;

  // An output edited by hand: runs again. --force: runs again although up to date.
  WriteFileAtomic(options.out_dir / "a" / "trajectory.tum", "edited\n");
  report = RunBatch(manifest, options);
  EXPECT_EQ(report.runs[0].status, BatchRunStatus::kOk);
  EXPECT_NE(report.runs[0].note.find("output trajectory.tum was changed"), std::string::npos)
      << report.runs[0].note;
  options.force = true;
  report = RunBatch(manifest, options);
  EXPECT_EQ(report.runs[0].status, BatchRunStatus::kOk);
  EXPECT_EQ(report.runs[1].status, BatchRunStatus::kOk);
  EXPECT_TRUE(report.runs[1].note.empty()) << report.runs[1].note;

  // Back to 12 frames: the same outputs as the first time.
  options.force = false;
  manifest.runs[0].max_frames = 12;
  EXPECT_EQ(RunBatch(manifest, options).runs[0].status, BatchRunStatus::kOk);
  EXPECT_EQ(hashes("a"), hashes_a);
}

TEST(BatchRun, OutOfDateReasonSeesChangedInputs) {
  const fs::path config = WriteConfig("c.json", kConfig);
  // A copy of the dataset whose images can be changed.
  const fs::path seq = Root() / "seq_copy";
  fs::copy(Dataset(), seq, fs::copy_options::recursive);
  BatchRunSpec spec = Spec("in", config, 12);
  spec.dataset.root = seq;
  BatchManifest manifest;
  manifest.runs = {spec};
  BatchOptions options;
  options.out_dir = Root() / "inputs";
  ASSERT_EQ(RunBatch(manifest, options).runs[0].status, BatchRunStatus::kOk);
  const PipelineOptions pipeline = BatchRunOptions(spec, 1);
  EXPECT_FALSE(RunOutOfDateReason(options.out_dir / "in", spec, pipeline).has_value());
  // An image after the frames used changes nothing; one within them does.
  fs::copy_file(seq / "images" / "image_00" / "000000.png", seq / "images" / "image_00" / "000015.png",
                fs::copy_options::overwrite_existing);
  EXPECT_FALSE(RunOutOfDateReason(options.out_dir / "in", spec, pipeline).has_value());
  fs::copy_file(seq / "images" / "image_00" / "000000.png", seq / "images" / "image_00" / "000005.png",
                fs::copy_options::overwrite_existing);
  const auto reason = RunOutOfDateReason(options.out_dir / "in", spec, pipeline);
  ASSERT_TRUE(reason.has_value());
  EXPECT_EQ(*reason, "inputs changed (images_sha256)");
}

TEST(BatchRun, AFailingRunDoesNotStopTheOthers) {
  const fs::path good = WriteConfig("good.json", kConfig);
  const fs::path bad = WriteConfig("bad.json", R"({"backend": {"window_sise": 10}})");
  BatchManifest manifest;
  manifest.runs = {Spec("first", good, 12), Spec("no_dataset", good, 12), Spec("bad_config", bad, 12),
                   Spec("last", good, 12)};
  manifest.runs[1].dataset.root = Root() / "no_such_dataset";
  BatchOptions options;
  options.out_dir = Root() / "isolation";
  options.jobs = 2;
  // A folder in the way that mcvo did not write is never replaced (util/output_folder.h).
  fs::create_directories(options.out_dir / "last");
  WriteFileAtomic(options.out_dir / "last" / "mine.txt", "keep");
  const BatchReport report = RunBatch(manifest, options);
  ASSERT_EQ(report.runs.size(), 4u);
  EXPECT_EQ(report.runs[0].status, BatchRunStatus::kOk);
  EXPECT_EQ(report.runs[1].status, BatchRunStatus::kFailed);
  EXPECT_NE(report.runs[1].note.find("no_such_dataset"), std::string::npos) << report.runs[1].note;
  EXPECT_EQ(report.runs[2].status, BatchRunStatus::kFailed);
  EXPECT_NE(report.runs[2].note.find("bad.json"), std::string::npos) << report.runs[2].note;
  EXPECT_NE(report.runs[2].note.find("window_sise"), std::string::npos) << report.runs[2].note;
  EXPECT_EQ(report.runs[3].status, BatchRunStatus::kFailed);
  EXPECT_NE(report.runs[3].note.find("holds no .mcvo-output marker"), std::string::npos)
      << report.runs[3].note;
  EXPECT_TRUE(fs::exists(options.out_dir / "last" / "mine.txt"));
  EXPECT_EQ(report.Count(BatchRunStatus::kFailed), 3);
  EXPECT_TRUE(fs::is_regular_file(options.out_dir / "first" / "run.json"));
  EXPECT_FALSE(fs::exists(options.out_dir / "no_dataset"));
  EXPECT_FALSE(fs::exists(options.out_dir / "bad_config"));
}

TEST(BatchRun, SummaryHoldsTheNumbersOfEachRun) {
  const fs::path config = WriteConfig("s.json", kConfig);
  BatchManifest manifest;
  manifest.runs = {Spec("full", config, 0), Spec("broken", config, 0)};
  manifest.runs[1].dataset.root = Root() / "gone";
  BatchOptions options;
  options.out_dir = Root() / "summary";
  BatchReport report = RunBatch(manifest, options);
  ASSERT_EQ(report.runs[0].status, BatchRunStatus::kOk) << report.runs[0].note;
  report = RunBatch(manifest, options);  // again: skipped, same numbers
  const BatchRunResult& r = report.runs[0];
  ASSERT_EQ(r.status, BatchRunStatus::kSkipped);
  const nlohmann::json run = RunJson(options.out_dir / "full");
  const nlohmann::json eval =
      nlohmann::json::parse(ReadFileToString(options.out_dir / "full" / "eval" / "eval.json"));
  EXPECT_EQ(r.frames, 20);
  EXPECT_EQ(r.posed_frames, run["result"]["posed_frames"].get<int>());
  EXPECT_GT(r.posed_frames, 10);
  ASSERT_TRUE(r.evaluated);
  EXPECT_EQ(r.ate_rmse_m, run["result"]["ate_rmse_m"].get<double>());
  EXPECT_EQ(r.ate_percent_of_path, run["result"]["ate_percent_of_path"].get<double>());
  EXPECT_EQ(r.scale_error_percent, run["result"]["scale_error_percent"].get<double>());
  ASSERT_TRUE(r.has_rpe);
  EXPECT_EQ(r.rpe_translation_percent, eval["rpe"]["average"]["translation_percent"].get<double>());
  EXPECT_DOUBLE_EQ(r.rpe_rotation_deg_per_100m,
                   100.0 * eval["rpe"]["average"]["rotation_deg_per_m"].get<double>());
  EXPECT_EQ(r.frames_per_second, run["timing"]["frames_per_second"].get<double>());

  const fs::path csv_path = WriteBatchSummary(options.out_dir, report);
  EXPECT_EQ(csv_path, options.out_dir / "summary.csv");
  std::istringstream csv(ReadFileToString(csv_path));
  std::string header, full, broken, extra;
  std::getline(csv, header);
  std::getline(csv, full);
  std::getline(csv, broken);
  EXPECT_FALSE(std::getline(csv, extra));
  EXPECT_EQ(header,
            "name,status,note,frames,posed_frames,segments,warning,ate_rmse_m,ate_percent_of_path,"
            "rpe_translation_percent,rpe_rotation_deg_per_100m,scale_error_percent,frames_per_second");
  EXPECT_EQ(full.rfind(StrCat("full,skipped,\"up to date\",20,", r.posed_frames, ",1,\"\","), 0), 0u) << full;
  EXPECT_NE(full.find(FormatDouble(r.ate_rmse_m)), std::string::npos) << full;
  EXPECT_EQ(broken.rfind("broken,failed,\"", 0), 0u) << broken;
  EXPECT_NE(broken.find("gone"), std::string::npos) << broken;
  EXPECT_NE(broken.find(",,,,,,,,,,"), std::string::npos) << broken;  // no numbers

  const std::string md = ReadFileToString(options.out_dir / "summary.md");
  EXPECT_NE(md.find(StrCat("| full | skipped (up to date) | 20 | ", r.posed_frames, " | 1 | ")),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| broken | failed: "), std::string::npos) << md;
  EXPECT_NE(md.find("2 runs: 0 ok, 1 skipped (up to date), 1 failed"), std::string::npos) << md;

  // Summary only: the same statuses from the records; a changed config shows as stale.
  options.summary_only = true;
  BatchReport gathered = RunBatch(manifest, options);
  EXPECT_EQ(gathered.runs[0].status, BatchRunStatus::kSkipped);
  EXPECT_EQ(gathered.runs[0].ate_rmse_m, r.ate_rmse_m);
  EXPECT_EQ(gathered.runs[1].status, BatchRunStatus::kFailed);
  WriteConfig("s.json", R"({"frontend": {"max_features_pinhole": 80}})");
  gathered = RunBatch(manifest, options);
  EXPECT_EQ(gathered.runs[0].status, BatchRunStatus::kStale);
  EXPECT_NE(gathered.runs[0].note.find("config changed"), std::string::npos) << gathered.runs[0].note;
}

TEST(BatchRun, OutputsDoNotDependOnJobs) {
  const fs::path config = WriteConfig("j.json", kConfig);
  BatchManifest manifest;
  for (int i = 0; i < 3; ++i) manifest.runs.push_back(Spec("run" + std::to_string(i), config, 10 + 2 * i));
  BatchOptions serial, parallel;
  serial.out_dir = Root() / "jobs1";
  parallel.out_dir = Root() / "jobs3";
  parallel.jobs = 3;
  const BatchReport a = RunBatch(manifest, serial), b = RunBatch(manifest, parallel);
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(a.runs[i].status, BatchRunStatus::kOk) << a.runs[i].note;
    ASSERT_EQ(b.runs[i].status, BatchRunStatus::kOk) << b.runs[i].note;
    nlohmann::json ha = RunJson(serial.out_dir / a.runs[i].name)["outputs_sha256"];
    nlohmann::json hb = RunJson(parallel.out_dir / b.runs[i].name)["outputs_sha256"];
    ha.erase("timing.csv");
    hb.erase("timing.csv");
    EXPECT_EQ(ha, hb) << a.runs[i].name;
  }
}

}  // namespace
}  // namespace mcvo
