#include "mcvo/config/config.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

std::string ErrorOf(const std::string& json) {
  try {
    ParsePipelineOptions(json, "c.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Config, DefaultsPassCheck) { EXPECT_NO_THROW(PipelineOptions().Check()); }

// config/default.json is the resolved defaults; regenerate it with
// `mcvo config --out config/default.json` when a default changes.
TEST(Config, ShippedDefaultJsonIsCurrent) {
  const std::filesystem::path path = std::filesystem::path(MCVO_SOURCE_DIR) / "config" / "default.json";
  EXPECT_EQ(ReadFileToString(path), PipelineOptionsToJson(PipelineOptions()));
  EXPECT_EQ(PipelineOptionsToJson(ReadPipelineOptions(path)), PipelineOptionsToJson(PipelineOptions()));
}

// Every preset in config/ (the pipeline configs, not the rigs) reads and
// passes Check, and its camera selection names cameras of the KITTI-360 rig
// where the preset is a KITTI-360 one.
TEST(Config, ShippedPresetsReadAndCheck) {
  int presets = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::path(MCVO_SOURCE_DIR) / "config")) {
    if (!entry.is_regular_file() || entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().string());
    PipelineOptions options;
    ASSERT_NO_THROW(options = ReadPipelineOptions(entry.path()));
    EXPECT_NO_THROW(options.Check());
    const std::string stem = entry.path().stem().string();
    if (stem.rfind("kitti360_", 0) == 0) {
      const size_t cameras = static_cast<size_t>(stem[9] - '0');
      EXPECT_EQ(options.dataset.cameras.size(), cameras);
    }
    ++presets;
  }
  EXPECT_GE(presets, 7);  // default + six presets
}

TEST(Config, EmptyObjectGivesDefaults) {
  EXPECT_EQ(PipelineOptionsToJson(ParsePipelineOptions("{}", "c.json")),
            PipelineOptionsToJson(PipelineOptions()));
}

TEST(Config, RoundTrip) {
  PipelineOptions options;
  options.frontend.detector = DetectorType::kSuperPoint;
  options.frontend.model_path = "models/superpoint.onnx";
  options.frontend.max_features_pinhole = 123;
  options.frontend.ransac_threshold_px = 0.1;
  options.frontend.clahe.enabled = false;
  options.frontend.lk.window_px = 31;
  options.frontend.superpoint.confidence_threshold = 1.0 / 3.0;
  options.frontend.superpoint.detect_missing_fraction = 0.25;
  options.frontend.detect_missing_fraction = 0.125;
  options.frontend.selection = FeatureSelection::kQuadtree;
  options.initializer.required_cameras = {"image_00", "image_02"};
  options.backend.loss = LossType::kHuber;
  options.backend.solver = SolverType::kLevenbergMarquardt;
  options.backend.refine_extrinsics = true;
  options.loop.enabled = false;
  options.runtime.seed = 1234567890123LL;
  options.runtime.threads = 2;
  options.eval.align = AlignmentMode::kSim3;
  options.eval.rpe_length_percents = {25.0};
  const std::string json = PipelineOptionsToJson(options);
  const PipelineOptions read = ParsePipelineOptions(json, "c.json");
  EXPECT_EQ(PipelineOptionsToJson(read), json);
  EXPECT_EQ(read.frontend.detector, DetectorType::kSuperPoint);
  EXPECT_EQ(read.frontend.superpoint.confidence_threshold, 1.0 / 3.0);
  EXPECT_EQ(read.frontend.superpoint.detect_missing_fraction, 0.25);
  EXPECT_EQ(read.frontend.detect_missing_fraction, 0.125);
  EXPECT_EQ(read.initializer.required_cameras, options.initializer.required_cameras);
  EXPECT_EQ(read.runtime.seed, 1234567890123LL);
  EXPECT_EQ(read.eval.rpe_length_percents, std::vector<double>{25.0});
}

TEST(Config, MissingKeysKeepDefaults) {
  const PipelineOptions options = ParsePipelineOptions(
      R"({"frontend": {"lk": {"window_px": 15}}, "backend": {"loss": "huber"}})", "c.json");
  EXPECT_EQ(options.frontend.lk.window_px, 15);
  EXPECT_EQ(options.frontend.lk.pyramid_levels, 3);
  EXPECT_EQ(options.frontend.max_features_pinhole, 100);
  EXPECT_EQ(options.backend.loss, LossType::kHuber);
  EXPECT_EQ(options.backend.max_iterations, 8);
}

TEST(Config, RequiredCamerasAllOrList) {
  EXPECT_TRUE(ParsePipelineOptions(R"({"initializer": {"required_cameras": "all"}})", "c")
                  .initializer.required_cameras.empty());
  EXPECT_EQ(ParsePipelineOptions(R"({"initializer": {"required_cameras": ["a"]}})", "c")
                .initializer.required_cameras,
            std::vector<std::string>{"a"});
  EXPECT_EQ(
      ErrorOf(R"({"initializer": {"required_cameras": "some"}})"),
      "c.json: /initializer/required_cameras: expected \"all\" or an array of camera names, got a string "
      "(\"some\")");
  EXPECT_EQ(ErrorOf(R"({"initializer": {"required_cameras": ["a", "a"]}})"),
            "c.json: /initializer/required_cameras/1: camera \"a\" listed twice");
}

TEST(Config, UnknownKeysAreRejectedAtAnyDepth) {
  EXPECT_EQ(
      ErrorOf(R"({"frontend": {"lk": {"window": 21}}})"),
      "c.json: /frontend/lk/window: unknown key (valid keys: window_px, pyramid_levels, max_iterations, "
      "forward_backward_check, forward_backward_threshold_px, predict_rotation, predict_rotation_min_px, "
      "predict_motion, predict_motion_min_px, predict_motion_min_points)");
  EXPECT_EQ(ErrorOf(R"({"frontnd": {}})"),
            "c.json: /frontnd: unknown key (valid keys: dataset, frontend, initializer, backend, loop, "
            "refine, output, colmap, runtime, eval)");
  EXPECT_NE(ErrorOf(R"({"backend": {"window_size": 10, "windowsize": 10}})")
                .find("c.json: /backend/windowsize: unknown key"),
            std::string::npos);
}

TEST(Config, WrongTypesAreRejected) {
  EXPECT_EQ(ErrorOf(R"({"frontend": {"max_features_pinhole": "100"}})"),
            "c.json: /frontend/max_features_pinhole: expected an integer, got a string (\"100\")");
  EXPECT_EQ(ErrorOf(R"({"frontend": {"max_features_pinhole": 100.5}})"),
            "c.json: /frontend/max_features_pinhole: expected an integer, got the number 100.5");
  EXPECT_EQ(ErrorOf(R"({"frontend": {"max_features_pinhole": 1e10}})"),
            "c.json: /frontend/max_features_pinhole: expected an integer, got the number 10000000000.0");
  EXPECT_EQ(ErrorOf(R"({"frontend": {"max_features_pinhole": 10000000000}})"),
            "c.json: /frontend/max_features_pinhole: must be <= 2147483647, got 10000000000");
  EXPECT_EQ(ErrorOf(R"({"frontend": {"clahe": true}})"),
            "c.json: /frontend/clahe: expected an object, got true");
  EXPECT_EQ(ErrorOf(R"({"runtime": {"deterministic": 1}})"),
            "c.json: /runtime/deterministic: expected true or false, got the number 1");
  EXPECT_EQ(ErrorOf(R"({"frontend": {"detector": "sift"}})"),
            "c.json: /frontend/detector: unknown value \"sift\" (valid: \"shi_tomasi\", \"orb\", \"xfeat\", "
            "\"superpoint\")");
  EXPECT_EQ(ErrorOf(R"({"backend": {"loss_scale": 1e400}})"),
            "c.json: /backend/loss_scale: number 1e400 is out of range (not finite)");
  EXPECT_EQ(ErrorOf("[]"), "c.json: /: expected an object, got an array");
  EXPECT_EQ(ErrorOf(R"({"loop": {"enabled": true, "enabled": false}})"),
            "c.json: /loop/enabled: duplicate key");
  EXPECT_NE(ErrorOf("{\"loop\": {\"enabled\": tru}}").find("c.json: JSON parse error at line 1, column"),
            std::string::npos);
}

TEST(Config, CheckFailuresNameTheField) {
  EXPECT_EQ(ErrorOf(R"({"frontend": {"max_features_pinhole": -3}})"),
            "c.json: /frontend/max_features_pinhole: must be > 0, got -3");
  EXPECT_EQ(ErrorOf(R"({"frontend": {"detector": "superpoint"}})"),
            "c.json: /frontend/model_path: required for detector \"superpoint\" (an ONNX model file)");
  EXPECT_EQ(ErrorOf(R"({"frontend": {"ransac_threshold_px": 0}})"),
            "c.json: /frontend/ransac_threshold_px: must be > 0, got 0");
  EXPECT_EQ(ErrorOf(R"({"loop": {"min_score": 1.5}})"),
            "c.json: /loop/min_score: must be in [0, 1], got 1.5");
  EXPECT_EQ(ErrorOf(R"({"frontend": {"superpoint": {"detect_missing_fraction": -0.1}}})"),
            "c.json: /frontend/superpoint/detect_missing_fraction: must be in [0, 1], got -0.1");
  EXPECT_EQ(ErrorOf(R"({"frontend": {"detect_missing_fraction": 1.5}})"),
            "c.json: /frontend/detect_missing_fraction: must be in [0, 1], got 1.5");
  EXPECT_EQ(
      ErrorOf(R"({"backend": {"max_solver_time_s": 0.04}})"),
      "c.json: /backend/max_solver_time_s: must be 0 when /runtime/deterministic is true (a wall-clock limit "
      "makes results depend on machine load), got 0.04");
  EXPECT_EQ(ErrorOf(R"({"backend": {"max_solver_time_s": 0.04}, "runtime": {"deterministic": false}})"),
            "(no error)");
  EXPECT_EQ(ErrorOf(R"({"initializer": {"window_size": 11}})"),
            "c.json: /initializer/window_size: must be <= /backend/window_size (10), got 11");
  EXPECT_EQ(ErrorOf(R"({"eval": {"rpe_length_percents": [10, 0]}})"),
            "c.json: /eval/rpe_length_percents: expected values in (0, 100], got 0");

  PipelineOptions options;
  options.backend.min_observations = 1;
  try {
    options.Check();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "/backend/min_observations: must be >= 2, got 1");
  }
}

TEST(Config, WriteIsAtomicAndReadable) {
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) / "mcvo_config_test.json";
  PipelineOptions options;
  options.backend.max_iterations = 12;
  WritePipelineOptions(path, options);
  EXPECT_EQ(ReadPipelineOptions(path).backend.max_iterations, 12);
  EXPECT_THROW(ReadPipelineOptions(path.string() + ".missing"), InputError);
}

}  // namespace
}  // namespace mcvo
