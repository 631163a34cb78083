#include "mcvo/synth/synthesize.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "mcvo/io/frame_table.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/synth/scene.h"
#include "mcvo/synth/trajectory.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"

namespace mcvo::synth {
namespace {

namespace fs = std::filesystem;

// Each test writes below its own parent folder, so a test that checks what
// is left beside its output never sees another test's staging folder
// (ctest runs tests in parallel).
fs::path TempDir(const std::string& name) {
  const fs::path parent = fs::path(::testing::TempDir()) / "mcvo_synthesize_test" / name;
  fs::remove_all(parent);
  fs::create_directories(parent);
  return parent / "out";
}
// A small, fast sequence of the full 4-camera KITTI-360 rig.
SynthOptions SmallKitti360(int threads) {
  SynthOptions options;
  options.preset = "kitti360";
  options.frames = 3;
  options.image_scale = 0.1;
  options.seed = 5;
  options.render.samples_per_axis = 1;
  options.render.threads = threads;
  options.render.seed = 5;
  options.render.effects.noise_sigma = 2.0;
  return options;
}

std::map<std::string, std::string> ReadTree(const fs::path& root) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (entry.is_regular_file())
      files[fs::relative(entry.path(), root).string()] = ReadFileToString(entry.path());
  }
  return files;
}

TEST(Synthesize, WritesTheDocumentedLayoutAndReadsBack) {
  const fs::path out = TempDir("layout");
  const SynthSummary summary = Synthesize(SmallKitti360(2), out);
  EXPECT_EQ(summary.frames, 3);
  EXPECT_EQ(summary.cameras, 4);

  const Rig rig = ReadRig(out / "rig.json");
  const Rig preset = PresetRig("kitti360");
  ASSERT_EQ(rig.NumCameras(), 4);
  for (int c = 0; c < 4; ++c) {
    const Camera expected = ScaledCamera(preset.cameras[c], 0.1);
    EXPECT_EQ(rig.cameras[c].name, expected.name);
    EXPECT_EQ(rig.cameras[c].width, expected.width);
    EXPECT_EQ(rig.cameras[c].height, expected.height);
    for (size_t i = 0; i < expected.params.size(); ++i)
      EXPECT_DOUBLE_EQ(rig.cameras[c].params[i], expected.params[i]);
    EXPECT_LT((rig.cameras[c].cam_from_rig.translation - expected.cam_from_rig.translation).norm(), 1e-12);
    EXPECT_LT(rig.cameras[c].cam_from_rig.rotation.angularDistance(expected.cam_from_rig.rotation), 1e-12);
    // Fisheyes (MEI) get the valid-pixel mask, the rectified pinholes none.
    EXPECT_EQ(rig.cameras[c].mask_path.empty(), expected.model == CameraModelId::kPinhole) << expected.name;
  }

  const FrameTable table = ReadFrameTable(out / "frames.csv");
  ASSERT_EQ(table.rows.size(), 3u);
  EXPECT_EQ(table.camera_names, (std::vector<std::string>{"image_00", "image_01", "image_02", "image_03"}));
  EXPECT_EQ(table.rows[1].t_ns - table.rows[0].t_ns, 100000000);  // 10 Hz
  for (const FrameTableRow& row : table.rows) {
    for (int c = 0; c < 4; ++c) {
      const cv::Mat image = cv::imread((out / row.image_paths[c]).string(), cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(image.empty()) << row.image_paths[c];
      EXPECT_EQ(image.type(), CV_8UC1);
      EXPECT_EQ(image.cols, rig.cameras[c].width);
      EXPECT_EQ(image.rows, rig.cameras[c].height);
      EXPECT_GT(cv::mean(image)[0], 5.0) << "image is black: " << row.image_paths[c];
    }
  }

  const Trajectory gt = ReadTrajectory(out / "groundtruth.tum", TrajectoryFormat::kTum);
  ASSERT_EQ(gt.poses.size(), 3u);
  for (size_t i = 0; i < 3; ++i) EXPECT_EQ(gt.poses[i].t_ns, table.rows[i].t_ns);
  // Vehicle speed at 10 Hz: the closed urban route starts at a corner exit
  // (about 5 m/s) and speeds up towards 10 m/s.
  const double step =
      (gt.poses[1].world_from_body.translation - gt.poses[0].world_from_body.translation).norm();
  EXPECT_GT(step, 0.3);
  EXPECT_LT(step, 1.5);

  EXPECT_GT(ReadFileToString(out / "structure" / "scene_quads.csv").size(), 1000u);
  EXPECT_NE(ReadFileToString(out / "meta.json").find("\"preset\": \"kitti360\""), std::string::npos);
  // No staging folder is left beside the output.
  for (const auto& entry : fs::directory_iterator(out.parent_path())) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
  }
}

TEST(Synthesize, SameArgumentsGiveByteIdenticalFilesAtAnyThreadCount) {
  const fs::path one = TempDir("threads1");
  const fs::path two = TempDir("threads2");
  Synthesize(SmallKitti360(1), one);
  Synthesize(SmallKitti360(2), two);
  const auto a = ReadTree(one);
  const auto b = ReadTree(two);
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [name, content] : a) {
    ASSERT_TRUE(b.count(name)) << name;
    EXPECT_TRUE(content == b.at(name)) << name << " differs between 1 and 2 threads";
  }
  // A different seed gives different images.
  const fs::path other = TempDir("seed6");
  SynthOptions options = SmallKitti360(2);
  options.seed = 6;
  options.render.seed = 6;
  Synthesize(options, other);
  EXPECT_NE(ReadFileToString(other / "images/image_00/000001.png"), a.at("images/image_00/000001.png"));
}

// meta.json names the realism effects (sensor noise, lens blur, tone curve)
// when they are set, and only then: without them it is as before they existed.
TEST(Synthesize, MetaRecordsTheRealismEffectsOnlyWhenSet) {
  const fs::path plain = TempDir("meta_plain");
  SynthOptions options = SmallKitti360(2);
  options.frames = 1;
  Synthesize(options, plain);
  const std::string meta = ReadFileToString(plain / "meta.json");
  for (const char* key : {"sensor_noise", "lens_blur_sigma_px", "tone"})
    EXPECT_EQ(meta.find(std::string("\"") + key + "\""), std::string::npos) << key;
  const fs::path real = TempDir("meta_real");
  options.render.effects.noise_sigma = 0.0;
  options.render.effects.sensor_noise_a = 0.033;
  options.render.effects.lens_blur_sigma_px = 0.9;
  options.render.effects.tone_gain = 1.5;
  options.render.effects.tone_gamma = 1.4;
  Synthesize(options, real);
  const std::string with = ReadFileToString(real / "meta.json");
  EXPECT_NE(with.find("\"sensor_noise\": {\n      \"a\": 0.033,\n      \"b\": 0.0"), std::string::npos)
      << with;
  EXPECT_NE(with.find("\"lens_blur_sigma_px\": 0.9"), std::string::npos) << with;
  EXPECT_NE(with.find("\"gamma\": 1.4"), std::string::npos) << with;
  EXPECT_NE(ReadFileToString(real / "images/image_00/000000.png"),
            ReadFileToString(plain / "images/image_00/000000.png"));
}

TEST(Synthesize, RefusesANonEmptyOutputFolderUnlessForced) {
  const fs::path out = TempDir("nonempty");
  fs::create_directories(out);
  WriteFileAtomic(out / "precious.txt", "keep me");
  try {
    Synthesize(SmallKitti360(2), out);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(out.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--force"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadFileToString(out / "precious.txt"), "keep me");
  // --force replaces only a folder mcvo wrote (util/output_folder.h): not this one.
  SynthOptions forced = SmallKitti360(2);
  forced.force = true;
  forced.frames = 1;
  EXPECT_THROW(Synthesize(forced, out), InputError);
  EXPECT_EQ(ReadFileToString(out / "precious.txt"), "keep me");
  // An earlier render is replaced whole.
  const fs::path render = TempDir("rerender");
  Synthesize(forced, render);
  WriteFileAtomic(render / "images" / "stray.txt", "from the first render");
  Synthesize(forced, render);
  EXPECT_FALSE(fs::exists(render / "images" / "stray.txt"));
  EXPECT_TRUE(fs::exists(render / "frames.csv"));
}

TEST(Synthesize, BadOptionsFailBeforeWritingAnything) {
  const fs::path out = TempDir("bad");
  SynthOptions unknown = SmallKitti360(1);
  unknown.preset = "kitti999";
  EXPECT_THROW(Synthesize(unknown, out), InputError);
  SynthOptions both = SmallKitti360(1);
  both.rig_path = "rig.json";
  EXPECT_THROW(Synthesize(both, out), UsageError);
  SynthOptions no_scene = SmallKitti360(1);
  no_scene.preset.clear();
  no_scene.rig_path = "rig.json";
  EXPECT_THROW(Synthesize(no_scene, out), UsageError);
  SynthOptions bad_scale = SmallKitti360(1);
  bad_scale.image_scale = 0.0;
  EXPECT_THROW(Synthesize(bad_scale, out), UsageError);
  SynthOptions bad_blackout = SmallKitti360(1);
  bad_blackout.render.effects.blackout_camera = 9;
  bad_blackout.render.effects.blackout_num_frames = 1;
  EXPECT_THROW(Synthesize(bad_blackout, out), UsageError);
  EXPECT_FALSE(fs::exists(out));
}

// The whole indoor route of `preset` at 1 frame/s and tiny images: the
// ground truth of every camera, and meta.json's rig height.
struct IndoorRoute {
  Rig rig;
  Trajectory ground_truth;
  double rig_height_m = 0.0;
};
constexpr uint64_t kIndoorSeed = 3;  // irregular5 fits its whole route (not every seed: see below)
IndoorRoute RenderIndoorRoute(const std::string& preset, const std::string& name) {
  SynthOptions options;
  options.preset = preset;
  options.scene = "indoor";
  options.frame_rate_hz = 1.0;
  options.image_scale = 0.05;
  options.seed = kIndoorSeed;
  options.render.samples_per_axis = 1;
  const fs::path out = TempDir(name);
  Synthesize(options, out);
  IndoorRoute route{ReadRig(out / "rig.json"),
                    ReadTrajectory(out / "groundtruth.tum", TrajectoryFormat::kTum), 0.0};
  const std::string meta = ReadFileToString(out / "meta.json");
  const size_t at = meta.find("\"rig_height_m\": ");
  EXPECT_NE(at, std::string::npos);
  if (at != std::string::npos) route.rig_height_m = std::stod(meta.substr(at + 16));
  return route;
}

// irregular5 is a car-roof rig (cameras 1.2 to 1.9 m above its origin):
// carried at the indoor scene's 1.4 m it put cameras in and above the 2.8 m
// ceiling. synth lowers it until every camera stays kCeilingClearanceM
// under the ceiling all along the route; multicam6 (cameras at its origin)
// fits and is not moved.
TEST(Synthesize, IndoorRigsAreFittedUnderTheCeiling) {
  const IndoorRoute tall = RenderIndoorRoute("irregular5", "fit_irregular5");
  ASSERT_GT(tall.ground_truth.poses.size(), 50u);
  double highest = -1e9, lowest = 1e9;
  for (const StampedPose& pose : tall.ground_truth.poses) {
    for (const Camera& camera : tall.rig.cameras) {
      const double z = (pose.world_from_body * camera.cam_from_rig.Inverse()).translation.z();
      highest = std::max(highest, z);
      lowest = std::min(lowest, z);
    }
  }
  EXPECT_LE(highest, 2.8 - kCeilingClearanceM + 1e-9);
  EXPECT_GT(highest,
            2.8 - kCeilingClearanceM - 0.05);  // lowered no more than needed (route sampled at 20 Hz)
  EXPECT_GE(lowest, kFloorClearanceM);
  EXPECT_LT(tall.rig_height_m, 1.4 - 0.5);

  const IndoorRoute fits = RenderIndoorRoute("multicam6", "fit_multicam6");
  EXPECT_EQ(fits.rig_height_m, 1.4);
}

// The stereo preset with camera 1's centre at camera 0's minus
// `offset_in_rig` (rig axes: x forward, y right, z down), rendered indoors:
// must be refused with a usage error containing every one of `messages`,
// leaving nothing behind.
void ExpectStereoVariantRefusedIndoors(const std::string& name, const Eigen::Vector3d& offset_in_rig,
                                       int frames, const std::vector<std::string>& messages) {
  Rig rig = PresetRig("stereo");
  Camera& camera = rig.cameras[1];
  camera.cam_from_rig.translation =
      rig.cameras[0].cam_from_rig.translation + camera.cam_from_rig.RotationMatrix() * offset_in_rig;
  const fs::path out = TempDir(name);
  const fs::path rig_path = out.parent_path() / (name + "_rig.json");
  WriteRig(rig_path, rig);
  SynthOptions options;
  options.rig_path = rig_path;
  options.scene = "indoor";
  options.frames = frames;
  options.frame_rate_hz = 1.0;
  options.image_scale = 0.05;
  try {
    Synthesize(options, out);
    ADD_FAILURE() << "no error";
  } catch (const UsageError& e) {
    for (const std::string& message : messages) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
  EXPECT_FALSE(fs::exists(out));
}

// A rig taller than the room leaves cannot be fitted: a usage error, and
// nothing is written. Camera 1's centre 3 m above camera 0's.
TEST(Synthesize, ARigTallerThanTheRoomIsRefused) {
  ExpectStereoVariantRefusedIndoors("tall", Eigen::Vector3d(0, 0, 3.0), 2,
                                    {"more than its 2.80 m ceiling leaves"});
}

// Whether a point is inside the indoor scene's rooms: the ceiling, and
// nothing else, is straight above it (outside the building, or inside the
// office block the corridors ring, there is no ceiling).
bool UnderTheCeiling(const Scene& scene, const Eigen::Vector3d& point) {
  const std::optional<Hit> up = scene.Intersect(point, Eigen::Vector3d::UnitZ(), 0);
  return up.has_value() && std::abs(up->point.z() - 2.8) < 1e-6;
}

// The KITTI-360 pair sits 1.6 m ahead of its rig's origin and 0.6 m apart.
// Carried through the corridors by its origin, a camera swung out through
// the wall at the corners and rendered the outside of the building. synth
// carries a rig by the middle of its cameras: every camera stays in the
// rooms on the whole route.
TEST(Synthesize, IndoorRigsAreCarriedByTheMiddleOfTheirCameras) {
  const SceneWithRoute world = BuildScene("indoor", kIndoorSeed);
  const Rig stereo = PresetRig("stereo");
  {  // the route followed by the origin, as before
    const SmoothTrajectory by_origin(RouteTrajectorySpec(world, kIndoorSeed));
    int outside = 0;
    for (int64_t t_ns = 0; t_ns <= by_origin.DurationNs(); t_ns += 100'000'000) {
      for (const Camera& camera : stereo.cameras) {
        outside += UnderTheCeiling(world.scene,
                                   (by_origin.WorldFromRig(t_ns) * camera.cam_from_rig.Inverse()).translation)
                       ? 0
                       : 1;
      }
    }
    EXPECT_GT(outside, 0);
  }
  const IndoorRoute route = RenderIndoorRoute("stereo", "carried_stereo");
  ASSERT_GT(route.ground_truth.poses.size(), 50u);
  for (const StampedPose& pose : route.ground_truth.poses) {
    Eigen::Vector3d middle = Eigen::Vector3d::Zero();
    for (const Camera& camera : route.rig.cameras) {
      const Eigen::Vector3d centre = (pose.world_from_body * camera.cam_from_rig.Inverse()).translation;
      EXPECT_TRUE(UnderTheCeiling(world.scene, centre)) << camera.name << " at frame " << pose.frame_index;
      middle += centre / static_cast<double>(route.rig.NumCameras());
    }
    // The middle of the pair keeps to the corridor (2.4 m wide; the route's
    // sway is a few cm): at least 0.9 m from every wall around it.
    for (int k = 0; k < 8; ++k) {
      const double a = k * M_PI / 4.0;
      const std::optional<Hit> wall =
          world.scene.Intersect(middle, Eigen::Vector3d(std::cos(a), std::sin(a), 0.0), 0);
      ASSERT_TRUE(wall.has_value());
      EXPECT_GT(wall->distance, 0.9) << "frame " << pose.frame_index << " direction " << k;
    }
  }
}

// A rig longer than the 2.4 m corridors leave at their corners (camera 1
// 5 m behind camera 0) is refused before anything is rendered, on the
// whole route: the camera is named (both are 2.5 m from the middle; the
// first one found), nothing is written.
TEST(Synthesize, ARigLongerThanTheCorridorsAllowIsRefused) {
  ExpectStereoVariantRefusedIndoors(
      "wide", Eigen::Vector3d(5.0, 0, 0), 0,
      {"camera image_0", "would be behind (or within 0.05 m of) a wall of scene 'indoor'"});
}

TEST(Synthesize, EveryPresetRigLoads) {
  for (const SynthPreset& preset : SynthPresets()) {
    const Rig rig = PresetRig(preset.name);
    EXPECT_GE(rig.NumCameras(), preset.name == "mono" ? 1 : 2) << preset.name;
  }
  EXPECT_EQ(PresetRig("mono").NumCameras(), 1);
  EXPECT_EQ(PresetRig("multicam6").NumCameras(), 6);
  EXPECT_EQ(PresetRig("irregular5").NumCameras(), 5);
  EXPECT_EQ(PresetRig("kitti360-3cam").NumCameras(), 3);
  EXPECT_EQ(PresetRig("stereo").NumCameras(), 2);
}

}  // namespace
}  // namespace mcvo::synth
