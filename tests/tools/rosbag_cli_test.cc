// `mcvo run` and `mcvo info` on a ROS1 bag, with no conversion: the bag is
// written by the rosbag library from a sequence `mcvo synth` rendered
// (image_00 as raw mono8 Images, image_01 as PNG CompressedImages, a
// PoseStamped ground-truth topic), calibrated by a Kalibr camchain.yaml of
// the same rig or by its rig.json. With rig.json (the identical rig) and
// lossless images the run gives the generic layout's trajectory byte for byte.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dataset/rosbag_fixtures.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/util/file.h"
#include "tools/run_mcvo.h"

namespace {

namespace fs = std::filesystem;
using mcvo::test::Quote;
using mcvo::test::Result;
using mcvo::test::RunMcvoWithin;

struct Fixture {
  fs::path generic;   // the rendered sequence, generic layout
  fs::path bag;       // the same sequence as a ROS bag
  fs::path camchain;  // Kalibr calibration of its rig
};

const Fixture& Sequence() {
  static const Fixture fixture = [] {
    const fs::path dir = mcvo::test::ProcessScratch("mcvo_rosbag_cli_test");
    Fixture f{dir / "generic", dir / "stereo.bag", dir / "camchain.yaml"};
    const Result synth = RunMcvoWithin(120, "synth --preset stereo --frames 10 --image-scale 0.25 --samples 1 "
                                            "--seed 3 --out " +
                                                Quote(f.generic.string()));
    EXPECT_EQ(synth.exit_code, 0) << synth.output;
    mcvo::testing::BagSpec spec;
    spec.encoding = {{"image_00", "mono8"}, {"image_01", "png"}};
    mcvo::testing::WriteBagFromGeneric(f.generic, f.bag, spec);
    std::ofstream(f.camchain) << mcvo::testing::CamchainOfRig(mcvo::ReadRig(f.generic / "rig.json"), spec);
    return f;
  }();
  return fixture;
}

nlohmann::json ReadJson(const fs::path& path) { return nlohmann::json::parse(mcvo::ReadFileToString(path)); }

fs::path Out(const std::string& name) { return Sequence().bag.parent_path() / name; }

TEST(RosbagCli, RunOnTheBagWithACamchainPosesEveryFrame) {
  const Fixture& f = Sequence();
  const fs::path out = Out("run_camchain");
  const Result r = RunMcvoWithin(120, "run --dataset " + Quote(f.bag.string()) + " --calib " +
                                          Quote(f.camchain.string()) +
                                          " --gt-topic /groundtruth/pose --threads 2 --out " + Quote(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json run = ReadJson(out / "run.json");
  EXPECT_EQ(run["dataset"]["format"], "rosbag");
  EXPECT_EQ(run["result"]["posed_frames"], 10);
  const mcvo::Trajectory trajectory =
      mcvo::ReadTrajectory(out / "trajectory.tum", mcvo::TrajectoryFormat::kTum);
  EXPECT_EQ(trajectory.poses.size(), 10u);
  // Evaluated against the bag's ground-truth topic.
  ASSERT_TRUE(run["result"].contains("ate_percent_of_path")) << run["result"].dump();
  EXPECT_LT(run["result"]["ate_percent_of_path"].get<double>(), 2.0);
}

TEST(RosbagCli, RunWithTheRigJsonGivesTheGenericTrajectoryByteForByte) {
  const Fixture& f = Sequence();
  const fs::path bag_out = Out("run_rig");
  const Result r = RunMcvoWithin(120, "run --dataset " + Quote(f.bag.string()) + " --calib " +
                                          Quote((f.generic / "rig.json").string()) + " --threads 2 --out " +
                                          Quote(bag_out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path generic_out = Out("run_generic");
  const Result g = RunMcvoWithin(
      120, "run --dataset " + Quote(f.generic.string()) + " --threads 2 --out " + Quote(generic_out.string()));
  ASSERT_EQ(g.exit_code, 0) << g.output;
  EXPECT_EQ(ReadJson(bag_out / "run.json")["result"]["posed_frames"], 10);
  const std::string trajectory = mcvo::ReadFileToString(bag_out / "trajectory.tum");
  EXPECT_FALSE(trajectory.empty());
  EXPECT_EQ(trajectory, mcvo::ReadFileToString(generic_out / "trajectory.tum"));
  // run.json hashes the images read from the bag (their messages).
  const nlohmann::json inputs = ReadJson(bag_out / "run.json")["inputs"];
  EXPECT_TRUE(inputs.dump().find("images_sha256") != std::string::npos) << inputs.dump();
}

TEST(RosbagCli, InfoDescribesTheBag) {
  const Fixture& f = Sequence();
  const Result r = RunMcvoWithin(
      60, "info --dataset " + Quote(f.bag.string()) + " --calib " + Quote(f.camchain.string()) + " --decode");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const std::string expected :
       {"  format     rosbag", "  name       stereo", "  frames     10", "interval   median 0.1000 s (10.00 Hz)",
        "rosbag: topic /image_00/image_raw: sensor_msgs/Image, 10 messages, 10.00 Hz",
        "rosbag: topic /image_01/image_raw: sensor_msgs/CompressedImage, 10 messages",
        "rosbag: camera cam0 <- /image_00/image_raw: 10 images (mono8 10)", "camera 0: cam0", "camera 1: cam1",
        "decode: 10 frames, 20 images"}) {
    EXPECT_NE(r.output.find(expected), std::string::npos) << expected << "\n" << r.output;
  }
}

TEST(RosbagCli, BadTopicAndMissingCalibration) {
  const Fixture& f = Sequence();
  Result r = RunMcvoWithin(60, "info --dataset " + Quote(f.bag.string()) + " --calib " +
                                   Quote(f.camchain.string()) + " --topics cam1=/nope");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find(f.bag.string() + ": topic /nope (camera cam1) has no message in the bag"),
            std::string::npos)
      << r.output;
  r = RunMcvoWithin(60, "info --dataset " + Quote(f.bag.string()));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("calib: a ROS bag needs its calibration"), std::string::npos) << r.output;
}

}  // namespace
