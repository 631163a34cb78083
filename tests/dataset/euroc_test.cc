// ReadEurocDataset on small fixtures written by the tests: the real V1_01 /
// MH_01 cam0 + cam1 sensor.yaml values, synthetic 752x480 images.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dataset/dataset_fixtures.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

const std::vector<double> kTbsCam0 = {0.0148655429818,
                                      -0.999880929698,
                                      0.00414029679422,
                                      -0.0216401454975,
                                      0.999557249008,
                                      0.0149672133247,
                                      0.025715529948,
                                      -0.064676986768,
                                      -0.0257744366974,
                                      0.00375618835797,
                                      0.999660727178,
                                      0.00981073058949,
                                      0.0,
                                      0.0,
                                      0.0,
                                      1.0};
const std::vector<double> kTbsCam1 = {0.0125552670891,
                                      -0.999755099723,
                                      0.0182237714554,
                                      -0.0198435579556,
                                      0.999598781151,
                                      0.0130119051815,
                                      0.0251588363115,
                                      0.0453689425024,
                                      -0.0253898008918,
                                      0.0179005838253,
                                      0.999517347078,
                                      0.00786212447038,
                                      0.0,
                                      0.0,
                                      0.0,
                                      1.0};
const std::vector<double> kIntrinsics0 = {458.654, 457.296, 367.215, 248.375};
const std::vector<double> kIntrinsics1 = {457.587, 456.134, 379.999, 255.238};
const std::vector<double> kRadTan0 = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
const std::vector<double> kRadTan1 = {-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05};
const int64_t kT0 = 1403715273262142976;  // V1_01_easy cam0, first image
const int64_t kDt = 50000000;             // 20 Hz

fs::path TestDir() {
  const char* env = std::getenv("MCVO_TEST_TMP");
  fs::path dir = env != nullptr ? fs::path(env) : fs::path(::testing::TempDir());
  dir /= fs::path("euroc_test") / ::testing::UnitTest::GetInstance()->current_test_info()->name();
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir / "V1_01_easy";
}

std::string List(const std::vector<double>& values) {
  std::ostringstream out;
  out.precision(17);
  out << "[";
  for (size_t i = 0; i < values.size(); ++i) out << (i ? ", " : "") << values[i];
  out << "]";
  return out.str();
}

void WriteText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

std::string SensorYaml(const std::vector<double>& t_bs, const std::vector<double>& intrinsics,
                       const std::string& model, const std::vector<double>& coeffs) {
  return "# General sensor definitions.\nsensor_type: camera\ncomment: VI-Sensor (MT9M034)\n\n"
         "T_BS:\n  cols: 4\n  rows: 4\n  data: " +
         List(t_bs) +
         "\n\nrate_hz: 20\nresolution: [752, 480]\ncamera_model: pinhole\nintrinsics: " + List(intrinsics) +
         " #fu, fv, cu, cv\ndistortion_model: " + model + "\ndistortion_coefficients: " + List(coeffs) + "\n";
}

// A sequence of `num_frames` stereo frames; camera `c` skips the frames in skip[c].
fs::path WriteEuroc(const std::string& model = "radial-tangential", int num_frames = 5,
                    const std::vector<std::vector<int>>& skip = {{}, {}}) {
  const fs::path root = TestDir();
  const fs::path mav0 = root / "mav0";
  const std::vector<std::vector<double>> coeffs =
      model == "equidistant" ? std::vector<std::vector<double>>{{0.0034, 0.0071, -0.0073, 0.0026},
                                                                {0.0032, 0.0069, -0.0071, 0.0025}}
                             : std::vector<std::vector<double>>{kRadTan0, kRadTan1};
  WriteText(mav0 / "cam0" / "sensor.yaml", SensorYaml(kTbsCam0, kIntrinsics0, model, coeffs[0]));
  WriteText(mav0 / "cam1" / "sensor.yaml", SensorYaml(kTbsCam1, kIntrinsics1, model, coeffs[1]));
  for (int c = 0; c < 2; ++c) {
    const fs::path cam = mav0 / ("cam" + std::to_string(c));
    fs::create_directories(cam / "data");
    std::string csv = "#timestamp [ns],filename\n";
    for (int f = 0; f < num_frames; ++f) {
      if (std::find(skip[c].begin(), skip[c].end(), f) != skip[c].end()) continue;
      const std::string name = std::to_string(kT0 + f * kDt) + ".png";
      cv::Mat image(480, 752, CV_8UC1);
      cv::randu(image, 0, 255);
      EXPECT_TRUE(cv::imwrite((cam / "data" / name).string(), image)) << name;
      csv += std::to_string(kT0 + f * kDt) + "," + name + "\n";
    }
    WriteText(cam / "data.csv", csv);
  }
  // 17 columns: time, p, q (w first), v, b_w, b_a.
  std::string gt =
      "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
      "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad "
      "s^-1], "
      "b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]\n";
  for (int i = 0; i < 3; ++i) {
    gt += std::to_string(kT0 + i * 5000000) + "," + std::to_string(0.878612 + 0.001 * i) +
          ",2.142470,0.947262,0.060514,-0.828459,-0.058956,-0.553641,0.009474,-0.014009,-0.002145,"
          "-0.002229,0.020700,0.076350,-0.012492,0.547666,0.069073\n";
  }
  WriteText(mav0 / "state_groundtruth_estimate0" / "data.csv", gt);
  return root;
}

DatasetOptions Options(const fs::path& root) {
  DatasetOptions options;
  options.root = root;
  options.format = "euroc";
  return options;
}

Eigen::Matrix4d Matrix(const std::vector<double>& values) {
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = values[static_cast<size_t>(i)];
  return m;
}

std::string ErrorOf(const DatasetOptions& options) {
  try {
    ReadEurocDataset(options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no InputError>";
}

using testing::LogHas;

TEST(EurocReader, StereoRigFramesAndGroundTruth) {
  const fs::path root = WriteEuroc();
  const DatasetIndex index = ReadEurocDataset(Options(root));
  EXPECT_EQ(index.format, "euroc");
  EXPECT_EQ(index.name, "V1_01_easy");
  ASSERT_EQ(index.rig.NumCameras(), 2);
  for (int c = 0; c < 2; ++c) {
    const Camera& camera = index.rig.cameras[static_cast<size_t>(c)];
    EXPECT_EQ(camera.name, "cam" + std::to_string(c));
    EXPECT_EQ(camera.model, CameraModelId::kRadTan);
    EXPECT_EQ(camera.width, 752);
    EXPECT_EQ(camera.height, 480);
    const Eigen::Matrix4d body_from_sensor = Matrix(c == 0 ? kTbsCam0 : kTbsCam1);
    // cam_from_rig = inverse(T_BS).
    EXPECT_LT((camera.cam_from_rig.ToMatrix4() * body_from_sensor - Eigen::Matrix4d::Identity()).norm(),
              1e-9);
  }
  const std::vector<double> expected0 = {458.654,    457.296,    367.215,        248.375, -0.28340811,
                                         0.07395907, 0.00019359, 1.76187114e-05, 0.0};
  EXPECT_EQ(index.rig.cameras[0].params, expected0);
  EXPECT_EQ(index.rig.cameras[1].params[0], 457.587);
  EXPECT_EQ(index.rig.cameras[1].params[7], -3.55590700e-05);
  // Stereo baseline of the VI-Sensor: ~11 cm.
  const Eigen::Vector3d center0 = index.rig.cameras[0].cam_from_rig.Inverse().translation;
  const Eigen::Vector3d center1 = index.rig.cameras[1].cam_from_rig.Inverse().translation;
  EXPECT_NEAR((center1 - center0).norm(), 0.110, 0.001);

  ASSERT_EQ(index.frames.size(), 5u);
  for (size_t f = 0; f < 5; ++f) {
    EXPECT_EQ(index.frames[f].t_ns, kT0 + static_cast<int64_t>(f) * kDt);
    ASSERT_EQ(index.frames[f].images.size(), 2u);
    EXPECT_EQ(index.frames[f].images[1],
              root / "mav0" / "cam1" / "data" / (std::to_string(index.frames[f].t_ns) + ".png"));
  }
  ASSERT_TRUE(index.ground_truth.has_value());
  ASSERT_EQ(index.ground_truth->poses.size(), 3u);
  EXPECT_EQ(index.ground_truth->poses[1].t_ns, kT0 + 5000000);
  EXPECT_NEAR(index.ground_truth->poses[1].world_from_body.translation.x(), 0.879612, 1e-12);
  EXPECT_NEAR(index.ground_truth->poses[0].world_from_body.rotation.w(), 0.060514, 1e-5);
  EXPECT_EQ(index.masks.size(), 2u);
  EXPECT_TRUE(LogHas(index, "body frame"));

  // The mav0 folder itself is accepted, and a camera subset.
  DatasetOptions subset = Options(root / "mav0");
  subset.cameras = {"cam1"};
  const DatasetIndex right = ReadEurocDataset(subset);
  ASSERT_EQ(right.rig.NumCameras(), 1);
  EXPECT_EQ(right.rig.cameras[0].name, "cam1");
  EXPECT_EQ(right.name, "V1_01_easy");
  subset.cameras = {"cam7"};
  EXPECT_THROW(ReadEurocDataset(subset), UsageError);
}

TEST(EurocReader, Equidistant) {
  const DatasetIndex index = ReadEurocDataset(Options(WriteEuroc("equidistant")));
  ASSERT_EQ(index.rig.NumCameras(), 2);
  EXPECT_EQ(index.rig.cameras[0].model, CameraModelId::kKannalaBrandt);
  const std::vector<double> expected = {458.654, 457.296, 367.215, 248.375, 0.0034, 0.0071, -0.0073, 0.0026};
  EXPECT_EQ(index.rig.cameras[0].params, expected);
}

TEST(EurocReader, CameraWithFewerImages) {
  const fs::path root = WriteEuroc("radial-tangential", 5, {{}, {2}});
  DatasetOptions options = Options(root);
  const DatasetIndex marked = ReadEurocDataset(options);
  ASSERT_EQ(marked.frames.size(), 5u);
  EXPECT_TRUE(marked.frames[2].images[1].empty());
  EXPECT_FALSE(marked.frames[2].images[0].empty());
  EXPECT_FALSE(marked.frames[3].images[1].empty());
  EXPECT_TRUE(LogHas(marked, "cam1: 4 of 5 frames matched"));
  EXPECT_TRUE(LogHas(marked, "1 incomplete frames kept"));

  options.missing_images = MissingImagePolicy::kSkipFrame;
  const DatasetIndex skipped = ReadEurocDataset(options);
  ASSERT_EQ(skipped.frames.size(), 4u);
  EXPECT_EQ(skipped.frames[2].t_ns, kT0 + 3 * kDt);
  EXPECT_TRUE(LogHas(skipped, "1 incomplete frames skipped"));

  // An image listed in data.csv but absent on disk is a missing image too.
  fs::remove(root / "mav0" / "cam1" / "data" / (std::to_string(kT0 + 4 * kDt) + ".png"));
  const DatasetIndex absent = ReadEurocDataset(Options(root));
  EXPECT_TRUE(absent.frames[4].images[1].empty());
  EXPECT_TRUE(LogHas(absent, "not on disk"));
}

TEST(EurocReader, MissingSensorYaml) {
  const fs::path root = WriteEuroc();
  fs::remove(root / "mav0" / "cam1" / "sensor.yaml");
  const std::string error = ErrorOf(Options(root));
  EXPECT_NE(error.find("cam1/sensor.yaml: missing calibration file"), std::string::npos) << error;
}

TEST(EurocReader, MissingKey) {
  const fs::path root = WriteEuroc();
  std::string yaml = SensorYaml(kTbsCam1, kIntrinsics1, "radial-tangential", kRadTan1);
  yaml.erase(yaml.find("intrinsics:"), yaml.find('\n', yaml.find("intrinsics:")) - yaml.find("intrinsics:"));
  WriteText(root / "mav0" / "cam1" / "sensor.yaml", yaml);
  const std::string error = ErrorOf(Options(root));
  EXPECT_NE(error.find("cam1/sensor.yaml"), std::string::npos) << error;
  EXPECT_NE(error.find("intrinsics: missing key"), std::string::npos) << error;
}

TEST(EurocReader, YamlSyntaxError) {
  const fs::path root = WriteEuroc();
  WriteText(root / "mav0" / "cam0" / "sensor.yaml",
            "sensor_type: camera\nT_BS:\n  data: [1, 2\nrate_hz: 20\n");
  const std::string error = ErrorOf(Options(root));
  EXPECT_NE(error.find("cam0/sensor.yaml:"), std::string::npos) << error;
  EXPECT_NE(error.find("YAML syntax error"), std::string::npos) << error;
}

TEST(EurocReader, NonOrthonormalRotation) {
  const fs::path root = WriteEuroc();
  std::vector<double> t_bs = kTbsCam1;
  t_bs[0] += 0.01;
  WriteText(root / "mav0" / "cam1" / "sensor.yaml",
            SensorYaml(t_bs, kIntrinsics1, "radial-tangential", kRadTan1));
  const std::string error = ErrorOf(Options(root));
  EXPECT_NE(error.find("cam1/sensor.yaml:"), std::string::npos) << error;
  EXPECT_NE(error.find("T_BS: rotation not orthonormal"), std::string::npos) << error;
}

TEST(EurocReader, NonMonotonicTimestamps) {
  const fs::path root = WriteEuroc();
  const std::string a = std::to_string(kT0 + kDt), b = std::to_string(kT0 + 2 * kDt);
  WriteText(root / "mav0" / "cam0" / "data.csv", "#timestamp [ns],filename\n" + std::to_string(kT0) + "," +
                                                     std::to_string(kT0) + ".png\n" + b + "," + b + ".png\n" +
                                                     a + "," + a + ".png\n");
  const std::string error = ErrorOf(Options(root));
  EXPECT_NE(error.find("cam0/data.csv:4:"), std::string::npos) << error;
  EXPECT_NE(error.find("strictly increasing"), std::string::npos) << error;

  WriteText(root / "mav0" / "cam0" / "data.csv", "#timestamp [ns],filename\nabc,x.png\n");
  EXPECT_NE(ErrorOf(Options(root)).find("cam0/data.csv:2:"), std::string::npos);
}

TEST(EurocReader, BadIntrinsicsAndMissingFolder) {
  const fs::path root = WriteEuroc();
  WriteText(root / "mav0" / "cam0" / "sensor.yaml",
            SensorYaml(kTbsCam0, {-458.654, 457.296, 367.215, 248.375}, "radial-tangential", kRadTan0));
  EXPECT_NE(ErrorOf(Options(root)).find("cam0/sensor.yaml"), std::string::npos);
  WriteText(root / "mav0" / "cam0" / "sensor.yaml",
            SensorYaml(kTbsCam0, kIntrinsics0, "radial-tangential", {-0.28, 0.07, 0.0001}));
  EXPECT_NE(ErrorOf(Options(root)).find("distortion_coefficients"), std::string::npos);
  EXPECT_NE(ErrorOf(Options(root / "nowhere")).find("nowhere"), std::string::npos);
}

TEST(EurocReader, OnlyCamDigitsFoldersAreCameras) {
  // The folder name is the camera name, a path component of the outputs:
  // "cam0" followed by a newline or a blank once passed as camera 0 and
  // split error messages; now it is just not a camera folder.
  const fs::path root = WriteEuroc();
  fs::rename(root / "mav0" / "cam1", root / "mav0" / "cam1\n");
  fs::create_directories(root / "mav0" / "cam2 ");
  const DatasetIndex index = ReadEurocDataset(Options(root));
  ASSERT_EQ(index.rig.NumCameras(), 1);
  EXPECT_EQ(index.rig.cameras[0].name, "cam0");
}

}  // namespace
}  // namespace mcvo
