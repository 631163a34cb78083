// Output safety as a careless or hostile user meets it (issue "Never touch
// what is not ours"; util/output_folder.h): --out over the dataset, an
// unmarked folder under --force, two runs on one --out, Ctrl-C, SIGTERM and
// SIGKILL mid-run, batch runs of stale inputs, eval, track and synth over
// their inputs. Each case checks the exit code, the one-line message, and
// that nothing the user had was touched.
#include <signal.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "mcvo/util/file.h"
#include "mcvo/util/sha256.h"
#include "mcvo/util/strings.h"
#include "tools/fixture_cache.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::Result;
using mcvo::test::RunMcvoWithin;
using mcvo::test::SmallMonoRender;

constexpr int kLimitSeconds = 90;

fs::path Root() {
  static const fs::path dir = mcvo::test::ProcessScratch("mcvo_output_safety_test");
  return dir;
}

// 200 frames: a run long enough (seconds) to be interrupted mid-way.
const fs::path& Long() {
  static const fs::path dir = [] {
    std::string error;
    const fs::path seq =
        mcvo::test::CachedSynth("--preset mono --frames 200 --image-scale 0.25 --samples 1 --seed 3", &error);
    EXPECT_FALSE(seq.empty()) << error;
    return seq;
  }();
  return dir;
}

// A private copy of a cached sequence, which a test may edit or offer to be destroyed.
fs::path CopyOf(const fs::path& seq, const std::string& name) {
  const fs::path dir = Root() / name;
  fs::remove_all(dir);
  fs::copy(seq, dir, fs::copy_options::recursive);
  return dir;
}

// Path -> SHA-256 of every file below `dir`: what must stay as it was.
std::map<std::string, std::string> Contents(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file())
      files[fs::relative(entry.path(), dir).string()] = mcvo::Sha256File(entry.path());
  }
  return files;
}

std::vector<std::string> Names(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

void ExpectOneErrorLine(const Result& r, int code, const std::string& part) {
  EXPECT_EQ(r.exit_code, code) << r.output;
  EXPECT_NE(r.output.find(part), std::string::npos) << r.output;
  size_t error_lines = 0;
  for (size_t at = r.output.find("error:"); at != std::string::npos; at = r.output.find("error:", at + 1))
    ++error_lines;
  EXPECT_EQ(error_lines, 1u) << r.output;
}

TEST(OutputSafety, ForceNeverDeletesTheDatasetOrItsParent) {
  const fs::path parent = Root() / "force_parent";
  fs::create_directories(parent);
  const fs::path seq = CopyOf(SmallMonoRender(), "force_parent/seq");
  const auto before = Contents(parent);
  for (const fs::path& out : {seq, parent, seq / "runs" / "r1"}) {
    const Result r = RunMcvoWithin(
        kLimitSeconds, "run --dataset " + Quote(seq.string()) + " --out " + Quote(out.string()) + " --force");
    ExpectOneErrorLine(r, 3, "input");
    EXPECT_EQ(Contents(parent), before) << out;
  }
}

TEST(OutputSafety, ForceNeverReplacesAFolderMcvoDidNotWrite) {
  const fs::path mine = Root() / "mine";
  fs::create_directories(mine);
  std::ofstream(mine / "notes.txt") << "mine";
  std::ofstream(mine / "run.json") << "{}";
  const Result r = RunMcvoWithin(kLimitSeconds, "run --dataset " + Quote(SmallMonoRender().string()) +
                                                    " --out " + Quote(mine.string()) + " --force");
  ExpectOneErrorLine(r, 3, ".mcvo-output");
  EXPECT_EQ(Names(mine), (std::vector<std::string>{"notes.txt", "run.json"}));
}

TEST(OutputSafety, ASecondRunOnTheSameOutRefusesAtOnceNamingTheLock) {
  // The first run is this test holding the lock, as a running mcvo does.
  const fs::path out = Root() / "locked";
  const fs::path lock = Root() / ".locked.lock";
  const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX), 0);
  const auto start = std::chrono::steady_clock::now();
  const Result r = RunMcvoWithin(
      kLimitSeconds, "run --dataset " + Quote(SmallMonoRender().string()) + " --out " + Quote(out.string()));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ExpectOneErrorLine(r, 3, ".locked.lock");
  EXPECT_NE(r.output.find("another mcvo"), std::string::npos) << r.output;
  EXPECT_LT(seconds, 30.0) << "it waited instead of refusing";
  EXPECT_FALSE(fs::exists(out));
  ::close(fd);
}

// Starts `mcvo <args>` in the background; returns its pid.
pid_t Spawn(const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::vector<char*> argv;
    static const std::string binary = MCVO_BINARY;
    argv.push_back(const_cast<char*>(binary.c_str()));
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(out, 1);
    ::dup2(out, 2);
    ::execv(binary.c_str(), argv.data());
    ::_exit(127);
  }
  return pid;
}

// Waits until the run's first frames are done (its progress in frame_stats
// is not visible; the staging folder holds the dataset's log line and the
// run is then in its frame loop), at most 60 s.
bool WaitForStaging(const fs::path& staging) {
  for (int i = 0; i < 6000; ++i) {
    if (fs::exists(staging)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

int WaitExit(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 1000 + WTERMSIG(status);
  return -1;
}

TEST(OutputSafety, SigintAndSigtermStopTheRunAndLeaveNothing) {
  for (const int signal_number : {SIGINT, SIGTERM}) {
    const fs::path folder = Root() / ("signal_" + std::to_string(signal_number));
    fs::create_directories(folder);
    const fs::path out = folder / "out";
    const pid_t pid = Spawn({"run", "--dataset", Long().string(), "--out", out.string(), "--threads", "1"},
                            folder / "log.txt");
    ASSERT_GT(pid, 0);
    const bool started = WaitForStaging(folder / ("out.tmp-" + std::to_string(pid)));
    ASSERT_TRUE(started);
    ::kill(pid, signal_number);
    const int code = WaitExit(pid);
    const std::string log = mcvo::ReadFileToString(folder / "log.txt");
    EXPECT_EQ(code, 128 + signal_number) << log;
    EXPECT_NE(log.find("cancelled by"), std::string::npos) << log;
    EXPECT_EQ(Names(folder), (std::vector<std::string>{"log.txt"})) << log;
  }
}

TEST(OutputSafety, AKilledRunsStagingIsRemovedByTheNextRun) {
  const fs::path folder = Root() / "killed";
  fs::create_directories(folder);
  const fs::path out = folder / "out";
  const pid_t pid = Spawn({"run", "--dataset", Long().string(), "--out", out.string(), "--threads", "1"},
                          folder / "log.txt");
  ASSERT_GT(pid, 0);
  const fs::path staging = folder / ("out.tmp-" + std::to_string(pid));
  ASSERT_TRUE(WaitForStaging(staging));
  ::kill(pid, SIGKILL);
  EXPECT_EQ(WaitExit(pid), 1000 + SIGKILL);
  ASSERT_TRUE(fs::exists(staging));
  const Result r = RunMcvoWithin(
      kLimitSeconds, "run --dataset " + Quote(SmallMonoRender().string()) + " --out " + Quote(out.string()));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("removed the stale staging folder"), std::string::npos) << r.output;
  EXPECT_EQ(Names(folder), (std::vector<std::string>{"log.txt", "out"}));
}

// A batch of one run over a private copy of the small sequence.
struct OneRunBatch {
  fs::path dir, seq, manifest, out;
  explicit OneRunBatch(const std::string& name) {
    dir = Root() / name;
    fs::create_directories(dir);
    seq = CopyOf(SmallMonoRender(), name + "/seq");
    manifest = dir / "batch.json";
    out = dir / "out";
    std::ofstream(manifest) << R"({"runs": [{"name": "r", "dataset": {"root": "seq"}}]})";
  }
  Result Run(const std::string& extra = "") const {
    return RunMcvoWithin(kLimitSeconds, "batch --manifest " + Quote(manifest.string()) + " --out " +
                                            Quote(out.string()) + extra);
  }
};

// Rewrites every non-comment line of a text file through `edit`.
void EditLines(const fs::path& path, const std::function<std::string(const std::string&)>& edit) {
  std::ifstream in(path);
  std::string line, text;
  while (std::getline(in, line)) text += (line.empty() || line[0] == '#' ? line : edit(line)) + "\n";
  in.close();
  std::ofstream(path, std::ios::trunc) << text;
}

TEST(OutputSafety, BatchRunsAgainWhenTheGroundTruthOrTheTimesChange) {
  const OneRunBatch batch("batch_stale");
  Result r = batch.Run();
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = batch.Run();
  EXPECT_NE(r.output.find("skipped (up to date)"), std::string::npos) << r.output;
  // The ground truth scaled by 1.1.
  EditLines(batch.seq / "groundtruth.tum", [](const std::string& line) {
    std::istringstream fields(line);
    std::string t;
    double x = 0, y = 0, z = 0;
    fields >> t >> x >> y >> z;
    std::string rest;
    std::getline(fields, rest);
    return t + " " + mcvo::FormatDouble(1.1 * x) + " " + mcvo::FormatDouble(1.1 * y) + " " +
           mcvo::FormatDouble(1.1 * z) + rest;
  });
  r = batch.Run();
  EXPECT_NE(r.output.find("ran again: inputs changed (dataset_sha256)"), std::string::npos) << r.output;
  r = batch.Run();
  EXPECT_NE(r.output.find("skipped (up to date)"), std::string::npos) << r.output;
  // Every frame time shifted by 1 ms (the header line starts with "t_ns").
  EditLines(batch.seq / "frames.csv", [](const std::string& line) {
    if (line.rfind("t_ns", 0) == 0) return line;
    const size_t comma = line.find(',');
    return std::to_string(std::stoll(line.substr(0, comma)) + 1000000) + line.substr(comma);
  });
  r = batch.Run();
  EXPECT_NE(r.output.find("ran again: inputs changed (dataset_sha256)"), std::string::npos) << r.output;
}

TEST(OutputSafety, BatchNeverReplacesAFolderThatMerelyHoldsARunJson) {
  const OneRunBatch batch("batch_foreign");
  fs::create_directories(batch.out / "r");
  std::ofstream(batch.out / "r" / "run.json") << "{}";
  std::ofstream(batch.out / "r" / "notes.txt") << "mine";
  for (const std::string& extra : {std::string(), std::string(" --force")}) {
    const Result r = batch.Run(extra);
    EXPECT_NE(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find(".mcvo-output"), std::string::npos) << r.output;
    EXPECT_EQ(Names(batch.out / "r"), (std::vector<std::string>{"notes.txt", "run.json"})) << extra;
  }
}

TEST(OutputSafety, BatchForceNeverDeletesADatasetNamedLikeARun) {
  const OneRunBatch batch("batch_named");
  // The run "seq" writes <out>/seq, and the dataset is <out>/seq.
  const fs::path manifest = batch.dir / "named.json";
  std::ofstream(manifest) << R"({"runs": [{"name": "seq", "dataset": {"root": "seq"}}]})";
  const auto before = Contents(batch.seq);
  const Result r = RunMcvoWithin(kLimitSeconds, "batch --manifest " + Quote(manifest.string()) + " --out " +
                                                    Quote(batch.dir.string()) + " --force");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("input"), std::string::npos) << r.output;
  EXPECT_EQ(Contents(batch.seq), before);
}

TEST(OutputSafety, EvalTrackAndSynthNeverWriteOverTheirInputs) {
  const fs::path seq = CopyOf(SmallMonoRender(), "file_outputs_seq");
  const auto before = Contents(seq);
  const std::string gt = Quote((seq / "groundtruth.tum").string());
  ExpectOneErrorLine(RunMcvoWithin(kLimitSeconds, "eval --gt " + gt + " --est " + gt + " --out " +
                                                      Quote(seq.string()) + " --force"),
                     3, "input");
  ExpectOneErrorLine(RunMcvoWithin(kLimitSeconds, "track --dataset " + Quote(seq.string()) + " --out " +
                                                      Quote((seq / "rig.json").string())),
                     3, "input");
  ExpectOneErrorLine(RunMcvoWithin(kLimitSeconds, "synth --rig " + Quote((seq / "rig.json").string()) +
                                                      " --scene indoor --frames 1 --out " +
                                                      Quote(seq.string()) + " --force"),
                     3, "input");
  EXPECT_EQ(Contents(seq), before);
  // eval --out twice: the second needs --force, and replaces only its own folder.
  const fs::path eval_out = Root() / "eval_out";
  EXPECT_EQ(
      RunMcvoWithin(kLimitSeconds, "eval --gt " + gt + " --est " + gt + " --out " + Quote(eval_out.string()))
          .exit_code,
      0);
  EXPECT_EQ(
      RunMcvoWithin(kLimitSeconds, "eval --gt " + gt + " --est " + gt + " --out " + Quote(eval_out.string()))
          .exit_code,
      3);
  EXPECT_EQ(RunMcvoWithin(kLimitSeconds, "eval --gt " + gt + " --est " + gt + " --out " +
                                             Quote(eval_out.string()) + " --force")
                .exit_code,
            0);
  EXPECT_TRUE(fs::is_regular_file(eval_out / "eval.json"));
}

TEST(OutputSafety, LongOutNamesAndSymbolicLinks) {
  const fs::path out = Root() / std::string(250, 'o');
  const Result r = RunMcvoWithin(
      kLimitSeconds, "run --dataset " + Quote(SmallMonoRender().string()) + " --out " + Quote(out.string()));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::is_regular_file(out / "run.json"));
  const fs::path target = Root() / "link_target";
  fs::create_directories(target);
  fs::create_directory_symlink(target, Root() / "link");
  ExpectOneErrorLine(RunMcvoWithin(kLimitSeconds, "run --dataset " + Quote(SmallMonoRender().string()) +
                                                      " --out " + Quote((Root() / "link").string())),
                     3, "symbolic link");
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(Root() / "link")));
}

}  // namespace
