// The two seed-11 cases of the robust-odometry issue (issue 14), shortened
// to 0.35 of the resolution with one sample per pixel, as a user runs them:
// the KITTI-360 rig without overlap (image_00 and both fisheyes,
// config/kitti360_3cam.json) on 400 frames of the urban route with seed 11,
// whose first corner comes after frame 310. Before it the rig drives
// straight, where a rig without overlapping views cannot observe its scale
// at one time: the initialiser waits for the corner, the reverse pass poses
// the straight from it, and the cross-camera links across time (one camera
// seeing later what another saw earlier, loop/cross_camera_links.h) tie the
// cameras' tracks through the metric baselines in the global BA.
//
// Once: 33 of 400 frames posed at 26 % ATE (a broken initialisation), and
// 67 of 400 at 4.3 % scale error. At half resolution, 2026-11-27: 400 of 400
// posed, scale error 0.245 % and 0.121 % (0.562 % and 0.847 % without the
// links; results/robustness_seed11.md). The bounds are the issue's.
#include <gtest/gtest.h>

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
  static const fs::path dir = mcvo::test::ProcessScratch("mcvo_seed11_cli_test");
  return dir;
}

// Renders `synth_args` (once per build), runs the 3-camera config on it and
// checks the bounds: frames posed >= 99 %, scale error <= 2 %, and
// the 3-camera ATE target of the suite (0.5 % of the path).
void RunSeed11Case(const std::string& synth_args, const std::string& name) {
  std::string error;
  const fs::path seq = mcvo::test::CachedSynth(synth_args, &error);
  ASSERT_FALSE(seq.empty()) << error;
  const fs::path out = Root() / name;
  const std::string config = Quote(std::string(MCVO_SOURCE_DIR) + "/config/kitti360_3cam.json");
  const auto r = RunMcvo("run --dataset " + Quote(seq.string()) + " --config " + config + " --out " +
                         Quote(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = nlohmann::json::parse(mcvo::ReadFileToString(out / "run.json"));
  const nlohmann::json& result = run["result"];
  EXPECT_GE(result["posed_frames"].get<int>(), 396) << r.output;
  // The straight before the corner is posed by the reverse pass.
  EXPECT_GE(result["frames_posed_by_reverse_pass"].get<int>(), 250) << r.output;
  EXPECT_GT(result["cross_camera_links"].get<int>(), 0) << r.output;
  EXPECT_LE(result["scale_error_percent"].get<double>(), 2.0) << r.output;
  EXPECT_LE(result["ate_percent_of_path"].get<double>(), 0.5) << r.output;
}

TEST(Seed11Cli, ThreeCameraRenderIsPosedWithItsScale) {
  RunSeed11Case("--preset kitti360-3cam --frames 400 --image-scale 0.35 --samples 1 --seed 11", "k3_s11");
}

TEST(Seed11Cli, FourCameraRenderWithNoiseRunAsThreeCamerasIsPosedWithItsScale) {
  RunSeed11Case("--preset kitti360 --frames 400 --image-scale 0.35 --samples 1 --noise 1 --seed 11",
                "k4_s11_noise1_3cam");
}

}  // namespace
