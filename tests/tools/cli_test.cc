// Runs the built `mcvo` binary: exit codes and one-line errors on bad input.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include "tools/run_mcvo.h"

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

const std::filesystem::path kSource(MCVO_SOURCE_DIR);

using mcvo::test::Quote;
using mcvo::test::Result;
using mcvo::test::RunMcvo;

std::filesystem::path TempDir() {
  const char* env = std::getenv("MCVO_TEST_TMP");
  std::filesystem::path dir =
      env != nullptr ? std::filesystem::path(env) : std::filesystem::path(::testing::TempDir());
  dir /= "cli_test";
  std::filesystem::create_directories(dir);
  return dir;
}

std::filesystem::path WriteTemp(const std::string& name, const std::string& content) {
  const std::filesystem::path path = TempDir() / name;
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

size_t CountLines(const std::string& text) {
  size_t lines = 0;
  for (char c : text) lines += c == '\n' ? 1 : 0;
  return lines;
}

// A valid camera with one field replaced (or added) by `override_json`.
std::string Camera(const std::string& name, const std::string& body) {
  return R"({"name": ")" + name + R"(", "model": "pinhole", "width": 640, "height": 480, )" + body + "}";
}
const std::string kParams = R"("params": [500, 500, 320, 240])";
const std::string kExtrinsics =
    R"("cam_from_rig": {"quaternion_wxyz": [1, 0, 0, 0], "translation": [0, 0, 0]})";
std::string GoodCamera(const std::string& name) { return Camera(name, kParams + ", " + kExtrinsics); }
std::string RigOf(const std::string& cameras) { return R"({"cameras": [)" + cameras + "]}"; }
std::string RigWithCamera(const std::string& body) { return RigOf(Camera("a", body)); }

struct BadRig {
  std::string name;
  std::string json;
  std::string expected;  // JSON path (or "line" for syntax errors) the message must name
};

std::vector<BadRig> BadRigs() {
  const std::string transform_prefix = kParams + R"(, "cam_from_rig": )";
  return {
      {"syntax_error", "{\"cameras\": [\n  {\"name\": \"a\",,}\n]}", "line 2"},
      {"truncated", "{\"cameras\": [", "line 1"},
      {"not_an_object", "[]", ": /: expected an object"},
      {"zero_cameras", R"({"cameras": []})", ": /cameras: "},
      {"cameras_not_array", R"({"cameras": {}})", ": /cameras: expected an array"},
      {"missing_cameras", R"({})", ": /cameras: missing required key"},
      {"missing_model", RigOf(R"({"name": "a", "width": 1, "height": 1, "params": []})"),
       ": /cameras/0/model: missing"},
      {"unknown_top_key", R"({"cameras": [)" + GoodCamera("a") + R"(], "camera": 1})",
       ": /camera: unknown key"},
      {"unknown_camera_key", RigWithCamera(kParams + ", " + kExtrinsics + R"(, "focal": 500)"),
       ": /cameras/0/focal: unknown key"},
      {"unknown_transform_key",
       RigWithCamera(transform_prefix +
                     R"({"quaternion_wxyz": [1, 0, 0, 0], "translation": [0, 0, 0], "scale": 2})"),
       ": /cameras/0/cam_from_rig/scale: unknown key"},
      {"width_is_string",
       RigOf(R"({"name": "a", "model": "pinhole", "width": "640", "height": 480, )" + kParams + ", " +
             kExtrinsics + "}"),
       ": /cameras/0/width: expected an integer"},
      {"width_fraction",
       RigOf(R"({"name": "a", "model": "pinhole", "width": 640.5, "height": 480, )" + kParams + ", " +
             kExtrinsics + "}"),
       ": /cameras/0/width: expected an integer"},
      {"height_zero",
       RigOf(R"({"name": "a", "model": "pinhole", "width": 640, "height": 0, )" + kParams + ", " +
             kExtrinsics + "}"),
       ": /cameras/0/height: must be >= 1"},
      {"not_orthonormal",
       RigOf(GoodCamera("a") + ", " +
             Camera("b",
                    transform_prefix +
                        R"({"rotation": [[1, 0, 0], [0, 1, 0.03], [0, 0, 1]], "translation": [0, 0, 0]})")),
       ": /cameras/1/cam_from_rig/rotation: not orthonormal"},
      {"reflection",
       RigWithCamera(transform_prefix +
                     R"({"rotation": [[-1, 0, 0], [0, 1, 0], [0, 0, 1]], "translation": [0, 0, 0]})"),
       ": /cameras/0/cam_from_rig/rotation: determinant"},
      {"rotation_2x3",
       RigWithCamera(transform_prefix + R"({"rotation": [[1, 0, 0], [0, 1, 0]], "translation": [0, 0, 0]})"),
       ": /cameras/0/cam_from_rig/rotation: expected an array of 3"},
      {"quaternion_not_unit",
       RigWithCamera(kParams +
                     R"(, "rig_from_cam": {"quaternion_wxyz": [1, 0.1, 0, 0], "translation": [0, 0, 0]})"),
       ": /cameras/0/rig_from_cam/quaternion_wxyz: not a unit quaternion"},
      {"rotation_and_quaternion",
       RigWithCamera(
           transform_prefix +
           R"({"rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "quaternion_wxyz": [1, 0, 0, 0], "translation": [0, 0, 0]})"),
       ": /cameras/0/cam_from_rig: give either"},
      {"both_directions",
       RigWithCamera(kParams + ", " + kExtrinsics +
                     R"(, "rig_from_cam": {"quaternion_wxyz": [1, 0, 0, 0], "translation": [0, 0, 0]})"),
       ": /cameras/0: give either"},
      {"no_extrinsics", RigWithCamera(kParams), ": /cameras/0: missing the extrinsics"},
      {"missing_translation", RigWithCamera(transform_prefix + R"({"quaternion_wxyz": [1, 0, 0, 0]})"),
       ": /cameras/0/cam_from_rig/translation: missing"},
      {"infinite_number",
       RigWithCamera(transform_prefix + R"({"quaternion_wxyz": [1, 0, 0, 0], "translation": [0, 0, 1e999]})"),
       ": /cameras/0/cam_from_rig/translation/2: number 1e999 is out of range"},
      {"negative_overflow", RigWithCamera(R"("params": [500, -1e400, 320, 240], )" + kExtrinsics),
       ": /cameras/0/params/1: number -1e400 is out of range"},
      {"string_for_number", RigWithCamera(R"("params": [500, 500, "320", 240], )" + kExtrinsics),
       ": /cameras/0/params/2: expected a number"},
      {"nan_literal", RigWithCamera(R"("params": [NaN, 500, 320, 240], )" + kExtrinsics), "line 1"},
      {"null_param", RigWithCamera(R"("params": [null, 500, 320, 240], )" + kExtrinsics),
       ": /cameras/0/params/0: expected a number, got null"},
      {"unknown_model",
       RigOf(R"({"name": "a", "model": "fisheye624", "width": 640, "height": 480, )" + kParams + ", " +
             kExtrinsics + "}"),
       ": /cameras/0/model: unknown camera model \"fisheye624\" (known: pinhole, radtan"},
      {"wrong_param_count", RigWithCamera(R"("params": [500, 500, 320], )" + kExtrinsics),
       ": /cameras/0/params: expected 4 parameters (fx fy cx cy) for model pinhole, got 3"},
      {"radtan_param_count",
       RigOf(
           R"({"name": "a", "model": "radtan", "width": 640, "height": 480, "params": [1, 1, 1, 1, 0, 0, 0], )" +
           kExtrinsics + "}"),
       ": /cameras/0/params: expected 8 or 9 parameters"},
      {"negative_focal", RigWithCamera(R"("params": [-500, 500, 320, 240], )" + kExtrinsics),
       ": /cameras/0/params: fx and fy must be > 0"},
      {"mei_zero_gamma",
       RigOf(
           R"({"name": "a", "model": "mei", "width": 1400, "height": 1400, "params": [2.2, 0, 0, 0, 0, 1336, 0, 700, 700], )" +
           kExtrinsics + "}"),
       ": /cameras/0/params: gamma1 and gamma2 must be > 0"},
      {"duplicate_names", RigOf(GoodCamera("a") + ", " + GoodCamera("b") + ", " + GoodCamera("a")),
       ": /cameras/2/name: duplicate camera name \"a\" (also /cameras/0/name)"},
      {"empty_name", RigOf(GoodCamera("")), ": /cameras/0/name: camera name must not be empty"},
      {"missing_mask", RigWithCamera(kParams + ", " + kExtrinsics + R"(, "mask": "masks/none.png")"),
       ": /cameras/0/mask: mask file not found: "},
      {"duplicate_json_key",
       RigOf(R"({"name": "a", "model": "pinhole", "width": 640, "width": 640, "height": 480, )" + kParams +
             ", " + kExtrinsics + "}"),
       ": /cameras/0/width: duplicate key"},
  };
}

TEST(Cli, EveryBadRigGivesExitCode3AndOneLineNamingFileAndJsonPath) {
  for (const BadRig& bad : BadRigs()) {
    SCOPED_TRACE(bad.name);
    const std::filesystem::path path = WriteTemp(bad.name + ".json", bad.json);
    const Result result = RunMcvo("info --rig " + Quote(path.string()));
    EXPECT_EQ(result.exit_code, 3) << result.output;
    EXPECT_EQ(CountLines(result.output), 1u) << result.output;
    EXPECT_NE(result.output.find(path.string()), std::string::npos) << result.output;
    EXPECT_NE(result.output.find(bad.expected), std::string::npos)
        << "expected '" << bad.expected << "' in " << result.output;
  }
}

TEST(Cli, MissingRigFile) {
  const std::string path = (TempDir() / "does_not_exist.json").string();
  const Result result = RunMcvo("info --rig " + Quote(path));
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_EQ(CountLines(result.output), 1u) << result.output;
  EXPECT_NE(result.output.find(path), std::string::npos) << result.output;
}

TEST(Cli, HelpAndUsageErrors) {
  EXPECT_EQ(RunMcvo("--help").exit_code, 0);
  EXPECT_EQ(RunMcvo("info --help").exit_code, 0);
  EXPECT_EQ(RunMcvo("config --help").exit_code, 0);
  const Result unknown = RunMcvo("no-such-command");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_EQ(CountLines(unknown.output), 1u) << unknown.output;
  EXPECT_EQ(RunMcvo("info --bogus 1").exit_code, 2);
  EXPECT_EQ(RunMcvo("info").exit_code, 2);
  EXPECT_EQ(RunMcvo("info --rig").exit_code, 2);
  EXPECT_EQ(RunMcvo("config --bogus").exit_code, 2);
}

TEST(Cli, InfoDescribesKitti360Rig) {
  const Result result = RunMcvo("info --rig " + Quote((kSource / "config/rigs/kitti360.json").string()));
  EXPECT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("image_00 - image_01: 0.5942 m, 0.000 deg"), std::string::npos)
      << result.output;
  EXPECT_NE(result.output.find("camera 3: image_03"), std::string::npos);
  for (const char* preset : {"kitti360_stereo.json", "kitti360_3cam.json"}) {
    EXPECT_EQ(RunMcvo("info --rig " + Quote((kSource / "config/rigs" / preset).string())).exit_code, 0)
        << preset;
  }
}

TEST(Cli, ConfigPrintsValidatesAndWrites) {
  std::ifstream in(kSource / "config/default.json", std::ios::binary);
  const std::string shipped((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const Result defaults = RunMcvo("config");
  EXPECT_EQ(defaults.exit_code, 0);
  EXPECT_EQ(defaults.output, shipped);

  const std::filesystem::path partial = WriteTemp("partial.json", R"({"backend": {"max_iterations": 12}})");
  const std::filesystem::path out = TempDir() / "resolved.json";
  std::filesystem::remove(out);
  const Result written =
      RunMcvo("config --config " + Quote(partial.string()) + " --out " + Quote(out.string()));
  EXPECT_EQ(written.exit_code, 0) << written.output;
  EXPECT_EQ(written.output, "");
  std::ifstream resolved(out, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(resolved)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"max_iterations\": 12"), std::string::npos) << text;

  const std::filesystem::path bad = WriteTemp("bad_config.json", R"({"frontend": {"lk": {"levels": 3}}})");
  const Result error = RunMcvo("config --config " + Quote(bad.string()));
  EXPECT_EQ(error.exit_code, 3);
  EXPECT_EQ(CountLines(error.output), 1u) << error.output;
  EXPECT_NE(error.output.find(bad.string() + ": /frontend/lk/levels: unknown key"), std::string::npos)
      << error.output;
}

}  // namespace
