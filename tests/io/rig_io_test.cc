#include "mcvo/io/rig_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

const std::filesystem::path kRigs = std::filesystem::path(MCVO_SOURCE_DIR) / "config" / "rigs";

std::filesystem::path TempDir() {
  const char* env = std::getenv("MCVO_TEST_TMP");
  std::filesystem::path dir =
      env != nullptr ? std::filesystem::path(env) : std::filesystem::path(::testing::TempDir());
  dir /= "rig_io_test";
  std::filesystem::create_directories(dir);
  return dir;
}

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

Eigen::Vector3d CenterInRig(const Camera& camera) { return camera.cam_from_rig.Inverse().translation; }

double AngleDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return Eigen::AngleAxisd(a.conjugate() * b).angle() * 180.0 / M_PI;
}

TEST(RigIo, Kitti360PresetsLoad) {
  const Rig rig = ReadRig(kRigs / "kitti360.json");
  ASSERT_EQ(rig.NumCameras(), 4);
  EXPECT_EQ(rig.cameras[0].name, "image_00");
  EXPECT_EQ(rig.cameras[0].model, CameraModelId::kPinhole);
  EXPECT_EQ(rig.cameras[0].width, 1408);
  EXPECT_EQ(rig.cameras[0].height, 376);
  EXPECT_EQ(rig.cameras[2].model, CameraModelId::kMei);
  EXPECT_EQ(rig.cameras[3].params[5], 1485.4388981875156);

  const Rig stereo = ReadRig(kRigs / "kitti360_stereo.json");
  ASSERT_EQ(stereo.NumCameras(), 2);
  const Rig three = ReadRig(kRigs / "kitti360_3cam.json");
  ASSERT_EQ(three.NumCameras(), 3);
  EXPECT_EQ(three.cameras[0].name, "image_00");
  EXPECT_EQ(three.cameras[1].name, "image_02");
  EXPECT_EQ(three.cameras[2].name, "image_03");
  // The subsets hold the same calibration as the full rig.
  for (const Rig* subset : {&stereo, &three}) {
    for (const Camera& camera : subset->cameras) {
      const Camera& full = rig.cameras[static_cast<size_t>(rig.FindCamera(camera.name))];
      EXPECT_EQ(camera.params, full.params);
      EXPECT_EQ(camera.cam_from_rig.translation, full.cam_from_rig.translation);
      EXPECT_EQ(camera.cam_from_rig.rotation.coeffs(), full.cam_from_rig.rotation.coeffs());
    }
  }
}

TEST(RigIo, Kitti360StereoGeometry) {
  const Rig rig = ReadRig(kRigs / "kitti360_stereo.json");
  const Camera& left = rig.cameras[0];
  const Camera& right = rig.cameras[1];
  // P_rect_01[0,3] = -fx * baseline.
  const double baseline_from_p_rect = 328.318735 / 552.554261;
  EXPECT_NEAR((CenterInRig(left) - CenterInRig(right)).norm(), 0.5942, 1e-4);
  EXPECT_NEAR((CenterInRig(left) - CenterInRig(right)).norm(), baseline_from_p_rect, 1e-6);
  // Rectified: one rotation for both cameras (the calibration gives 2.8e-5 deg)...
  EXPECT_LT(AngleDeg(left.cam_from_rig.rotation, right.cam_from_rig.rotation), 1e-3);
  // ... and the right camera on the +x axis of the left one (a pure x shift as in P_rect_01).
  const Eigen::Vector3d right_in_left = left.cam_from_rig * CenterInRig(right);
  EXPECT_NEAR(right_in_left.x(), baseline_from_p_rect, 1e-6);
  EXPECT_LT(std::abs(right_in_left.y()), 1e-5);
  EXPECT_LT(std::abs(right_in_left.z()), 1e-5);
  // Both look forward (+x of the pose frame), the fisheyes to the sides.
  EXPECT_GT((left.cam_from_rig.rotation.conjugate() * Eigen::Vector3d::UnitZ()).x(), 0.99);
  const Rig full = ReadRig(kRigs / "kitti360.json");
  EXPECT_LT((full.cameras[2].cam_from_rig.rotation.conjugate() * Eigen::Vector3d::UnitZ()).y(), -0.99);
  EXPECT_GT((full.cameras[3].cam_from_rig.rotation.conjugate() * Eigen::Vector3d::UnitZ()).y(), 0.99);
  // The fisheyes' extrinsics are calib_cam_to_pose.txt as given.
  EXPECT_NEAR(CenterInRig(full.cameras[2]).x(), 0.7264036936, 1e-12);
}

TEST(RigIo, RoundTripIsBitExact) {
  const std::filesystem::path dir = TempDir() / "round_trip";
  std::filesystem::create_directories(dir / "masks");
  WriteFileAtomic(dir / "masks" / "left.png", "not really a png");
  const std::string json = R"({
    "cameras": [
      {"name": "a", "model": "opencv", "width": 720, "height": 540,
       "params": [461.6, 460.3, 363.0, 248.1, -0.2917, 0.08228, 5.333e-05, -1.578e-04],
       "cam_from_rig": {"quaternion_wxyz": [0.5, 0.5, 0.5, 0.5], "translation": [0.1, -0.2, 1e-3]},
       "mask": "masks/left.png"},
      {"name": "b", "model": "kannala_brandt", "width": 640, "height": 480,
       "params": [380.1, 380.2, 320.5, 240.5, 0.01, -0.002, 0.0003, -4e-05],
       "rig_from_cam": {"rotation": [[0, -1, 0], [1, 0, 0], [0, 0, 1]], "translation": [1, 2, 3]}},
      {"name": "c", "model": "double_sphere", "width": 512, "height": 512,
       "params": [156.1, 156.2, 254.9, 256.0, -0.18, 0.59],
       "cam_from_rig": {"quaternion_wxyz": [0.8, 0, -0.6, 0], "translation": [0, 0, 0]}}
    ]
  })";
  WriteFileAtomic(dir / "rig.json", json);
  const Rig rig = ReadRig(dir / "rig.json");
  ASSERT_EQ(rig.NumCameras(), 3);
  EXPECT_EQ(rig.cameras[0].model, CameraModelId::kRadTan);
  ASSERT_EQ(rig.cameras[0].params.size(), 9u);  // k3 = 0 appended
  EXPECT_EQ(rig.cameras[0].params[8], 0.0);
  EXPECT_EQ(rig.cameras[0].mask_path, (dir / "masks" / "left.png").lexically_normal().string());
  // rig_from_cam is inverted into cam_from_rig.
  EXPECT_NEAR((CenterInRig(rig.cameras[1]) - Eigen::Vector3d(1, 2, 3)).norm(), 0.0, 1e-15);

  std::filesystem::create_directories(dir / "copy");
  WriteRig(dir / "copy" / "rig.json", rig);
  const Rig again = ReadRig(dir / "copy" / "rig.json");
  ASSERT_EQ(again.NumCameras(), rig.NumCameras());
  for (int i = 0; i < rig.NumCameras(); ++i) {
    const Camera& a = rig.cameras[static_cast<size_t>(i)];
    const Camera& b = again.cameras[static_cast<size_t>(i)];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.model, b.model);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(a.mask_path, b.mask_path);
    ASSERT_EQ(a.params.size(), b.params.size());
    for (size_t k = 0; k < a.params.size(); ++k) EXPECT_TRUE(SameBits(a.params[k], b.params[k]));
    for (int k = 0; k < 4; ++k) {
      EXPECT_TRUE(SameBits(a.cam_from_rig.rotation.coeffs()[k], b.cam_from_rig.rotation.coeffs()[k]));
    }
    for (int k = 0; k < 3; ++k) {
      EXPECT_TRUE(SameBits(a.cam_from_rig.translation[k], b.cam_from_rig.translation[k]));
    }
  }
  EXPECT_NE(ReadFileToString(dir / "copy" / "rig.json").find("\"mask\": \"../masks/left.png\""),
            std::string::npos);
  // Writing is deterministic.
  WriteRig(dir / "copy" / "rig2.json", again);
  EXPECT_EQ(ReadFileToString(dir / "copy" / "rig.json"), ReadFileToString(dir / "copy" / "rig2.json"));
}

std::string ErrorOf(const std::string& json) {
  try {
    ParseRigJson(json, "r.json", TempDir());
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string Camera0(const std::string& transform) {
  return R"({"cameras": [{"name": "a", "model": "pinhole", "width": 10, "height": 10, "params": [5, 5, 5, 5], )" +
         transform + "}]}";
}

TEST(RigIo, ErrorMessagesNameTheJsonPath) {
  EXPECT_EQ(
      ErrorOf(Camera0(
          R"("cam_from_rig": {"rotation": [[1, 0, 0], [0, 1, 0.03], [0, 0, 1]], "translation": [0, 0, 0]})")),
      "r.json: /cameras/0/cam_from_rig/rotation: not orthonormal (max |R^T R - I| = 0.03, tolerance 1e-05)");
  EXPECT_EQ(
      ErrorOf(Camera0(R"("rig_from_cam": {"quaternion_wxyz": [1, 0, 0, 0.1], "translation": [0, 0, 0]})")),
      "r.json: /cameras/0/rig_from_cam/quaternion_wxyz: not a unit quaternion (norm 1.004987562112089, "
      "tolerance 1e-05)");
  EXPECT_EQ(
      ErrorOf(Camera0(R"("cam_from_rig": {"quaternion_wxyz": [1, 0, 0, 0], "translation": [0, "x", 0]})")),
      "r.json: /cameras/0/cam_from_rig/translation/1: expected a number, got a string (\"x\")");
  EXPECT_EQ(
      ErrorOf(Camera0(R"("cam_from_rig": {"quaternion_wxyz": [1, 0, 0, 0], "translation": [0, 1e999, 0]})")),
      "r.json: /cameras/0/cam_from_rig/translation/1: number 1e999 is out of range (not finite)");
  EXPECT_EQ(
      ErrorOf(Camera0(
          R"("cam_from_rig": {"quaternion_wxyz": [1, 0, 0, 0], "translation": [0, 0, 0]}, "mask": "nope.png")")),
      "r.json: /cameras/0/mask: mask file not found: " + (TempDir() / "nope.png").string());
  EXPECT_EQ(ErrorOf(R"({"cameras": []})"),
            "r.json: /cameras: the rig has no cameras (expected at least one)");
  EXPECT_EQ(ErrorOf(R"({"cameras": [], "cameras": []})"), "r.json: /cameras: duplicate key");
  EXPECT_EQ(ErrorOf(R"({"cameras": [{"name": "a"}]})"), "r.json: /cameras/0/model: missing required key");
  EXPECT_NE(ErrorOf("{\n\"cameras\": [\n}").find("r.json: JSON parse error at line 3, column 1"),
            std::string::npos)
      << ErrorOf("{\n\"cameras\": [\n}");
}

TEST(RigIo, ErrorMessagesAreValidUtf8) {
  // A long string value is cut for the message: never inside a character
  // ("x" and 20 three-byte letters: the cut at 37 bytes of its JSON text,
  // quote included, falls in the 12th letter).
  std::string letters;
  for (int i = 0; i < 20; ++i) letters += "\xE6\x9D\xB1";
  const std::string cut = ErrorOf(R"({"cameras": [{"name": "a", "model": "pinhole", "width": "x)" + letters +
                                  R"(", "height": 10, "params": [5, 5, 5, 5]}]})");
  EXPECT_EQ(cut.find("r.json: /cameras/0/width: expected an integer, got a string (\"x" +
                     letters.substr(0, 33) + "...)"),
            0u)
      << cut;
  EXPECT_TRUE(IsValidUtf8(cut)) << cut;
  // Bytes that are not UTF-8 make the parser fail; its message quotes them.
  const std::string parse = ErrorOf("{\"cameras\": [\"\xFF\xFE\"]}");
  EXPECT_EQ(parse.find("r.json: JSON "), 0u) << parse;
  EXPECT_TRUE(IsValidUtf8(parse)) << parse;
  // A key with a newline is quoted in the pointer, escaped onto one line.
  const std::string key = ErrorOf("{\"cameras\": [], \"x\\ny\": 1}");
  EXPECT_EQ(key, "r.json: /x\\ny: unknown key (valid keys: cameras, description)");
}

TEST(RigIo, ParamNames) {
  EXPECT_EQ(CameraModelParamNames(CameraModelId::kMei).size(), 9u);
  for (CameraModelId id : {CameraModelId::kPinhole, CameraModelId::kRadTan, CameraModelId::kKannalaBrandt,
                           CameraModelId::kMei, CameraModelId::kDoubleSphere}) {
    EXPECT_EQ(static_cast<int>(CameraModelParamNames(id).size()), CameraModelNumParams(id));
  }
}

}  // namespace
}  // namespace mcvo
