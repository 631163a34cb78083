// Initialisation from overlapping views without motion
// (include/mcvo/initializer/overlap_start.h), through the Initializer and
// directly, on synthetic tracks of the preset rigs (synthetic_rig_tracks.h).
#include "mcvo/initializer/overlap_start.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "initializer/synthetic_rig_tracks.h"
#include "mcvo/initializer/initializer.h"

namespace mcvo {
namespace {

using testing::AnchorFromRig;
using testing::LoadPresetRig;
using testing::StraightTrajectory;
using testing::SyntheticRigTracks;

SyntheticRigTracks Tracks(const Rig& rig, const std::vector<Rigid3d>& world_from_rig, double noise_px,
                          uint64_t seed, bool cross_camera) {
  return testing::NoisyRigTracks(rig, world_from_rig, noise_px, seed, cross_camera);
}

// The overlap start at the first full window that fails (the default waits
// for after_failed_windows = 100 of them: GatesAndDelay).
InitializerOptions AtOnce() {
  InitializerOptions options;
  options.overlap_start.after_failed_windows = 0;
  return options;
}

struct Outcome {
  std::optional<InitializationResult> result;
  int frames_fed = 0;
  std::string reason;
};

Outcome RunInitializer(const Rig& rig, const SyntheticRigTracks& tracks, const InitializerOptions& options) {
  Initializer initializer(rig, options, 1);
  Outcome out;
  for (const RigFrameObservations& frame : tracks.frames) {
    ++out.frames_fed;
    out.result = initializer.AddFrame(frame);
    if (out.result) return out;
    out.reason = initializer.WaitingReason();
  }
  return out;
}

// Worst position (m) and rotation (deg) error of the result's poses, and the
// median relative error of the landmarks' distances from the anchor rig.
struct Errors {
  double position_m = 0.0;
  double rotation_deg = 0.0;
  double median_distance_error = 0.0;
};

Errors ErrorsOf(const InitializationResult& result, const SyntheticRigTracks& tracks) {
  Errors e;
  const int l = result.anchor_frame_index;
  for (size_t k = 0; k < result.frame_index.size(); ++k) {
    const Rigid3d truth = AnchorFromRig(tracks, l, result.frame_index[k]);
    e.position_m = std::max(e.position_m, (truth.translation - result.world_from_rig[k].translation).norm());
    e.rotation_deg = std::max(
        e.rotation_deg, truth.rotation.angularDistance(result.world_from_rig[k].rotation) * 180.0 / M_PI);
  }
  const Rigid3d anchor_from_world = tracks.world_from_rig[static_cast<size_t>(l)].Inverse();
  std::vector<double> errors;
  for (const InitializationResult::Landmark& lm : result.landmarks) {
    const auto truth = tracks.features.find(lm.id);
    if (truth == tracks.features.end() || truth->second.outlier) continue;
    const Eigen::Vector3d p = anchor_from_world * tracks.landmarks[static_cast<size_t>(truth->second.landmark)];
    errors.push_back(std::abs(lm.point_in_world.norm() / p.norm() - 1.0));
  }
  if (!errors.empty()) {
    std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(errors.size() / 2), errors.end());
    e.median_distance_error = errors[errors.size() / 2];
  }
  return e;
}

// A stereo rig standing still: the motion initialisation has no parallax,
// the overlap start initialises at the first full window, every frame at rest.
TEST(OverlapStart, StereoRigStandingStillInitialisesAtRest) {
  const Rig rig = LoadPresetRig("kitti360_stereo");
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    const SyntheticRigTracks tracks = Tracks(rig, StraightTrajectory(12, 0.0), 1.0, seed, true);
    const Outcome o = RunInitializer(rig, tracks, AtOnce());
    ASSERT_TRUE(o.result) << o.reason;
    EXPECT_EQ(o.frames_fed, 10);
    EXPECT_EQ(o.result->source, ScaleSource::kOverlapStart);
    EXPECT_EQ(o.result->frame_index.size(), 10u);
    const Errors e = ErrorsOf(*o.result, tracks);
    std::printf("seed %d: %zu landmarks, %d in the newest frame, sigma %.2f %%, position %.4f m, "
                "rotation %.4f deg, landmark distance %.2f %% (median)\n",
                static_cast<int>(seed), o.result->landmarks.size(), o.result->cross_camera_matches,
                100 * o.result->relative_scale_sigma, e.position_m, e.rotation_deg, 100 * e.median_distance_error);
    // Measured (1 px noise, full-resolution focal 552 px, 0.6 m baseline):
    // 0.9-1.5 cm, 0.02-0.04 deg, landmark distances 1.8-2.2 % (median).
    EXPECT_LT(e.position_m, 0.025);
    EXPECT_LT(e.rotation_deg, 0.08);
    EXPECT_LT(e.median_distance_error, 0.035);
    EXPECT_GT(o.result->relative_scale_sigma, 0.0);
    EXPECT_LE(o.result->relative_scale_sigma, InitializerOptions().overlap_start.max_relative_scale_sigma);
    EXPECT_TRUE(o.result->camera_used[0]);
    EXPECT_TRUE(o.result->camera_used[1]);
  }
}

// Creeping forward at 2 cm per frame (too little parallax for the motion
// initialisation): the overlap start follows the motion, metric.
TEST(OverlapStart, CreepingStereoRigIsPosedMetric) {
  const Rig rig = LoadPresetRig("kitti360_stereo");
  const SyntheticRigTracks tracks = Tracks(rig, StraightTrajectory(12, 0.02), 0.5, 4, true);
  const Outcome o = RunInitializer(rig, tracks, AtOnce());
  ASSERT_TRUE(o.result) << o.reason;
  EXPECT_EQ(o.result->source, ScaleSource::kOverlapStart);
  const Errors e = ErrorsOf(*o.result, tracks);
  EXPECT_LT(e.position_m, 0.015);  // measured 0.7 cm at 0.5 px
  EXPECT_LT(e.median_distance_error, 0.03);
  // 18 cm travelled over the window, to within a few mm.
  const double travel = o.result->world_from_rig.back().translation.norm();
  EXPECT_NEAR(travel, 0.18, 0.015);
}

// The 4-camera KITTI-360 rig (front stereo pair overlapping, fisheyes) at rest.
TEST(OverlapStart, FourCameraRigAtRest) {
  const Rig rig = LoadPresetRig("kitti360");
  const SyntheticRigTracks tracks = Tracks(rig, StraightTrajectory(11, 0.0), 1.0, 5, true);
  const Outcome o = RunInitializer(rig, tracks, AtOnce());
  ASSERT_TRUE(o.result) << o.reason;
  EXPECT_EQ(o.result->source, ScaleSource::kOverlapStart);
  const Errors e = ErrorsOf(*o.result, tracks);
  std::printf("kitti360 at rest: position %.4f m, landmark distance %.2f %% (median)\n", e.position_m,
              100 * e.median_distance_error);
  EXPECT_LT(e.position_m, 0.025);
  EXPECT_LT(e.median_distance_error, 0.035);
}

// Without overlapping views there is nothing to start from: the initializer
// waits and its reason does not mention the overlap start.
TEST(OverlapStart, RigWithoutOverlapWaits) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  const SyntheticRigTracks tracks = Tracks(rig, StraightTrajectory(12, 0.0), 0.5, 6, false);
  const Outcome o = RunInitializer(rig, tracks, AtOnce());
  EXPECT_FALSE(o.result);
  EXPECT_EQ(o.reason.find("overlap start"), std::string::npos) << o.reason;
}

// The gates refuse with a reason: too few landmarks, a scale too uncertain;
// and after_failed_windows delays the start by that many windows.
TEST(OverlapStart, GatesAndDelay) {
  const Rig rig = LoadPresetRig("kitti360_stereo");
  const SyntheticRigTracks tracks = Tracks(rig, StraightTrajectory(16, 0.0), 1.0, 7, true);
  InitializerOptions options = AtOnce();
  options.overlap_start.min_points = 100000;
  Outcome o = RunInitializer(rig, tracks, options);
  EXPECT_FALSE(o.result);
  EXPECT_NE(o.reason.find("cross-camera landmarks in the newest frame < 100000"), std::string::npos) << o.reason;
  EXPECT_NE(o.reason.find("parallax"), std::string::npos) << o.reason;  // the motion initialisation's first

  options = AtOnce();
  options.overlap_start.max_relative_scale_sigma = 1e-6;
  o = RunInitializer(rig, tracks, options);
  EXPECT_FALSE(o.result);
  EXPECT_NE(o.reason.find("overlap start: scale sigma"), std::string::npos) << o.reason;

  options = AtOnce();
  options.overlap_start.after_failed_windows = 3;
  o = RunInitializer(rig, tracks, options);
  ASSERT_TRUE(o.result) << o.reason;
  EXPECT_EQ(o.frames_fed, 13);

  // The default: 100 failed windows first (the rig stands for 110 frames).
  const SyntheticRigTracks standing = Tracks(rig, StraightTrajectory(112, 0.0), 1.0, 7, true);
  o = RunInitializer(rig, standing, InitializerOptions());
  ASSERT_TRUE(o.result) << o.reason;
  EXPECT_EQ(o.frames_fed, 110);
  EXPECT_EQ(o.result->source, ScaleSource::kOverlapStart);
}

// Same input, same result, bit for bit; a one-camera rig is refused.
TEST(OverlapStart, DeterministicAndNeedsTwoCameras) {
  const Rig rig = LoadPresetRig("kitti360_stereo");
  const SyntheticRigTracks tracks = Tracks(rig, StraightTrajectory(10, 0.05), 1.0, 8, true);
  const std::deque<RigFrameObservations> window(tracks.frames.begin(), tracks.frames.end());
  std::string reason_a, reason_b;
  const auto a = InitialiseFromOverlap(rig, window, InitializerOptions(), &reason_a);
  const auto b = InitialiseFromOverlap(rig, window, InitializerOptions(), &reason_b);
  ASSERT_TRUE(a && b) << reason_a;
  ASSERT_EQ(a->world_from_rig.size(), b->world_from_rig.size());
  for (size_t k = 0; k < a->world_from_rig.size(); ++k) {
    EXPECT_EQ(a->world_from_rig[k].translation, b->world_from_rig[k].translation);
    EXPECT_EQ(a->world_from_rig[k].rotation.coeffs(), b->world_from_rig[k].rotation.coeffs());
  }
  ASSERT_EQ(a->landmarks.size(), b->landmarks.size());
  for (size_t k = 0; k < a->landmarks.size(); ++k) {
    EXPECT_EQ(a->landmarks[k].point_in_world, b->landmarks[k].point_in_world);
  }
  Rig mono = rig;
  mono.cameras.resize(1);
  std::deque<RigFrameObservations> mono_window = window;
  for (RigFrameObservations& frame : mono_window) {
    frame.cameras.resize(1);
    frame.camera_missing.clear();
    frame.cross_camera.clear();
  }
  std::string reason;
  EXPECT_FALSE(InitialiseFromOverlap(mono, mono_window, InitializerOptions(), &reason));
  EXPECT_NE(reason.find("two cameras"), std::string::npos) << reason;
}

}  // namespace
}  // namespace mcvo
