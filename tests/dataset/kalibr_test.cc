// ReadKalibrDataset on small fixtures written by the tests: a 4-camera
// MultiCamData-like camchain.yaml (radtan and equidistant cameras, chained
// T_cn_cnm1) and camN/<ns>.png images.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dataset/dataset_fixtures.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

const int64_t kT0 = 1641379183000000000;
const int64_t kDt = 40000000;  // 25 Hz
const int kNumFrames = 5;

fs::path TestDir() {
  const char* env = std::getenv("MCVO_TEST_TMP");
  fs::path dir = env != nullptr ? fs::path(env) : fs::path(::testing::TempDir());
  dir /= fs::path("kalibr_test") / ::testing::UnitTest::GetInstance()->current_test_info()->name();
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir / "multicam_seq";
}

void WriteText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

std::string Num(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

std::string List(const std::vector<double>& values) {
  std::string text = "[";
  for (size_t i = 0; i < values.size(); ++i) text += (i ? ", " : "") + Num(values[i]);
  return text + "]";
}

// camN_from_cam(N-1) of a ring of 4 cameras looking outwards, 90 degrees apart
// (with small tilts so that nothing is axis-aligned).
Eigen::Matrix4d CamFromPrevious(int n) {
  const Eigen::Matrix3d rotation = (Eigen::AngleAxisd(-M_PI / 2 + 0.01 * n, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(0.02 * n, Eigen::Vector3d::UnitX()) *
                                    Eigen::AngleAxisd(-0.015 * n, Eigen::Vector3d::UnitZ()))
                                       .toRotationMatrix();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = rotation;
  m.topRightCorner<3, 1>() = Eigen::Vector3d(-0.0707 - 0.001 * n, 0.002 * n, -0.0707 + 0.0005 * n);
  return m;
}

std::string MatrixYaml(const Eigen::Matrix4d& m) {
  std::string text;
  for (int r = 0; r < 4; ++r) {
    text += "  - " + List({m(r, 0), m(r, 1), m(r, 2), m(r, 3)}) + "\n";
  }
  return text;
}

struct CamchainEdits {
  int drop_intrinsics = -1;  // camera without `intrinsics`
  int bad_rotation = -1;     // camera whose T_cn_cnm1 is not orthonormal
  bool cam0_imu = false;     // cam0 has T_cam_imu
};

Eigen::Matrix4d Cam0FromImu() {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  m.topRightCorner<3, 1>() = Eigen::Vector3d(0.01, -0.02, 0.03);
  return m;
}

std::string Camchain(const CamchainEdits& edits = {}) {
  std::string text;
  for (int n = 0; n < 4; ++n) {
    const bool fisheye = n >= 2;
    text += "cam" + std::to_string(n) + ":\n";
    if (n > 0) {
      Eigen::Matrix4d m = CamFromPrevious(n);
      if (edits.bad_rotation == n) m(0, 1) += 0.01;
      text += "  T_cn_cnm1:\n" + MatrixYaml(m);
    }
    if (n == 0 && edits.cam0_imu) text += "  T_cam_imu:\n" + MatrixYaml(Cam0FromImu());
    text += "  cam_overlaps: [" + std::to_string((n + 1) % 4) + ", " + std::to_string((n + 3) % 4) + "]\n";
    text += "  camera_model: pinhole\n";
    text += fisheye
                ? "  distortion_coeffs: [0.0213, -0.0089, 0.0031, -0.0007]\n  distortion_model: equidistant\n"
                : "  distortion_coeffs: [-0.2917, 0.0805, 0.00021, -0.00013]\n  distortion_model: radtan\n";
    if (edits.drop_intrinsics != n) {
      text += "  intrinsics: " + List({380.5 + n, 380.1 + n, 362.3 - n, 270.4 + n}) + "\n";
    }
    text += "  resolution: [720, 540]\n  rostopic: /cam" + std::to_string(n) + "/image_raw\n";
  }
  return text;
}

// Camera c takes its images at kT0 + f kDt + c ms (1 ms jitter between cameras).
fs::path WriteKalibr(const std::string& camchain = Camchain()) {
  const fs::path root = TestDir();
  WriteText(root / "camchain.yaml", camchain);
  cv::Mat image(540, 720, CV_8UC1);
  cv::randu(image, 0, 255);
  for (int c = 0; c < 4; ++c) {
    fs::create_directories(root / ("cam" + std::to_string(c)));
    for (int f = 0; f < kNumFrames; ++f) {
      const int64_t t = kT0 + f * kDt + c * 1000000;
      EXPECT_TRUE(
          cv::imwrite((root / ("cam" + std::to_string(c)) / (std::to_string(t) + ".png")).string(), image));
    }
  }
  return root;
}

fs::path ImagePath(const fs::path& root, int c, int f, int64_t offset_ns = 0) {
  return root / ("cam" + std::to_string(c)) /
         (std::to_string(kT0 + f * kDt + c * 1000000 + offset_ns) + ".png");
}

DatasetOptions Options(const fs::path& root) {
  DatasetOptions options;
  options.root = root;
  options.format = "kalibr";
  return options;
}

std::string ErrorOf(const DatasetOptions& options) {
  try {
    ReadKalibrDataset(options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no InputError>";
}

using testing::LogHas;

TEST(KalibrReader, ChainedRigAndSyncedFrames) {
  const fs::path root = WriteKalibr();
  const DatasetIndex index = ReadKalibrDataset(Options(root));
  EXPECT_EQ(index.format, "kalibr");
  EXPECT_EQ(index.name, "multicam_seq");
  ASSERT_EQ(index.rig.NumCameras(), 4);
  Eigen::Matrix4d cam_from_cam0 = Eigen::Matrix4d::Identity();
  for (int n = 0; n < 4; ++n) {
    if (n > 0) cam_from_cam0 = CamFromPrevious(n) * cam_from_cam0;
    const Camera& camera = index.rig.cameras[static_cast<size_t>(n)];
    EXPECT_EQ(camera.name, "cam" + std::to_string(n));
    EXPECT_LT((camera.cam_from_rig.ToMatrix4() - cam_from_cam0).cwiseAbs().maxCoeff(), 1e-12) << n;
    EXPECT_EQ(camera.width, 720);
    EXPECT_EQ(camera.height, 540);
    EXPECT_EQ(camera.params[0], 380.5 + n);
  }
  EXPECT_EQ(index.rig.cameras[0].model, CameraModelId::kRadTan);
  EXPECT_EQ(index.rig.cameras[0].params.size(), 9u);
  EXPECT_EQ(index.rig.cameras[0].params[4], -0.2917);
  EXPECT_EQ(index.rig.cameras[0].params[8], 0.0);
  EXPECT_EQ(index.rig.cameras[3].model, CameraModelId::kKannalaBrandt);
  EXPECT_EQ(index.rig.cameras[3].params[7], -0.0007);
  // After 4 quarter turns the chain is almost back to cam0's orientation.
  EXPECT_LT(Eigen::AngleAxisd(index.rig.cameras[3].cam_from_rig.rotation).angle(), M_PI / 2 + 0.2);

  ASSERT_EQ(index.frames.size(), static_cast<size_t>(kNumFrames));
  for (int f = 0; f < kNumFrames; ++f) {
    EXPECT_EQ(index.frames[static_cast<size_t>(f)].t_ns, kT0 + f * kDt);
    for (int c = 0; c < 4; ++c) {
      EXPECT_EQ(index.frames[static_cast<size_t>(f)].images[static_cast<size_t>(c)], ImagePath(root, c, f));
    }
  }
  EXPECT_FALSE(index.ground_truth.has_value());
  EXPECT_TRUE(LogHas(index, "rig frame = cam0"));
  EXPECT_TRUE(LogHas(index, "cam3: 5 of 5 frames matched (max |dt| 3.000 ms)"));

  DatasetOptions subset = Options(root);
  subset.cameras = {"cam2", "cam0"};
  const DatasetIndex two = ReadKalibrDataset(subset);
  ASSERT_EQ(two.rig.NumCameras(), 2);
  EXPECT_EQ(two.rig.cameras[0].name, "cam2");
  EXPECT_EQ(two.frames[1].t_ns, kT0 + kDt + 2000000);  // the first selected camera leads
  subset.cameras = {"cam4"};
  EXPECT_THROW(ReadKalibrDataset(subset), UsageError);
}

TEST(KalibrReader, ImuRigFrameAndGroundTruth) {
  CamchainEdits edits;
  edits.cam0_imu = true;
  const fs::path root = WriteKalibr(Camchain(edits));
  WriteText(root / "groundtruth.tum",
            "# t tx ty tz qx qy qz qw\n1641379183.0 1 2 3 0 0 0 1\n1641379183.04 1.1 2 3 0 0 0 1\n");
  const DatasetIndex index = ReadKalibrDataset(Options(root));
  EXPECT_LT((index.rig.cameras[0].cam_from_rig.ToMatrix4() - Cam0FromImu()).cwiseAbs().maxCoeff(), 1e-12);
  const Eigen::Matrix4d expected1 = CamFromPrevious(1) * Cam0FromImu();
  EXPECT_LT((index.rig.cameras[1].cam_from_rig.ToMatrix4() - expected1).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_TRUE(LogHas(index, "rig frame = IMU"));
  ASSERT_TRUE(index.ground_truth.has_value());
  EXPECT_EQ(index.ground_truth->poses.size(), 2u);
  EXPECT_EQ(index.ground_truth->poses[1].t_ns, kT0 + kDt);
}

TEST(KalibrReader, MissingImagePolicy) {
  const fs::path root = WriteKalibr();
  fs::remove(ImagePath(root, 2, 3));
  DatasetOptions options = Options(root);
  const DatasetIndex marked = ReadKalibrDataset(options);
  ASSERT_EQ(marked.frames.size(), static_cast<size_t>(kNumFrames));
  EXPECT_TRUE(marked.frames[3].images[2].empty());
  EXPECT_EQ(marked.frames[3].images[1], ImagePath(root, 1, 3));
  EXPECT_TRUE(LogHas(marked, "cam2: 4 of 5 frames matched"));

  options.missing_images = MissingImagePolicy::kSkipFrame;  // the MultiCamData convention
  const DatasetIndex skipped = ReadKalibrDataset(options);
  ASSERT_EQ(skipped.frames.size(), static_cast<size_t>(kNumFrames - 1));
  EXPECT_EQ(skipped.frames[3].t_ns, kT0 + 4 * kDt);
  EXPECT_TRUE(LogHas(skipped, "1 incomplete frames skipped"));
}

TEST(KalibrReader, TimestampBeyondTolerance) {
  const fs::path root = WriteKalibr();
  // cam1's image of frame 2 is 20 ms late: beyond a 10 ms tolerance.
  fs::rename(ImagePath(root, 1, 2), ImagePath(root, 1, 2, 19000000));
  DatasetOptions options = Options(root);
  options.sync_tolerance_s = 0.01;
  const DatasetIndex index = ReadKalibrDataset(options);
  ASSERT_EQ(index.frames.size(), static_cast<size_t>(kNumFrames));
  EXPECT_TRUE(index.frames[2].images[1].empty());
  EXPECT_EQ(index.frames[3].images[1], ImagePath(root, 1, 3));
  EXPECT_TRUE(LogHas(index, "cam1: 4 of 5 frames matched"));
  EXPECT_TRUE(LogHas(index, "1 of its 5 images matched no cam0 time"));
  // With the default 40 ms tolerance it is matched.
  EXPECT_EQ(ReadKalibrDataset(Options(root)).frames[2].images[1], ImagePath(root, 1, 2, 19000000));
}

TEST(KalibrReader, MissingCamchain) {
  const fs::path root = WriteKalibr();
  fs::remove(root / "camchain.yaml");
  const std::string error = ErrorOf(Options(root));
  EXPECT_NE(error.find("camchain.yaml: missing calibration file"), std::string::npos) << error;
  // A single camchain-<bag>.yaml is found.
  WriteText(root / "camchain-multicam.yaml", Camchain());
  EXPECT_EQ(ReadKalibrDataset(Options(root)).rig.NumCameras(), 4);
}

TEST(KalibrReader, MissingIntrinsics) {
  CamchainEdits edits;
  edits.drop_intrinsics = 2;
  const std::string error = ErrorOf(Options(WriteKalibr(Camchain(edits))));
  EXPECT_NE(error.find("camchain.yaml"), std::string::npos) << error;
  EXPECT_NE(error.find("cam2/intrinsics: missing key"), std::string::npos) << error;
}

TEST(KalibrReader, NonOrthonormalChain) {
  CamchainEdits edits;
  edits.bad_rotation = 1;
  const std::string error = ErrorOf(Options(WriteKalibr(Camchain(edits))));
  EXPECT_NE(error.find("camchain.yaml:"), std::string::npos) << error;
  EXPECT_NE(error.find("cam1/T_cn_cnm1: rotation not orthonormal"), std::string::npos) << error;
}

TEST(KalibrReader, NonNumericImageName) {
  const fs::path root = WriteKalibr();
  fs::copy_file(ImagePath(root, 1, 0), root / "cam1" / "frame_001.png");
  const std::string error = ErrorOf(Options(root));
  EXPECT_NE(error.find("cam1/frame_001.png: image file name is not a time stamp"), std::string::npos)
      << error;
}

TEST(KalibrReader, BadYamlAndFolders) {
  const fs::path root = WriteKalibr();
  WriteText(root / "camchain.yaml", "cam0:\n  camera_model: pinhole\n   intrinsics: [1, 2\n");
  const std::string error = ErrorOf(Options(root));
  EXPECT_NE(error.find("camchain.yaml:"), std::string::npos) << error;
  EXPECT_NE(error.find("YAML syntax error"), std::string::npos) << error;

  WriteText(root / "camchain.yaml", Camchain());
  fs::remove_all(root / "cam3");
  EXPECT_NE(ErrorOf(Options(root)).find("cam3: image folder missing"), std::string::npos);
  EXPECT_NE(ErrorOf(Options(root / "nowhere")).find("nowhere"), std::string::npos);
}

}  // namespace
}  // namespace mcvo
