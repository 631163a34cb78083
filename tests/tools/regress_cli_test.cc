// `mcvo regress` as CI runs it: the committed baseline
// (tests/data/regress_baseline/run) against a run made now by
// tools/make_regress_baseline.sh, within the committed tolerances; and on
// copies of the baseline: a perturbed trajectory fails with a readable
// message, a change within the tolerances passes, a missing file fails, bad
// input exits 3.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <system_error>

#include "mcvo/util/file.h"
#include "test_temp_dir.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::RunMcvo;

const fs::path kBaseline = fs::path(MCVO_SOURCE_DIR) / "tests" / "data" / "regress_baseline";

fs::path Root() { return mcvo::testing::TestTempDir("regress_cli_test"); }

std::string Tolerances() { return Quote((kBaseline / "tolerances.json").string()); }

// The baseline keeps the text copy of its COLMAP model, not the binary one
// (tools/make_regress_baseline.sh): comparisons without the tolerances file
// ignore the binary files it lists in ignore_files.
const char kIgnoreBinaryModel[] = " --ignore 'colmap/sparse/0/*'";

// True when the report has a line "  <file>  <verdict>..." (the file column
// is padded to the longest file name).
bool HasLine(const std::string& output, const std::string& file, const std::string& verdict) {
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    const std::string head = "  " + file + " ";
    if (line.rfind(head, 0) != 0) continue;
    const size_t text = line.find_first_not_of(' ', head.size());
    if (text != std::string::npos && line.compare(text, verdict.size(), verdict) == 0) return true;
  }
  return false;
}

// A writable copy of the committed baseline run.
fs::path CopyBaseline(const std::string& name) {
  const fs::path out = Root() / name;
  fs::remove_all(out);
  fs::copy(kBaseline / "run", out, fs::copy_options::recursive);
  return out;
}

// Moves the position of pose `index` (0-based data line) of a TUM file by dz metres along z.
void MovePose(const fs::path& tum, int index, double dz) {
  std::istringstream in(mcvo::ReadFileToString(tum));
  std::string out, line;
  int data = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') {
      if (data++ == index) {
        std::istringstream fields(line);
        double v[8];
        for (double& x : v) fields >> x;
        char text[256];
        std::snprintf(text, sizeof(text), "%.9f %.17g %.17g %.17g %.17g %.17g %.17g %.17g", v[0], v[1], v[2],
                      v[3] + dz, v[4], v[5], v[6], v[7]);
        line = text;
      }
    }
    out += line + "\n";
  }
  mcvo::WriteFileAtomic(tum, out);
}

TEST(RegressCli, FreshRunMatchesTheCommittedBaseline) {
  ASSERT_TRUE(fs::is_regular_file(kBaseline / "run" / "run.json"))
      << "no baseline: run tools/make_regress_baseline.sh";
  const fs::path candidate = Root() / "candidate";
  const std::string script = (fs::path(MCVO_SOURCE_DIR) / "tools" / "make_regress_baseline.sh").string();
  const std::string command = "bash " + Quote(script) + " --mcvo " + Quote(MCVO_BINARY) + " --out " +
                              Quote(candidate.string()) + " --work " + Quote((Root() / "work").string()) +
                              " > " + Quote((Root() / "make.log").string()) + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << mcvo::ReadFileToString(Root() / "make.log");
  ASSERT_TRUE(fs::is_regular_file(candidate / "trajectory.tum"));
  EXPECT_FALSE(fs::exists(candidate / "timing.csv"));

  const auto r = RunMcvo("regress --baseline " + Quote((kBaseline / "run").string()) + " --candidate " +
                         Quote(candidate.string()) + " --tolerances " + Tolerances());
  std::printf("%s", r.output.c_str());
  EXPECT_EQ(r.exit_code, 0)
      << "the pipeline's outputs changed beyond the tolerances; if that is intended, "
         "run tools/make_regress_baseline.sh and commit tests/data/regress_baseline/run\n"
      << r.output;
  EXPECT_NE(r.output.find("trajectory.tum"), std::string::npos) << r.output;
}

TEST(RegressCli, PerturbedWithinAndMissing) {
  const std::string baseline = Quote((kBaseline / "run").string());
  // The baseline against itself: identical, exit 0, even without tolerances.
  auto r = RunMcvo("regress --baseline " + baseline + " --candidate " + baseline + kIgnoreBinaryModel);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(HasLine(r.output, "trajectory.tum", "identical")) << r.output;

  // 5 mm on pose 20: beyond 1 mm, named with its time and distance.
  const fs::path moved = CopyBaseline("moved");
  MovePose(moved / "trajectory.tum", 20, 0.005);
  r = RunMcvo("regress --baseline " + baseline + " --candidate " + Quote(moved.string()) + " --tolerances " +
              Tolerances());
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_TRUE(HasLine(r.output, "trajectory.tum", "DIFFERENT: pose 20 (t ")) << r.output;
  EXPECT_NE(r.output.find(": 0.005 m, 0 deg apart (tolerance 0.001 m, 0.01 deg)"), std::string::npos)
      << r.output;
  EXPECT_TRUE(HasLine(r.output, "trajectory_kitti.txt", "identical")) << r.output;
  EXPECT_NE(r.output.find("result: DIFFERENT (1 of "), std::string::npos) << r.output;
  // Within flags given on the command line.
  r = RunMcvo("regress --baseline " + baseline + " --candidate " + Quote(moved.string()) +
              " --translation-m 0.01 --rotation-deg 0.01" + kIgnoreBinaryModel);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(HasLine(r.output, "trajectory.tum", "within tolerance (40 poses, max 0.005 m at pose 20"))
      << r.output;
  // Exact: any change is a difference.
  const fs::path nudged = CopyBaseline("nudged");
  MovePose(nudged / "trajectory.tum", 3, 1e-9);
  r = RunMcvo("regress --baseline " + baseline + " --candidate " + Quote(nudged.string()) +
              kIgnoreBinaryModel);
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_TRUE(HasLine(r.output, "trajectory.tum", "DIFFERENT: pose 3 ")) << r.output;
  r = RunMcvo("regress --baseline " + baseline + " --candidate " + Quote(nudged.string()) + " --tolerances " +
              Tolerances());
  EXPECT_EQ(r.exit_code, 0) << r.output;

  // A missing output is a difference, unless ignored.
  const fs::path missing = CopyBaseline("missing");
  fs::remove(missing / "scale_log.csv");
  r = RunMcvo("regress --baseline " + baseline + " --candidate " + Quote(missing.string()) +
              " --tolerances " + Tolerances());
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_TRUE(HasLine(r.output, "scale_log.csv", "MISSING in candidate")) << r.output;
  r = RunMcvo("regress --baseline " + baseline + " --candidate " + Quote(missing.string()) +
              " --ignore 'scale_*.csv,colmap/sparse/0/*'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST(RegressCli, BadInput) {
  const std::string baseline = Quote((kBaseline / "run").string());
  auto r = RunMcvo("regress --baseline " + baseline + " --candidate " + Quote(Root().string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("is not a run folder (no run.json)"), std::string::npos) << r.output;
  r = RunMcvo("regress --baseline " + baseline + " --candidate " + baseline + " --rel -1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = RunMcvo("regress --baseline " + baseline);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  const fs::path bad = Root() / "tol.json";
  mcvo::WriteFileAtomic(bad, R"({"trajectory": {"translation_mm": 1}})");
  r = RunMcvo("regress --baseline " + baseline + " --candidate " + baseline + " --tolerances " +
              Quote(bad.string()));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("tol.json: /trajectory/translation_mm: unknown key"), std::string::npos)
      << r.output;
}

}  // namespace
