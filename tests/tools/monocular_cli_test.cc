// `mcvo run` on a one-camera rig (`mcvo synth --preset mono`: KITTI-360's
// image_00 alone, 1.7 m from the rig origin): monocular odometry at an
// arbitrary scale. Every frame is posed; run.json, the scale log and the log
// say the scale is arbitrary; the run's evaluation and `mcvo eval --align
// auto` align with a similarity, about the camera centre; the COLMAP model
// is written; the outputs are identical at 1 and 2 threads.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "mcvo/util/file.h"
#include "tools/fixture_cache.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::RunMcvo;

fs::path Root() {
  static const fs::path dir = mcvo::test::ProcessScratch("mcvo_monocular_cli_test");
  return dir;
}

nlohmann::json ReadJson(const fs::path& path) { return nlohmann::json::parse(mcvo::ReadFileToString(path)); }

// 200 frames at 10 Hz of the urban route (186 m, two corners), 563x150
// (0.4 image scale: the fixture costs two thirds of 0.5's), 1 grey level of
// noise. Measured: 200 posed, Sim3 ATE 0.375 % of the path (0.18 % at 0.5;
// at 0.35 tracking is lost twice).
TEST(MonocularCli, OneCameraRunsAtAnArbitraryScaleAndSaysSo) {
  std::string error;
  const fs::path seq = mcvo::test::CachedSynth(
      "--preset mono --frames 200 --image-scale 0.4 --samples 1 --noise 1 --seed 5", &error);
  ASSERT_FALSE(seq.empty()) << error;
  const fs::path out1 = Root() / "mono_t1", out2 = Root() / "mono_t2";
  auto r = RunMcvo("run --dataset " + Quote(seq.string()) + " --threads 1 --out " + Quote(out1.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("monocular at an arbitrary scale"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("arbitrary scale: 1 unit = "), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("warning"), std::string::npos) << r.output;

  const nlohmann::json run = ReadJson(out1 / "run.json");
  const nlohmann::json& result = run["result"];
  EXPECT_EQ(result["posed_frames"], 200);
  EXPECT_EQ(result["segments"], 1);
  EXPECT_EQ(result["scale"], "arbitrary");
  EXPECT_EQ(result["alignment"], "sim3");
  EXPECT_FALSE(result.contains("scale_error_percent")) << result.dump();
  const double ate = result["ate_percent_of_path"].get<double>();
  const double unit = result["unit_m"].get<double>();
  std::printf("one camera: Sim3 ATE %.3f %% of %.1f m, 1 unit = %.3f m\n", ate,
              result["gt_path_length_m"].get<double>(), unit);
  EXPECT_LT(ate, 0.5);
  // The unit is the camera's travel over the initialisation window: metres, not millimetres or kilometres.
  EXPECT_GT(unit, 0.5);
  EXPECT_LT(unit, 50.0);
  // The trajectory is of the camera centre: where it is on the rig.
  const nlohmann::json& origin = result["trajectory_origin_in_rig_m"];
  ASSERT_EQ(origin.size(), 3u);
  EXPECT_NEAR(origin[0].get<double>(), 1.5753, 1e-3);
  EXPECT_NEAR(origin[2].get<double>(), -0.65, 1e-3);
  // The COLMAP model is written, of the one camera.
  EXPECT_GE(run["colmap"]["images"].get<int>(), 100);
  EXPECT_GE(run["colmap"]["points"].get<int>(), 300);
  EXPECT_TRUE(fs::exists(out1 / "colmap" / "sparse" / "0" / "images.bin"));
  const std::string scale_log = mcvo::ReadFileToString(out1 / "scale_log.csv");
  EXPECT_NE(scale_log.find("arbitrary scale (one camera, image_00)"), std::string::npos) << scale_log;
  EXPECT_EQ(scale_log.find("correction"), std::string::npos) << scale_log;  // nothing to correct with
  EXPECT_NE(mcvo::ReadFileToString(out1 / "report.md").find("arbitrary"), std::string::npos);

  // Deterministic at any thread count (timing.csv aside: wall clock).
  r = RunMcvo("run --dataset " + Quote(seq.string()) + " --threads 2 --out " + Quote(out2.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json hashes1 = run["outputs_sha256"], hashes2 = ReadJson(out2 / "run.json")["outputs_sha256"];
  EXPECT_EQ(hashes1.erase("timing.csv"), 1u);
  EXPECT_EQ(hashes2.erase("timing.csv"), 1u);
  EXPECT_GT(hashes1.size(), 10u);
  EXPECT_EQ(hashes1, hashes2);

  // `mcvo eval` on the run's trajectory against the dataset's (rig) ground
  // truth: auto picks sim3 and moves the ground truth to the camera centre,
  // so it agrees with the run's own evaluation; a rigid alignment measures
  // the unit instead.
  const fs::path eval_out = Root() / "eval";
  r = RunMcvo("eval --gt " + Quote((seq / "groundtruth.tum").string()) + " --est " +
              Quote((out1 / "trajectory.tum").string()) + " --out " + Quote(eval_out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("--align auto: sim3"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("ground truth moved"), std::string::npos) << r.output;
  const double eval_rmse = ReadJson(eval_out / "eval.json")["ate"]["translation_m"]["rmse"].get<double>();
  EXPECT_NEAR(eval_rmse, result["ate_rmse_m"].get<double>(), 1e-9);
  const fs::path rigid_out = Root() / "eval_se3";
  r = RunMcvo("eval --align se3 --gt " + Quote((seq / "groundtruth.tum").string()) + " --est " +
              Quote((out1 / "trajectory.tum").string()) + " --out " + Quote(rigid_out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find("--align auto"), std::string::npos) << r.output;
  EXPECT_GT(ReadJson(rigid_out / "eval.json")["ate"]["translation_m"]["rmse"].get<double>(),
            10.0 * eval_rmse);
}

// The KITTI-360 3-camera rig (no overlapping views) on the first 60 frames of
// the urban route, a straight road: its metric scale is never observable,
// so no window initialises. Offline, the run is made again with the camera
// that tracked the most features alone, at an arbitrary scale, and says so
// (measured: image_03 alone, 60 of 60 posed, Sim3 ATE 0.21 % of 46 m);
// with initializer.monocular_fallback off it poses nothing and exits with 5.
TEST(MonocularCli, ARigWhoseScaleIsNeverObservableFinishesUpToScale) {
  std::string error;
  const fs::path seq = mcvo::test::CachedSynth(
      "--preset kitti360-3cam --frames 60 --image-scale 0.3 --samples 1 --noise 1 --seed 8", &error);
  ASSERT_FALSE(seq.empty()) << error;
  const std::string config = std::string(MCVO_SOURCE_DIR) + "/config/kitti360_3cam.json";
  const fs::path out = Root() / "straight";
  auto r = RunMcvo("run --dataset " + Quote(seq.string()) + " --config " + Quote(config) + " --out " +
                   Quote(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("the metric scale was never observable"), std::string::npos) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  const nlohmann::json& result = run["result"];
  EXPECT_EQ(result["posed_frames"], 60);
  EXPECT_EQ(result["scale"], "arbitrary");
  EXPECT_EQ(result["alignment"], "sim3");
  ASSERT_TRUE(result.contains("monocular_fallback")) << result.dump();
  const std::string camera = run["dataset"]["cameras"][0].get<std::string>();
  EXPECT_EQ(run["dataset"]["cameras"].size(), 1u);
  EXPECT_EQ(result["monocular_fallback"].get<std::string>().rfind(camera + " alone at an arbitrary scale", 0),
            0u)
      << result["monocular_fallback"];
  const double ate = result["ate_percent_of_path"].get<double>();
  std::printf("straight road, 3 cameras without overlap: %s alone, Sim3 ATE %.3f %% of %.1f m\n",
              camera.c_str(), ate, result["gt_path_length_m"].get<double>());
  EXPECT_LT(ate, 1.0);
  const std::string scale_log = mcvo::ReadFileToString(out / "scale_log.csv");
  EXPECT_NE(scale_log.find("offline fallback: the metric scale was never observable"), std::string::npos)
      << scale_log;
  // The frame statistics are of the one camera.
  const std::string stats = mcvo::ReadFileToString(out / "frame_stats.csv");
  EXPECT_NE(stats.find("features_" + camera), std::string::npos);
  EXPECT_EQ(stats.find("features_image_00,features_image_02"), std::string::npos);
  // The input hashes are of the dataset as given (all three cameras): batch's
  // up-to-date check opens it that way.
  EXPECT_TRUE(run["inputs"].contains("images_sha256"));

  const fs::path off_config = Root() / "no_monocular_fallback.json";
  nlohmann::json c = nlohmann::json::parse(mcvo::ReadFileToString(config));
  c["initializer"]["monocular_fallback"] = false;
  mcvo::WriteFileAtomic(off_config, c.dump(2));
  const fs::path off = Root() / "straight_off";
  r = RunMcvo("run --dataset " + Quote(seq.string()) + " --frames 30 --config " + Quote(off_config.string()) +
              " --out " + Quote(off.string()));
  EXPECT_EQ(r.exit_code, 5) << r.output;
  EXPECT_NE(r.output.find("no frame posed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the metric scale was never observable"), std::string::npos) << r.output;
}

}  // namespace
