// Loop closure in `mcvo run`, on short synthetic sequences of the KITTI-360
// rig (4 cameras) at quarter resolution:
//  - urban_block driven for more than one lap: the second lap revisits the
//    first, a loop is found and accepted, the trajectory after the pose
//    graph is more accurate than before, the run is identical at 1 and 2
//    threads;
//  - urban_repeated (every facade alike, a route that never returns),
//    driven to its end: no loop is accepted. (The end's view matches a
//    look-alike block 220 m back geometrically, with 40-50 inliers in 2-4
//    cameras over consecutive keyframes; the drift that loop would imply
//    is what rejects it.)
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "mcvo/util/file.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::RunMcvo;

fs::path Root() {
  return fs::path(::testing::TempDir()) / ("mcvo_loop_cli_test_" + std::to_string(::getpid()));
}

// length: "--laps X" or "--frames N".
fs::path Render(const std::string& name, const std::string& scene, const std::string& length) {
  const fs::path seq = Root() / name;
  const auto r =
      RunMcvo("synth --preset kitti360 --scene " + scene + " " + length +
              " --image-scale 0.35 --samples 1 --noise 1 --seed 3 --out " + Quote(seq.string()) + " --force");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return seq;
}

std::string Config() { return Quote(std::string(MCVO_SOURCE_DIR) + "/config/kitti360_4cam.json"); }

nlohmann::json ReadJson(const fs::path& path) { return nlohmann::json::parse(mcvo::ReadFileToString(path)); }

int CountLines(const fs::path& path) {
  std::istringstream in(mcvo::ReadFileToString(path));
  int n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

class LoopCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    fs::remove_all(Root());
    fs::create_directories(Root());
  }
  static void TearDownTestSuite() { fs::remove_all(Root()); }
};

TEST_F(LoopCli, RevisitIsClosedAndImprovesTheTrajectory) {
  const fs::path seq = Render("block", "urban_block", "--laps 1.25");
  const fs::path out1 = Root() / "run1", out2 = Root() / "run2";
  auto r = RunMcvo("run --dataset " + Quote(seq.string()) + " --config " + Config() + " --threads 1 --out " +
                   Quote(out1.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunMcvo("run --dataset " + Quote(seq.string()) + " --config " + Config() + " --threads 2 --out " +
              Quote(out2.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;

  const nlohmann::json run = ReadJson(out1 / "run.json");
  const nlohmann::json& result = run["result"];
  std::printf("loops: %d accepted of %d verified; ATE %.3f m after, %.3f m before, over %.1f m\n",
              result["loops_accepted"].get<int>(), result["loop_candidates_verified"].get<int>(),
              result["ate_rmse_m"].get<double>(),
              result.value("ate_rmse_m_before_loop_closure", result["ate_rmse_m"].get<double>()),
              result["gt_path_length_m"].get<double>());
  EXPECT_GE(result["loops_accepted"].get<int>(), 1);
  ASSERT_TRUE(result["loop_closure_applied"].get<bool>());
  EXPECT_LT(result["ate_rmse_m"].get<double>(), result["ate_rmse_m_before_loop_closure"].get<double>());
  for (const char* file : {"trajectory_vo.tum", "keyframes_vo.tum", "loops.csv", "eval_vo/eval.json"}) {
    EXPECT_TRUE(fs::is_regular_file(out1 / file)) << file;
  }
  // loops.csv: a header and one line per verified or rejected candidate.
  EXPECT_GE(CountLines(out1 / "loops.csv"), 2);
  // The report draws the trajectory before loop closure too.
  EXPECT_NE(mcvo::ReadFileToString(out1 / "report.html").find("before loop closure"), std::string::npos);

  // Identical at 1 and 2 threads, loop closure included.
  nlohmann::json h1 = run["outputs_sha256"], h2 = ReadJson(out2 / "run.json")["outputs_sha256"];
  h1.erase("timing.csv");
  h2.erase("timing.csv");
  EXPECT_EQ(h1, h2);
}

TEST_F(LoopCli, RepeatedFacadesWithoutRevisitGiveNoLoop) {
  const fs::path seq = Render("repeated", "urban_repeated", "--frames 0");
  const fs::path out = Root() / "run";
  const auto r = RunMcvo("run --dataset " + Quote(seq.string()) + " --config " + Config() + " --out " +
                         Quote(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json result = ReadJson(out / "run.json")["result"];
  std::printf("repeated facades: %d candidates verified, %d accepted\n",
              result["loop_candidates_verified"].get<int>(), result["loops_accepted"].get<int>());
  EXPECT_EQ(result["loops_accepted"].get<int>(), 0);
  EXPECT_FALSE(result["loop_closure_applied"].get<bool>());
  EXPECT_FALSE(fs::exists(out / "trajectory_vo.tum"));
}

}  // namespace
