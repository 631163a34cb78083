// The reverse pass (backend/reverse_pass.h) on synthetic rig tracks: a rig
// without overlapping views drives straight before its first corner, where
// the forward estimator can only initialise; the reverse pass must pose the
// straight too, at the scale found in the corner.
#include "mcvo/backend/reverse_pass.h"

#include <cmath>
#include <map>
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

constexpr double kDeg = M_PI / 180.0;

Rigid3d RandomPose(int k) {
  const Eigen::Vector3d axis = Eigen::Vector3d(std::sin(1.3 * k), std::cos(0.7 * k), 0.5).normalized();
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * k, axis)),
                 Eigen::Vector3d(2.0 * k, std::sin(k) * 3.0, 0.2 * k * k));
}

TEST(AlignPosesSim3Test, RecoversAKnownSimilarity) {
  const Sim3d truth(1.7, Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, 3).normalized())),
                    Eigen::Vector3d(4, -5, 6));
  std::vector<Rigid3d> from, to;
  for (int k = 0; k < 8; ++k) {
    from.push_back(RandomPose(k));
    to.push_back(truth.TransformPose(from.back()));
  }
  double rms = -1.0;
  const Sim3d found = AlignPosesSim3(from, to, &rms);
  EXPECT_NEAR(found.scale, 1.7, 1e-9);
  EXPECT_LT(found.rotation.angularDistance(truth.rotation), 1e-9);
  EXPECT_LT((found.translation - truth.translation).norm(), 1e-8);
  EXPECT_LT(rms, 1e-8);
}

TEST(AlignPosesSim3Test, RotationAboutAStraightLineComesFromTheOrientations) {
  // Positions on one line leave the roll about it free; the orientations fix it.
  const Sim3d truth(0.9, Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX())),
                    Eigen::Vector3d(1, 2, 3));
  std::vector<Rigid3d> from, to;
  for (int k = 0; k < 6; ++k) {
    from.emplace_back(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * k, Eigen::Vector3d::UnitY())),
                      Eigen::Vector3d(1.5 * k, 0, 0));
    to.push_back(truth.TransformPose(from.back()));
  }
  const Sim3d found = AlignPosesSim3(from, to, nullptr);
  EXPECT_NEAR(found.scale, 0.9, 1e-9);
  EXPECT_LT(found.rotation.angularDistance(truth.rotation), 1e-9);
}

TEST(AlignPosesSim3Test, StandingStillKeepsScaleOne) {
  std::vector<Rigid3d> from(4, RandomPose(2)), to;
  for (const Rigid3d& pose : from) to.push_back(Rigid3d(pose.rotation, pose.translation + Eigen::Vector3d(1, 0, 0)));
  const Sim3d found = AlignPosesSim3(from, to, nullptr);
  EXPECT_DOUBLE_EQ(found.scale, 1.0);
  EXPECT_LT((found.translation - Eigen::Vector3d(1, 0, 0)).norm(), 1e-9);
}

// 60 frames straight, a 90-degree corner over 30 frames, 30 frames straight;
// 0.6 m per frame.
SyntheticRigTracks StraightThenCorner(const Rig& rig, int straight_frames) {
  DriveSpec spec;
  spec.num_frames = straight_frames + 60;
  spec.step_m = 0.6;
  spec.straight_frames = straight_frames;
  spec.turn_deg_per_frame = 3.0;
  spec.turn_frames = 30;
  spec.pitch_roll_wobble_deg = 0.3;
  spec.yaw_wobble_deg = 0.3;
  const std::vector<Rigid3d> world_from_rig = DriveTrajectory(spec);
  const std::vector<Eigen::Vector3d> landmarks = LandmarksAroundPath(world_from_rig, LandmarkOptions());
  TrackOptions track_options;
  track_options.pixel_noise_px = 0.5;
  track_options.cross_camera = false;
  return MakeRigTracks(rig, world_from_rig, landmarks, track_options);
}

struct Completed {
  std::map<int, Rigid3d> forward;
  ReversePassResult reverse;
};

Completed RunForwardAndReverse(const Rig& rig, const std::vector<RigFrameObservations>& frames,
                               const ReversePassOptions& reverse_options = ReversePassOptions()) {
  InitializerOptions init_options;
  init_options.max_relative_scale_sigma = 0.02;  // as config/kitti360_3cam.json
  const BackendOptions options;
  Estimator estimator(rig, init_options, options, 2);
  ReversePass reverse(rig, init_options, options, reverse_options, 2);
  Completed out;
  for (const RigFrameObservations& frame : frames) {
    const FrameEstimate estimate = estimator.AddFrame(frame);
    for (const PoseUpdate& update : estimate.poses) out.forward[update.frame_index] = update.world_from_rig;
    reverse.Add(frame, estimate);
    reverse.AddKeyframes(estimator.TakeFinishedKeyframes());
  }
  reverse.AddKeyframes(estimator.Finish());
  out.reverse = reverse.Run();
  return out;
}

// seeded: ReversePassOptions::seed_from_forward (step 1 of reverse_pass.h),
// else the reverse run's own initialisation, aligned (step 2).
void CheckStraightBeforeFirstCorner(bool seeded) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  const SyntheticRigTracks truth = StraightThenCorner(rig, 60);
  ReversePassOptions reverse_options;
  reverse_options.seed_from_forward = seeded;
  const Completed out = RunForwardAndReverse(rig, truth.frames, reverse_options);
  ASSERT_FALSE(out.forward.empty());
  const int first_forward = out.forward.begin()->first;
  std::printf("forward: first posed frame %d, %zu posed\n", first_forward, out.forward.size());
  // Without overlap, the straight cannot give the scale: the forward pass waits for the corner.
  ASSERT_GE(first_forward, 40);
  ASSERT_EQ(out.reverse.reports.size(), 1u);
  const ReversePassReport& report = out.reverse.reports.front();
  std::printf("reverse: %s\n", report.note.c_str());
  ASSERT_TRUE(report.applied) << report.note;
  EXPECT_EQ(report.seeded, seeded);
  EXPECT_EQ(report.first_posed_frame, first_forward);
  EXPECT_GE(report.overlap_poses, 5);
  EXPECT_EQ(report.reverse_init_frame, seeded ? first_forward : report.reverse_init_frame);
  // Every frame before the forward initialisation is posed.
  ASSERT_EQ(static_cast<int>(out.reverse.frames.size()), first_forward);
  EXPECT_EQ(out.reverse.frames.front().frame_index, 0);
  EXPECT_EQ(out.reverse.scale_log.size(), 1u);
  EXPECT_EQ(out.reverse.scale_log.front().event, "backfill");
  EXPECT_FALSE(out.reverse.keyframes.empty());
  for (const KeyframeEstimate& kf : out.reverse.keyframes) EXPECT_LT(kf.frame_index, first_forward);

  // Accuracy of the backfilled straight in the forward world, compared with
  // the truth aligned at the forward pass's first frame (no fitting): the
  // scale error of the corner (a few %) shows as drift along the straight.
  const Rigid3d gt_from_est = truth.world_from_rig[first_forward] * out.forward.at(first_forward).Inverse();
  double sum = 0.0, est_path = 0.0, gt_path = 0.0;
  std::optional<Eigen::Vector3d> last_est, last_gt;
  for (const BackfilledFrame& frame : out.reverse.frames) {
    const Eigen::Vector3d est = (gt_from_est * frame.world_from_rig).translation;
    const Eigen::Vector3d gt = truth.world_from_rig[frame.frame_index].translation;
    sum += (est - gt).squaredNorm();
    if (last_est) {
      est_path += (est - *last_est).norm();
      gt_path += (gt - *last_gt).norm();
    }
    last_est = est;
    last_gt = gt;
  }
  const double rmse = std::sqrt(sum / out.reverse.frames.size());
  std::printf("backfilled %zu frames: rmse %.3f m over %.1f m, scale %.4f\n", out.reverse.frames.size(), rmse,
              gt_path, est_path / gt_path);
  // A wrong alignment (rotation, direction of travel) gives tens of metres
  // here; a scale not applied back (the reverse world's own) a few percent.
  EXPECT_LT(rmse, 0.03 * gt_path);
  EXPECT_NEAR(est_path / gt_path, 1.0, 0.06);
  // The junction is continuous: the last backfilled frame is one step from the first forward one.
  const double junction =
      (out.reverse.frames.back().world_from_rig.translation - out.forward.at(first_forward).translation).norm();
  EXPECT_NEAR(junction, 0.6, 0.1);
  if (seeded) {
    // The forward segment's own scale over its first 20 frames (where the
    // seeds are) is what the straight gets: equal to within 1 %.
    const double forward_ratio =
        (out.forward.at(first_forward + 20).translation - out.forward.at(first_forward).translation).norm() /
        (truth.world_from_rig[first_forward + 20].translation - truth.world_from_rig[first_forward].translation)
            .norm();
    std::printf("forward scale over its first 20 frames %.4f\n", forward_ratio);
    EXPECT_NEAR(est_path / gt_path, forward_ratio, 0.01);
  }
}

TEST(ReversePassTest, PosesTheStraightBeforeTheFirstCornerFromTheForwardPoses) {
  CheckStraightBeforeFirstCorner(/*seeded=*/true);
}

TEST(ReversePassTest, PosesTheStraightBeforeTheFirstCornerFromItsOwnInitialisationAligned) {
  CheckStraightBeforeFirstCorner(/*seeded=*/false);
}

TEST(ReversePassTest, CompletesTheFramesAnOverlappingRigWaitedForParallaxOn) {
  // The 4-camera rig gets its scale from the stereo overlap on the straight,
  // but its initializer still waits for 30 px of parallax; the reverse pass
  // poses the frames it waited on.
  const Rig rig = LoadPresetRig("kitti360");
  const SyntheticRigTracks truth = StraightThenCorner(rig, 20);
  const Completed out = RunForwardAndReverse(rig, truth.frames);
  ASSERT_FALSE(out.forward.empty());
  const int first_forward = out.forward.begin()->first;
  ASSERT_GT(first_forward, 0);
  ASSERT_EQ(out.reverse.reports.size(), 1u);
  ASSERT_TRUE(out.reverse.reports.front().applied) << out.reverse.reports.front().note;
  ASSERT_EQ(static_cast<int>(out.reverse.frames.size()), first_forward);
  const Rigid3d gt_from_est = truth.world_from_rig[first_forward] * out.forward.at(first_forward).Inverse();
  for (const BackfilledFrame& frame : out.reverse.frames) {
    const double error = ((gt_from_est * frame.world_from_rig).translation -
                          truth.world_from_rig[frame.frame_index].translation)
                             .norm();
    // Odometry drift from the alignment frame: 3 % of the distance (0.6 m a frame), plus 5 cm.
    const double distance = 0.6 * (first_forward - frame.frame_index);
    EXPECT_LT(error, 0.05 + 0.03 * distance) << "frame " << frame.frame_index;
  }
}

TEST(ReversePassTest, AStraightThatNeverTurnsStaysUnposedWithAReason) {
  const Rig rig = LoadPresetRig("kitti360_3cam");
  SyntheticRigTracks truth = StraightThenCorner(rig, 60);
  truth.frames.resize(60);  // never reaches the corner
  const Completed out = RunForwardAndReverse(rig, truth.frames);
  EXPECT_TRUE(out.forward.empty());
  EXPECT_TRUE(out.reverse.frames.empty());
  EXPECT_TRUE(out.reverse.reports.empty());
}

}  // namespace
}  // namespace mcvo
