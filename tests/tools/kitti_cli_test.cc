// `mcvo info` and `mcvo run` on a KITTI odometry sequence in the layout KITTI
// ships, built in a scratch folder from the real sample
// ../shared/data/real/kitti06_stereo (sequence 06, frames 0-50): its images
// linked into sequences/06/image_0 and image_1, calib.txt with the official
// "P0:" keys from its source/calib.txt, times.txt from the KITTI 06 times,
// poses/06.txt = its source/poses.txt. The run is evaluated against the
// ground truth and gives the trajectory of the same sample's generic layout.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "mcvo/util/file.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::Result;
using mcvo::test::RunMcvoWithin;

const fs::path kSample = fs::path(MCVO_SHARED_DIR) / "data" / "real" / "kitti06_stereo";

fs::path Scratch() {
  static const fs::path dir = mcvo::test::ProcessScratch("mcvo_kitti_cli_test");
  return dir;
}

std::vector<std::string> Lines(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

// <scratch>/kitti/{sequences/06/..., poses/06.txt}; empty when the sample is
// not there.
fs::path KittiLayout() {
  if (!fs::is_directory(kSample)) return {};
  const fs::path root = Scratch() / "kitti";
  if (fs::exists(root / "poses" / "06.txt")) return root;
  const fs::path seq = root / "sequences" / "06";
  for (const auto& [from, to] :
       {std::pair<std::string, std::string>{"image_00", "image_0"}, {"image_01", "image_1"}}) {
    fs::create_directories(seq / to);
    for (const fs::directory_entry& entry : fs::directory_iterator(kSample / "images" / from))
      fs::create_symlink(entry.path(), seq / to / entry.path().filename());
  }
  const std::vector<std::string> calib = Lines(kSample / "source" / "calib.txt");
  EXPECT_EQ(calib.size(), 2u);
  std::ofstream calib_out(seq / "calib.txt", std::ios::binary);
  for (size_t i = 0; i < calib.size(); ++i) calib_out << "P" << i << ": " << calib[i] << "\n";
  const std::vector<std::string> times = Lines(kSample / "source" / "times_06_full.txt");
  EXPECT_GE(times.size(), 51u);
  std::ofstream times_out(seq / "times.txt", std::ios::binary);
  for (size_t i = 0; i < 51 && i < times.size(); ++i) times_out << times[i] << "\n";
  fs::create_directories(root / "poses");
  fs::copy_file(kSample / "source" / "poses.txt", root / "poses" / "06.txt");
  return root;
}

nlohmann::json ReadJson(const fs::path& path) { return nlohmann::json::parse(mcvo::ReadFileToString(path)); }

#define SKIP_WITHOUT_SAMPLE(root) \
  if ((root).empty())             \
  GTEST_SKIP() << "no real KITTI sample at " << kSample.string() << " (../shared/data/real/kitti06_stereo)"

TEST(KittiCli, InfoDescribesTheSequenceAtTheFolderAndAtTheRoot) {
  const fs::path root = KittiLayout();
  SKIP_WITHOUT_SAMPLE(root);
  for (const std::string& args : {"--dataset " + Quote((root / "sequences" / "06").string()),
                                  "--dataset " + Quote(root.string()) + " --sequence 06 --format kitti"}) {
    const Result r = RunMcvoWithin(60, "info " + args);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    for (const std::string expected :
         {"  format     kitti", "  name       06", "  frames     51, 0.000000000 s .. 5.195994000 s",
          "  gt         51 poses", "camera 0: image_00", "camera 1: image_01", "pinhole, 1226 x 370 px",
          "fx=707.0912 fy=707.0912 cx=601.8873 cy=183.1104", "image_00 - image_01: 0.5372 m, 0.000 deg"}) {
      EXPECT_NE(r.output.find(expected), std::string::npos) << expected << "\n" << r.output;
    }
  }
}

// Measured (20 frames, default config): SE3 ATE 0.295 % of the 22.7 m path,
// the same trajectory as the generic layout's, byte for byte.
TEST(KittiCli, RunIsEvaluatedAgainstTheGroundTruthAndMatchesTheGenericLayout) {
  const fs::path root = KittiLayout();
  SKIP_WITHOUT_SAMPLE(root);
  const fs::path out = Scratch() / "run_kitti";
  const Result r = RunMcvoWithin(300, "run --dataset " + Quote((root / "sequences" / "06").string()) +
                                          " --frames 20 --threads 2 --out " + Quote(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(Lines(out / "trajectory_kitti.txt").size(), 20u);
  const nlohmann::json run = ReadJson(out / "run.json");
  EXPECT_EQ(run["dataset"]["format"], "kitti");
  const nlohmann::json& result = run["result"];
  EXPECT_EQ(result["posed_frames"], 20);
  ASSERT_TRUE(result.contains("ate_percent_of_path")) << result.dump();
  const double ate = result["ate_percent_of_path"].get<double>();
  std::printf("kitti 06, 20 frames: SE3 ATE %.3f %% of %.1f m\n", ate,
              result["gt_path_length_m"].get<double>());
  EXPECT_EQ(result["alignment"], "se3");
  EXPECT_GT(result["gt_path_length_m"].get<double>(), 20.0);
  EXPECT_LT(ate, 0.6);

  // The generic layout of the same sample: the same rig (same camera names),
  // images and times, so the same trajectory.
  const fs::path generic = Scratch() / "run_generic";
  const Result g = RunMcvoWithin(300, "run --dataset " + Quote(kSample.string()) +
                                          " --frames 20 --threads 2 --out " + Quote(generic.string()));
  ASSERT_EQ(g.exit_code, 0) << g.output;
  EXPECT_EQ(mcvo::ReadFileToString(out / "trajectory.tum"),
            mcvo::ReadFileToString(generic / "trajectory.tum"));
}

}  // namespace
