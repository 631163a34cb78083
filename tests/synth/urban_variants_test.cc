// The urban variants for loop-closure tests: urban_block (a short closed lap,
// driven again when the sequence is longer than a lap) and urban_repeated
// (look-alike facades along a route that never comes back), and a guard that
// urban itself still renders exactly as before the variants existed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mcvo/io/frame_table.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/synth/scene.h"
#include "mcvo/synth/synthesize.h"
#include "mcvo/synth/trajectory.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/sha256.h"

namespace mcvo::synth {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;

// Each test writes below its own folder (ctest runs the tests in parallel).
fs::path TempDir(const std::string& name) {
  const fs::path parent = fs::path(::testing::TempDir()) / "mcvo_urban_variants_test" / name;
  fs::remove_all(parent);
  fs::create_directories(parent);
  return parent / "out";
}

// The trajectory `mcvo synth` drives through the scene.
SmoothTrajectory TrajectoryOf(const SceneWithRoute& scene, uint64_t seed) {
  return SmoothTrajectory(RouteTrajectorySpec(scene, seed));
}

// Rig positions at ground level every step_ns, with their arc length along the path.
struct PathSample {
  Vector3d position;
  double arc_length_m;
};
std::vector<PathSample> SamplePath(const SmoothTrajectory& trajectory, int64_t step_ns) {
  std::vector<PathSample> samples;
  for (int64_t t = 0; t <= trajectory.DurationNs(); t += step_ns) {
    Vector3d p = trajectory.WorldFromRig(t).translation;
    p.z() = 0.0;
    const double s =
        samples.empty() ? 0.0 : samples.back().arc_length_m + (p - samples.back().position).norm();
    samples.push_back({p, s});
  }
  return samples;
}

bool IsBuildingFacade(Material m) { return m == Material::kFacadeBrick || m == Material::kFacadePlaster; }
bool IsFacade(Material m) {
  return IsBuildingFacade(m) || m == Material::kShopFront || m == Material::kPoster;
}

std::map<Material, int> QuadsPerMaterial(const SceneWithRoute& s) {
  std::map<Material, int> count;
  for (const Quad& q : s.scene.quads()) ++count[q.material];
  return count;
}

// Fractions of the route (sampled every 2 m of the rig path) with a facade
// within 25 m on the left and on the right.
std::pair<double, double> FacadeFractions(const SceneWithRoute& s, const SmoothTrajectory& trajectory) {
  const std::vector<PathSample> path = SamplePath(trajectory, 200'000'000);
  int left = 0, right = 0;
  for (size_t i = 0; i + 1 < path.size(); ++i) {
    const Vector3d forward = (path[i + 1].position - path[i].position).normalized();
    const Vector3d to_left(-forward.y(), forward.x(), 0.0);
    for (int side : {-1, 1}) {
      bool facade = false;
      for (double z : {1.5, 3.0, 5.0}) {
        const auto hit =
            s.scene.Intersect(path[i].position + Vector3d(0, 0, z), side * to_left, 0, 1e-4, 25.0);
        facade = facade || (hit && IsFacade(hit->quad->material));
      }
      (side > 0 ? left : right) += facade;
    }
  }
  const double n = static_cast<double>(path.size() - 1);
  return {left / n, right / n};
}

// Nearest horizontal hit around p (24 directions, several heights, three instants).
double NearestAround(const SceneWithRoute& s, const Vector3d& p) {
  double nearest = 1e9;
  for (double z : {0.3, 0.7, 1.0, s.rig_height_m, 2.0}) {
    for (int k = 0; k < 24; ++k) {
      const Vector3d direction(std::cos(k * kPi / 12), std::sin(k * kPi / 12), 0.0);
      for (int64_t t_ns : {int64_t{0}, int64_t{5'000'000'000}, int64_t{13'000'000'000}}) {
        const auto hit = s.scene.Intersect(p + Vector3d(0, 0, z), direction, t_ns);
        if (hit) nearest = std::min(nearest, hit->distance);
      }
    }
  }
  return nearest;
}

double PositionError(const Rigid3d& a, const Rigid3d& b) { return (a.translation - b.translation).norm(); }
double AngleError(const Rigid3d& a, const Rigid3d& b) { return a.rotation.angularDistance(b.rotation); }

SynthOptions TinyStereo(const std::string& scene, uint64_t seed, double image_scale) {
  SynthOptions options;
  options.preset = "stereo";
  options.scene = scene;
  options.seed = seed;
  options.image_scale = image_scale;
  options.render.samples_per_axis = 1;
  options.render.seed = seed;
  options.render.threads = 1;  // ctest runs the tests in parallel on few cores
  return options;
}

// ---------------------------------------------------------------- urban_block

TEST(UrbanBlockTest, IsAShortClosedLapAroundOneBlock) {
  for (uint64_t seed : {0, 1, 2, 3, 4}) {
    const SceneWithRoute s = BuildScene("urban_block", seed);
    EXPECT_EQ(s.name, "urban_block");
    EXPECT_TRUE(s.route_closed);
    EXPECT_EQ(s.style, MotionStyle::kVehicle);
    const RouteStats stats = ComputeRouteStats(s);
    EXPECT_EQ(stats.left_turns, 4) << "seed " << seed;
    EXPECT_EQ(stats.right_turns, 0) << "seed " << seed;
    // Documented: the rig path about 290-360 m (it cuts the four corners).
    EXPECT_GE(stats.length_m, 300.0) << "seed " << seed;
    EXPECT_LE(stats.length_m, 380.0) << "seed " << seed;
    const SmoothTrajectory trajectory = TrajectoryOf(s, seed);
    EXPECT_GE(trajectory.LengthM(), 285.0) << "seed " << seed;
    EXPECT_LE(trajectory.LengthM(), 365.0) << "seed " << seed;
    // One block: a counter-clockwise rectangle whose area is that of a
    // square of a quarter of the perimeter (within 15%).
    double twice_area = 0.0;
    for (size_t i = 0; i < s.waypoints.size(); ++i) {
      const Vector3d& a = s.waypoints[i];
      const Vector3d& b = s.waypoints[(i + 1) % s.waypoints.size()];
      twice_area += a.x() * b.y() - b.x() * a.y();
    }
    const double quarter = stats.length_m / 4.0;
    EXPECT_NEAR(0.5 * twice_area / (quarter * quarter), 1.0, 0.15) << "seed " << seed;
    // Closed: the end of the lap meets its start (position and orientation).
    const Rigid3d start = trajectory.WorldFromRig(0);
    const Rigid3d end = trajectory.WorldFromRig(trajectory.DurationNs() - 1);
    EXPECT_LT(PositionError(start, end), 1e-6) << "seed " << seed;
    EXPECT_LT(AngleError(start, end), 1e-6) << "seed " << seed;
    std::printf("[measured] urban_block seed %d: route %.1f m, rig path %.1f m, lap %.2f s\n",
                static_cast<int>(seed), stats.length_m, trajectory.LengthM(), trajectory.DurationNs() * 1e-9);
  }
}

// The same generator as urban: facades on both sides, shop fronts, posters,
// trees, parked and moving cars.
TEST(UrbanBlockTest, LooksLikeUrban) {
  for (uint64_t seed : {1, 2, 3}) {
    const SceneWithRoute s = BuildScene("urban_block", seed);
    const std::map<Material, int> count = QuadsPerMaterial(s);
    for (Material m : {Material::kFacadeBrick, Material::kFacadePlaster, Material::kShopFront,
                       Material::kPoster, Material::kFoliage, Material::kRoadMarking, Material::kMetal}) {
      EXPECT_GT(count.count(m) ? count.at(m) : 0, 0) << MaterialName(m) << " seed " << seed;
    }
    EXPECT_GE(s.scene.moving_objects().size(), 1u) << "seed " << seed;
    const auto [left, right] = FacadeFractions(s, TrajectoryOf(s, seed));
    EXPECT_GE(left, 0.6) << "seed " << seed;
    EXPECT_GE(right, 0.6) << "seed " << seed;
  }
}

// 1.3 laps at 10 Hz: past the lap the rig drives the loop again; the ground
// truth at t + lap is the ground truth at t, and every second-lap frame has a
// first-lap frame within half a frame step.
TEST(UrbanBlockTest, ASequenceLongerThanALapDrivesTheLoopAgain) {
  const uint64_t seed = 3;
  const fs::path out = TempDir("laps");
  SynthOptions options = TinyStereo("urban_block", seed, 0.05);
  options.laps = 1.3;
  const SynthSummary summary = Synthesize(options, out);

  const SmoothTrajectory trajectory = TrajectoryOf(BuildScene("urban_block", seed), seed);
  const int64_t lap_ns = trajectory.DurationNs();
  const int64_t period_ns = 100'000'000;
  EXPECT_TRUE(summary.route_closed);
  EXPECT_EQ(summary.frames, static_cast<int>(std::floor(1.3 * lap_ns / static_cast<double>(period_ns))));
  EXPECT_NEAR(summary.laps, 1.3, 0.01);
  EXPECT_NEAR(summary.lap_seconds, lap_ns * 1e-9, 1e-9);

  const Trajectory gt = ReadTrajectory(out / "groundtruth.tum", TrajectoryFormat::kTum);
  ASSERT_EQ(static_cast<int>(gt.poses.size()), summary.frames);
  EXPECT_EQ(ReadFrameTable(out / "frames.csv").rows.size(), gt.poses.size());
  std::vector<const StampedPose*> first_lap;
  int second_lap = 0;
  double worst_revisit_m = 0.0, worst_revisit_rad = 0.0;
  for (size_t i = 0; i < gt.poses.size(); ++i) {
    const StampedPose& pose = gt.poses[i];
    const int64_t t = pose.t_ns - options.first_t_ns;
    ASSERT_EQ(t, static_cast<int64_t>(i) * period_ns);
    EXPECT_LT(PositionError(pose.world_from_body, trajectory.WorldFromRig(t)), 1e-12) << i;
    if (i > 0) {  // never stands still
      EXPECT_GT(PositionError(pose.world_from_body, gt.poses[i - 1].world_from_body), 0.2) << i;
    }
    if (t < lap_ns) {
      first_lap.push_back(&pose);
      continue;
    }
    ++second_lap;
    const Rigid3d lap_before = trajectory.WorldFromRig(t - lap_ns);
    EXPECT_LT(PositionError(pose.world_from_body, lap_before), 1e-9) << i;
    EXPECT_LT(AngleError(pose.world_from_body, lap_before), 1e-9) << i;
    double nearest = 1e9;
    const StampedPose* match = nullptr;
    for (const StampedPose* earlier : first_lap) {
      const double d = PositionError(pose.world_from_body, earlier->world_from_body);
      if (d < nearest) nearest = d, match = earlier;
    }
    ASSERT_NE(match, nullptr);
    worst_revisit_m = std::max(worst_revisit_m, nearest);
    worst_revisit_rad = std::max(worst_revisit_rad, AngleError(pose.world_from_body, match->world_from_body));
  }
  EXPECT_GE(second_lap, static_cast<int>(0.25 * lap_ns / period_ns));
  // Half a frame step at <= 10 m/s; the heading changes by at most 28 deg/s.
  EXPECT_LE(worst_revisit_m, 0.55);
  EXPECT_LE(worst_revisit_rad, 2.0 * kPi / 180.0);
  std::printf(
      "[measured] urban_block 1.3 laps: %d frames, lap %.3f s, %d second-lap frames, revisits within "
      "%.3f m and %.3f deg\n",
      summary.frames, lap_ns * 1e-9, second_lap, worst_revisit_m, worst_revisit_rad * 180.0 / kPi);

  // Between frames too: t, t + lap and t + 2 laps give the same pose.
  for (int64_t t = 0; t < lap_ns; t += 370'000'001) {
    const Rigid3d a = trajectory.WorldFromRig(t);
    for (int laps = 1; laps <= 2; ++laps) {
      const Rigid3d b = trajectory.WorldFromRig(t + laps * lap_ns);
      EXPECT_LT(PositionError(a, b), 1e-9) << t;
      EXPECT_LT(AngleError(a, b), 1e-9) << t;
    }
  }
}

TEST(UrbanBlockTest, LapsOptionIsChecked) {
  const fs::path out = TempDir("laps_checks");
  SynthOptions both = TinyStereo("urban_block", 0, 0.05);
  both.laps = 1.3;
  both.frames = 10;
  EXPECT_THROW(both.Check(), UsageError);
  SynthOptions negative = TinyStereo("urban_block", 0, 0.05);
  negative.laps = -1.0;
  EXPECT_THROW(negative.Check(), UsageError);
  // An open route is driven once at most; nothing is written.
  SynthOptions open = TinyStereo("urban_repeated", 0, 0.05);
  open.laps = 1.5;
  try {
    Synthesize(open, out);
    FAIL() << "expected UsageError";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("open"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(out));
  EXPECT_TRUE(fs::is_empty(out.parent_path()));
}

// ------------------------------------------------------------- urban_repeated

// The closest two rig positions come in space among pairs more than
// `min_arc_m` apart along the path (how near the route comes back).
double ClosestReturnM(const std::vector<PathSample>& path, double min_arc_m) {
  double closest = 1e9;
  for (size_t i = 0; i < path.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (path[i].arc_length_m - path[j].arc_length_m <= min_arc_m) break;
      closest = std::min(closest, (path[i].position - path[j].position).norm());
    }
  }
  return closest;
}

// The (material, texture seed) pairs of the building facades.
std::set<std::pair<Material, uint32_t>> FacadeTextures(const SceneWithRoute& s) {
  std::set<std::pair<Material, uint32_t>> textures;
  for (const Quad& q : s.scene.quads()) {
    if (IsBuildingFacade(q.material)) textures.insert({q.material, q.texture_seed});
  }
  return textures;
}

TEST(UrbanRepeatedTest, OpenRouteNeverComesBackNearAnEarlierPlace) {
  for (uint64_t seed : {0, 1, 2, 3, 4}) {
    const SceneWithRoute s = BuildScene("urban_repeated", seed);
    EXPECT_EQ(s.name, "urban_repeated");
    EXPECT_FALSE(s.route_closed);
    EXPECT_EQ(s.style, MotionStyle::kVehicle);
    const RouteStats stats = ComputeRouteStats(s);
    EXPECT_EQ(stats.left_turns, 2) << "seed " << seed;
    EXPECT_EQ(stats.right_turns, 2) << "seed " << seed;
    // Documented: 5 blocks of 97-101 m, the rig path about 470-490 m.
    EXPECT_GE(stats.length_m, 480.0) << "seed " << seed;
    EXPECT_LE(stats.length_m, 510.0) << "seed " << seed;
    const SmoothTrajectory trajectory = TrajectoryOf(s, seed);
    EXPECT_GE(trajectory.LengthM(), 462.0) << "seed " << seed;
    EXPECT_LE(trajectory.LengthM(), 492.0) << "seed " << seed;
    // Every pair of rig positions more than 100 m apart along the path is
    // more than 30 m apart in space.
    const std::vector<PathSample> path = SamplePath(trajectory, 50'000'000);
    const double closest = ClosestReturnM(path, 100.0);
    EXPECT_GT(path.back().arc_length_m, 400.0);
    EXPECT_GE(closest, 30.0) << "seed " << seed;
    std::printf("[measured] urban_repeated seed %d: route %.1f m, rig path %.1f m, closest return %.1f m\n",
                static_cast<int>(seed), stats.length_m, trajectory.LengthM(), closest);
    // Past its end the rig stands still there.
    const Rigid3d end = trajectory.WorldFromRig(trajectory.DurationNs());
    EXPECT_EQ(PositionError(end, trajectory.WorldFromRig(trajectory.DurationNs() + 5'000'000'000)), 0.0);
  }
}

// The small versions: the same routes around smaller blocks.
TEST(UrbanSmallVariantsTest, ShorterRoutesOfTheSameShape) {
  for (uint64_t seed : {1, 2, 3}) {
    const SceneWithRoute block = BuildScene("urban_small_block", seed);
    EXPECT_TRUE(block.route_closed);
    const RouteStats block_stats = ComputeRouteStats(block);
    EXPECT_EQ(block_stats.left_turns, 4) << "seed " << seed;
    EXPECT_EQ(block_stats.right_turns, 0) << "seed " << seed;
    const double lap = TrajectoryOf(block, seed).LengthM();
    EXPECT_GE(lap, 150.0) << "seed " << seed;  // documented: about 190 m
    EXPECT_LE(lap, 215.0) << "seed " << seed;

    const SceneWithRoute repeated = BuildScene("urban_small_repeated", seed);
    EXPECT_FALSE(repeated.route_closed);
    const RouteStats stats = ComputeRouteStats(repeated);
    EXPECT_EQ(stats.left_turns, 2) << "seed " << seed;
    EXPECT_EQ(stats.right_turns, 2) << "seed " << seed;
    const SmoothTrajectory trajectory = TrajectoryOf(repeated, seed);
    EXPECT_GE(trajectory.LengthM(), 230.0) << "seed " << seed;  // documented: about 250 m
    EXPECT_LE(trajectory.LengthM(), 275.0) << "seed " << seed;
    // Never back near an earlier place: positions more than 60 m apart
    // along the path are more than 20 m apart.
    const double closest = ClosestReturnM(SamplePath(trajectory, 50'000'000), 60.0);
    EXPECT_GE(closest, 20.0) << "seed " << seed;
    EXPECT_EQ(static_cast<int>(FacadeTextures(repeated).size()), kUrbanRepeatedFacadeTextures)
        << "seed " << seed;
    std::printf(
        "[measured] seed %d: urban_small_block lap %.1f m; urban_small_repeated rig path %.1f m, closest "
        "return %.1f m\n",
        static_cast<int>(seed), lap, trajectory.LengthM(), closest);
  }
}

TEST(UrbanRepeatedTest, FacadesUseTheStatedFewTextures) {
  for (uint64_t seed : {1, 2}) {
    const SceneWithRoute s = BuildScene("urban_repeated", seed);
    std::set<std::pair<Material, uint32_t>> facade_textures;
    std::set<uint32_t> shop_fronts;
    int facades = 0;
    for (const Quad& q : s.scene.quads()) {
      if (IsBuildingFacade(q.material)) {
        ++facades;
        facade_textures.insert({q.material, q.texture_seed});
      }
      if (q.material == Material::kShopFront) shop_fronts.insert(q.texture_seed);
    }
    EXPECT_EQ(static_cast<int>(facade_textures.size()), kUrbanRepeatedFacadeTextures) << "seed " << seed;
    EXPECT_EQ(shop_fronts.size(), 1u) << "seed " << seed;
    EXPECT_GE(facades, 400) << "seed " << seed;
    const std::map<Material, int> count = QuadsPerMaterial(s);
    EXPECT_EQ(count.count(Material::kPoster), 0u) << "seed " << seed;
    EXPECT_EQ(count.count(Material::kFoliage), 0u) << "seed " << seed;
    // The count sees variety where there is some: urban's facades differ.
    std::set<std::pair<Material, uint32_t>> urban_textures;
    const SceneWithRoute urban = BuildScene("urban", seed);
    for (const Quad& q : urban.scene.quads()) {
      if (IsBuildingFacade(q.material)) urban_textures.insert({q.material, q.texture_seed});
    }
    EXPECT_GE(urban_textures.size(), 200u);
    // Still a street canyon along the route.
    const auto [left, right] = FacadeFractions(s, TrajectoryOf(s, seed));
    EXPECT_GE(left, 0.6) << "seed " << seed;
    EXPECT_GE(right, 0.6) << "seed " << seed;
  }
}

// The rig never passes through or next to geometry (as urban's routes).
TEST(UrbanVariantsTest, RigPathIsClearOfGeometry) {
  for (const std::string name :
       {"urban_block", "urban_small_block", "urban_repeated", "urban_small_repeated"}) {
    for (uint64_t seed : {1, 2}) {
      const SceneWithRoute s = BuildScene(name, seed);
      const SmoothTrajectory trajectory = TrajectoryOf(s, seed);
      for (const PathSample& sample : SamplePath(trajectory, 200'000'000)) {
        ASSERT_GE(NearestAround(s, sample.position), 1.5)
            << name << " seed " << seed << " at " << sample.position.transpose();
      }
    }
  }
}

// ------------------------------------------------------------------ rendering

void ExpectRendersTexturedFrames(const std::string& scene) {
  const fs::path out = TempDir("render_" + scene);
  SynthOptions options = TinyStereo(scene, 2, 0.2);
  options.frames = 2;
  const SynthSummary summary = Synthesize(options, out);
  EXPECT_EQ(summary.frames, 2);
  const FrameTable table = ReadFrameTable(out / "frames.csv");
  ASSERT_EQ(table.rows.size(), 2u);
  for (const FrameTableRow& row : table.rows) {
    for (const std::string& path : row.image_paths) {
      const cv::Mat image = cv::imread((out / path).string(), cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(image.empty()) << path;
      EXPECT_EQ(image.type(), CV_8UC1);
      cv::Scalar mean, stddev;
      cv::meanStdDev(image, mean, stddev);
      EXPECT_GT(mean[0], 20.0) << scene << " " << path;
      EXPECT_LT(mean[0], 235.0) << scene << " " << path;
      EXPECT_GT(stddev[0], 10.0) << scene << " " << path << ": no texture";
    }
  }
  EXPECT_NE(ReadFileToString(out / "meta.json").find("\"scene\": \"" + scene + "\""), std::string::npos);
}

TEST(UrbanVariantsTest, RendersUrbanBlock) { ExpectRendersTexturedFrames("urban_block"); }
TEST(UrbanVariantsTest, RendersUrbanRepeated) { ExpectRendersTexturedFrames("urban_repeated"); }
TEST(UrbanVariantsTest, RendersUrbanSmallBlock) { ExpectRendersTexturedFrames("urban_small_block"); }
TEST(UrbanVariantsTest, RendersUrbanSmallRepeated) { ExpectRendersTexturedFrames("urban_small_repeated"); }

// urban renders exactly as it did before the variants were added (the
// benchmarks and the committed regression baseline depend on it): hashes of
// the scene, the ground truth and the pixels of a small sequence, taken with
// the build before the change. A deliberate change of urban updates these
// and the regression baseline (tools/make_regress_baseline.sh) together.
TEST(UrbanVariantsTest, UrbanIsUnchanged) {
  const fs::path out = TempDir("urban_unchanged");
  SynthOptions options = TinyStereo("urban", 0, 0.1);
  options.frames = 3;
  Synthesize(options, out);
  EXPECT_EQ(Sha256File(out / "structure" / "scene_quads.csv"),
            "545c9161f8a721f6b8fd7cfdfa35de73b618aa6c8feeee288202334ad08a0227");
  EXPECT_EQ(Sha256File(out / "groundtruth.tum"),
            "d94f0af689193857958268a796bc7a0a9af807ae8cce07825acdadd893f2e038");
  Sha256 pixels;
  for (const char* path : {"images/image_00/000002.png", "images/image_01/000002.png"}) {
    const cv::Mat image = cv::imread((out / path).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(image.empty()) << path;
    ASSERT_TRUE(image.isContinuous());
    pixels.Update(
        std::string_view(reinterpret_cast<const char*>(image.data), image.total() * image.elemSize()));
  }
  EXPECT_EQ(pixels.HexDigest(), "2dcb84889a4722b95b5551a9ee8cc15f59d2e4c4f8cc2824a36d299cb65a1ee6");
}

}  // namespace
}  // namespace mcvo::synth
