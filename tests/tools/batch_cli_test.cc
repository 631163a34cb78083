// `mcvo batch` as a user runs it: a manifest with two good runs and one bad
// dataset (exit 4, the others finish, summary.csv/md written), a second
// batch that skips what is up to date, two shards and --summary-only that
// gathers them, usage and manifest errors, and the Slurm example's syntax.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include "mcvo/util/file.h"
#include "test_temp_dir.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::RunMcvo;

fs::path Root() { return mcvo::testing::TestTempDir("batch_cli_test"); }

// Rendered once per process: 16 frames of the stereo preset, small.
void RenderDataset() {
  static const bool done = [] {
    const auto r = RunMcvo("synth --preset stereo --frames 16 --image-scale 0.35 --samples 1 --out " +
                           Quote((Root() / "data" / "seq").string()));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return true;
  }();
  (void)done;
}

// A manifest in Root()/name.json whose paths are relative to Root().
fs::path WriteManifest(const std::string& name) {
  RenderDataset();
  mcvo::WriteFileAtomic(Root() / "config.json", R"({"frontend": {"max_features_pinhole": 100}})");
  const fs::path path = Root() / (name + ".json");
  mcvo::WriteFileAtomic(path, R"({"runs": [
    {"name": "short", "dataset": {"root": "data/seq"}, "config": "config.json", "max_frames": 12, "threads": 1},
    {"name": "missing", "dataset": {"root": "data/not_there"}, "config": "config.json"},
    {"name": "all", "dataset": {"root": "data/seq", "format": "generic"}, "config": "config.json", "threads": 2}
  ]})");
  return path;
}

TEST(BatchCli, RunsResumesAndIsolatesFailures) {
  const fs::path manifest = WriteManifest("m1");
  const fs::path out = Root() / "out1";
  auto r = RunMcvo("batch --manifest " + Quote(manifest.string()) + " --jobs 2 --out " + Quote(out.string()));
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("| short | ok | 12 | "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| all | ok | 16 | "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| missing | failed: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not_there"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::is_regular_file(out / "short" / "run.json"));
  EXPECT_TRUE(fs::is_regular_file(out / "all" / "trajectory.tum"));
  EXPECT_FALSE(fs::exists(out / "missing"));
  const std::string csv = mcvo::ReadFileToString(out / "summary.csv");
  EXPECT_EQ(csv.find("name,status,note,frames,posed_frames,segments,warning,ate_rmse_m"), 0u) << csv;
  // Manifest order, whatever order the jobs finished in.
  const size_t a = csv.find("\nshort,ok,"), b = csv.find("\nmissing,failed,"), c = csv.find("\nall,ok,");
  EXPECT_LT(a, b) << csv;
  EXPECT_LT(b, c) << csv;
  EXPECT_NE(c, std::string::npos) << csv;
  EXPECT_TRUE(fs::is_regular_file(out / "summary.md"));

  // Again: the good runs are up to date, the bad one fails again.
  r = RunMcvo("batch --manifest " + Quote(manifest.string()) + " --out " + Quote(out.string()));
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("| short | skipped (up to date) | 12 | "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| all | skipped (up to date) | 16 | "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("1 failed"), std::string::npos) << r.output;

  // Without the bad run: exit 0. The default output folder is the manifest's path without .json.
  mcvo::WriteFileAtomic(Root() / "m2.json", R"({"runs": [
    {"name": "short", "dataset": {"root": "data/seq"}, "config": "config.json", "max_frames": 12}]})");
  r = RunMcvo("batch --manifest " + Quote((Root() / "m2.json").string()));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::is_regular_file(Root() / "m2" / "short" / "run.json"));
  EXPECT_TRUE(fs::is_regular_file(Root() / "m2" / "summary.csv"));
}

TEST(BatchCli, ShardsThenSummaryOnly) {
  const fs::path manifest = WriteManifest("m3");
  const fs::path out = Root() / "out3";
  const std::string base = "batch --manifest " + Quote(manifest.string()) + " --out " + Quote(out.string());
  // Shard 1/2 takes run 1 only (missing): it fails.
  auto r = RunMcvo(base + " --shard 1/2");
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_FALSE(fs::exists(out / "short"));
  EXPECT_FALSE(fs::exists(out / "all"));
  // Before shard 0 ran: its runs are missing from the summary.
  r = RunMcvo(base + " --summary-only");
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("| short | not run (no run folder)"), std::string::npos) << r.output;
  // Shard 0/2 takes runs 0 and 2.
  r = RunMcvo(base + " --shard 0/2");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::is_regular_file(out / "short" / "run.json"));
  EXPECT_TRUE(fs::is_regular_file(out / "all" / "run.json"));
  EXPECT_FALSE(fs::exists(out / "missing"));
  EXPECT_TRUE(fs::is_regular_file(out / ".batch" / "summary_shard_0_of_2.csv"));
  EXPECT_TRUE(fs::is_regular_file(out / ".batch" / "summary_shard_1_of_2.md"));
  r = RunMcvo(base + " --summary-only");
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("| short | ok | 12 | "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| missing | failed: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| all | ok | 16 | "), std::string::npos) << r.output;
  const std::string csv = mcvo::ReadFileToString(out / "summary.csv");
  EXPECT_NE(csv.find("\nshort,ok,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\nmissing,failed,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\nall,ok,"), std::string::npos) << csv;
}

TEST(BatchCli, UsageAndManifestErrors) {
  const fs::path manifest = WriteManifest("m4");
  const std::string m = " --manifest " + Quote(manifest.string());
  auto r = RunMcvo("batch" + m + " --shard 2/2");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--shard"), std::string::npos) << r.output;
  r = RunMcvo("batch" + m + " --jobs 0");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = RunMcvo("batch" + m + " --summary-only --force");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = RunMcvo("batch --out x");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  const fs::path bad = Root() / "bad.json";
  mcvo::WriteFileAtomic(bad, R"({"runs": [{"name": "a b", "dataset": {"root": "x"}}]})");
  r = RunMcvo("batch --manifest " + Quote(bad.string()) + " --out " + Quote((Root() / "bad_out").string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("bad.json: /runs/0/name: \"a b\": character ' ' not allowed"), std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(Root() / "bad_out"));
  r = RunMcvo("batch --manifest " + Quote((Root() / "none.json").string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("none.json"), std::string::npos) << r.output;
}

TEST(BatchCli, SlurmExampleIsValidBash) {
  const std::string script = std::string(MCVO_SOURCE_DIR) + "/tools/slurm_batch.sh";
  EXPECT_EQ(std::system(("bash -n " + Quote(script)).c_str()), 0);
  // Without arguments it prints its usage and submits nothing.
  EXPECT_NE(std::system(("bash " + Quote(script) + " > /dev/null 2>&1").c_str()), 0);
}

}  // namespace
