// End-to-end: the `mcvo eval` binary on files written here.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "eval/trajectory_fixtures.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

fs::path TestDir(const std::string& name) {
  const char* env = std::getenv("MCVO_TEST_TMP");
  const fs::path dir = fs::path(env != nullptr ? env : ::testing::TempDir()) / ("eval_cli_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

std::string Tum(const Trajectory& trajectory) {
  std::string text = "# t tx ty tz qx qy qz qw\n";
  for (const StampedPose& p : trajectory.poses) {
    const Rigid3d& pose = p.world_from_body;
    text += FormatNsAsSeconds(p.t_ns) + " " + FormatDouble(pose.translation.x()) + " " +
            FormatDouble(pose.translation.y()) + " " + FormatDouble(pose.translation.z()) + " " +
            FormatDouble(pose.rotation.x()) + " " + FormatDouble(pose.rotation.y()) + " " +
            FormatDouble(pose.rotation.z()) + " " + FormatDouble(pose.rotation.w()) + "\n";
  }
  return text;
}

std::string Kitti(const Trajectory& trajectory) {
  std::string text;
  for (const StampedPose& p : trajectory.poses) {
    const Eigen::Matrix<double, 3, 4> m = p.world_from_body.ToMatrix3x4();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) text += FormatDouble(m(r, c)) + (r == 2 && c == 3 ? "\n" : " ");
    }
  }
  return text;
}

// Runs `mcvo <args>` with stdout / stderr into files in `dir`; the exit code.
int RunMcvo(const fs::path& dir, const std::string& args) {
  const std::string command = std::string("\"") + MCVO_BINARY + "\" " + args + " > \"" +
                              (dir / "stdout.txt").string() + "\" 2> \"" + (dir / "stderr.txt").string() +
                              "\"";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(EvalCli, TumEndToEnd) {
  const fs::path dir = TestDir("tum");
  const Trajectory gt = testing::Helix(80);
  const Trajectory est =
      testing::Transformed(gt, Rigid3d(So3Exp(Eigen::Vector3d(0.1, -0.2, 0.3)), Eigen::Vector3d(1, 2, 3)));
  WriteText(dir / "gt.tum", Tum(gt));
  WriteText(dir / "est.tum", Tum(est));
  const std::string files =
      "--gt \"" + (dir / "gt.tum").string() + "\" --est \"" + (dir / "est.tum").string() + "\"";
  ASSERT_EQ(RunMcvo(dir, "eval " + files + " --out \"" + (dir / "out").string() + "\""), 0)
      << ReadFileToString(dir / "stderr.txt");
  const nlohmann::json j = nlohmann::json::parse(ReadFileToString(dir / "out" / "eval.json"));
  EXPECT_EQ(j["association"]["mode"], "time");
  EXPECT_EQ(j["association"]["matched"], 80);
  EXPECT_EQ(j["alignment"]["mode"], "se3");
  EXPECT_LT(j["ate"]["translation_m"]["rmse"].get<double>(), 1e-6);
  EXPECT_NEAR(j["scale"]["sim3_scale"].get<double>(), 1.0, 1e-9);
  EXPECT_TRUE(fs::exists(dir / "out" / "eval.md"));
  EXPECT_TRUE(fs::exists(dir / "out" / "ate_errors.csv"));
  EXPECT_TRUE(fs::exists(dir / "out" / "est_aligned.tum"));
  // The reports: titled by the file names, every plot of an evaluation.
  const std::string html = ReadFileToString(dir / "out" / "report.html");
  EXPECT_NE(html.find("<title>est.tum vs gt.tum</title>"), std::string::npos);
  for (const char* id : {"plot-trajectory", "plot-translation-error", "plot-rotation-error",
                         "plot-rpe-translation", "plot-rpe-rotation"}) {
    EXPECT_NE(html.find(std::string("<svg id=\"") + id + "\""), std::string::npos) << id;
  }
  const std::string md = ReadFileToString(dir / "out" / "report.md");
  EXPECT_EQ(md.rfind("# est.tum vs gt.tum\n", 0), 0u) << md.substr(0, 200);
  EXPECT_NE(md.find("| ATE RMSE | 0.0000 m |"), std::string::npos);
  // stdout carries the same Markdown as eval.md.
  EXPECT_EQ(ReadFileToString(dir / "stdout.txt"), ReadFileToString(dir / "out" / "eval.md"));

  // A second run gives byte-identical files.
  ASSERT_EQ(RunMcvo(dir, "eval " + files + " --out \"" + (dir / "out2").string() + "\""), 0);
  for (const char* name :
       {"eval.json", "eval.md", "ate_errors.csv", "est_aligned.tum", "report.html", "report.md"}) {
    EXPECT_EQ(ReadFileToString(dir / "out" / name), ReadFileToString(dir / "out2" / name)) << name;
  }

  // Without alignment the error is the transform's displacement: non-zero.
  ASSERT_EQ(RunMcvo(dir, "eval " + files + " --align none --out \"" + (dir / "out3").string() + "\""), 0);
  const nlohmann::json none = nlohmann::json::parse(ReadFileToString(dir / "out3" / "eval.json"));
  EXPECT_GT(none["ate"]["translation_m"]["rmse"].get<double>(), 1.0);
}

TEST(EvalCli, KittiDefaultsToIndexAssociation) {
  const fs::path dir = TestDir("kitti");
  const Trajectory gt = testing::Helix(40);
  const Trajectory est = testing::Transformed(gt, Rigid3d(), 1.1);
  WriteText(dir / "gt.txt", Kitti(gt));
  WriteText(dir / "est.txt", Kitti(est));
  ASSERT_EQ(
      RunMcvo(dir, "eval --gt \"" + (dir / "gt.txt").string() + "\" --est \"" + (dir / "est.txt").string() +
                       "\" --align sim3 --rpe-lengths 5,10 --out \"" + (dir / "out").string() + "\""),
      0)
      << ReadFileToString(dir / "stderr.txt");
  const nlohmann::json j = nlohmann::json::parse(ReadFileToString(dir / "out" / "eval.json"));
  EXPECT_EQ(j["association"]["mode"], "index");
  EXPECT_EQ(j["association"]["matched"], 40);
  EXPECT_NEAR(j["scale"]["est_scale_factor"].get<double>(), 1.1, 1e-9);
  EXPECT_NEAR(j["scale"]["scale_error_percent"].get<double>(), 10.0, 1e-7);
  EXPECT_EQ(j["rpe"]["lengths"].size(), 2u);
  EXPECT_EQ(j["options"]["rpe_lengths_m"][1], 10.0);
  EXPECT_TRUE(fs::exists(dir / "out" / "est_aligned.kitti"));
  // KITTI files have no time: the report plots by distance all the same.
  const std::string html = ReadFileToString(dir / "out" / "report.html");
  EXPECT_NE(html.find("<svg id=\"plot-translation-error\""), std::string::npos);
  EXPECT_NE(html.find("kitti"), std::string::npos);  // the settings name the format
  EXPECT_TRUE(fs::exists(dir / "out" / "report.md"));
}

TEST(EvalCli, ExitCodes) {
  const fs::path dir = TestDir("errors");
  const Trajectory gt = testing::Helix(10);
  WriteText(dir / "gt.tum", Tum(gt));
  WriteText(dir / "bad.tum", Tum(gt) + "1.5 1 2 oops 0 0 0 1\n");
  const std::string gt_arg = "--gt \"" + (dir / "gt.tum").string() + "\"";
  // Malformed file: bad input, 3, one line naming the file.
  EXPECT_EQ(RunMcvo(dir, "eval " + gt_arg + " --est \"" + (dir / "bad.tum").string() + "\""), 3);
  const std::string message = ReadFileToString(dir / "stderr.txt");
  EXPECT_NE(message.find("bad.tum"), std::string::npos) << message;
  // Missing file: 3.
  EXPECT_EQ(RunMcvo(dir, "eval " + gt_arg + " --est \"" + (dir / "missing.tum").string() + "\""), 3);
  // Bad option values: usage, 2 (checked before any file is read).
  EXPECT_EQ(RunMcvo(dir, "eval " + gt_arg + " --est \"" + (dir / "gt.tum").string() + "\" --align foo"), 2);
  EXPECT_NE(ReadFileToString(dir / "stderr.txt").find("--align"), std::string::npos);
  EXPECT_EQ(RunMcvo(dir, "eval " + gt_arg + " --est \"" + (dir / "missing.tum").string() + "\" --align foo"),
            2);
  EXPECT_EQ(
      RunMcvo(dir, "eval " + gt_arg + " --est \"" + (dir / "gt.tum").string() + "\" --rpe-lengths 10,x"), 2);
  EXPECT_EQ(RunMcvo(dir, "eval " + gt_arg + " --est \"" + (dir / "gt.tum").string() + "\" --associate foo"),
            2);
  EXPECT_EQ(RunMcvo(dir, "eval " + gt_arg + " --est \"" + (dir / "gt.tum").string() + "\" --max-dt -1"), 2);
  EXPECT_EQ(RunMcvo(dir, "eval " + gt_arg), 2);  // --est missing
  // Identical files: exit 0, zero error.
  EXPECT_EQ(RunMcvo(dir, "eval " + gt_arg + " --est \"" + (dir / "gt.tum").string() + "\""), 0);
}

}  // namespace
}  // namespace mcvo
