// The global rig bundle adjustment (refine/global_ba.h) on a known scene: the
// KITTI-360 3-camera rig (no overlap between its cameras) driving a turning
// route past landmarks; observations are the true projections plus pixel
// noise, the start is the truth with drifted poses, a wrong scale and
// displaced landmarks.
#include "mcvo/refine/global_ba.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>
#include <set>
#include <vector>

#include <dlfcn.h>
#include <gtest/gtest.h>

#include "initializer/synthetic_rig_tracks.h"
#include "mcvo/util/blas.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

using testing::LoadPresetRig;

struct Scene {
  Rig rig;
  std::vector<Rigid3d> truth;                 // world_from_rig per keyframe
  std::map<int64_t, Eigen::Vector3d> points;  // id -> true position
  SparseMap map;                              // observations (noisy pixels), poses and points to refine
};

// `keyframes` keyframes 1.5 m apart, turning 2 deg per keyframe (80 deg
// over 40); every landmark within 60 m seen by a camera within 70 deg of its
// axis.
// turn_deg: per keyframe (0: a straight). one_camera_per_landmark: each
// landmark observed only by the first camera that sees it (views that do
// not overlap, as a frontend without cross-camera matching makes them).
Scene MakeScene(const std::string& rig_name, double pixel_noise, double start_scale, unsigned seed,
                int keyframes = 24, double turn_deg = 2.0, bool one_camera_per_landmark = false) {
  Scene scene;
  scene.rig = LoadPresetRig(rig_name);
  scene.truth = testing::TurningTrajectory(keyframes, 1.5, turn_deg);
  std::map<int64_t, int> owner;  // landmark -> the camera allowed to see it
  testing::LandmarkOptions landmark_options;
  landmark_options.per_metre = 12.0;
  const std::vector<Eigen::Vector3d> points = testing::LandmarksAroundPath(scene.truth, landmark_options);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, pixel_noise), wobble(0.0, 1.0);
  for (size_t p = 0; p < points.size(); ++p) scene.points[static_cast<int64_t>(p) + 1] = points[p];
  // The start: positions scaled about the first keyframe and drifting, a
  // small rotation error growing along the route.
  const Eigen::Vector3d origin = scene.truth.front().translation;
  for (size_t k = 0; k < scene.truth.size(); ++k) {
    MapKeyframe kf;
    kf.frame_index = static_cast<int>(3 * k);
    kf.t_ns = static_cast<int64_t>(k) * 300000000;
    const Rigid3d& truth = scene.truth[k];
    const Eigen::Quaterniond drift(Eigen::AngleAxisd(0.0005 * k * wobble(rng), Eigen::Vector3d::UnitZ()));
    kf.world_from_rig =
        Rigid3d(drift * truth.rotation, origin + start_scale * (truth.translation - origin) +
                                            0.05 * Eigen::Vector3d(wobble(rng), wobble(rng), wobble(rng)));
    if (k == 0) kf.world_from_rig = truth;
    for (int c = 0; c < scene.rig.NumCameras(); ++c) {
      const Camera& camera = scene.rig.cameras[static_cast<size_t>(c)];
      const Rigid3d cam_from_world = camera.cam_from_rig * truth.Inverse();
      for (const auto& [id, point] : scene.points) {
        const Eigen::Vector3d in_cam = cam_from_world * point;
        if (in_cam.norm() > 60.0 || in_cam.z() < in_cam.norm() * std::cos(70.0 * M_PI / 180.0)) continue;
        const std::optional<Eigen::Vector2d> pixel = camera.Project(in_cam);
        if (!pixel) continue;
        if (one_camera_per_landmark && owner.emplace(id, c).first->second != c) continue;
        MapObservation ob;
        ob.camera = c;
        ob.landmark_id = id;
        ob.pixel = *pixel + Eigen::Vector2d(noise(rng), noise(rng));
        if (ob.pixel.x() < 0 || ob.pixel.y() < 0 || ob.pixel.x() > camera.width - 1 ||
            ob.pixel.y() > camera.height - 1)
          continue;
        kf.observations.push_back(ob);
      }
    }
    scene.map.keyframes.push_back(kf);
  }
  for (const auto& [id, point] : scene.points) {
    scene.map.landmarks.push_back({id, origin + start_scale * (point - origin) +
                                           0.2 * Eigen::Vector3d(wobble(rng), wobble(rng), wobble(rng))});
  }
  return scene;
}

double MaxPositionError(const SparseMap& map, const std::vector<Rigid3d>& truth) {
  double worst = 0.0;
  for (size_t k = 0; k < truth.size(); ++k) {
    worst = std::max(worst, (map.keyframes[k].world_from_rig.translation - truth[k].translation).norm());
  }
  return worst;
}

// Length of the route from the first to the last keyframe, estimate / truth.
double RouteScale(const SparseMap& map, const std::vector<Rigid3d>& truth) {
  return (map.keyframes.back().world_from_rig.translation - map.keyframes.front().world_from_rig.translation)
             .norm() /
         (truth.back().translation - truth.front().translation).norm();
}

TEST(GlobalBaTest, NonOverlappingRigRecoversPosesAndTheScaleAlongTheRoute) {
  const Scene scene = MakeScene("kitti360_3cam", 0.5, 1.05, 1, 40);
  ASSERT_GT(scene.map.keyframes.front().observations.size(), 100u);
  EXPECT_NEAR(RouteScale(scene.map, scene.truth), 1.05, 0.01);
  EXPECT_GT(MaxPositionError(scene.map, scene.truth), 2.0);

  const GlobalBaResult result = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  ASSERT_TRUE(result.ran) << result.message;
  EXPECT_EQ(result.keyframes_refined, 40);
  EXPECT_EQ(result.components, 1);
  EXPECT_EQ(result.observations_removed, 0);
  EXPECT_LT(result.final_cost, result.initial_cost);
  // 0.5 px noise at the cameras' ~550 px focal: about 0.6 px at the 460 px
  // virtual focal in each of two axes.
  EXPECT_LT(result.rms_error_px_after, 0.8);
  EXPECT_GT(result.rms_error_px_before, 5.0);
  // The first keyframe is the gauge: exactly where it was.
  EXPECT_EQ(result.map.keyframes.front().world_from_rig.translation, scene.truth.front().translation);
  // The 5 % scale error is gone along the whole route, and every pose is
  // within centimetres of the truth (60 m of route).
  EXPECT_NEAR(RouteScale(result.map, scene.truth), 1.0, 0.002);
  EXPECT_LT(MaxPositionError(result.map, scene.truth), 0.05);
  // Landmarks: errors relative to their distance from the route (a far
  // point seen over a short baseline is uncertain along its ray).
  std::vector<double> relative;
  for (const MapLandmark& landmark : result.map.landmarks) {
    double nearest = 1e9;
    for (const Rigid3d& pose : scene.truth)
      nearest = std::min(nearest, (pose.translation - landmark.position_world).norm());
    relative.push_back((landmark.position_world - scene.points.at(landmark.id)).norm() / nearest);
  }
  std::sort(relative.begin(), relative.end());
  const double median = relative[relative.size() / 2], p90 = relative[relative.size() * 9 / 10];
  std::printf(
      "%zu landmarks: relative error median %.4f, p90 %.4f; route scale %.5f, worst pose error %.3f m\n",
      relative.size(), median, p90, RouteScale(result.map, scene.truth),
      MaxPositionError(result.map, scene.truth));
  EXPECT_LT(median, 0.005);
  EXPECT_LT(p90, 0.03);
}

// "Long tracks" in global_ba.h: landmarks seen in more than 10 keyframes
// enter the solves through every other keyframe (and their last). The
// route comes out as well as with every observation, and the map keeps
// every observation: the thinned ones are only left out of the solves.
TEST(GlobalBaTest, ThinnedLongTracksKeepTheRouteAndEveryObservation) {
  const Scene scene = MakeScene("kitti360_3cam", 0.5, 1.05, 1, 40);
  const GlobalBaResult full = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  GlobalBaOptions options;
  options.thin_tracks_longer_than = 10;
  const GlobalBaResult thin = RunGlobalBundleAdjustment(scene.rig, scene.map, false, options);
  ASSERT_TRUE(full.ran && thin.ran) << thin.message;
  std::printf("observations in the solve %d -> %d; route scale %.5f -> %.5f; worst pose error %.4f -> %.4f m\n",
              full.observations_used, thin.observations_used, RouteScale(full.map, scene.truth),
              RouteScale(thin.map, scene.truth), MaxPositionError(full.map, scene.truth),
              MaxPositionError(thin.map, scene.truth));
  EXPECT_LT(thin.observations_used, full.observations_used * 9 / 10);
  EXPECT_EQ(thin.observations_removed, 0);
  size_t observations_full = 0, observations_thin = 0;
  for (const MapKeyframe& kf : full.map.keyframes) observations_full += kf.observations.size();
  for (const MapKeyframe& kf : thin.map.keyframes) observations_thin += kf.observations.size();
  EXPECT_EQ(observations_thin, observations_full);
  EXPECT_EQ(thin.map.landmarks.size(), full.map.landmarks.size());
  EXPECT_NEAR(RouteScale(thin.map, scene.truth), 1.0, 0.002);
  EXPECT_LT(MaxPositionError(thin.map, scene.truth), 0.05);

  // Stride 1 thins nothing: the same solve, bit for bit.
  options.thin_track_stride = 1;
  const GlobalBaResult stride_one = RunGlobalBundleAdjustment(scene.rig, scene.map, false, options);
  EXPECT_EQ(stride_one.final_cost, full.final_cost);
  EXPECT_EQ(stride_one.observations_used, full.observations_used);
}

// Every landmark seen by more than one camera is split: the observations of
// the cameras other than its first observer's become those of a second
// landmark (id + kDuplicateOffset) that starts where the first does, as a
// frontend without cross-camera matching makes them. Returns the ids split.
constexpr int64_t kDuplicateOffset = 1000000;
std::vector<int64_t> SplitLandmarksByCamera(Scene* scene) {
  std::map<int64_t, int> owner;
  std::set<int64_t> split;
  for (MapKeyframe& kf : scene->map.keyframes) {
    for (MapObservation& ob : kf.observations) {
      if (owner.emplace(ob.landmark_id, ob.camera).first->second == ob.camera) continue;
      split.insert(ob.landmark_id);
      ob.landmark_id += kDuplicateOffset;
    }
  }
  const std::vector<MapLandmark> landmarks = scene->map.landmarks;
  for (const MapLandmark& l : landmarks) {
    if (split.count(l.id) > 0) scene->map.landmarks.push_back({l.id + kDuplicateOffset, l.position_world});
  }
  return {split.begin(), split.end()};
}

TEST(GlobalBaTest, TiedLandmarksOfCamerasWithoutOverlapGiveTheScaleOnAStraight) {
  // A straight without overlap: each camera's tracks fit any scale (with a
  // shift of its own), so the bundle adjustment cannot find it (the input's
  // 5 % error drifts further along that free direction).
  // The same points seen by two cameras at different times, tied
  // (GlobalBaLandmarkTie, as `mcvo run` ties cross-camera links), tie the
  // cameras through the rig's metric baselines.
  Scene scene = MakeScene("kitti360_3cam", 0.3, 1.05, 21, 30, 0.0, false);
  const std::vector<int64_t> split = SplitLandmarksByCamera(&scene);
  ASSERT_GT(split.size(), 50u);
  const GlobalBaResult untied = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  ASSERT_TRUE(untied.ran) << untied.message;
  EXPECT_EQ(untied.ties_used, 0);
  std::vector<GlobalBaLandmarkTie> ties;
  for (const int64_t id : split) ties.push_back({id, id + kDuplicateOffset, 0.02, 3.0});
  // A tie naming a landmark the map lacks is left out.
  ties.push_back({split.front(), 999999999, 0.02, 3.0});
  const GlobalBaResult tied =
      RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions(), {}, ties);
  ASSERT_TRUE(tied.ran) << tied.message;
  // Ties whose landmarks both have the 2 observations a refined landmark needs.
  std::map<int64_t, int> observations;
  for (const MapKeyframe& kf : scene.map.keyframes) {
    for (const MapObservation& ob : kf.observations) ++observations[ob.landmark_id];
  }
  int usable = 0;
  for (const int64_t id : split)
    usable += observations[id] >= 2 && observations[id + kDuplicateOffset] >= 2 ? 1 : 0;
  EXPECT_LE(tied.ties_used, usable);
  EXPECT_GE(tied.ties_used, usable * 9 / 10);
  EXPECT_EQ(tied.components, 1);
  const double untied_scale = RouteScale(untied.map, scene.truth),
               tied_scale = RouteScale(tied.map, scene.truth);
  std::printf("%zu ties: route scale %.5f untied, %.5f tied\n", split.size(), untied_scale, tied_scale);
  EXPECT_GT(std::abs(untied_scale - 1.0), 0.03);
  EXPECT_NEAR(tied_scale, 1.0, 0.005);
  // Both landmarks of a tie end where the point is, within centimetres.
  std::map<int64_t, Eigen::Vector3d> refined;
  for (const MapLandmark& l : tied.map.landmarks) refined[l.id] = l.position_world;
  int near = 0;
  for (const int64_t id : split) {
    const auto a = refined.find(id), b = refined.find(id + kDuplicateOffset);
    near += a != refined.end() && b != refined.end() && (a->second - b->second).norm() < 0.05 ? 1 : 0;
  }
  EXPECT_GE(near, tied.ties_used * 9 / 10);
}

// Log of the ratio of the summed interval lengths of keyframes [mid, end)
// to those of [0, mid].
double ProfileStep(const SparseMap& map, size_t mid) {
  double first = 0.0, second = 0.0;
  for (size_t k = 1; k < map.keyframes.size(); ++k) {
    const double d =
        (map.keyframes[k].world_from_rig.translation - map.keyframes[k - 1].world_from_rig.translation)
            .norm();
    (k <= mid ? first : second) +=
        d / (k <= mid ? static_cast<double>(mid) : static_cast<double>(map.keyframes.size() - 1 - mid));
  }
  return std::log(second / first);
}

TEST(GlobalBaTest, StraightScaleHoldOnlyOnStraightsWithoutOverlappingViews) {
  // Turning 2 deg per keyframe: never held.
  const Scene turning = MakeScene("kitti360_3cam", 0.3, 1.0, 11, 24, 2.0, true);
  EXPECT_EQ(
      RunGlobalBundleAdjustment(turning.rig, turning.map, false, GlobalBaOptions()).straight_scale_residuals,
      0);
  // Straight, the 4-camera rig's overlapping views: never held.
  const Scene overlap = MakeScene("kitti360", 0.3, 1.0, 12, 24, 0.0, false);
  EXPECT_EQ(
      RunGlobalBundleAdjustment(overlap.rig, overlap.map, false, GlobalBaOptions()).straight_scale_residuals,
      0);
  // Straight without overlap: spans of 5 keyframes, pairs at 5, 10, 15 (of 24).
  const Scene straight = MakeScene("kitti360_3cam", 0.3, 1.0, 13, 24, 0.0, true);
  const GlobalBaResult held = RunGlobalBundleAdjustment(straight.rig, straight.map, false, GlobalBaOptions());
  ASSERT_TRUE(held.ran) << held.message;
  EXPECT_EQ(held.straight_scale_residuals, 3);
  GlobalBaOptions off;
  off.straight_scale_sigma = 0.0;
  EXPECT_EQ(RunGlobalBundleAdjustment(straight.rig, straight.map, false, off).straight_scale_residuals, 0);
}

TEST(GlobalBaTest, TheHoldPullsAStraightsScaleProfileTowardsTheInputs) {
  // The input's second half has 4 % longer intervals than its first. On
  // these clean synthetic tracks (0.3 px noise, no systematic error) the
  // free bundle adjustment finds the true, uniform profile through the
  // landmarks both halves see; the hold (a prior on the input's profile)
  // keeps part of the step: it costs accuracy where the images are this
  // clean and the input's profile is wrong. It is on by default because on
  // rendered images the free solution's profile drifted along straights
  // (global_ba.h "Scale on straights"). This checks its direction and size.
  Scene scene = MakeScene("kitti360_3cam", 0.3, 1.0, 14, 30, 0.0, true);
  const size_t mid = 15;
  const Eigen::Vector3d pivot = scene.map.keyframes[mid].world_from_rig.translation;
  for (size_t k = mid + 1; k < scene.map.keyframes.size(); ++k) {
    Rigid3d& pose = scene.map.keyframes[k].world_from_rig;
    pose.translation = pivot + 1.04 * (pose.translation - pivot);
  }
  const double step_in = ProfileStep(scene.map, mid);
  ASSERT_NEAR(step_in, std::log(1.04), 0.01);
  const GlobalBaResult held = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  ASSERT_TRUE(held.ran) << held.message;
  EXPECT_GT(held.straight_scale_residuals, 0);
  const double step_held = ProfileStep(held.map, mid);
  GlobalBaOptions off;
  off.straight_scale_sigma = 0.0;
  const GlobalBaResult free = RunGlobalBundleAdjustment(scene.rig, scene.map, false, off);
  const double step_free = ProfileStep(free.map, mid);
  std::printf("profile step: input %.4f, held %.4f, free %.4f (log ratio)\n", step_in, step_held, step_free);
  EXPECT_NEAR(step_free, 0.0, 0.005);  // the truth is uniform
  // Held: between the two, at least a quarter of the input's step kept.
  EXPECT_GT(step_held, step_free + 0.25 * (step_in - step_free));
  EXPECT_LT(step_held, step_in);
  EXPECT_LT(held.rms_error_px_after, 0.6);
  EXPECT_LT(free.rms_error_px_after, 0.6);
}

TEST(GlobalBaTest, OutliersAreRemovedAndDoNotMoveTheSolution) {
  Scene scene = MakeScene("kitti360", 0.3, 1.0, 2);
  // Every 25th observation is moved by 30-60 px.
  int injected = 0;
  for (MapKeyframe& kf : scene.map.keyframes) {
    for (size_t i = 0; i < kf.observations.size(); i += 25) {
      kf.observations[i].pixel += Eigen::Vector2d(30.0 + (i % 30), -20.0);
      ++injected;
    }
  }
  const GlobalBaResult result = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  ASSERT_TRUE(result.ran);
  EXPECT_GE(result.observations_removed, injected * 9 / 10);
  EXPECT_LE(result.observations_removed, injected + injected / 5);
  EXPECT_LT(result.rms_error_px_after, 0.6);
  EXPECT_LT(MaxPositionError(result.map, scene.truth), 0.1);
  // Removed observations are gone from the map.
  size_t kept = 0, before = 0;
  for (size_t k = 0; k < scene.map.keyframes.size(); ++k) {
    before += scene.map.keyframes[k].observations.size();
    kept += result.map.keyframes[k].observations.size();
  }
  EXPECT_EQ(before - kept, static_cast<size_t>(result.observations_removed));
}

// global_ba.h "Robust loss": the first solve's knee is the configured
// 1.5 px; the second's follows the noise measured in the first's residuals
// (2 sigma), so it scales with the pixel noise and never exceeds the first.
TEST(GlobalBaTest, TheSecondSolvesKneeFollowsTheMeasuredNoise) {
  std::vector<double> knees;
  for (const double noise : {0.2, 0.5}) {
    Scene scene = MakeScene("kitti360", noise, 1.0, 4);
    // Outliers, so that the second solve runs with the knee off too.
    for (MapKeyframe& kf : scene.map.keyframes) {
      for (size_t i = 0; i < kf.observations.size(); i += 40)
        kf.observations[i].pixel += Eigen::Vector2d(25.0, 10.0);
    }
    const GlobalBaResult result = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
    ASSERT_TRUE(result.ran);
    ASSERT_EQ(result.loss_knee_px.size(), 2u);
    EXPECT_EQ(result.loss_knee_px[0], 1.5);
    std::printf(
        "pixel noise %.1f px: knees %.3f, %.3f px (at the virtual focal); max position error %.4f m\n", noise,
        result.loss_knee_px[0], result.loss_knee_px[1], MaxPositionError(result.map, scene.truth));
    knees.push_back(result.loss_knee_px[1]);
    EXPECT_LT(MaxPositionError(result.map, scene.truth), 0.1);

    GlobalBaOptions fixed;
    fixed.adaptive_loss_sigmas = 0.0;
    const GlobalBaResult off = RunGlobalBundleAdjustment(scene.rig, scene.map, false, fixed);
    ASSERT_EQ(off.loss_knee_px.size(), 2u);
    EXPECT_EQ(off.loss_knee_px[1], 1.5);
  }
  // 2 x 0.2 px of image noise, expressed at the virtual focal (0.32 px
  // measured: the tangent-plane error is the image error scaled by the
  // virtual focal over the camera's), and in proportion to the noise.
  EXPECT_GT(knees[0], 0.2);
  EXPECT_LT(knees[0], 0.6);
  EXPECT_NEAR(knees[1] / knees[0], 2.5, 0.4);
  // Noise of 2 px: the measured knee would exceed the first; it stays.
  const Scene noisy = MakeScene("kitti360", 2.0, 1.0, 4);
  const GlobalBaResult result = RunGlobalBundleAdjustment(noisy.rig, noisy.map, false, GlobalBaOptions());
  ASSERT_TRUE(result.ran);
  for (const double knee : result.loss_knee_px) EXPECT_EQ(knee, 1.5);
}

// global_ba.h "Solves": the first solve stops at the looser
// first_solve_function_tolerance when another follows; the result is as
// good as with a full first solve, and a loose solve is never the last.
TEST(GlobalBaTest, ALooseFirstSolveGivesTheSameResultAndIsNeverTheLast) {
  Scene scene = MakeScene("kitti360", 0.3, 1.03, 6);
  for (MapKeyframe& kf : scene.map.keyframes) {
    for (size_t i = 0; i < kf.observations.size(); i += 30)
      kf.observations[i].pixel += Eigen::Vector2d(-20.0, 25.0);
  }
  GlobalBaOptions full;
  full.first_solve_function_tolerance = full.function_tolerance;
  const GlobalBaResult a = RunGlobalBundleAdjustment(scene.rig, scene.map, false, full);
  const GlobalBaResult b = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  ASSERT_TRUE(a.ran && b.ran);
  ASSERT_EQ(a.solves, 2);
  ASSERT_EQ(b.solves, 2);
  const double error_a = MaxPositionError(a.map, scene.truth), error_b = MaxPositionError(b.map, scene.truth);
  std::printf(
      "first solve to %g / %g: %d / %d iterations in all, max position error %.4f / %.4f m, "
      "route scale %.5f / %.5f, %d / %d observations removed\n",
      full.function_tolerance, GlobalBaOptions().first_solve_function_tolerance, a.iterations, b.iterations,
      error_a, error_b, RouteScale(a.map, scene.truth), RouteScale(b.map, scene.truth),
      a.observations_removed, b.observations_removed);
  EXPECT_LT(b.iterations, a.iterations);
  EXPECT_LT(error_b, 0.05);
  EXPECT_NEAR(error_b, error_a, 0.005);
  EXPECT_NEAR(RouteScale(b.map, scene.truth), RouteScale(a.map, scene.truth), 1e-3);
  EXPECT_EQ(b.observations_removed, a.observations_removed);

  // Nothing removed and a knee that would not tighten (2 px of noise): a
  // full first solve is the last; a short one is continued by a second.
  const Scene noisy = MakeScene("kitti360", 2.0, 1.03, 6);
  GlobalBaOptions keep_all;
  keep_all.outlier_threshold_px = 1000.0;
  keep_all.first_solve_function_tolerance = 0.5;  // stops after an iteration or two
  const GlobalBaResult short_first = RunGlobalBundleAdjustment(noisy.rig, noisy.map, false, keep_all);
  keep_all.first_solve_function_tolerance = keep_all.function_tolerance;
  const GlobalBaResult full_first = RunGlobalBundleAdjustment(noisy.rig, noisy.map, false, keep_all);
  ASSERT_TRUE(short_first.ran && full_first.ran);
  EXPECT_EQ(full_first.solves, 1);
  EXPECT_EQ(short_first.solves, 2);
  EXPECT_EQ(short_first.observations_removed, 0);
  EXPECT_NEAR(MaxPositionError(short_first.map, noisy.truth), MaxPositionError(full_first.map, noisy.truth),
              0.01);

  // One solve only (outlier_rounds 0): it is the last, never loose.
  GlobalBaOptions single;
  single.outlier_rounds = 0;
  single.first_solve_function_tolerance = 0.5;
  const GlobalBaResult one = RunGlobalBundleAdjustment(scene.rig, scene.map, false, single);
  single.first_solve_function_tolerance = single.function_tolerance;
  const GlobalBaResult one_full = RunGlobalBundleAdjustment(scene.rig, scene.map, false, single);
  EXPECT_EQ(one.solves, 1);
  EXPECT_EQ(one.iterations, one_full.iterations);
  EXPECT_GT(one.iterations, 1);
}

TEST(GlobalBaTest, ScaleFreeProblemKeepsTheDistanceFromFirstToLastKeyframe) {
  // One camera: the map's unit is arbitrary (here 1.05 of the truth) and
  // must stay so; the shape is still refined.
  const Scene scene = MakeScene("kitti360", 0.3, 1.05, 3);
  Rig mono;
  mono.cameras.push_back(scene.rig.cameras[0]);
  SparseMap map = scene.map;
  for (MapKeyframe& kf : map.keyframes) {
    std::vector<MapObservation> kept;
    for (const MapObservation& ob : kf.observations) {
      if (ob.camera == 0) kept.push_back(ob);
    }
    kf.observations = kept;
  }
  const double distance_before =
      (map.keyframes.back().world_from_rig.translation - map.keyframes.front().world_from_rig.translation)
          .norm();
  const GlobalBaResult result = RunGlobalBundleAdjustment(mono, map, true, GlobalBaOptions());
  ASSERT_TRUE(result.ran);
  const double distance_after = (result.map.keyframes.back().world_from_rig.translation -
                                 result.map.keyframes.front().world_from_rig.translation)
                                    .norm();
  EXPECT_NEAR(distance_after / distance_before, 1.0, 1e-3);
  EXPECT_LT(result.rms_error_px_after, 0.6);
}

TEST(GlobalBaTest, DisconnectedPartsAreEachHeldByTheirFirstKeyframe) {
  // Two halves of the route with disjoint landmark ids: two components.
  Scene scene = MakeScene("kitti360", 0.3, 1.0, 4);
  for (size_t k = 12; k < scene.map.keyframes.size(); ++k) {
    for (MapObservation& ob : scene.map.keyframes[k].observations) ob.landmark_id += 1000000;
  }
  const std::vector<MapLandmark> first_half = scene.map.landmarks;
  for (MapLandmark landmark : first_half) {
    landmark.id += 1000000;
    scene.map.landmarks.push_back(landmark);
  }
  const GlobalBaResult result = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  ASSERT_TRUE(result.ran);
  EXPECT_EQ(result.components, 2);
  EXPECT_EQ(result.map.keyframes[12].world_from_rig.translation,
            scene.map.keyframes[12].world_from_rig.translation);
  EXPECT_EQ(result.map.keyframes[0].world_from_rig.translation,
            scene.map.keyframes[0].world_from_rig.translation);
}

TEST(GlobalBaTest, ALoopConstraintJoinsAndPlacesADisconnectedPart) {
  // The two halves share no landmark; the second half starts 2 m and 3 deg
  // off. One relative pose between keyframes 11 and 12 (the truth, as a
  // verified loop would give) joins them: one gauge component, and the
  // second half lands where it belongs.
  Scene scene = MakeScene("kitti360", 0.3, 1.0, 7);
  const Rigid3d offset(Eigen::Quaterniond(Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ())),
                       Eigen::Vector3d(2.0, -1.0, 0.3));
  std::set<int64_t> second_half;
  for (size_t k = 12; k < scene.map.keyframes.size(); ++k) {
    MapKeyframe& kf = scene.map.keyframes[k];
    kf.world_from_rig = offset * scene.truth[k];
    for (MapObservation& ob : kf.observations) {
      ob.landmark_id += 1000000;
      second_half.insert(ob.landmark_id);
    }
  }
  const std::vector<MapLandmark> first_half = scene.map.landmarks;
  for (const MapLandmark& landmark : first_half) {
    if (second_half.count(landmark.id + 1000000) == 0) continue;
    scene.map.landmarks.push_back({landmark.id + 1000000, offset * scene.points.at(landmark.id)});
  }
  GlobalBaPoseConstraint loop;
  loop.from = 11;
  loop.to = 12;
  loop.from_T_to = scene.truth[11].Inverse() * scene.truth[12];
  loop.rotation_sigma_rad = 0.001;
  loop.translation_sigma_m = 0.01;
  const GlobalBaResult without = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  const GlobalBaResult with =
      RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions(), {loop});
  ASSERT_TRUE(without.ran && with.ran);
  EXPECT_EQ(without.components, 2);
  EXPECT_EQ(without.constraints_used, 0);
  EXPECT_EQ(with.components, 1);
  EXPECT_EQ(with.constraints_used, 1);
  EXPECT_GT(MaxPositionError(without.map, scene.truth), 1.5);
  EXPECT_LT(MaxPositionError(with.map, scene.truth), 0.1);
}

// refine.inner_iterations: between the LM steps every point (then every
// pose) alone is moved to its own minimum. On the rig without overlap,
// whose scale along the route only the chain of landmarks holds (the slow
// direction of the plain LM), both reach the same minimum; with the inner
// iterations in fewer LM iterations. (This scene's scale is 0.5 % off
// either way: 40 keyframes of one turn hold it weakly.)
TEST(GlobalBaTest, InnerIterationsReachTheSameMinimumInFewerSteps) {
  const Scene scene = MakeScene("kitti360_3cam", 0.3, 1.05, 8, 40, 2.0, true);
  GlobalBaOptions plain, inner;
  plain.inner_iterations = false;
  inner.inner_iterations = true;
  plain.max_iterations = inner.max_iterations = 200;  // both to convergence
  const GlobalBaResult a = RunGlobalBundleAdjustment(scene.rig, scene.map, false, plain);
  const GlobalBaResult b = RunGlobalBundleAdjustment(scene.rig, scene.map, false, inner);
  ASSERT_TRUE(a.ran && b.ran);
  const double scale_a = RouteScale(a.map, scene.truth), scale_b = RouteScale(b.map, scene.truth);
  const double error_a = MaxPositionError(a.map, scene.truth), error_b = MaxPositionError(b.map, scene.truth);
  std::printf(
      "plain / inner: %d / %d LM iterations, cost %.6g / %.6g, route scale %.5f / %.5f, max position "
      "error %.4f / %.4f m\n",
      a.iterations, b.iterations, a.final_cost, b.final_cost, scale_a, scale_b, error_a, error_b);
  EXPECT_LT(b.iterations, a.iterations);
  EXPECT_NEAR(b.final_cost / a.final_cost, 1.0, 1e-3);
  EXPECT_NEAR(scale_b, scale_a, 1e-3);
  EXPECT_NEAR(error_b, error_a, 0.03);  // the minimum is flat along the scale
}

TEST(GlobalBaTest, DeterministicBitForBit) {
  const Scene scene = MakeScene("kitti360_3cam", 0.5, 1.03, 5);
  const GlobalBaResult a = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  const GlobalBaResult b = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  ASSERT_EQ(a.map.keyframes.size(), b.map.keyframes.size());
  for (size_t k = 0; k < a.map.keyframes.size(); ++k) {
    EXPECT_EQ(a.map.keyframes[k].world_from_rig.translation, b.map.keyframes[k].world_from_rig.translation);
    EXPECT_EQ(a.map.keyframes[k].world_from_rig.rotation.coeffs(),
              b.map.keyframes[k].world_from_rig.rotation.coeffs());
  }
  ASSERT_EQ(a.map.landmarks.size(), b.map.landmarks.size());
  for (size_t i = 0; i < a.map.landmarks.size(); ++i) {
    EXPECT_EQ(a.map.landmarks[i].position_world, b.map.landmarks[i].position_world);
  }
  EXPECT_EQ(a.final_cost, b.final_cost);
}

TEST(GlobalBaTest, NothingSeenTwiceIsNotRunAndSaysWhy) {
  Scene scene = MakeScene("kitti360", 0.3, 1.0, 6);
  int64_t next = 5000000;
  for (MapKeyframe& kf : scene.map.keyframes) {
    for (MapObservation& ob : kf.observations) ob.landmark_id = next++;  // every observation its own landmark
  }
  const GlobalBaResult result = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  EXPECT_FALSE(result.ran);
  EXPECT_NE(result.message.find("observed twice"), std::string::npos);
  EXPECT_EQ(result.map.keyframes.size(), scene.map.keyframes.size());
}

// A calibration error: camera 1 of the 4-camera KITTI-360 rig given to the
// BA turned by 0.4 deg and moved by 3 cm from where the observations were
// made. With the extrinsics fixed the error stays in the solution; refined
// (refine_extrinsics, prior 0.5 deg / 2 cm around the wrong calibration)
// the BA moves camera 1 most of the way back; camera 0, the reference,
// stays, and the other two barely move.
TEST(GlobalBaTest, RefinedExtrinsicsRecoverACalibrationError) {
  const Scene scene = MakeScene("kitti360", 0.3, 1.0, 3, 16);
  Rig wrong = scene.rig;
  const Rigid3d truth_1 = scene.rig.cameras[1].cam_from_rig;
  const Rigid3d error(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.4 * M_PI / 180.0, Eigen::Vector3d(0.6, 0.8, 0.0))),
      Eigen::Vector3d(0.03, 0.0, 0.0));
  wrong.cameras[1].cam_from_rig = error * truth_1;
  auto rotation_error_deg = [&](const Rigid3d& cam_from_rig) {
    return cam_from_rig.rotation.angularDistance(truth_1.rotation) * 180.0 / M_PI;
  };
  auto centre_error_m = [&](const Rigid3d& cam_from_rig) {
    return (cam_from_rig.Inverse().translation - truth_1.Inverse().translation).norm();
  };
  ASSERT_NEAR(rotation_error_deg(wrong.cameras[1].cam_from_rig), 0.4, 1e-9);
  const double centre_error_before = centre_error_m(wrong.cameras[1].cam_from_rig);

  const GlobalBaResult fixed = RunGlobalBundleAdjustment(wrong, scene.map, false, GlobalBaOptions());
  GlobalBaOptions options;
  options.refine_extrinsics = true;
  const GlobalBaResult refined = RunGlobalBundleAdjustment(wrong, scene.map, false, options);
  ASSERT_TRUE(fixed.ran && refined.ran) << fixed.message << " / " << refined.message;
  ASSERT_EQ(refined.cam_from_rig.size(), 4u);
  std::printf(
      "camera 1: rotation error 0.400 -> %.3f deg, centre error %.4f -> %.4f m; rms %.3f px fixed, %.3f px "
      "refined; changes %.3f / %.3f / %.3f / %.3f deg\n",
      rotation_error_deg(refined.cam_from_rig[1]), centre_error_before,
      centre_error_m(refined.cam_from_rig[1]), fixed.rms_error_px_after, refined.rms_error_px_after,
      refined.extrinsic_rotation_change_deg[0], refined.extrinsic_rotation_change_deg[1],
      refined.extrinsic_rotation_change_deg[2], refined.extrinsic_rotation_change_deg[3]);
  // Fixed: the input's extrinsics come back unchanged.
  EXPECT_EQ(fixed.cam_from_rig[1].translation, wrong.cameras[1].cam_from_rig.translation);
  EXPECT_EQ(fixed.extrinsic_rotation_change_deg[1], 0.0);
  // Refined: camera 1 most of the way back, the observations explained better.
  EXPECT_LT(rotation_error_deg(refined.cam_from_rig[1]), 0.02);
  EXPECT_LT(centre_error_m(refined.cam_from_rig[1]), 0.01);
  EXPECT_GT(refined.extrinsic_rotation_change_deg[1], 0.3);
  EXPECT_EQ(refined.extrinsic_rotation_change_deg[0], 0.0);
  EXPECT_EQ(refined.extrinsic_translation_change_m[0], 0.0);
  for (int c : {2, 3}) EXPECT_LT(refined.extrinsic_rotation_change_deg[static_cast<size_t>(c)], 0.05) << c;
  EXPECT_LT(refined.rms_error_px_after, 0.8 * fixed.rms_error_px_after);
  EXPECT_LE(MaxPositionError(refined.map, scene.truth), MaxPositionError(fixed.map, scene.truth));
}

// The global BA's sparse Cholesky calls BLAS (mcvo/util/blas.h): this
// binary links it as mcvo does, through libblas.so.3, so a BLAS is loaded
// and named by its file; pinning a threaded OpenBLAS to one thread leaves
// the solution bit for bit as it was.
TEST(BlasTest, TheLoadedBlasIsNamedByItsFileAndOneThreadChangesNothing) {
  const std::string library = BlasLibrary();
  ASSERT_FALSE(library.empty());
  EXPECT_TRUE(std::filesystem::is_regular_file(library)) << library;
  // dgemm_ comes from the machine's libblas.so.3 (Debian's alternatives),
  // not from a BLAS linked by name ahead of it (CMakeLists.txt).
  void* system_blas = dlopen("libblas.so.3", RTLD_LAZY | RTLD_NOLOAD);
  ASSERT_NE(system_blas, nullptr) << "libblas.so.3 is not loaded";
  void* dgemm = dlsym(system_blas, "dgemm_");
  ASSERT_NE(dgemm, nullptr);
  Dl_info info{};
  ASSERT_NE(dladdr(dgemm, &info), 0);
  EXPECT_EQ(std::filesystem::canonical(info.dli_fname).string(), library);
  dlclose(system_blas);

  const Scene scene = MakeScene("kitti360_3cam", 0.5, 1.03, 5);
  const GlobalBaResult a = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  PinBlasToOneThread();
  PinBlasToOneThread();
  const GlobalBaResult b = RunGlobalBundleAdjustment(scene.rig, scene.map, false, GlobalBaOptions());
  EXPECT_EQ(a.final_cost, b.final_cost);
}

TEST(GlobalBaOptionsTest, CheckNamesTheField) {
  GlobalBaOptions adaptive;
  adaptive.adaptive_loss_min_px = 0.0;
  try {
    adaptive.Check();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/refine/adaptive_loss_min_px"), std::string::npos) << e.what();
  }
  adaptive = GlobalBaOptions();
  adaptive.adaptive_loss_sigmas = -1.0;
  EXPECT_THROW(adaptive.Check(), InputError);
  GlobalBaOptions first;
  first.first_solve_function_tolerance = 0.0;
  try {
    first.Check();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/refine/first_solve_function_tolerance"), std::string::npos)
        << e.what();
  }
  GlobalBaOptions options;
  options.min_observations = 1;
  try {
    options.Check();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/refine/min_observations"), std::string::npos);
  }
}

}  // namespace
}  // namespace mcvo
