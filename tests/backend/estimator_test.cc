// The sliding-window estimator on synthetic rig tracks (tests/initializer/
// synthetic_rig_tracks.h): a car-like drive with a corner, landmarks on
// facades, the ground and clutter, Gaussian pixel noise.
#include "mcvo/backend/estimator.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "initializer/synthetic_rig_tracks.h"

namespace mcvo {
namespace {

using testing::DriveSpec;
using testing::DriveTrajectory;
using testing::LandmarkOptions;
using testing::LandmarksAroundPath;
using testing::LoadPresetRig;
using testing::MakeRigTracks;
using testing::SyntheticRigTracks;
using testing::TrackOptions;

struct RunOutput {
  std::map<int, Rigid3d> poses;  // frame index -> latest pose
  std::vector<FrameEstimate> frames;
  std::vector<ScaleLogEntry> scale_log;
  std::vector<KeyframeEstimate> keyframes;       // every keyframe, as it left the estimator
  std::map<int64_t, Eigen::Vector3d> landmarks;  // final positions (latest per id)
};

// The kitti360 presets of config/ accept an initial scale known to 2 % (the
// back end refines it); the initializer's own default is stricter.
InitializerOptions PipelineInitOptions() {
  InitializerOptions init_options;
  init_options.max_relative_scale_sigma = 0.02;
  return init_options;
}

RunOutput RunEstimator(const Rig& rig, const std::vector<RigFrameObservations>& frames,
                       const BackendOptions& options, int threads,
                       const InitializerOptions& init_options = PipelineInitOptions()) {
  Estimator estimator(rig, init_options, options, threads);
  RunOutput out;
  for (const RigFrameObservations& frame : frames) {
    FrameEstimate estimate = estimator.AddFrame(frame);
    for (const PoseUpdate& update : estimate.poses) out.poses[update.frame_index] = update.world_from_rig;
    out.frames.push_back(std::move(estimate));
    for (auto& e : estimator.TakeScaleLog()) out.scale_log.push_back(e);
    for (auto& kf : estimator.TakeFinishedKeyframes()) out.keyframes.push_back(std::move(kf));
    for (const MapLandmark& lm : estimator.TakeFinishedLandmarks()) out.landmarks[lm.id] = lm.position_world;
  }
  double init = 0, pnp = 0, ba = 0, marg = 0, scale = 0;
  for (const FrameEstimate& f : out.frames) {
    init += f.seconds_initializer;
    pnp += f.seconds_pnp;
    ba += f.seconds_ba;
    marg += f.seconds_marginalization;
    scale += f.seconds_scale;
  }
  std::printf("seconds: init %.2f pnp %.2f ba %.2f marg %.2f scale %.2f\n", init, pnp, ba, marg, scale);
  for (auto& kf : estimator.Finish()) out.keyframes.push_back(std::move(kf));
  for (const MapLandmark& lm : estimator.TakeFinishedLandmarks()) out.landmarks[lm.id] = lm.position_world;
  for (auto& e : estimator.TakeScaleLog()) out.scale_log.push_back(e);
  return out;
}

// A 150-frame drive: 20 frames into a 90-degree left city corner (3 deg per
// frame over 30 frames at 0.6 m per frame, an 11.5 m radius), then straight;
// 0.6 m per frame (6 m/s at 10 Hz, 90 m).
SyntheticRigTracks Drive(const Rig& rig, double noise_px, bool cross_camera, int num_frames = 150) {
  DriveSpec spec;
  spec.num_frames = num_frames;
  spec.step_m = 0.6;
  spec.straight_frames = 20;
  spec.turn_deg_per_frame = 3.0;
  spec.turn_frames = 30;
  spec.pitch_roll_wobble_deg = 0.3;
  spec.yaw_wobble_deg = 0.3;
  const std::vector<Rigid3d> world_from_rig = DriveTrajectory(spec);
  LandmarkOptions landmark_options;
  const std::vector<Eigen::Vector3d> landmarks = LandmarksAroundPath(world_from_rig, landmark_options);
  TrackOptions track_options;
  track_options.pixel_noise_px = noise_px;
  track_options.cross_camera = cross_camera;
  return MakeRigTracks(rig, world_from_rig, landmarks, track_options);
}

struct Accuracy {
  int posed = 0;
  double rmse_m = 0.0;
  double max_m = 0.0;
  double path_m = 0.0;
  double scale_ratio = 0.0;  // estimated path / true path over the posed frames
};

// Errors after aligning the estimate's world to the truth at the first
// posed frame (no fitting: the drift shows in full).
Accuracy Measure(const RunOutput& out, const SyntheticRigTracks& truth) {
  Accuracy acc;
  if (out.poses.empty()) return acc;
  const int first = out.poses.begin()->first;
  const Rigid3d gt_from_est = truth.world_from_rig[first] * out.poses.begin()->second.Inverse();
  double sum = 0.0, est_path = 0.0;
  std::optional<Eigen::Vector3d> last_gt, last_est;
  for (const auto& [frame, pose] : out.poses) {
    const Eigen::Vector3d est = (gt_from_est * pose).translation;
    const Eigen::Vector3d gt = truth.world_from_rig[frame].translation;
    const double e = (est - gt).norm();
    sum += e * e;
    acc.max_m = std::max(acc.max_m, e);
    if (last_gt) {
      acc.path_m += (gt - *last_gt).norm();
      est_path += (est - *last_est).norm();
    }
    last_gt = gt;
    last_est = est;
    ++acc.posed;
  }
  acc.rmse_m = std::sqrt(sum / acc.posed);
  acc.scale_ratio = acc.path_m > 0 ? est_path / acc.path_m : 0.0;
  return acc;
}

TEST(EstimatorTest, FourCameraRigTracksACornerAtMetricScale) {
  const Rig rig = LoadPresetRig("kitti360");
  const SyntheticRigTracks truth = Drive(rig, 0.5, /*cross_camera=*/true);
  const RunOutput out = RunEstimator(rig, truth.frames, BackendOptions(), 2);
  const Accuracy acc = Measure(out, truth);
  std::printf("4-cam: %d posed, rmse %.3f m, max %.3f m over %.1f m, scale %.4f\n", acc.posed, acc.rmse_m,
              acc.max_m, acc.path_m, acc.scale_ratio);
  ASSERT_FALSE(out.scale_log.empty());
  EXPECT_EQ(out.scale_log.front().event, "init");
  // Initialised within the first 20 frames (the stereo pair gives the scale
  // on the straight), every later frame posed.
  EXPECT_GE(acc.posed, 130);
  EXPECT_LT(acc.rmse_m, 0.01 * acc.path_m);
  EXPECT_NEAR(acc.scale_ratio, 1.0, 0.01);
  for (const FrameEstimate& f : out.frames) EXPECT_EQ(f.segment, 0);
}

TEST(EstimatorTest, ThreeCamerasWithoutOverlapGetScaleFromTheCorner) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  const SyntheticRigTracks truth = Drive(rig, 0.5, /*cross_camera=*/false);
  const RunOutput out = RunEstimator(rig, truth.frames, BackendOptions(), 2);
  const Accuracy acc = Measure(out, truth);
  std::printf("3-cam: %d posed, rmse %.3f m, max %.3f m over %.1f m, scale %.4f\n", acc.posed, acc.rmse_m,
              acc.max_m, acc.path_m, acc.scale_ratio);
  // The straight approach cannot give the scale: it initialises in the corner.
  ASSERT_GE(acc.posed, 90);
  // One corner is all this drive has to hold the scale: it is as good as
  // the initialisation's (accepted at an estimated 2 % std, so up to ~3 x
  // that), and the straight afterwards cannot improve it. Measured: 3.4 %,
  // rmse 1.4 m over 80 m. A wrong scale source or a broken back end gives
  // tens of percent.
  EXPECT_LT(acc.rmse_m, 0.03 * acc.path_m);
  EXPECT_NEAR(acc.scale_ratio, 1.0, 0.06);
}

TEST(EstimatorTest, IdenticalResultsAtOneAndTwoThreadsAndOnASecondRun) {
  const Rig rig = LoadPresetRig("kitti360");
  const SyntheticRigTracks truth = Drive(rig, 0.5, true, 80);
  const RunOutput a = RunEstimator(rig, truth.frames, BackendOptions(), 1);
  const RunOutput b = RunEstimator(rig, truth.frames, BackendOptions(), 2);
  const RunOutput c = RunEstimator(rig, truth.frames, BackendOptions(), 2);
  ASSERT_FALSE(a.poses.empty());
  for (const RunOutput* other : {&b, &c}) {
    ASSERT_EQ(a.poses.size(), other->poses.size());
    for (const auto& [frame, pose] : a.poses) {
      const Rigid3d& q = other->poses.at(frame);
      EXPECT_EQ(pose.translation, q.translation) << frame;
      EXPECT_EQ(pose.rotation.coeffs(), q.rotation.coeffs()) << frame;
    }
  }
}

TEST(EstimatorTest, ContinuesWhenACameraIsBlackedOut) {
  const Rig rig = LoadPresetRig("kitti360");
  SyntheticRigTracks truth = Drive(rig, 0.5, true);
  for (int f = 60; f < 100; ++f) {
    truth.frames[f].cameras[2].clear();
    truth.frames[f].camera_missing[2] = true;
    auto& cross = truth.frames[f].cross_camera;
    cross.erase(
        std::remove_if(cross.begin(), cross.end(),
                       [](const CrossCameraObservation& x) { return x.camera_a == 2 || x.camera_b == 2; }),
        cross.end());
  }
  const RunOutput out = RunEstimator(rig, truth.frames, BackendOptions(), 2);
  const Accuracy acc = Measure(out, truth);
  std::printf("blackout: %d posed, rmse %.3f m over %.1f m\n", acc.posed, acc.rmse_m, acc.path_m);
  EXPECT_GE(acc.posed, 130);
  for (const FrameEstimate& f : out.frames) EXPECT_EQ(f.segment, 0) << f.frame_index;
  EXPECT_LT(acc.rmse_m, 0.02 * acc.path_m);
}

TEST(EstimatorTest, AllCamerasLostStartsANewSegmentAndInitialisesAgain) {
  const Rig rig = LoadPresetRig("kitti360");
  SyntheticRigTracks truth = Drive(rig, 0.5, true);
  for (int f = 70; f < 73; ++f) {
    for (size_t c = 0; c < truth.frames[f].cameras.size(); ++c) {
      truth.frames[f].cameras[c].clear();
      truth.frames[f].camera_missing[c] = true;
    }
    truth.frames[f].cross_camera.clear();
  }
  const RunOutput out = RunEstimator(rig, truth.frames, BackendOptions(), 2);
  int lost = 0, reinit = 0;
  for (const ScaleLogEntry& e : out.scale_log) {
    lost += e.event == "lost" ? 1 : 0;
    reinit += e.event == "reinit" ? 1 : 0;
  }
  EXPECT_EQ(lost, 1);
  EXPECT_EQ(reinit, 1);
  EXPECT_EQ(out.frames.back().segment, 1);
  EXPECT_EQ(out.frames.back().state, EstimatorState::kTracking);
  EXPECT_TRUE(out.frames.back().has_pose);
}

// One camera (monocular, estimator.h "Monocular"): it initialises at an
// arbitrary scale that then holds (the scale gauge), and three losses of
// every feature (frames 70-72, 100-102, 130-132) each start a segment that
// initialises again: a frame whose pose fails goes back to the pool (it once
// leaked, and the second loss with a full window aborted the run).
TEST(EstimatorTest, OneCameraHoldsItsArbitraryScaleAndSurvivesRepeatedLosses) {
  Rig rig = LoadPresetRig("kitti360_stereo");
  rig.cameras.resize(1);
  rig.cameras[0].cam_from_rig.translation.setZero();
  SyntheticRigTracks truth = Drive(rig, 0.5, false);
  for (int start : {70, 100, 130}) {
    for (int f = start; f < start + 3; ++f) {
      truth.frames[f].cameras[0].clear();
      truth.frames[f].camera_missing[0] = true;
    }
  }
  const RunOutput out = RunEstimator(rig, truth.frames, BackendOptions(), 2);
  int lost = 0, init = 0, corrections = 0;
  for (const ScaleLogEntry& e : out.scale_log) {
    lost += e.event == "lost" ? 1 : 0;
    init += e.event == "init" || e.event == "reinit" ? 1 : 0;
    corrections += e.event == "correction" ? 1 : 0;
    if (e.event == "init") {
      EXPECT_NE(e.note.find("arbitrary scale"), std::string::npos) << e.note;
    }
  }
  EXPECT_EQ(lost, 3);
  EXPECT_EQ(init, 4);
  EXPECT_EQ(corrections, 0);
  EXPECT_TRUE(out.frames.back().has_pose);
  // The first segment (to frame 69, through the corner): the estimated
  // distance per true metre is the same in its first and second half.
  std::vector<int> first_segment;
  for (const FrameEstimate& f : out.frames) {
    if (f.has_pose && f.segment == 0 && out.poses.count(f.frame_index) != 0) first_segment.push_back(f.frame_index);
  }
  ASSERT_GE(first_segment.size(), 50u);
  auto ratio = [&](size_t a, size_t b) {
    const int fa = first_segment[a], fb = first_segment[b];
    return (out.poses.at(fb).translation - out.poses.at(fa).translation).norm() /
           (truth.world_from_rig[fb].translation - truth.world_from_rig[fa].translation).norm();
  };
  const size_t mid = first_segment.size() / 2, last = first_segment.size() - 1;
  const double early = ratio(0, mid), late = ratio(mid, last);
  std::printf("one camera: units per metre %.4f (frames %d-%d), %.4f (frames %d-%d)\n", early, first_segment[0],
              first_segment[mid], late, first_segment[mid], first_segment[last]);
  EXPECT_NEAR(late / early, 1.0, 0.03);
}

TEST(EstimatorTest, ScaleCorrectionIsLoggedAndChangesTheState) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  const SyntheticRigTracks truth = Drive(rig, 0.5, false);
  BackendOptions with;
  with.scale_correction_period = 5;
  with.scale_correction_min_change = 0.0;  // apply every observable correction
  BackendOptions without;
  without.scale_correction_period = 0;
  const RunOutput a = RunEstimator(rig, truth.frames, with, 2);
  const RunOutput b = RunEstimator(rig, truth.frames, without, 2);
  int corrections = 0, applied = 0;
  for (const ScaleLogEntry& e : a.scale_log) {
    if (e.event != "correction") continue;
    ++corrections;
    if (e.applied) {
      ++applied;
      EXPECT_EQ(e.camera_scales.size(), 3u);
    } else {
      EXPECT_FALSE(e.note.empty());
    }
  }
  for (const ScaleLogEntry& e : b.scale_log) EXPECT_NE(e.event, "correction");
  EXPECT_GT(corrections, 5);
  ASSERT_GT(applied, 0);
  // Applied corrections change the estimate.
  bool differs = false;
  for (const auto& [frame, pose] : a.poses) {
    auto it = b.poses.find(frame);
    if (it != b.poses.end() && (it->second.translation - pose.translation).norm() > 1e-9) differs = true;
  }
  EXPECT_TRUE(differs);
  const Accuracy acc = Measure(a, truth);
  std::printf("3-cam with corrections: rmse %.3f m over %.1f m, scale %.4f; %d/%d applied\n", acc.rmse_m,
              acc.path_m, acc.scale_ratio, applied, corrections);
  EXPECT_NEAR(acc.scale_ratio, 1.0, 0.06);
}

// The sparse map (keyframe observations and final landmark positions) of a
// 4-camera drive agrees with the truth it was made from.
TEST(EstimatorTest, SparseMapOfKeyframesAndLandmarksMatchesTheTruth) {
  const Rig rig = LoadPresetRig("kitti360");
  const SyntheticRigTracks truth = Drive(rig, 0.5, /*cross_camera=*/true);
  const RunOutput out = RunEstimator(rig, truth.frames, BackendOptions(), 2);
  ASSERT_FALSE(out.keyframes.empty());
  ASSERT_GT(out.landmarks.size(), 500u);
  // Keyframes in frame order, each once; the estimate's world is the rig at
  // the first initialisation frame: compare in the truth's world.
  const int first = out.poses.begin()->first;
  const Rigid3d gt_from_est = truth.world_from_rig[first] * out.poses.begin()->second.Inverse();
  std::set<int> seen;
  size_t observations = 0, matched = 0;
  std::vector<double> errors;
  for (const KeyframeEstimate& kf : out.keyframes) {
    EXPECT_TRUE(seen.insert(kf.frame_index).second) << kf.frame_index;
    for (const MapObservation& ob : kf.observations) {
      ++observations;
      ASSERT_GE(ob.camera, 0);
      ASSERT_LT(ob.camera, rig.NumCameras());
      // The observation is the input's pixel of that feature in that camera,
      // or of its cross-camera match in that camera (another camera's feature).
      const RigFrameObservations& input = truth.frames[kf.frame_index];
      const auto& features = input.cameras[ob.camera];
      const bool in_input =
          std::any_of(features.begin(), features.end(),
                      [&](const FeatureObservation& f) {
                        return static_cast<int64_t>(f.id) == ob.landmark_id && (f.pixel - ob.pixel).norm() == 0.0;
                      }) ||
          std::any_of(input.cross_camera.begin(), input.cross_camera.end(), [&](const CrossCameraObservation& x) {
            return x.camera_b == ob.camera && static_cast<int64_t>(x.id) == ob.landmark_id &&
                   (x.pixel_b - ob.pixel).norm() == 0.0;
          });
      EXPECT_TRUE(in_input);
      auto lm = out.landmarks.find(ob.landmark_id);
      if (lm == out.landmarks.end()) continue;
      ++matched;
    }
  }
  for (const auto& [id, position] : out.landmarks) {
    auto f = truth.features.find(static_cast<uint64_t>(id));
    ASSERT_NE(f, truth.features.end());
    errors.push_back(((gt_from_est * position) - truth.landmarks[f->second.landmark]).norm());
  }
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  std::printf(
      "map: %zu keyframes, %zu observations (%zu of landmarks with a position), %zu landmarks, "
      "median error %.3f m\n",
      out.keyframes.size(), observations, matched, out.landmarks.size(), median);
  EXPECT_GT(observations, 1000u);
  // Measured: 81 % of the observations are of landmarks with a final
  // position (the others lost theirs after the keyframe left: too few
  // observations, outliers), median error 0.16 m for landmarks 3-40 m away
  // (0.5 px noise). A map in the wrong frame or from wrong ids is off by metres.
  EXPECT_GT(matched, observations * 7 / 10);
  EXPECT_LT(median, 0.3);
}

// Four city corners (3 deg per frame over 30 frames, alternating left and
// right) with straights between, no overlap: the initial scale comes from
// the first corner; every later corner gives a scale measurement (the rig BA
// of the window without the prior) that is fused with it.
TEST(EstimatorTest, ScaleCorrectionsOverLaterCornersReduceTheScaleError) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  testing::DriveSpec spec;
  spec.step_m = 0.6;
  spec.pitch_roll_wobble_deg = 0.3;
  spec.yaw_wobble_deg = 0.3;
  const std::vector<Rigid3d> world_from_rig = testing::LegsTrajectory(
      spec, {{20, 0}, {30, 3}, {60, 0}, {30, -3}, {60, 0}, {30, 3}, {60, 0}, {30, -3}, {40, 0}});
  const std::vector<Eigen::Vector3d> landmarks = LandmarksAroundPath(world_from_rig, LandmarkOptions());
  TrackOptions track_options;
  track_options.pixel_noise_px = 0.5;
  track_options.cross_camera = false;
  const SyntheticRigTracks truth = MakeRigTracks(rig, world_from_rig, landmarks, track_options);
  BackendOptions without;
  without.scale_correction_period = 0;
  const Accuracy a = Measure(RunEstimator(rig, truth.frames, without, 2), truth);
  const RunOutput out = RunEstimator(rig, truth.frames, BackendOptions(), 2);
  const Accuracy b = Measure(out, truth);
  std::printf("without corrections: rmse %.3f m, scale %.4f; with: rmse %.3f m, scale %.4f over %.1f m\n",
              a.rmse_m, a.scale_ratio, b.rmse_m, b.scale_ratio, a.path_m);
  int applied = 0;
  double previous_sigma = 0.0;
  for (const ScaleLogEntry& e : out.scale_log) {
    if (e.event == "init") previous_sigma = e.scale_sigma;
    if (e.event != "correction" || !e.applied) continue;
    ++applied;
    // A fused measurement shrinks the uncertainty it was fused into.
    EXPECT_GT(e.gain, 0.0);
    EXPECT_LT(e.gain, 1.0);
    EXPECT_NEAR(std::log(e.applied_ratio), e.gain * std::log(e.measured_ratio), 1e-9);
    EXPECT_GT(e.scale_sigma, 0.0);
    previous_sigma = e.scale_sigma;
  }
  EXPECT_GT(previous_sigma, 0.0);
  // One correction per later corner. Measured: scale 0.9915 -> 0.9965,
  // rmse 0.80 -> 0.51 m over 206 m.
  EXPECT_GE(applied, 2);
  EXPECT_LT(std::abs(b.scale_ratio - 1.0), std::abs(a.scale_ratio - 1.0));
  EXPECT_LT(b.rmse_m, a.rmse_m);
}

}  // namespace
}  // namespace mcvo
