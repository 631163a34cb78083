// OpenDataset on the generic rig format: what `mcvo synth` writes reads back,
// the missing-image policy, the camera subset, and bad input naming the file.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "dataset/dataset_fixtures.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/synth/synthesize.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
using testing::CopyDataset;
using testing::SetCsvField;
using testing::SynthDataset;

constexpr char kSuite[] = "generic_reader_test";

fs::path Stereo() { return SynthDataset(kSuite, "stereo", 3); }

DatasetOptions Options(const fs::path& root) {
  DatasetOptions options;
  options.root = root;
  return options;
}

std::string JoinedLog(const DatasetIndex& index) {
  std::string text;
  for (const std::string& line : index.log) text += line + "\n";
  return text;
}

// Runs OpenDataset, expects InputError and returns its message.
std::string InputErrorOf(const DatasetOptions& options) {
  try {
    OpenDataset(options);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError for " << options.root;
  return "";
}

TEST(GenericReader, ReadsWhatSynthWrites) {
  const DatasetIndex index = OpenDataset(Options(Stereo()));
  EXPECT_EQ(index.format, "generic");
  EXPECT_EQ(index.name, "pristine_stereo_3");
  ASSERT_EQ(index.rig.NumCameras(), 2);
  EXPECT_EQ(index.rig.cameras[0].name, "image_00");
  EXPECT_EQ(index.rig.cameras[1].name, "image_01");
  EXPECT_EQ(index.rig.cameras[0].width, 141);
  ASSERT_EQ(index.frames.size(), 3u);
  for (size_t i = 0; i < index.frames.size(); ++i) {
    EXPECT_EQ(index.frames[i].t_ns, 1000000000 + static_cast<int64_t>(i) * 100000000);
    ASSERT_EQ(index.frames[i].images.size(), 2u);
    for (const fs::path& image : index.frames[i].images) EXPECT_TRUE(fs::is_regular_file(image)) << image;
  }
  EXPECT_EQ(index.frames[2].images[1].filename(), "000002.png");
  EXPECT_EQ(index.frames[2].images[1].parent_path().filename(), "image_01");
  ASSERT_TRUE(index.ground_truth.has_value());
  EXPECT_EQ(index.ground_truth->poses.size(), 3u);
  EXPECT_EQ(index.ground_truth->poses[1].t_ns, index.frames[1].t_ns);
  ASSERT_EQ(index.masks.size(), 2u);
  EXPECT_TRUE(index.masks[0].empty());  // pinhole: every pixel valid
  EXPECT_TRUE(index.masks[1].empty());
}

TEST(GenericReader, ExplicitFormatAndTrailingSlash) {
  DatasetOptions options = Options(Stereo().string() + "/");
  options.format = "generic";
  const DatasetIndex index = OpenDataset(options);
  EXPECT_EQ(index.name, "pristine_stereo_3");
  EXPECT_EQ(index.frames.size(), 3u);
}

TEST(GenericReader, LoadsFisheyeMasks) {
  const DatasetIndex index = OpenDataset(Options(SynthDataset(kSuite, "kitti360-3cam", 1)));
  ASSERT_EQ(index.rig.NumCameras(), 3);
  ASSERT_EQ(index.masks.size(), 3u);
  EXPECT_TRUE(index.masks[0].empty());  // image_00, pinhole
  for (int c = 1; c < 3; ++c) {
    const cv::Mat& mask = index.masks[static_cast<size_t>(c)];
    const Camera& camera = index.rig.cameras[static_cast<size_t>(c)];
    ASSERT_FALSE(mask.empty()) << camera.name;
    EXPECT_EQ(mask.type(), CV_8UC1);
    EXPECT_EQ(mask.cols, camera.width);
    EXPECT_EQ(mask.rows, camera.height);
    EXPECT_EQ(mask.at<uint8_t>(camera.height / 2, camera.width / 2), 255);
    // The mask synth wrote is the camera's valid-pixel mask.
    EXPECT_EQ(cv::countNonZero(mask != ValidPixelMask(camera)), 0) << camera.name;
  }
}

TEST(GenericReader, MissingImagePolicy) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "missing_image");
  SetCsvField(root / "frames.csv", /*line=*/2, /*field=*/2, "");  // frame 1, image_01

  DatasetOptions options = Options(root);
  options.missing_images = MissingImagePolicy::kMarkMissing;
  const DatasetIndex marked = OpenDataset(options);
  ASSERT_EQ(marked.frames.size(), 3u);
  EXPECT_FALSE(marked.frames[1].images[0].empty());
  EXPECT_TRUE(marked.frames[1].images[1].empty());
  EXPECT_NE(JoinedLog(marked).find("1 of 3 frames miss an image (image_01: 1)"), std::string::npos)
      << JoinedLog(marked);
  EXPECT_NE(JoinedLog(marked).find("mark-missing"), std::string::npos);

  options.missing_images = MissingImagePolicy::kSkipFrame;
  const DatasetIndex skipped = OpenDataset(options);
  ASSERT_EQ(skipped.frames.size(), 2u);
  EXPECT_EQ(skipped.frames[0].t_ns, 1000000000);
  EXPECT_EQ(skipped.frames[1].t_ns, 1200000000);
  EXPECT_NE(JoinedLog(skipped).find("skip-frame: 1 frame(s) dropped"), std::string::npos)
      << JoinedLog(skipped);

  // With only image_00 selected, no frame misses an image.
  options.cameras = {"image_00"};
  const DatasetIndex subset = OpenDataset(options);
  EXPECT_EQ(subset.frames.size(), 3u);
  EXPECT_EQ(JoinedLog(subset).find("miss an image"), std::string::npos);
}

TEST(GenericReader, CameraSubsetAndOrder) {
  DatasetOptions options = Options(Stereo());
  options.cameras = {"image_01", "image_00"};
  const DatasetIndex index = OpenDataset(options);
  ASSERT_EQ(index.rig.NumCameras(), 2);
  EXPECT_EQ(index.rig.cameras[0].name, "image_01");
  EXPECT_EQ(index.frames[0].images[0].parent_path().filename(), "image_01");
  EXPECT_EQ(index.frames[0].images[1].parent_path().filename(), "image_00");
  EXPECT_EQ(index.masks.size(), 2u);

  options.cameras = {"image_07"};
  try {
    OpenDataset(options);
    ADD_FAILURE() << "unknown camera accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("cameras: 'image_07'"), std::string::npos) << e.what();
  }
}

TEST(GenericReader, OptionsCheckNamesTheField) {
  const auto usage_error = [](const DatasetOptions& options) -> std::string {
    try {
      options.Check();
    } catch (const UsageError& e) {
      return e.what();
    }
    return "";
  };
  DatasetOptions options = Options(Stereo());
  EXPECT_EQ(usage_error(options), "");
  options.format = "tum";
  EXPECT_EQ(usage_error(options).rfind("format:", 0), 0u);
  options = Options("");
  EXPECT_EQ(usage_error(options).rfind("root:", 0), 0u);
  options = Options(Stereo());
  options.sync_tolerance_s = -1.0;
  EXPECT_EQ(usage_error(options).rfind("sync_tolerance_s:", 0), 0u);
  options = Options(Stereo());
  options.fisheye_max_angle_deg = 0.0;
  EXPECT_EQ(usage_error(options).rfind("fisheye_max_angle_deg:", 0), 0u);
  options = Options(Stereo());
  options.cameras = {"image_00", "image_00"};
  EXPECT_EQ(usage_error(options).rfind("cameras:", 0), 0u);
}

TEST(GenericReaderBadInput, MissingRigJson) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "no_rig");
  fs::remove(root / "rig.json");
  EXPECT_NE(InputErrorOf(Options(root)).find("rig.json"), std::string::npos);  // auto-detection
  DatasetOptions options = Options(root);
  options.format = "generic";
  EXPECT_NE(InputErrorOf(options).find((root / "rig.json").string()), std::string::npos);
}

TEST(GenericReaderBadInput, NotADataset) {
  const fs::path root = testing::TestTempDir(kSuite) / "empty";
  fs::create_directories(root);
  EXPECT_NE(InputErrorOf(Options(root)).find("unknown dataset layout"), std::string::npos);
  EXPECT_NE(InputErrorOf(Options(root / "nowhere")).find("does not exist"), std::string::npos);
}

TEST(GenericReaderBadInput, HeaderDoesNotMatchRig) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "bad_header");
  SetCsvField(root / "frames.csv", 0, 2, "image_02");
  const std::string message = InputErrorOf(Options(root));
  EXPECT_NE(message.find((root / "frames.csv").string()), std::string::npos) << message;
  EXPECT_NE(message.find("image_00, image_02"), std::string::npos) << message;
}

TEST(GenericReaderBadInput, ReferencedImageMissing) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "image_missing");
  fs::remove(root / "images" / "image_01" / "000001.png");
  const std::string message = InputErrorOf(Options(root));
  EXPECT_NE(message.find("image_01/000001.png"), std::string::npos) << message;
  EXPECT_NE(message.find("frames.csv"), std::string::npos) << message;
}

TEST(GenericReaderBadInput, NonMonotonicTimes) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "times");
  SetCsvField(root / "frames.csv", 3, 0, "1050000000");  // frame 2 before frame 1
  const std::string message = InputErrorOf(Options(root));
  EXPECT_NE(message.find("frames.csv:4"), std::string::npos) << message;
}

TEST(GenericReaderBadInput, MaskOfWrongSize) {
  const fs::path root = CopyDataset(SynthDataset(kSuite, "kitti360-3cam", 1), kSuite, "bad_mask");
  const fs::path mask = root / "masks" / "image_02.png";
  ASSERT_TRUE(fs::exists(mask));
  cv::imwrite(mask.string(), cv::Mat(10, 12, CV_8UC1, cv::Scalar(255)));
  const std::string message = InputErrorOf(Options(root));
  EXPECT_NE(message.find("image_02.png"), std::string::npos) << message;
  EXPECT_NE(message.find("12 x 10"), std::string::npos) << message;

  fs::remove(mask);
  EXPECT_NE(InputErrorOf(Options(root)).find("image_02.png"), std::string::npos);
  testing::WriteText(mask, "not a png");
  EXPECT_NE(InputErrorOf(Options(root)).find("image_02.png: cannot decode"), std::string::npos);
}

TEST(GenericReaderBadInput, MalformedGroundTruth) {
  const fs::path root = CopyDataset(Stereo(), kSuite, "bad_gt");
  testing::WriteText(root / "groundtruth.tum", "1.0 0 0 0 0 0 0\n");
  EXPECT_NE(InputErrorOf(Options(root)).find("groundtruth.tum"), std::string::npos);
}

TEST(ValidPixelMask, PinholeAllValidFisheyeCircle) {
  const Rig rig = synth::PresetRig("kitti360");
  EXPECT_TRUE(ValidPixelMask(ScaledCamera(rig.cameras[0], 0.1)).empty());
  const Camera fisheye = ScaledCamera(rig.cameras[2], 0.1);
  const cv::Mat domain = ValidPixelMask(fisheye);
  ASSERT_FALSE(domain.empty());
  EXPECT_EQ(domain.at<uint8_t>(fisheye.height / 2, fisheye.width / 2), 255);
  const int domain_pixels = cv::countNonZero(domain);
  const cv::Mat narrow = ValidPixelMask(fisheye, 60.0);
  ASSERT_FALSE(narrow.empty());
  EXPECT_LT(cv::countNonZero(narrow), domain_pixels);
  EXPECT_GT(cv::countNonZero(narrow), 0);
  EXPECT_EQ(cv::countNonZero(narrow & ~domain), 0);  // the angle limit only removes pixels
}

}  // namespace
}  // namespace mcvo
