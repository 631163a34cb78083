// run.json as one type (include/mcvo/pipeline/run_manifest.h): written by
// `mcvo run`, read by batch, regress and eval.
#include "mcvo/pipeline/run_manifest.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "test_temp_dir.h"

namespace mcvo {
namespace {

RunManifest Example() {
  RunManifest m;
  m.version = "0.1.0";
  m.executable_sha256 = "ab12";
  m.blas = "/usr/lib/x86_64-linux-gnu/openblas-serial/libblas.so.3";
  m.command_line = "mcvo run --dataset d";
  m.config_source = "config/kitti360_4cam.json";
  m.config = {{"runtime", {{"threads", 0}}}, {"backend", {{"window_size", 10}}}};
  m.dataset = {"/data/seq", "generic", "seq", 150, {"image_00", "image_01"}};
  m.inputs = {{"frames.csv", "11"}, {"rig.json", "22"}};
  m.outputs_sha256 = {{"trajectory.tum", "33"}, {"eval/eval.json", "44"}};
  m.result = {{"frames", 150},
              {"posed_frames", 148},
              {"segments", 1},
              {"ate_rmse_m", 0.25},
              {"ate_percent_of_path", 0.12},
              {"scale_error_percent", 0.3},
              {"scale", "arbitrary"},
              {"trajectory_origin_in_rig_m", {0.5, -0.1, 1.7}},
              {"warning", "posed 148 of 150"}};
  m.timing = {{"frames_per_second", 31.5}};
  return m;
}

TEST(RunManifest, RoundTripsThroughJsonInRunJsonsOrder) {
  const RunManifest m = Example();
  const nlohmann::ordered_json json = m.ToJson();
  std::vector<std::string> keys;
  for (const auto& item : json.items()) keys.push_back(item.key());
  EXPECT_EQ(keys,
            (std::vector<std::string>{"program", "version", "build", "command_line", "config_source",
                                      "config", "dataset", "inputs", "outputs_sha256", "result", "timing"}));
  EXPECT_EQ(json["build"]["executable_sha256"], "ab12");
  EXPECT_EQ(json["build"]["blas"], "/usr/lib/x86_64-linux-gnu/openblas-serial/libblas.so.3");
  // The config keeps the writer's order (backend after runtime here).
  EXPECT_EQ(json["config"].begin().key(), "runtime");

  const RunManifest back = RunManifest::FromJson(json);
  EXPECT_EQ(back.ToJson(), json);
  EXPECT_TRUE(back.Has("outputs_sha256"));
  EXPECT_FALSE(back.Has("colmap"));  // not exported, not written
  EXPECT_EQ(back.dataset.cameras, m.dataset.cameras);
  EXPECT_EQ(back.inputs, m.inputs);
}

TEST(RunManifest, HeadlineReadsTheResultNumbers) {
  const RunHeadline h = Example().Headline();
  EXPECT_EQ(h.frames, 150);
  EXPECT_EQ(h.posed_frames, 148);
  EXPECT_EQ(h.segments, 1);
  ASSERT_TRUE(h.ate_rmse_m.has_value());
  EXPECT_DOUBLE_EQ(*h.ate_rmse_m, 0.25);
  EXPECT_DOUBLE_EQ(h.scale_error_percent.value(), 0.3);
  EXPECT_DOUBLE_EQ(h.frames_per_second.value(), 31.5);
  EXPECT_TRUE(h.scale_arbitrary);
  ASSERT_TRUE(h.trajectory_origin_in_rig_m.has_value());
  EXPECT_DOUBLE_EQ(h.trajectory_origin_in_rig_m->z(), 1.7);
  EXPECT_EQ(h.warning.value(), "posed 148 of 150");
  EXPECT_FALSE(h.rpe_translation_percent.has_value());
}

TEST(RunManifest, MissingOrMistypedMembersAreAbsentNotFatal) {
  nlohmann::ordered_json json = Example().ToJson();
  json.erase("inputs");
  json["outputs_sha256"] = "not an object";
  json["result"]["ate_rmse_m"] = "NaN";
  json["result"]["trajectory_origin_in_rig_m"] = {1.0, 2.0};
  const RunManifest m = RunManifest::FromJson(json);
  EXPECT_FALSE(m.Has("inputs"));
  EXPECT_FALSE(m.Has("outputs_sha256"));
  EXPECT_TRUE(m.outputs_sha256.empty());
  EXPECT_TRUE(m.Has("result"));
  const RunHeadline h = m.Headline();
  EXPECT_FALSE(h.ate_rmse_m.has_value());  // not a number: not evaluated
  EXPECT_FALSE(h.trajectory_origin_in_rig_m.has_value());
  EXPECT_TRUE(RunManifest::FromJson(nlohmann::ordered_json::array()).present.empty());
}

TEST(RunManifest, ReadNamesTheFileOfBrokenJson) {
  const std::filesystem::path dir = testing::TestTempDir("run_manifest_test");
  WriteFileAtomic(dir / "run.json", "{\"program\": ");
  try {
    RunManifest::Read(dir / "run.json");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "run.json").string()), std::string::npos) << e.what();
  }
  WriteFileAtomic(dir / "run.json", "[1, 2]");
  EXPECT_THROW(RunManifest::Read(dir / "run.json"), InputError);
  WriteFileAtomic(dir / "run.json", Example().ToJson().dump(2));
  EXPECT_EQ(RunManifest::Read(dir / "run.json").ToJson(), Example().ToJson());
}

}  // namespace
}  // namespace mcvo
