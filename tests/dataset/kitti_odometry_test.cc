// KITTI odometry reader: small sequences in the layout KITTI ships
// (sequences/NN/{calib.txt,times.txt,image_K/}, poses/NN.txt), with tiny
// generated images and the real sequence 06 P0/P1: the cameras project as
// calib.txt's P_i do, the camera selection, the frame times and the ground
// truth, and bad calib.txt / times.txt lines give an InputError naming the
// file and the line.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/imgcodecs.hpp>

#include "mcvo/dataset/dataset.h"
#include "mcvo/util/error.h"
#include "test_temp_dir.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
using Matrix34d = Eigen::Matrix<double, 3, 4, Eigen::RowMajor>;

// P0 and P1 of KITTI odometry sequence 06
// (../shared/data/real/kitti06_stereo/source/calib.txt, which has no keys).
const char* const kP0 =
    "7.070912000000e+02 0.000000000000e+00 6.018873000000e+02 0.000000000000e+00 0.000000000000e+00 "
    "7.070912000000e+02 1.831104000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 "
    "1.000000000000e+00 0.000000000000e+00";
const char* const kP1 =
    "7.070912000000e+02 0.000000000000e+00 6.018873000000e+02 -3.798145000000e+02 0.000000000000e+00 "
    "7.070912000000e+02 1.831104000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 "
    "1.000000000000e+00 0.000000000000e+00";
// Colour cameras in the form of KITTI's P2 / P3: the same K, a last column
// with x, y and z parts (the colour cameras sit slightly off the grey ones).
const char* const kP2 =
    "7.070912000000e+02 0.000000000000e+00 6.018873000000e+02 4.688783000000e+01 0.000000000000e+00 "
    "7.070912000000e+02 1.831104000000e+02 1.178601000000e-01 0.000000000000e+00 0.000000000000e+00 "
    "1.000000000000e+00 6.203223000000e-03";
const char* const kP3 =
    "7.070912000000e+02 0.000000000000e+00 6.018873000000e+02 -3.334597000000e+02 0.000000000000e+00 "
    "7.070912000000e+02 1.831104000000e+02 1.930130000000e+00 0.000000000000e+00 0.000000000000e+00 "
    "1.000000000000e+00 3.318498000000e-03";
const char* const kTr =
    "-1.857739385241e-03 -9.999659513510e-01 -8.039975204516e-03 -4.784029760483e-03 -6.481465826011e-03 "
    "8.051860151134e-03 -9.999466081774e-01 -7.337429464231e-02 9.999773098287e-01 -1.805528627661e-03 "
    "-6.496203536139e-03 -3.339968064433e-01";

std::string OfficialCalib() {
  return std::string("P0: ") + kP0 + "\nP1: " + kP1 + "\nP2: " + kP2 + "\nP3: " + kP3 + "\nTr: " + kTr + "\n";
}

Matrix34d ParseP(const char* text) {
  Matrix34d p;
  std::istringstream in(text);
  for (int i = 0; i < 12; ++i) in >> p(i / 4, i % 4);
  return p;
}

void WriteText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string Times(int frames) {
  std::string text;
  for (int i = 0; i < frames; ++i) {
    char line[32];
    std::snprintf(line, sizeof(line), "%e\n", 0.1036 * i + 0.0002 * (i % 3));
    text += line;
  }
  return text;
}

// Ground-truth line of frame i: a small rotation about y and a forward drive.
std::string PoseLine(int i) {
  const double a = 0.01 * i, c = std::cos(a), s = std::sin(a);
  char line[256];
  std::snprintf(line, sizeof(line), "%.9e 0 %.9e %.9e 0 1 0 %.9e %.9e 0 %.9e %.9e\n", c, s, 0.1 * i, 0.02 * i,
                -s, c, 1.2 * i);
  return line;
}

fs::path Scratch(const std::string& name) {
  const fs::path root = testing::TestTempDir("kitti_odometry_test") / name;
  fs::remove_all(root);
  return root;
}

// <root>/sequences/<seq>/ with image_K folders for `cameras` (grey 40x12 for
// 0/1, RGB 44x14 for 2/3), `frames` frames, calib.txt, times.txt and
// <root>/poses/<seq>.txt.
fs::path WriteSequence(const fs::path& root, const std::string& seq, const std::vector<int>& cameras,
                       int frames = 4) {
  const fs::path folder = root / "sequences" / seq;
  for (const int k : cameras) {
    const bool colour = k >= 2;
    const cv::Mat image(colour ? 14 : 12, colour ? 44 : 40, colour ? CV_8UC3 : CV_8UC1,
                        cv::Scalar(90, 120, 30));
    fs::create_directories(folder / ("image_" + std::to_string(k)));
    for (int i = 0; i < frames; ++i) {
      char name[32];
      std::snprintf(name, sizeof(name), "%06d.png", i);
      EXPECT_TRUE(cv::imwrite((folder / ("image_" + std::to_string(k)) / name).string(), image));
    }
  }
  WriteText(folder / "calib.txt", OfficialCalib());
  WriteText(folder / "times.txt", Times(frames));
  std::string poses;
  for (int i = 0; i < frames; ++i) poses += PoseLine(i);
  WriteText(root / "poses" / (seq + ".txt"), poses);
  return folder;
}

DatasetOptions Options(const fs::path& root, const std::vector<std::string>& cameras = {}) {
  DatasetOptions options;
  options.root = root;
  options.format = "kitti";
  options.cameras = cameras;
  return options;
}

// Opening `options` throws InputError whose message holds every one of `parts`.
void ExpectInputError(const DatasetOptions& options, const std::vector<std::string>& parts) {
  try {
    OpenDataset(options);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    for (const std::string& part : parts)
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << part << " not in: " << e.what();
  }
}

// A point in the rig frame (camera 0) projects through the rig camera to the
// pixel P_i * X gives.
void ExpectProjectsLikeP(const Camera& camera, const char* p_text) {
  const Matrix34d p = ParseP(p_text);
  for (const Eigen::Vector3d& x :
       {Eigen::Vector3d(1.5, -0.7, 9.0), Eigen::Vector3d(-4.0, 1.2, 25.0), Eigen::Vector3d(0.3, 0.1, 3.0)}) {
    const Eigen::Vector3d h = p * x.homogeneous();
    const std::optional<Eigen::Vector2d> pixel = camera.Project(camera.cam_from_rig * x);
    ASSERT_TRUE(pixel.has_value());
    EXPECT_NEAR(pixel->x(), h.x() / h.z(), 1e-9) << camera.name;
    EXPECT_NEAR(pixel->y(), h.y() / h.z(), 1e-9) << camera.name;
  }
}

TEST(KittiOdometry, GreyPairIntrinsicsAndBaselineReadBackExactly) {
  const fs::path root = Scratch("grey");
  const fs::path folder = WriteSequence(root, "06", {0, 1, 2, 3});
  const DatasetIndex index = OpenDataset(Options(folder));
  EXPECT_EQ(index.format, "kitti");
  EXPECT_EQ(index.name, "06");
  ASSERT_EQ(index.rig.NumCameras(), 2);  // default: the grey pair
  const Camera& c0 = index.rig.cameras[0];
  const Camera& c1 = index.rig.cameras[1];
  EXPECT_EQ(c0.name, "image_00");
  EXPECT_EQ(c1.name, "image_01");
  for (const Camera* c : {&c0, &c1}) {
    EXPECT_EQ(c->model, CameraModelId::kPinhole);
    EXPECT_EQ(c->params, (std::vector<double>{707.0912, 707.0912, 601.8873, 183.1104}));
    EXPECT_EQ(c->width, 40);
    EXPECT_EQ(c->height, 12);
    EXPECT_TRUE(c->cam_from_rig.RotationMatrix() == Eigen::Matrix3d::Identity());
  }
  EXPECT_EQ(c0.cam_from_rig.translation, Eigen::Vector3d::Zero());
  // P1[0,3] / fx exactly: camera 1 sits 0.5372 m along camera 0's x.
  EXPECT_EQ(c1.cam_from_rig.translation, Eigen::Vector3d(-379.8145 / 707.0912, 0.0, 0.0));
  EXPECT_NEAR(c1.cam_from_rig.Inverse().translation.x(), 0.5372, 1e-4);
  ExpectProjectsLikeP(c0, kP0);
  ExpectProjectsLikeP(c1, kP1);
  ASSERT_EQ(index.frames.size(), 4u);
  EXPECT_EQ(index.frames[2].images[1], folder / "image_1" / "000002.png");
  EXPECT_EQ(index.frames[3].t_ns, 310800000);  // 3.108000e-01 s
}

TEST(KittiOdometry, ColourPairOffsetsAndCameraSelection) {
  const fs::path root = Scratch("colour");
  const fs::path folder = WriteSequence(root, "06", {0, 1, 2, 3});
  const DatasetIndex colour = OpenDataset(Options(folder, {"image_02", "image_03"}));
  ASSERT_EQ(colour.rig.NumCameras(), 2);
  EXPECT_EQ(colour.rig.cameras[0].name, "image_02");
  EXPECT_EQ(colour.rig.cameras[0].width, 44);
  EXPECT_EQ(colour.rig.cameras[0].height, 14);
  // Camera 0 stays the rig frame: the colour cameras are offset in x, y and z.
  const Eigen::Vector3d t2 = colour.rig.cameras[0].cam_from_rig.translation;
  EXPECT_NEAR(t2.z(), 6.203223e-03, 1e-15);
  EXPECT_NEAR(t2.y(), (1.178601e-01 - 183.1104 * 6.203223e-03) / 707.0912, 1e-15);
  EXPECT_NEAR(t2.x(), (4.688783e+01 - 601.8873 * 6.203223e-03) / 707.0912, 1e-15);
  EXPECT_GT(std::abs(t2.y()), 1e-4);
  ExpectProjectsLikeP(colour.rig.cameras[0], kP2);
  ExpectProjectsLikeP(colour.rig.cameras[1], kP3);
  EXPECT_EQ(colour.frames[1].images[0], folder / "image_2" / "000001.png");

  const DatasetIndex all = OpenDataset(Options(folder, {"image_00", "image_01", "image_02", "image_03"}));
  ASSERT_EQ(all.rig.NumCameras(), 4);
  const std::vector<const char*> p_all = {kP0, kP1, kP2, kP3};
  for (size_t k = 0; k < 4; ++k) ExpectProjectsLikeP(all.rig.cameras[k], p_all[k]);

  const DatasetIndex mono = OpenDataset(Options(folder, {"image_03"}));
  ASSERT_EQ(mono.rig.NumCameras(), 1);
  EXPECT_EQ(mono.frames[0].images[0], folder / "image_3" / "000000.png");

  EXPECT_THROW(OpenDataset(Options(folder, {"image_2"})), UsageError);
  fs::remove_all(folder / "image_1");
  ExpectInputError(Options(folder, {"image_00", "image_01"}), {"image_1", "missing image folder"});
}

TEST(KittiOdometry, DefaultCamerasAreTheGreyPairElseTheColourPairElseWhatThereIs) {
  const DatasetIndex colour = OpenDataset(Options(WriteSequence(Scratch("only_colour"), "00", {2, 3})));
  ASSERT_EQ(colour.rig.NumCameras(), 2);
  EXPECT_EQ(colour.rig.cameras[0].name, "image_02");
  EXPECT_EQ(colour.rig.cameras[1].name, "image_03");
  const DatasetIndex mono = OpenDataset(Options(WriteSequence(Scratch("only_0"), "00", {0})));
  ASSERT_EQ(mono.rig.NumCameras(), 1);
  EXPECT_EQ(mono.rig.cameras[0].name, "image_00");
}

TEST(KittiOdometry, AutoDetectedAtTheRootAndAtTheSequenceFolder) {
  const fs::path root = Scratch("detect");
  const fs::path folder = WriteSequence(root, "06", {0, 1});
  EXPECT_EQ(DetectDatasetFormat(root), "kitti");
  EXPECT_EQ(DetectDatasetFormat(folder), "kitti");
  DatasetOptions options;
  options.root = root;  // the only sequence
  const DatasetIndex index = OpenDataset(options);
  EXPECT_EQ(index.format, "kitti");
  EXPECT_EQ(index.name, "06");
  EXPECT_EQ(index.frames.size(), 4u);
  // Two sequences: --sequence chooses.
  WriteSequence(root, "07", {0, 1}, 6);
  EXPECT_THROW(OpenDataset(Options(root)), UsageError);
  DatasetOptions seven = Options(root);
  seven.sequence = "07";
  EXPECT_EQ(OpenDataset(seven).frames.size(), 6u);
  seven.sequence = "08";
  ExpectInputError(seven, {"08", "sequence folder does not exist"});
  DatasetOptions wrong = Options(folder);
  wrong.sequence = "07";
  EXPECT_THROW(OpenDataset(wrong), UsageError);
}

TEST(KittiOdometry, GroundTruthIsCameraZeroInTheRigFrameTimedByTimesTxt) {
  const fs::path root = Scratch("gt");
  const fs::path folder = WriteSequence(root, "06", {0, 1}, 5);
  DatasetOptions at_root = Options(root);
  at_root.sequence = "06";
  for (const DatasetOptions& options : {Options(folder), at_root}) {
    const DatasetIndex index = OpenDataset(options);
    ASSERT_TRUE(index.ground_truth.has_value());
    const Trajectory& gt = *index.ground_truth;
    ASSERT_EQ(gt.poses.size(), 5u);
    EXPECT_TRUE(gt.has_time);
    for (size_t i = 0; i < 5; ++i) EXPECT_EQ(gt.poses[i].t_ns, index.frames[i].t_ns);
    // Line 3 (frame 2): world_from_cam0 = world_from_rig as written.
    const Rigid3d& pose = gt.poses[2].world_from_body;
    EXPECT_NEAR(pose.translation.x(), 0.2, 1e-12);
    EXPECT_NEAR(pose.translation.z(), 2.4, 1e-12);
    EXPECT_NEAR((pose.RotationMatrix() * Eigen::Vector3d::UnitZ()).x(), std::sin(0.02), 1e-9);
    // Camera 1's centre in the world: 0.537 m along camera 0's x axis.
    const Eigen::Vector3d c1 = pose * index.rig.cameras[1].cam_from_rig.Inverse().translation;
    const Eigen::Vector3d expected =
        pose.translation + 0.5371506 * (pose.RotationMatrix() * Eigen::Vector3d::UnitX());
    EXPECT_NEAR((c1 - expected).norm(), 0.0, 1e-6);
  }
  fs::remove(root / "poses" / "06.txt");
  EXPECT_FALSE(OpenDataset(Options(folder)).ground_truth.has_value());
  // More poses than frames.
  std::string poses;
  for (int i = 0; i < 7; ++i) poses += PoseLine(i);
  WriteText(root / "poses" / "06.txt", poses);
  ExpectInputError(Options(folder), {"06.txt:6:", "7 poses for 5 frames"});
}

TEST(KittiOdometry, TimesTxtMustHaveOneIncreasingTimePerFrame) {
  const fs::path folder = WriteSequence(Scratch("times"), "06", {0, 1}, 4);
  const fs::path times = folder / "times.txt";
  WriteText(times, Times(3));
  ExpectInputError(Options(folder), {"times.txt:4:", "no time for frame 3", "000003.png"});
  WriteText(times, Times(6));
  ExpectInputError(Options(folder), {"times.txt:5:", "6 times for 4 frames"});
  WriteText(times, "0.0\n0.1\n0.1\n0.3\n");
  ExpectInputError(Options(folder), {"times.txt:3:", "is not after the previous one"});
  WriteText(times, "0.0\n0.1\nabc\n0.3\n");
  ExpectInputError(Options(folder), {"times.txt:3:", "expected a time in seconds", "abc"});
  fs::remove(times);
  ExpectInputError(Options(folder), {"times.txt", "missing frame times"});
}

TEST(KittiOdometry, BadCalibLinesNameTheFileAndLine) {
  const fs::path folder = WriteSequence(Scratch("calib"), "06", {0, 1});
  const fs::path calib = folder / "calib.txt";
  WriteText(calib, std::string("P0: ") + kP0 + "\nP1: 1 2 3\n");
  ExpectInputError(Options(folder), {"calib.txt:2:", "P1: expected 12 numbers", "got 3"});
  WriteText(calib, std::string("P0: ") + kP0 + "\nP1: " + kP1 + " x\n");
  ExpectInputError(Options(folder), {"calib.txt:2:", "expected 12 numbers"});
  std::string nan_p1 = kP1;
  nan_p1.replace(0, 18, "nan");
  WriteText(calib, std::string("P0: ") + kP0 + "\nP1: " + nan_p1 + "\n");
  ExpectInputError(Options(folder), {"calib.txt:2:", "field 1 'nan' is not a finite number"});
  // Skew.
  std::string skewed = kP1;
  skewed.replace(19, 18, "1.000000000000e-03");
  WriteText(calib, std::string("P0: ") + kP0 + "\nP1: " + skewed + "\n");
  ExpectInputError(Options(folder), {"calib.txt: P1", "skew"});
  // Keys on some lines only: which line is which cannot be told.
  WriteText(calib, std::string("P0: ") + kP0 + "\n" + kP1 + "\n");
  ExpectInputError(Options(folder), {"calib.txt:2:", "expected 'P0: 12 numbers'"});
  WriteText(calib, std::string("P0: ") + kP0 + "\n");
  ExpectInputError(Options(folder), {"calib.txt", "missing P1"});
  WriteText(calib, std::string("P0: ") + kP0 + "\nP0: " + kP0 + "\nP1: " + kP1 + "\n");
  ExpectInputError(Options(folder), {"calib.txt:2:", "given twice"});
  fs::remove(calib);
  ExpectInputError(Options(folder), {"calib.txt", "missing calibration file"});
}

TEST(KittiOdometry, LenientCalibForms) {
  const fs::path folder = WriteSequence(Scratch("lenient"), "06", {0, 1});
  const fs::path calib = folder / "calib.txt";
  // Without keys (as ../shared/data/real/kitti06_stereo/source/calib.txt): P0, P1 in order.
  WriteText(calib, std::string(kP0) + "\n" + kP1);
  DatasetIndex index = OpenDataset(Options(folder));
  EXPECT_EQ(index.rig.cameras[1].cam_from_rig.translation.x(), -379.8145 / 707.0912);
  // Tr_velo_to_cam is Tr; unknown keys are not used.
  WriteText(calib, std::string("P0: ") + kP0 + "\nP1: " + kP1 + "\nTr_velo_to_cam: " + kTr +
                       "\ncalib_time: 09-Jan-2012 13:57:47\n");
  index = OpenDataset(Options(folder));
  EXPECT_EQ(index.rig.NumCameras(), 2);
  // Six lines without keys are more than P0..P3 + Tr.
  WriteText(calib, std::string(kP0) + "\n" + kP1 + "\n" + kP2 + "\n" + kP3 + "\n" + kTr + "\n" + kTr + "\n");
  ExpectInputError(Options(folder), {"calib.txt:6:", "without 'P0:'-style keys"});
}

TEST(KittiOdometry, MissingImagesFollowThePolicy) {
  const fs::path folder = WriteSequence(Scratch("missing"), "06", {0, 1}, 5);
  fs::remove(folder / "image_1" / "000002.png");
  const DatasetIndex marked = OpenDataset(Options(folder));
  ASSERT_EQ(marked.frames.size(), 5u);
  EXPECT_TRUE(marked.frames[2].images[1].empty());
  EXPECT_FALSE(marked.frames[2].images[0].empty());
  DatasetOptions skip = Options(folder);
  skip.missing_images = MissingImagePolicy::kSkipFrame;
  const DatasetIndex skipped = OpenDataset(skip);
  ASSERT_EQ(skipped.frames.size(), 4u);
  EXPECT_EQ(skipped.frames[2].t_ns, marked.frames[3].t_ns);
  // An image of another size in the folder.
  cv::imwrite((folder / "image_0" / "000001.png").string(), cv::Mat(13, 40, CV_8UC1, cv::Scalar(0)));
  ExpectInputError(Options(folder), {"000001.png", "image is 40x13", "000000.png"});
}

}  // namespace
}  // namespace mcvo
