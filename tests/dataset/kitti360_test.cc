// KITTI-360 reader and writer: the real calibration values give the preset
// rig, a synthetic sequence survives a round trip through the layout, and
// every kind of bad input gives an InputError naming the file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "dataset/dataset_fixtures.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/dataset/kitti360_writer.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/synth/synthesize.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

const char* const kSequence = "2013_05_28_drive_0000_sync";

// Values of ../shared/reference/kitti360.md, in the dataset's own formatting.
const char* const kCalibCamToPose =
    "image_00: 0.0371783278 -0.0986182135 0.9944306009 1.5752681039 0.9992675562 -0.0053553387 -0.0378902567 "
    "0.0043914093 0.0090621821 0.9951109327 0.0983468786 -0.6500000000\n"
    "image_01: 0.0194000864 -0.1051529641 0.9942668106 1.5977241400 0.9997374956 -0.0100836652 -0.0205732716 "
    "0.5981494900 0.0121891942 0.9944049345 0.1049297370 -0.6488433108\n"
    "image_02: 0.9995185086 0.0041276589 -0.0307524527 0.7264036936 -0.0307926666 0.0100608424 -0.9994751579 "
    "-0.1499658517 -0.0038160970 0.9999408692 0.0101830998 -1.0686400091\n"
    "image_03: -0.9996821702 0.0005703407 -0.0252038325 0.7016842127 -0.0252033830 0.0007820814 0.9996820384 "
    "0.7463650950 0.0005898709 0.9999995315 -0.0007674583 -1.0751978255\n";

const char* const kPerspective =
    "calib_time: 09-Jan-2012 14:00:15\n"
    "corner_dist: 9.950000e-02\n"
    "S_00: 1.392000e+03 5.120000e+02\n"
    "K_00: 788.629315 0.000000 687.158398 0.000000 786.382230 317.752196 0.000000 0.000000 1.000000\n"
    "D_00: -0.344441 0.141678 0.000414 -0.000222 -0.029608\n"
    "S_rect_00: 1.408000e+03 3.760000e+02\n"
    "R_rect_00: 0.999974 -0.007141 -0.000089 0.007141 0.999969 -0.003247 0.000112 0.003247 0.999995\n"
    "P_rect_00: 552.554261 0.000000 682.049453 0.000000 0.000000 552.554261 238.769549 0.000000 0.000000 "
    "0.000000 1.000000 0.000000\n"
    "S_rect_01: 1.408000e+03 3.760000e+02\n"
    "R_rect_01: 0.999837 0.004862 -0.017390 -0.004974 0.999967 -0.006389 0.017358 0.006474 0.999828\n"
    "P_rect_01: 552.554261 0.000000 682.049453 -328.318735 0.000000 552.554261 238.769549 0.000000 0.000000 "
    "0.000000 1.000000 0.000000\n";

// The quirky OpenCV YAML of the dataset: "%YAML:1.0", keys without a space.
std::string MeiYaml(const std::string& name, const std::string& xi, const std::string& k1,
                    const std::string& k2, const std::string& p1, const std::string& p2,
                    const std::string& gamma1, const std::string& gamma2, const std::string& u0,
                    const std::string& v0) {
  return "%YAML:1.0\n---\nmodel_type: MEI\ncamera_name: " + name +
         "\nimage_width: 1400\nimage_height:1400\nmirror_parameters:\n   xi:" + xi +
         "\ndistortion_parameters:\n   k1: " + k1 + "\n   k2: " + k2 + "\n   p1:" + p1 + "\n   p2: " + p2 +
         "\nprojection_parameters:\n   gamma1: " + gamma1 + "\n   gamma2:" + gamma2 + "\n   u0: " + u0 +
         "\n   v0: " + v0 + "\n";
}

std::string Yaml02() {
  return MeiYaml("image_02", "2.2134047507854890e+00", "1.6798235660113681e-02", "1.6548773243373522e+00",
                 "4.2223943394772046e-04", "4.2462134260997584e-04", "1.3363220825849971e+03",
                 "1.3357883350012958e+03", "7.1694323510126321e+02", "7.0576498308221585e+02");
}
std::string Yaml03() {
  return MeiYaml("image_03", "2.5535139132482758e+00", "4.9370396274089505e-02", "4.5068455478645308e+00",
                 "1.3477698472982495e-03", "-7.0340482615055284e-04", "1.4854388981875156e+03",
                 "1.4849477411748708e+03", "6.9888316784030962e+02", "6.9814541887723055e+02");
}

void WriteText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string Timestamps(int frames, int64_t offset_ns = 0) {
  std::string text;
  for (int i = 0; i < frames; ++i) {
    const int64_t ns = 100'000'000LL * i + 123456789 + offset_ns;
    char line[64];
    std::snprintf(line, sizeof(line), "2013-05-28 08:46:%02lld.%09lld\n",
                  static_cast<long long>(ns / 1'000'000'000), static_cast<long long>(ns % 1'000'000'000));
    text += line;
  }
  return text;
}

fs::path CameraDir(const fs::path& root, const std::string& camera) {
  return root / "data_2d_raw" / kSequence / camera;
}
fs::path ImagePath(const fs::path& root, const std::string& camera, int frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "%010d.png", frame);
  const bool rect = camera == "image_00" || camera == "image_01";
  return CameraDir(root, camera) / (rect ? "data_rect" : "data_rgb") / name;
}

// A complete KITTI-360 fixture with the real calibration: `frames` frames of
// every camera, fisheye masks (unless with_masks is false), sparse poses.
fs::path WriteFixture(const std::string& test_name, int frames = 3, bool with_masks = true) {
  const fs::path root = fs::path(::testing::TempDir()) / "mcvo_kitti360_test" / test_name;
  fs::remove_all(root);
  WriteText(root / "calibration" / "calib_cam_to_pose.txt", kCalibCamToPose);
  WriteText(root / "calibration" / "perspective.txt", kPerspective);
  WriteText(root / "calibration" / "image_02.yaml", Yaml02());
  WriteText(root / "calibration" / "image_03.yaml", Yaml03());
  for (const std::string camera : {"image_00", "image_01", "image_02", "image_03"}) {
    const bool rect = camera == "image_00" || camera == "image_01";
    const cv::Mat image(rect ? 376 : 1400, rect ? 1408 : 1400, CV_8UC1, cv::Scalar(100));
    for (int i = 0; i < frames; ++i) {
      fs::create_directories(ImagePath(root, camera, i).parent_path());
      EXPECT_TRUE(cv::imwrite(ImagePath(root, camera, i).string(), image));
    }
    WriteText(CameraDir(root, camera) / "timestamps.txt", Timestamps(frames));
    if (!rect && with_masks) {
      const cv::Mat mask(1400, 1400, CV_8UC1, cv::Scalar(255));
      EXPECT_TRUE(cv::imwrite((root / "calibration" / ("mask_" + camera.substr(6) + ".png")).string(), mask));
    }
  }
  return root;
}

DatasetOptions Options(const fs::path& root) {
  DatasetOptions options;
  options.root = root;
  options.format = "kitti360";
  options.sequence = kSequence;
  return options;
}

using testing::LogHas;

double MaxAbs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

// Opening `options` throws InputError whose message holds every one of `parts`.
void ExpectInputError(const DatasetOptions& options, const std::vector<std::string>& parts) {
  try {
    OpenDataset(options);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    for (const std::string& part : parts)
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(Kitti360, RealCalibrationGivesThePresetRig) {
  const fs::path root = WriteFixture("real", 3, /*with_masks=*/false);
  const DatasetIndex index = OpenDataset(Options(root));
  const Rig preset = ReadRig(fs::path(MCVO_SOURCE_DIR) / "config" / "rigs" / "kitti360.json");
  ASSERT_EQ(index.rig.NumCameras(), 4);
  double max_rotation = 0.0, max_translation = 0.0;
  for (int c = 0; c < 4; ++c) {
    const Camera& got = index.rig.cameras[static_cast<size_t>(c)];
    const Camera& want = preset.cameras[static_cast<size_t>(c)];
    EXPECT_EQ(got.name, want.name);
    EXPECT_EQ(got.model, want.model);
    EXPECT_EQ(got.width, want.width);
    EXPECT_EQ(got.height, want.height);
    ASSERT_EQ(got.params.size(), want.params.size());
    for (size_t i = 0; i < got.params.size(); ++i)
      EXPECT_NEAR(got.params[i], want.params[i], 1e-9) << got.name;
    max_rotation = std::max(max_rotation,
                            MaxAbs(got.cam_from_rig.RotationMatrix() - want.cam_from_rig.RotationMatrix()));
    max_translation =
        std::max(max_translation, MaxAbs(got.cam_from_rig.translation - want.cam_from_rig.translation));
  }
  std::printf("real calibration vs config/rigs/kitti360.json: max |dR| %.3g, max |dt| %.3g m\n", max_rotation,
              max_translation);
  EXPECT_LT(max_rotation, 1e-9);
  EXPECT_LT(max_translation, 1e-9);
  // Fisheye masks generated from the image circle; none for the rectified cameras.
  EXPECT_TRUE(index.masks[0].empty());
  ASSERT_FALSE(index.masks[2].empty());
  EXPECT_EQ(index.masks[2].cols, 1400);
  EXPECT_TRUE(LogHas(index, "image_02: mask generated"));
  EXPECT_EQ(index.frames.size(), 3u);
  EXPECT_FALSE(index.ground_truth.has_value());
}

TEST(Kitti360, SyntheticSequenceRoundTrips) {
  const fs::path dir = fs::path(::testing::TempDir()) / "mcvo_kitti360_test" / "round_trip";
  fs::remove_all(dir);
  fs::create_directories(dir);
  synth::SynthOptions synth_options;
  synth_options.preset = "kitti360";
  synth_options.frames = 3;
  synth_options.image_scale = 0.1;
  synth_options.seed = 3;
  synth_options.render.samples_per_axis = 1;
  synth::Synthesize(synth_options, dir / "synth");
  DatasetOptions generic;
  generic.root = dir / "synth";
  generic.format = "generic";
  const DatasetIndex source = OpenDataset(generic);
  ASSERT_TRUE(source.ground_truth.has_value());

  WriteKitti360Layout(source, dir / "kitti360", kSequence);
  const DatasetIndex back = OpenDataset(Options(dir / "kitti360"));

  ASSERT_EQ(back.rig.NumCameras(), source.rig.NumCameras());
  double max_rotation = 0.0, max_translation = 0.0, max_param = 0.0;
  for (size_t c = 0; c < source.rig.cameras.size(); ++c) {
    const Camera& want = source.rig.cameras[c];
    const Camera& got = back.rig.cameras[c];
    EXPECT_EQ(got.name, want.name);
    EXPECT_EQ(got.model, want.model);
    EXPECT_EQ(got.width, want.width);
    EXPECT_EQ(got.height, want.height);
    ASSERT_EQ(got.params.size(), want.params.size());
    for (size_t i = 0; i < got.params.size(); ++i)
      max_param = std::max(max_param, std::abs(got.params[i] - want.params[i]));
    max_rotation = std::max(max_rotation,
                            MaxAbs(got.cam_from_rig.RotationMatrix() - want.cam_from_rig.RotationMatrix()));
    max_translation =
        std::max(max_translation, MaxAbs(got.cam_from_rig.translation - want.cam_from_rig.translation));
    // Fisheye masks travel as calibration/mask_0N.png.
    ASSERT_EQ(got.model == CameraModelId::kMei, !back.masks[c].empty());
    if (!back.masks[c].empty()) {
      EXPECT_EQ(cv::norm(back.masks[c], source.masks[c], cv::NORM_INF), 0.0);
    }
  }
  ASSERT_EQ(back.frames.size(), source.frames.size());
  for (size_t i = 0; i < source.frames.size(); ++i) {
    EXPECT_EQ(back.frames[i].t_ns, source.frames[i].t_ns);
    for (size_t c = 0; c < source.rig.cameras.size(); ++c) {
      EXPECT_EQ(ReadFileToString(back.frames[i].images[c]), ReadFileToString(source.frames[i].images[c]));
    }
  }
  ASSERT_TRUE(back.ground_truth.has_value());
  ASSERT_EQ(back.ground_truth->poses.size(), source.ground_truth->poses.size());
  double max_pose = 0.0;
  for (size_t i = 0; i < source.ground_truth->poses.size(); ++i) {
    const StampedPose& want = source.ground_truth->poses[i];
    const StampedPose& got = back.ground_truth->poses[i];
    EXPECT_EQ(got.t_ns, want.t_ns);
    max_pose =
        std::max(max_pose, MaxAbs(got.world_from_body.ToMatrix3x4() - want.world_from_body.ToMatrix3x4()));
  }
  std::printf("round trip: max |dR| %.3g, max |dt| %.3g m, max |dparam| %.3g, max |dpose| %.3g\n",
              max_rotation, max_translation, max_param, max_pose);
  EXPECT_LT(max_rotation, 1e-9);
  EXPECT_LT(max_translation, 1e-9);
  EXPECT_LT(max_param, 1e-9);
  EXPECT_LT(max_pose, 1e-9);
}

TEST(Kitti360, WriterRejectsRigsThatAreNotKitti360Shaped) {
  DatasetIndex index;
  Camera camera;
  camera.name = "cam0";
  camera.params = {100, 100, 50, 50};
  camera.width = camera.height = 100;
  index.rig.cameras.push_back(camera);
  const fs::path root = fs::path(::testing::TempDir()) / "mcvo_kitti360_test" / "writer_rejects";
  EXPECT_THROW(WriteKitti360Layout(index, root, kSequence), InputError);
  index.rig.cameras[0].name = "image_02";  // a pinhole where a MEI camera belongs
  EXPECT_THROW(WriteKitti360Layout(index, root, kSequence), InputError);
  index.rig.cameras[0].name = "image_01";  // image_01 without image_00
  EXPECT_THROW(WriteKitti360Layout(index, root, kSequence), InputError);
}

TEST(Kitti360, CameraSubsetInTheGivenOrder) {
  const fs::path root = WriteFixture("subset");
  DatasetOptions options = Options(root);
  options.cameras = {"image_03", "image_00", "image_02"};
  const DatasetIndex index = OpenDataset(options);
  ASSERT_EQ(index.rig.NumCameras(), 3);
  EXPECT_EQ(index.rig.cameras[0].name, "image_03");
  EXPECT_EQ(index.rig.cameras[1].name, "image_00");
  EXPECT_EQ(index.rig.cameras[2].name, "image_02");
  ASSERT_EQ(index.frames.size(), 3u);
  EXPECT_EQ(index.frames[1].images[0], ImagePath(root, "image_03", 1));
  EXPECT_EQ(index.frames[1].images[1], ImagePath(root, "image_00", 1));
  EXPECT_FALSE(index.masks[0].empty());
  EXPECT_TRUE(index.masks[1].empty());
  EXPECT_TRUE(LogHas(index, "image_03: mask loaded"));
  options.cameras = {"image_07"};
  EXPECT_THROW(OpenDataset(options), UsageError);
}

TEST(Kitti360, SparsePosesTakeImage00Times) {
  const fs::path root = WriteFixture("sparse", 4);
  WriteText(root / "data_poses" / kSequence / "poses.txt",
            "1 1 0 0 10 0 1 0 20 0 0 1 30\n"
            "3 0 -1 0 11 1 0 0 21 0 0 1 31\n");
  DatasetOptions options = Options(root);
  options.cameras = {"image_02", "image_00"};
  const DatasetIndex index = OpenDataset(options);
  ASSERT_TRUE(index.ground_truth.has_value());
  ASSERT_EQ(index.ground_truth->poses.size(), 2u);
  EXPECT_TRUE(index.ground_truth->has_time);
  EXPECT_EQ(index.ground_truth->poses[0].frame_index, 1);
  EXPECT_EQ(index.ground_truth->poses[1].frame_index, 3);
  EXPECT_EQ(index.ground_truth->poses[0].t_ns, index.frames[1].t_ns);
  EXPECT_EQ(index.ground_truth->poses[1].t_ns, index.frames[3].t_ns);
  EXPECT_EQ(index.ground_truth->poses[1].world_from_body.translation, Eigen::Vector3d(11, 21, 31));
  // 2013-05-28 08:46:00.123456789 UTC + 0.3 s.
  EXPECT_EQ(index.frames[3].t_ns, 1369730760423456789LL);
}

TEST(Kitti360, MissingCalibrationFile) {
  const fs::path root = WriteFixture("missing_calib");
  fs::remove(root / "calibration" / "calib_cam_to_pose.txt");
  ExpectInputError(Options(root), {"calib_cam_to_pose.txt", "missing calibration file"});
  const fs::path root2 = WriteFixture("missing_yaml");
  fs::remove(root2 / "calibration" / "image_03.yaml");
  ExpectInputError(Options(root2), {"image_03.yaml", "missing"});
}

TEST(Kitti360, MissingKeys) {
  const fs::path root = WriteFixture("missing_key");
  std::string perspective = kPerspective;
  perspective.erase(perspective.find("P_rect_00"),
                    perspective.find("S_rect_01") - perspective.find("P_rect_00"));
  WriteText(root / "calibration" / "perspective.txt", perspective);
  ExpectInputError(Options(root), {"perspective.txt", "P_rect_00"});

  const fs::path root2 = WriteFixture("missing_yaml_key");
  std::string yaml = Yaml02();
  yaml.erase(yaml.find("   gamma1"), yaml.find("   gamma2") - yaml.find("   gamma1"));
  WriteText(root2 / "calibration" / "image_02.yaml", yaml);
  ExpectInputError(Options(root2), {"image_02.yaml", "projection_parameters/gamma1", "missing"});
}

TEST(Kitti360, MalformedNumbers) {
  const fs::path root = WriteFixture("malformed");
  std::string calib = kCalibCamToPose;
  calib.replace(calib.find("0.5981494900"), 12, "0.59814949x0");
  WriteText(root / "calibration" / "calib_cam_to_pose.txt", calib);
  ExpectInputError(Options(root), {"calib_cam_to_pose.txt:2", "image_01", "0.59814949x0"});

  const fs::path root2 = WriteFixture("bad_rotation");
  std::string perspective = kPerspective;
  perspective.replace(perspective.find("0.999974"), 8, "0.989974");
  WriteText(root2 / "calibration" / "perspective.txt", perspective);
  ExpectInputError(Options(root2), {"perspective.txt", "R_rect_00", "orthonormal"});
}

// Inputs found by tests/fuzz (docs/fuzzing.md).
TEST(Kitti360, FuzzFindingsAreInputErrors) {
  // cv::FileStorage, which read image_0N.yaml before, threw std::length_error
  // on the first and never returned on the second.
  const fs::path root = WriteFixture("fuzz_mei_yaml", 1);
  WriteText(root / "calibration" / "image_02.yaml", "%YAML:1.\n k:0\n :");
  ExpectInputError(Options(root), {"image_02.yaml:2: image_width: missing key"});
  WriteText(root / "calibration" / "image_02.yaml", "%YAML:1.\n k:0\n %YAML:1.0\n:---\nm");
  ExpectInputError(Options(root), {"image_02.yaml:", "YAML syntax error"});
  // A year beyond int64 nanoseconds overflowed.
  const fs::path root2 = WriteFixture("fuzz_timestamps_year", 1);
  std::string times = Timestamps(1);
  times.replace(0, 4, "20113");
  WriteText(CameraDir(root2, "image_02") / "timestamps.txt", times);
  ExpectInputError(Options(root2), {"image_02/timestamps.txt:1", "expected a time"});
}

TEST(Kitti360, CorruptOrTruncatedPng) {
  const fs::path root = WriteFixture("truncated_png");
  const fs::path png = ImagePath(root, "image_01", 1);
  const std::string bytes = ReadFileToString(png);
  WriteText(png, bytes.substr(0, bytes.size() / 2));
  ExpectInputError(Options(root), {png.string(), "truncated"});

  const fs::path root2 = WriteFixture("corrupt_png");
  WriteText(ImagePath(root2, "image_02", 2), "this is not a PNG file at all, just some text bytes");
  ExpectInputError(Options(root2), {ImagePath(root2, "image_02", 2).string(), "not a PNG"});

  const fs::path root3 = WriteFixture("wrong_size_png");
  cv::imwrite(ImagePath(root3, "image_00", 0).string(), cv::Mat(10, 20, CV_8UC1, cv::Scalar(0)));
  ExpectInputError(Options(root3), {ImagePath(root3, "image_00", 0).string(), "20x10"});
}

TEST(Kitti360, NonMonotonicTimestamps) {
  const fs::path root = WriteFixture("timestamps");
  std::string times = Timestamps(3);
  times.replace(times.rfind("08:46:00.3"), 10, "08:46:00.1");
  WriteText(CameraDir(root, "image_02") / "timestamps.txt", times);
  ExpectInputError(Options(root), {"image_02/timestamps.txt:3", "not after"});
}

TEST(Kitti360, CorruptPosesLine) {
  const fs::path root = WriteFixture("poses");
  WriteText(root / "data_poses" / kSequence / "poses.txt",
            "0 1 0 0 10 0 1 0 20 0 0 1 30\n"
            "1 1 0 0 10 0 1 0 20 0 0 1\n");
  ExpectInputError(Options(root), {"poses.txt:2"});
}

TEST(Kitti360, CameraWithFewerImages) {
  const fs::path root = WriteFixture("fewer");
  fs::remove(ImagePath(root, "image_03", 2));
  DatasetOptions options = Options(root);
  const DatasetIndex marked = OpenDataset(options);
  ASSERT_EQ(marked.frames.size(), 3u);
  EXPECT_TRUE(marked.frames[2].images[3].empty());
  EXPECT_FALSE(marked.frames[1].images[3].empty());
  EXPECT_TRUE(LogHas(marked, "image_03: no image at 1 frame(s), marked missing"));
  options.missing_images = MissingImagePolicy::kSkipFrame;
  const DatasetIndex skipped = OpenDataset(options);
  EXPECT_EQ(skipped.frames.size(), 2u);
  EXPECT_TRUE(LogHas(skipped, "image_03: no image at 1 frame(s), skipped"));
}

TEST(Kitti360, OutOfSyncImagesFollowThePolicy) {
  const fs::path root = WriteFixture("sync");
  // Frame 1 of image_02 is 0.05 s late (tolerance 0.04 s); frame 2 is 0.03 s late (kept).
  const std::string on_time = Timestamps(3), late_50ms = Timestamps(3, 50'000'000),
                    late_30ms = Timestamps(3, 30'000'000);
  const size_t line = on_time.find('\n') + 1;  // every line has the same length
  const std::string edited =
      on_time.substr(0, line) + late_50ms.substr(line, line) + late_30ms.substr(2 * line, line);
  WriteText(CameraDir(root, "image_02") / "timestamps.txt", edited);
  DatasetOptions options = Options(root);
  const DatasetIndex marked = OpenDataset(options);
  ASSERT_EQ(marked.frames.size(), 3u);
  EXPECT_TRUE(marked.frames[1].images[2].empty());
  EXPECT_FALSE(marked.frames[2].images[2].empty());
  EXPECT_FALSE(marked.frames[1].images[3].empty());
  EXPECT_TRUE(LogHas(marked, "image_02: 1 image(s) more than 0.04 s from image_00's time, marked missing"));
  options.missing_images = MissingImagePolicy::kSkipFrame;
  const DatasetIndex skipped = OpenDataset(options);
  ASSERT_EQ(skipped.frames.size(), 2u);
  EXPECT_EQ(skipped.frames[1].t_ns, marked.frames[2].t_ns);
}

}  // namespace
}  // namespace mcvo
