// ReadRosbagDataset (--format rosbag) on ROS1 bags written by the rosbag
// library from a rendered stereo sequence (rosbag_fixtures.h): raw (mono8,
// mono16, bgr8, rgb8) and compressed (png, jpeg) image topics, a
// PoseStamped ground-truth topic, an unrelated topic, a dropped message;
// images streamed from the bag decode to the generic layout's; bad inputs
// name the bag, the topic and the message index.
#include <gtest/gtest.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "dataset/dataset_fixtures.h"
#include "dataset/rosbag_fixtures.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/dataset/image_container.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;
using testing::BagSpec;

fs::path Generic() { return testing::SynthDataset("rosbag_test", "stereo", 10); }

fs::path TestDir() {
  const fs::path dir =
      testing::TestTempDir("rosbag_test") / ::testing::UnitTest::GetInstance()->current_test_info()->name();
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

struct Bag {
  fs::path bag;
  fs::path camchain;
};

Bag WriteBag(const BagSpec& spec) {
  const fs::path dir = TestDir();
  Bag out{dir / "seq.bag", dir / "camchain.yaml"};
  testing::WriteBagFromGeneric(Generic(), out.bag, spec);
  testing::WriteText(out.camchain, testing::CamchainOfRig(ReadRig(Generic() / "rig.json"), spec));
  return out;
}

DatasetOptions Options(const Bag& bag) {
  DatasetOptions options;
  options.root = bag.bag;  // format auto: a *.bag file
  options.calib = bag.camchain;
  return options;
}

std::vector<FrameImages> DecodeAll(const DatasetIndex& index) {
  FrameStream stream(index, {2, 4, false});
  std::vector<FrameImages> frames;
  while (std::optional<FrameImages> frame = stream.Next()) frames.push_back(std::move(*frame));
  return frames;
}

double MeanAbsDiff(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_L1) / a.total(); }

std::string ErrorOf(const DatasetOptions& options) {
  try {
    OpenDataset(options);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "<no error>";
}

bool Has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(RosbagReader, RawAndCompressedTopicsStreamTheGenericImages) {
  BagSpec spec;
  spec.encoding = {{"image_00", "mono8"}, {"image_01", "png"}};
  spec.lz4 = true;
  const Bag bag = WriteBag(spec);
  DatasetOptions options = Options(bag);
  options.gt_topic = spec.gt_topic;
  const DatasetIndex index = OpenDataset(options);
  DatasetOptions generic_options;
  generic_options.root = Generic();
  const DatasetIndex generic = OpenDataset(generic_options);

  EXPECT_EQ(index.format, "rosbag");
  EXPECT_EQ(index.name, "seq");
  ASSERT_EQ(index.rig.NumCameras(), 2);
  EXPECT_EQ(index.rig.cameras[0].name, "cam0");
  EXPECT_EQ(index.rig.cameras[1].name, "cam1");
  ASSERT_EQ(index.frames.size(), generic.frames.size());
  for (size_t f = 0; f < index.frames.size(); ++f) {
    EXPECT_EQ(index.frames[f].t_ns, generic.frames[f].t_ns);
    // Members of the bag, not files: nothing was extracted.
    EXPECT_EQ(index.frames[f].images[1], bag.bag / "image_01" / "image_raw" / std::to_string(f));
    EXPECT_FALSE(fs::exists(index.frames[f].images[1]));
    EXPECT_EQ(ImageContainerFile(index.frames[f].images[0]), fs::absolute(bag.bag).lexically_normal());
  }
  const std::vector<FrameImages> ours = DecodeAll(index);
  const std::vector<FrameImages> theirs = DecodeAll(generic);
  ASSERT_EQ(ours.size(), theirs.size());
  for (size_t f = 0; f < ours.size(); ++f) {
    for (size_t c = 0; c < 2; ++c) {
      ASSERT_EQ(ours[f].images[c].size(), theirs[f].images[c].size());
      EXPECT_EQ(cv::norm(ours[f].images[c], theirs[f].images[c], cv::NORM_INF), 0.0) << f << " " << c;
    }
  }
  // Ground truth from the PoseStamped topic: the groundtruth.tum poses.
  ASSERT_TRUE(index.ground_truth.has_value());
  ASSERT_TRUE(generic.ground_truth.has_value());
  ASSERT_EQ(index.ground_truth->poses.size(), generic.ground_truth->poses.size());
  EXPECT_TRUE(index.ground_truth->has_time);
  for (size_t i = 0; i < index.ground_truth->poses.size(); ++i) {
    const StampedPose& a = index.ground_truth->poses[i];
    const StampedPose& b = generic.ground_truth->poses[i];
    EXPECT_EQ(a.t_ns, b.t_ns);
    EXPECT_LT((a.world_from_body.translation - b.world_from_body.translation).norm(), 1e-9);
    EXPECT_LT(a.world_from_body.rotation.angularDistance(b.world_from_body.rotation), 1e-9);
  }
  // The rig of the camchain is the rig of rig.json (T_cam_imu of cam0 = cam0_from_rig).
  for (size_t c = 0; c < 2; ++c) {
    EXPECT_LT(
        (index.rig.cameras[c].cam_from_rig.translation - generic.rig.cameras[c].cam_from_rig.translation)
            .norm(),
        1e-9);
  }
  // The log says what is in the bag, for `mcvo info`.
  std::string log;
  for (const std::string& line : index.log) log += line + "\n";
  for (const std::string expected :
       {"rosbag: topic /image_00/image_raw: sensor_msgs/Image, 10 messages, 10.00 Hz",
        "rosbag: topic /image_01/image_raw: sensor_msgs/CompressedImage, 10 messages",
        "rosbag: topic /imu/pose_unrelated: geometry_msgs/PoseStamped, 10 messages",
        "rosbag: camera cam0 <- /image_00/image_raw: 10 images (mono8 10), 10.00 Hz by header.stamp",
        "rosbag: camera cam1 <- /image_01/image_raw: 10 images (compressed mono8; png compressed 10)",
        "ground truth: topic /groundtruth/pose (geometry_msgs/PoseStamped, 10 poses"}) {
    EXPECT_TRUE(Has(log, expected)) << expected << "\n" << log;
  }
  // The hash of a member is that of its message, stable.
  EXPECT_EQ(Sha256OfImage(index.frames[3].images[0]), Sha256OfImage(index.frames[3].images[0]));
  EXPECT_NE(Sha256OfImage(index.frames[3].images[0]), Sha256OfImage(index.frames[4].images[0]));
}

TEST(RosbagReader, EveryEncodingDecodesToTheSameGrey) {
  DatasetOptions generic_options;
  generic_options.root = Generic();
  const std::vector<FrameImages> theirs = DecodeAll(OpenDataset(generic_options));
  for (const auto& [first, second] :
       std::vector<std::pair<std::string, std::string>>{{"mono16", "bgr8"}, {"rgb8", "jpeg"}}) {
    BagSpec spec;
    spec.encoding = {{"image_00", first}, {"image_01", second}};
    const std::vector<FrameImages> ours = DecodeAll(OpenDataset(Options(WriteBag(spec))));
    ASSERT_EQ(ours.size(), theirs.size());
    for (size_t f = 0; f < ours.size(); ++f) {
      EXPECT_EQ(cv::norm(ours[f].images[0], theirs[f].images[0], cv::NORM_INF), 0.0) << first << " " << f;
      if (second == "jpeg") {
        EXPECT_LT(MeanAbsDiff(ours[f].images[1], theirs[f].images[1]), 4.0) << f;  // lossy
      } else {
        EXPECT_EQ(cv::norm(ours[f].images[1], theirs[f].images[1], cv::NORM_INF), 0.0) << second << " " << f;
      }
    }
  }
}

TEST(RosbagReader, DroppedMessageFollowsTheMissingImagePolicy) {
  BagSpec spec;
  spec.dropped = {{"image_01", 4}};
  const Bag bag = WriteBag(spec);
  const DatasetIndex marked = OpenDataset(Options(bag));
  ASSERT_EQ(marked.frames.size(), 10u);
  EXPECT_TRUE(marked.frames[4].images[1].empty());
  EXPECT_FALSE(marked.frames[4].images[0].empty());
  // Message indices count the messages of the topic: frame 5 is message 4.
  EXPECT_EQ(marked.frames[5].images[1].filename(), "4");
  const std::vector<FrameImages> frames = DecodeAll(marked);
  EXPECT_TRUE(frames[4].images[1].empty());
  EXPECT_FALSE(frames[5].images[1].empty());

  DatasetOptions skip = Options(bag);
  skip.missing_images = MissingImagePolicy::kSkipFrame;
  const DatasetIndex skipped = OpenDataset(skip);
  EXPECT_EQ(skipped.frames.size(), 9u);
  bool logged = false;
  for (const std::string& line : skipped.log) logged = logged || Has(line, "1 incomplete frames skipped");
  EXPECT_TRUE(logged);
}

TEST(RosbagReader, RigJsonCalibrationTopicsAndGroundTruthFile) {
  BagSpec spec;
  spec.topic = {{"image_01", "/right/image"}};
  spec.gt_topic = "";
  const Bag bag = WriteBag(spec);
  DatasetOptions options = Options(bag);
  options.calib = Generic() / "rig.json";  // no rostopic: /<camera>/image_raw unless --topics
  options.topics = {{"image_01", "/right/image"}};
  options.gt_file = Generic() / "groundtruth.tum";
  options.cameras = {"image_01"};
  const DatasetIndex index = OpenDataset(options);
  ASSERT_EQ(index.rig.NumCameras(), 1);
  EXPECT_EQ(index.rig.cameras[0].name, "image_01");
  EXPECT_EQ(index.frames.size(), 10u);
  ASSERT_TRUE(index.ground_truth.has_value());
  EXPECT_EQ(index.ground_truth->poses.size(), 10u);
  EXPECT_EQ(DecodeAll(index).size(), 10u);
}

TEST(RosbagReader, BadInputsNameTheBagTopicAndMessage) {
  BagSpec spec;
  spec.encoding = {{"image_01", "png"}};
  spec.bad_encoding = {{{"image_00", 3}, "yuv422"}};
  const Bag bag = WriteBag(spec);
  const std::string name = bag.bag.string();

  // Wrong encoding, found when the bag is opened.
  std::string error = ErrorOf(Options(bag));
  EXPECT_TRUE(Has(error, name + ": topic /image_00/image_raw, message 3: encoding 'yuv422' is not supported"))
      << error;

  // Unknown topic: the bag's topics are listed.
  DatasetOptions unknown = Options(bag);
  unknown.topics = {{"cam0", "/nope"}};
  error = ErrorOf(unknown);
  EXPECT_TRUE(Has(error, name + ": topic /nope (camera cam0) has no message in the bag")) << error;
  EXPECT_TRUE(Has(error, "/image_01/image_raw (sensor_msgs/CompressedImage)")) << error;

  // A ground-truth topic that is not a pose.
  DatasetOptions gt = Options(bag);
  gt.cameras = {"cam1"};
  gt.gt_topic = "/image_01/image_raw";
  error = ErrorOf(gt);
  EXPECT_TRUE(
      Has(error, name + ": topic /image_01/image_raw, message 0: type sensor_msgs/CompressedImage is not "
                        "a pose"))
      << error;

  // Usage: no calibration; bag flags on a folder.
  DatasetOptions no_calib = Options(bag);
  no_calib.calib.clear();
  EXPECT_TRUE(Has(ErrorOf(no_calib), "calib: a ROS bag needs its calibration")) << ErrorOf(no_calib);
  DatasetOptions folder;
  folder.root = Generic();
  folder.calib = bag.camchain;
  EXPECT_TRUE(Has(ErrorOf(folder), "calib: only for ROS bags")) << ErrorOf(folder);
}

TEST(RosbagReader, CorruptCompressedImageStopsTheStreamNamingTheMessage) {
  BagSpec spec;
  spec.encoding = {{"image_01", "png"}};
  spec.corrupt = {{"image_01", 2}};
  const Bag bag = WriteBag(spec);
  const DatasetIndex index = OpenDataset(Options(bag));  // the index decodes no compressed image
  FrameStream stream(index, {1, 2, false});
  std::string error;
  try {
    while (stream.Next()) {
    }
  } catch (const InputError& e) {
    error = e.what();
  }
  EXPECT_TRUE(Has(error, bag.bag.string() + ": topic /image_01/image_raw, message 2: cannot decode"))
      << error;
}

TEST(RosbagReader, TruncatedOrMissingBagNamesTheBag) {
  const Bag bag = WriteBag(BagSpec());
  const fs::path truncated = bag.bag.parent_path() / "truncated.bag";
  const std::string bytes = testing::ReadText(bag.bag);
  testing::WriteText(truncated, bytes.substr(0, bytes.size() / 2));
  Bag cut = bag;
  cut.bag = truncated;
  std::string error = ErrorOf(Options(cut));
  EXPECT_TRUE(Has(error, truncated.string() + ": cannot read the ROS bag")) << error;

  cut.bag = bag.bag.parent_path() / "absent.bag";
  error = ErrorOf(Options(cut));
  EXPECT_TRUE(Has(error, cut.bag.string() + ": ROS bag ")) << error;

  testing::WriteText(truncated, "#ROSBAG V2.0\nnot a bag");
  cut.bag = truncated;
  error = ErrorOf(Options(cut));
  EXPECT_TRUE(Has(error, truncated.string() + ": cannot read the ROS bag")) << error;
}

}  // namespace
}  // namespace mcvo
