// The odometry stage of `mcvo run` (src/pipeline/odometry_stage.h, private
// to the pipeline) on synthetic rig tracks: every camera blacked out for 10
// frames, and a sequence whose only initialisation needs the fallback bound.
#include "../../src/pipeline/odometry_stage.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "initializer/synthetic_rig_tracks.h"

namespace mcvo::pipeline_internal {
namespace {

using testing::DriveSpec;
using testing::DriveTrajectory;
using testing::LandmarkOptions;
using testing::LandmarksAroundPath;
using testing::LoadPresetRig;
using testing::MakeRigTracks;
using testing::SyntheticRigTracks;
using testing::TrackOptions;

// The rig's tracks along `world_from_rig` (0.5 px noise), landmarks around the path.
SyntheticRigTracks TracksAlong(const Rig& rig, const std::vector<Rigid3d>& world_from_rig,
                               bool cross_camera) {
  TrackOptions track_options;
  track_options.pixel_noise_px = 0.5;
  track_options.cross_camera = cross_camera;
  return MakeRigTracks(rig, world_from_rig, LandmarksAroundPath(world_from_rig, LandmarkOptions()),
                       track_options);
}

// 20 frames straight, a 90-degree corner over 30 frames, then straight; 0.6 m a frame.
SyntheticRigTracks Drive(const Rig& rig, int frames, bool cross_camera) {
  DriveSpec spec;
  spec.num_frames = frames;
  spec.step_m = 0.6;
  spec.straight_frames = 20;
  spec.turn_deg_per_frame = 3.0;
  spec.turn_frames = 30;
  spec.pitch_roll_wobble_deg = 0.3;
  spec.yaw_wobble_deg = 0.3;
  return TracksAlong(rig, DriveTrajectory(spec), cross_camera);
}

PipelineOptions Options() {
  PipelineOptions options;
  options.initializer.max_relative_scale_sigma = 0.02;  // as the kitti360 configs
  return options;
}

OdometryOutput RunStage(const Rig& rig, const std::vector<RigFrameObservations>& frames,
                        const PipelineOptions& options) {
  OdometryStage stage(rig, options, 2);
  for (const RigFrameObservations& frame : frames) stage.Add(frame, 0.0);
  return stage.Finish();
}

TEST(OdometryStageTest, AfterEveryCameraIsBlackedOutTheNewSegmentContinuesWhereTheRigWent) {
  const Rig rig = LoadPresetRig("kitti360");
  SyntheticRigTracks truth = Drive(rig, 130, true);
  constexpr int kFirst = 80, kCount = 10;  // on the straight after the corner
  for (int f = kFirst; f < kFirst + kCount; ++f) {
    for (size_t c = 0; c < truth.frames[f].cameras.size(); ++c) {
      truth.frames[f].cameras[c].clear();
      truth.frames[f].camera_missing[c] = true;
    }
    truth.frames[f].cross_camera.clear();
  }
  const OdometryOutput out = RunStage(rig, truth.frames, Options());
  EXPECT_EQ(out.segments, 2);
  int links = 0;
  for (const ScaleLogEntry& e : out.scale_log) links += e.event == "link" ? 1 : 0;
  EXPECT_EQ(links, 1);
  // Every frame with images is posed: the new segment's initialisation
  // window is completed back to the blackout by the reverse pass.
  for (int f = 0; f < static_cast<int>(truth.frames.size()); ++f) {
    const bool dark = f >= kFirst && f < kFirst + kCount;
    EXPECT_EQ(out.poses.count(f) != 0, !dark) << "frame " << f;
  }
  // Aligned at frame 0 (no fitting), the frames after the blackout are where
  // the rig was: the link predicts 11 frames (6.6 m) of straight driving.
  // Without it the new segment would start at the last pose before the
  // blackout, 6 m behind.
  const Rigid3d gt_from_est = truth.world_from_rig[0] * out.poses.at(0).world_from_body.Inverse();
  for (int f = kFirst + kCount; f < static_cast<int>(truth.frames.size()); f += 5) {
    const double error =
        ((gt_from_est * out.poses.at(f).world_from_body).translation - truth.world_from_rig[f].translation)
            .norm();
    EXPECT_LT(error, 1.0) << "frame " << f;
  }
  // Keyframes and landmarks of both segments are in the same world.
  ASSERT_FALSE(out.keyframes.empty());
  for (const KeyframeEstimate& kf : out.keyframes) {
    const double error =
        ((gt_from_est * kf.world_from_rig).translation - truth.world_from_rig[kf.frame_index].translation)
            .norm();
    EXPECT_LT(error, 1.0) << "keyframe " << kf.frame_index;
  }
}

// One camera: the segment after the blackout initialises in a unit of its
// own; the link scales it to continue the previous segment's speed, so the
// whole trajectory has one unit (the rig drives at a constant 0.6 m a frame).
TEST(OdometryStageTest, MonocularSegmentsAreLinkedAtTheSpeedOfTheOneBefore) {
  Rig rig = LoadPresetRig("kitti360_stereo");
  rig.cameras.resize(1);
  rig.cameras[0].cam_from_rig.translation.setZero();
  SyntheticRigTracks truth = Drive(rig, 130, false);
  constexpr int kFirst = 80, kCount = 10;
  for (int f = kFirst; f < kFirst + kCount; ++f) {
    truth.frames[f].cameras[0].clear();
    truth.frames[f].camera_missing[0] = true;
  }
  const OdometryOutput out = RunStage(rig, truth.frames, Options());
  ASSERT_EQ(out.segments, 2);
  double applied = 0.0;
  for (const ScaleLogEntry& e : out.scale_log) {
    if (e.event != "link") continue;
    EXPECT_NE(e.note.find("scaled by"), std::string::npos) << e.note;
    applied = e.applied_ratio;
  }
  // Units per metre: estimated over true distance, before and after the blackout.
  auto units_per_metre = [&](int a, int b) {
    return (out.poses.at(b).world_from_body.translation - out.poses.at(a).world_from_body.translation)
               .norm() /
           (truth.world_from_rig[b].translation - truth.world_from_rig[a].translation).norm();
  };
  const double before = units_per_metre(55, 79), after = units_per_metre(95, 129);
  std::printf("one camera: %.4f units/m before the blackout, %.4f after (link scaled by %.4f)\n", before,
              after, applied);
  EXPECT_NEAR(after / before, 1.0, 0.05);
}

TEST(OdometryStageTest, FallbackInitialisesWhenNoWindowMeetsTheStrictBound) {
  // Three cameras without overlap: the scale comes from the corner only; a
  // bound no window can meet leaves the sequence unposed, and the fallback
  // runs it again with max_relative_scale_sigma_fallback.
  const Rig rig = LoadPresetRig("kitti360_3cam");
  // 60 frames: the 20-frame straight, the 30-frame corner and 10 after it
  // (every initialiser pass over a sequence that never initialises costs:
  // this test makes three).
  const SyntheticRigTracks truth = Drive(rig, 60, false);
  PipelineOptions options = Options();
  options.initializer.max_relative_scale_sigma = 1e-4;
  options.initializer.max_relative_scale_sigma_fallback = 0.05;
  const OdometryOutput out = RunStage(rig, truth.frames, options);
  EXPECT_EQ(out.fallback_sigma, 0.05);
  EXPECT_GE(out.poses.size(), 59u);
  bool noted = false;
  for (const ScaleLogEntry& e : out.scale_log) {
    if (e.event == "init") noted = e.note.find("offline fallback") != std::string::npos;
  }
  EXPECT_TRUE(noted);

  // Fallback off (and the monocular one, the last resort after it): nothing posed.
  options.initializer.max_relative_scale_sigma_fallback = 0.0;
  options.initializer.monocular_fallback = false;
  const OdometryOutput off = RunStage(rig, truth.frames, options);
  EXPECT_EQ(off.fallback_sigma, 0.0);
  EXPECT_TRUE(off.poses.empty());
}

// A drive that never turns: a rig's metric scale is observable only from
// cross-camera matches. Without any (three cameras, matching off as in
// config/kitti360_3cam.json) nothing is posed in the first pass, the
// overlap start at once is not tried (it reads cross-camera matches only:
// that pass would repeat the first), and the monocular fallback poses the
// frames: two passes. With them (the 4-camera rig standing still: no
// motion to initialise from, fewer failed windows than the overlap start
// waits for) the pass with the overlap start at once poses the frames.
TEST(OdometryStageTest, OverlapStartAtOnceRunsOnlyWhereCamerasOverlap) {
  DriveSpec straight;  // no turn, no wobble: the scale of a rig without overlap is not observable
  straight.num_frames = 30;
  straight.step_m = 0.6;
  const Rig apart = LoadPresetRig("kitti360_3cam");
  const OdometryOutput mono =
      RunStage(apart, TracksAlong(apart, DriveTrajectory(straight), false).frames, Options());
  EXPECT_EQ(mono.passes, 2);
  EXPECT_GE(mono.monocular_camera, 0);
  EXPECT_GE(mono.poses.size(), 25u);

  const Rig overlapping = LoadPresetRig("kitti360");
  DriveSpec still = straight;  // standing
  still.step_m = 0.0;
  const OdometryOutput metric =
      RunStage(overlapping, TracksAlong(overlapping, DriveTrajectory(still), true).frames, Options());
  EXPECT_EQ(metric.passes, 2);
  EXPECT_EQ(metric.monocular_camera, -1);
  EXPECT_GE(metric.poses.size(), 25u);
}

}  // namespace
}  // namespace mcvo::pipeline_internal
