// `mcvo run` and `mcvo batch` when the system refuses threads or memory
// (issue 57): an ordinary error line and exit 1, never std::terminate
// (exit 134), no output folder left, and a batch goes on with its next run.
//
// The thread limit (RLIMIT_NPROC, `ulimit -u`) does not apply to root, and
// CI runs as root: the child runs as user nobody (setpriv), on inputs that
// nobody can read, into a scratch folder nobody can write.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include <nlohmann/json.hpp>

#include "mcvo/util/file.h"
#include "tools/fixture_cache.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::RunShell;

// The address space limit (`ulimit -v`, prlimit --as) of the out-of-memory test, KiB: room for start-up, not
// for the render.
constexpr long kAddressSpaceKib = 2L * 1024 * 1024;

const char kSynth[] = "--preset stereo --frames 10 --image-scale 0.3 --samples 1 --seed 5";

// Why the tests cannot run the child as nobody here, or "" when they can.
std::string CannotRunAsNobody() {
  if (::geteuid() != 0) return "needs root to run mcvo as user nobody (RLIMIT_NPROC does not bind root)";
  if (RunShell("command -v setpriv >/dev/null && command -v prlimit >/dev/null").exit_code != 0) {
    return "setpriv and prlimit (util-linux) are not installed";
  }
  return "";
}

// A scratch folder that nobody may write into, under a path nobody may walk.
fs::path WorldWritableScratch() {
  const fs::path root = mcvo::test::ProcessScratch("resource_limits_cli_test");
  fs::permissions(root, fs::perms::all);
  for (fs::path p = root.parent_path(); p != p.root_path(); p = p.parent_path()) {
    struct stat st {};
    if (::stat(p.c_str(), &st) == 0 && (st.st_mode & S_IXOTH) == 0) {
      ADD_FAILURE() << p << " is not traversable by other users";
    }
  }
  return root;
}

// `mcvo <args>` as nobody with RLIMIT_NPROC `processes` (`ulimit -u`; it
// counts every process and thread of nobody).
mcvo::test::Result RunAsNobody(int processes, const std::string& args) {
  const std::string n = std::to_string(processes);
  return RunShell(
      "timeout --kill-after=5 120 setpriv --reuid=65534 --regid=65534 --clear-groups -- prlimit --nproc=" +
      n + ":" + n + " -- " + Quote(MCVO_BINARY) + " " + args);
}

// Some line of `output` starts with `prefix` and mentions `part`.
bool HasLine(const std::string& output, const std::string& prefix, const std::string& part) {
  size_t start = 0;
  while (start < output.size()) {
    size_t end = output.find('\n', start);
    if (end == std::string::npos) end = output.size();
    const std::string line = output.substr(start, end - start);
    if (line.rfind(prefix, 0) == 0 && line.find(part) != std::string::npos) return true;
    start = end + 1;
  }
  return false;
}

fs::path Dataset() {
  std::string error;
  const fs::path seq = mcvo::test::CachedSynth(kSynth, &error);
  EXPECT_FALSE(seq.empty()) << error;
  return seq;
}

TEST(ResourceLimitsCli, RunOutOfThreadsIsAnErrorLineNotAnAbort) {
  if (const std::string why = CannotRunAsNobody(); !why.empty()) GTEST_SKIP() << why;
  const fs::path seq = Dataset();
  ASSERT_FALSE(seq.empty());
  const fs::path scratch = WorldWritableScratch();
  // Unlimited, as nobody: the run works, so what fails below is the limit.
  auto r = RunAsNobody(4096, "run --dataset " + Quote(seq.string()) + " --threads 64 --out " +
                                 Quote((scratch / "free").string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (int limit : {1, 3, 6}) {
    const fs::path out = scratch / ("limited_" + std::to_string(limit));
    r = RunAsNobody(limit,
                    "run --dataset " + Quote(seq.string()) + " --threads 64 --out " + Quote(out.string()));
    EXPECT_EQ(r.exit_code, 1) << "ulimit -u " << limit << ":\n" << r.output;
    EXPECT_TRUE(HasLine(r.output, "mcvo run: error: cannot start ", "ulimit -u, or memory); try --threads 1"))
        << r.output;
    EXPECT_EQ(r.output.find("terminate"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out)) << out;
  }
}

TEST(ResourceLimitsCli, BatchGoesOnAfterARunOutOfThreads) {
  if (const std::string why = CannotRunAsNobody(); !why.empty()) GTEST_SKIP() << why;
  const fs::path seq = Dataset();
  ASSERT_FALSE(seq.empty());
  const fs::path scratch = WorldWritableScratch();
  const fs::path manifest = scratch / "batch.json";
  mcvo::WriteFileAtomic(
      manifest,
      "{\"runs\": [\n  {\"name\": \"first\", \"dataset\": {\"root\": " + nlohmann::json(seq.string()).dump() +
          "}, \"threads\": 64},\n  {\"name\": \"second\", \"dataset\": {\"root\": " +
          nlohmann::json(seq.string()).dump() + "}, \"threads\": 64}\n]}\n");
  fs::permissions(manifest, fs::perms::owner_all | fs::perms::group_read | fs::perms::others_read);
  const fs::path out = scratch / "batch_out";
  const auto r =
      RunAsNobody(2, "batch --manifest " + Quote(manifest.string()) + " --out " + Quote(out.string()));
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_EQ(r.output.find("terminate"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| first | failed: cannot start "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("| second | failed: cannot start "), std::string::npos) << r.output;
  EXPECT_TRUE(fs::is_regular_file(out / "summary.csv")) << r.output;
  EXPECT_TRUE(fs::is_regular_file(out / "summary.md")) << r.output;
  EXPECT_FALSE(fs::exists(out / "first" / "run.json"));
}

// The render of a 4x stereo image at 8 x 8 samples builds its camera rays
// first (12 bytes a sample: over 4 GB a camera), far beyond the
// address space left under kAddressSpaceKib, while start-up needs much less.
TEST(ResourceLimitsCli, OutOfMemoryNamesTheStage) {
  const fs::path scratch = mcvo::test::ProcessScratch("resource_limits_oom");
  const fs::path out = scratch / "seq";
  const std::string as = std::to_string(kAddressSpaceKib * 1024);
  const std::string command =
      "prlimit --as=" + as + ":" + as + " -- " + Quote(MCVO_BINARY) +
      " synth --preset stereo --frames 2 --image-scale 4 --samples 8 --threads 1 --out " +
      Quote(out.string());
  const auto r = RunShell("timeout --kill-after=5 120 " + command);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_TRUE(HasLine(r.output,
                      "mcvo synth: error: out of memory in synth --out " + out.string() +
                          ": synth: rendering frame 0 of camera ",
                      "std::bad_alloc"))
      << r.output;
  EXPECT_FALSE(fs::exists(out)) << out;
}

}  // namespace
