// Hand-computed evaluation cases. Each expected number is derived in the
// comment above the check.
#include <cmath>

#include <gtest/gtest.h>

#include "eval/trajectory_fixtures.h"
#include "mcvo/eval/evaluate.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

using testing::Helix;
using testing::kPi;
using testing::MakeTrajectory;
using testing::Transformed;

EvalOptions WithAlign(AlignmentMode mode) {
  EvalOptions options;
  options.align = mode;
  return options;
}

TEST(Evaluate, PureOffset) {
  // est = gt + (1, 2, 2): |offset| = 3 for every pose.
  const Trajectory gt = Helix(100);
  const Trajectory est =
      Transformed(gt, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1.0, 2.0, 2.0)));

  // align none: ATE = 3 exactly (rmse = mean = median = min = max), std 0, rotation 0.
  const EvalResult none = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kNone));
  EXPECT_EQ(none.association.pairs.size(), 100u);
  EXPECT_EQ(none.ate_translation_m.count, 100u);
  EXPECT_NEAR(none.ate_translation_m.rmse, 3.0, 1e-12);
  EXPECT_NEAR(none.ate_translation_m.mean, 3.0, 1e-12);
  EXPECT_NEAR(none.ate_translation_m.median, 3.0, 1e-12);
  EXPECT_NEAR(none.ate_translation_m.min, 3.0, 1e-12);
  EXPECT_NEAR(none.ate_translation_m.max, 3.0, 1e-12);
  EXPECT_NEAR(none.ate_translation_m.std, 0.0, 1e-12);
  EXPECT_NEAR(none.ate_rotation_deg.max, 0.0, 1e-9);
  EXPECT_EQ(none.num_alignment_poses, 0u);

  // align se3: the offset is a rigid motion, removed entirely.
  const EvalResult se3 = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kSe3));
  EXPECT_LT(se3.ate_translation_m.max, 1e-9);
  EXPECT_LT(se3.ate_rotation_deg.max, 1e-9);
  EXPECT_LT((se3.gt_world_from_est_world.translation - Eigen::Vector3d(-1.0, -2.0, -2.0)).norm(), 1e-9);
  EXPECT_EQ(se3.num_alignment_poses, 100u);
}

TEST(Evaluate, KnownRotationOfTheWholeTrajectory) {
  // est = Rz(90 deg) * gt. The helix has |p_xy| = 10 for every pose and the
  // rotation leaves z alone, so |p - Rz p| = 2 sin(45 deg) * 10 = 10 sqrt(2).
  // Rotation error: R_est^T R_gt = R_gt^T Rz^T R_gt, a 90 degree rotation.
  const Trajectory gt = Helix(100);
  const Rigid3d rz(So3Exp(Eigen::Vector3d(0.0, 0.0, kPi / 2.0)), Eigen::Vector3d::Zero());
  const Trajectory est = Transformed(gt, rz);

  const EvalResult none = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kNone));
  EXPECT_NEAR(none.ate_translation_m.min, 10.0 * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(none.ate_translation_m.max, 10.0 * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(none.ate_rotation_deg.min, 90.0, 1e-9);
  EXPECT_NEAR(none.ate_rotation_deg.max, 90.0, 1e-9);

  const EvalResult se3 = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kSe3));
  EXPECT_LT(se3.ate_translation_m.max, 1e-9);
  EXPECT_LT(se3.ate_rotation_deg.max, 1e-7);
}

TEST(Evaluate, KnownScale) {
  // est positions = 1.25 gt positions (the estimate is 25 % too large).
  // sim3: gt = s est with s = 0.8; est_scale_factor = 1 / s = 1.25;
  // scale_error_percent = 100 |1.25 - 1| = 25 (and signed +25).
  const Trajectory gt = Helix(100);
  const Trajectory est = Transformed(gt, Rigid3d(), 1.25);

  const EvalResult sim3 = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kSim3));
  EXPECT_NEAR(sim3.gt_world_from_est_world.scale, 0.8, 1e-12);
  ASSERT_TRUE(sim3.scale.available);
  EXPECT_NEAR(sim3.scale.sim3_scale, 0.8, 1e-12);
  EXPECT_NEAR(sim3.scale.est_scale_factor, 1.25, 1e-12);
  EXPECT_NEAR(sim3.scale.scale_error_percent, 25.0, 1e-9);
  EXPECT_NEAR(sim3.scale.scale_error_signed_percent, 25.0, 1e-9);
  EXPECT_LT(sim3.ate_translation_m.max, 1e-9);
  // RPE on the scaled estimate: nothing left.
  ASSERT_TRUE(sim3.rpe.computed);
  EXPECT_LT(sim3.rpe.average.translation_percent, 1e-9);
  // Scale drift: raw ratio 1.25 on every segment, 1 after the Sim3 scale.
  for (const RpeLengthResult& length : sim3.rpe.lengths) {
    ASSERT_GT(length.scale_ratio.count, 0u);
    EXPECT_NEAR(length.scale_ratio.min, 1.25, 1e-9);
    EXPECT_NEAR(length.scale_ratio.max, 1.25, 1e-9);
    EXPECT_NEAR(length.scale_ratio_sim3_normalized.mean, 1.0, 1e-9);
  }

  // se3: cov = 1.25 * (positive definite scatter of gt) so R = I and
  // t = mu_gt - 1.25 mu_gt; the error of pose k is
  // |p_k - 1.25 p_k + 0.25 mu| = 0.25 |p_k - mu|.
  const EvalResult se3 = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kSe3));
  Eigen::Vector3d mu = Eigen::Vector3d::Zero();
  for (const StampedPose& p : gt.poses) mu += p.world_from_body.translation;
  mu /= 100.0;
  double sum_sq = 0.0;
  for (const StampedPose& p : gt.poses)
    sum_sq += std::pow(0.25 * (p.world_from_body.translation - mu).norm(), 2);
  EXPECT_NEAR(se3.ate_translation_m.rmse, std::sqrt(sum_sq / 100.0), 1e-9);
  EXPECT_LT(se3.ate_rotation_deg.max, 1e-7);
  // The scale report does not depend on --align.
  EXPECT_NEAR(se3.scale.sim3_scale, 0.8, 1e-12);
  EXPECT_NEAR(se3.scale.scale_error_percent, 25.0, 1e-9);
}

TEST(Evaluate, DeterministicNoiseWithKnownStats) {
  // Offsets of norm 3 (even k) and 4 (odd k) in varying directions, and
  // rotation errors of 1 deg (even) and 2 deg (odd) about the body x axis.
  // align none. Translation: rmse = sqrt((9 + 16) / 2) = sqrt(12.5),
  // mean = median = 3.5, population std = 0.5, min 3, max 4.
  // Rotation: rmse = sqrt((1 + 4) / 2) = sqrt(2.5), mean 1.5, std 0.5.
  const Trajectory gt = Helix(100);
  Trajectory est = gt;
  for (int k = 0; k < 100; ++k) {
    const double r = k % 2 == 0 ? 3.0 : 4.0;
    const double deg = k % 2 == 0 ? 1.0 : 2.0;
    Rigid3d& pose = est.poses[k].world_from_body;
    pose.translation += r * Eigen::Vector3d(std::cos(0.7 * k), std::sin(0.7 * k), 0.0);
    pose.rotation = pose.rotation * So3Exp(Eigen::Vector3d(deg * kPi / 180.0, 0.0, 0.0));
  }
  const EvalResult result = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kNone));
  EXPECT_NEAR(result.ate_translation_m.rmse, std::sqrt(12.5), 1e-12);
  EXPECT_NEAR(result.ate_translation_m.mean, 3.5, 1e-12);
  EXPECT_NEAR(result.ate_translation_m.median, 3.5, 1e-12);
  EXPECT_NEAR(result.ate_translation_m.std, 0.5, 1e-12);
  EXPECT_NEAR(result.ate_translation_m.min, 3.0, 1e-12);
  EXPECT_NEAR(result.ate_translation_m.max, 4.0, 1e-12);
  EXPECT_NEAR(result.ate_rotation_deg.rmse, std::sqrt(2.5), 1e-9);
  EXPECT_NEAR(result.ate_rotation_deg.mean, 1.5, 1e-9);
  EXPECT_NEAR(result.ate_rotation_deg.std, 0.5, 1e-9);
  // Per-pose errors in pair order.
  ASSERT_EQ(result.pose_errors.size(), 100u);
  EXPECT_NEAR(result.pose_errors[0].translation_m, 3.0, 1e-12);
  EXPECT_NEAR(result.pose_errors[1].translation_m, 4.0, 1e-12);
  EXPECT_NEAR(result.pose_errors[1].rotation_deg, 2.0, 1e-9);
}

TEST(Evaluate, PosYawRecoversYawAndTranslation) {
  // est = (Rz(0.7), (5, -3, 2)) * gt: posyaw removes it exactly and reports
  // gt_world_from_est_world = its inverse.
  const Trajectory gt = Helix(100);
  const Rigid3d est_from_gt(So3Exp(Eigen::Vector3d(0.0, 0.0, 0.7)), Eigen::Vector3d(5.0, -3.0, 2.0));
  const EvalResult result =
      EvaluateTrajectory(gt, Transformed(gt, est_from_gt), WithAlign(AlignmentMode::kPosYaw));
  EXPECT_LT(result.ate_translation_m.max, 1e-9);
  EXPECT_LT(result.ate_rotation_deg.max, 1e-7);
  const Rigid3d expected = est_from_gt.Inverse();
  EXPECT_LT((result.gt_world_from_est_world.translation - expected.translation).norm(), 1e-9);
  EXPECT_LT(RotationAngle(result.gt_world_from_est_world.rotation.conjugate() * expected.rotation), 1e-12);
  EXPECT_EQ(result.gt_world_from_est_world.scale, 1.0);

  // A roll of the estimate cannot be removed by posyaw (but se3 can).
  const Rigid3d roll(So3Exp(Eigen::Vector3d(0.2, 0.0, 0.0)), Eigen::Vector3d::Zero());
  EXPECT_GT(
      EvaluateTrajectory(gt, Transformed(gt, roll), WithAlign(AlignmentMode::kPosYaw)).ate_rotation_deg.min,
      1.0);
  EXPECT_LT(
      EvaluateTrajectory(gt, Transformed(gt, roll), WithAlign(AlignmentMode::kSe3)).ate_rotation_deg.max,
      1e-7);
}

TEST(Evaluate, AlignOnFirstPoses) {
  // est = gt for k < 10, gt + (0, 0, 1) after. Aligning on the first 10
  // poses gives the identity, so the later poses keep their full 1 m error.
  const Trajectory gt = Helix(100);
  Trajectory est = gt;
  for (int k = 10; k < 100; ++k) est.poses[k].world_from_body.translation.z() += 1.0;
  EvalOptions options = WithAlign(AlignmentMode::kSe3);
  options.align_num_poses = 10;
  const EvalResult result = EvaluateTrajectory(gt, est, options);
  EXPECT_EQ(result.num_alignment_poses, 10u);
  EXPECT_NEAR(result.ate_translation_m.min, 0.0, 1e-9);
  EXPECT_NEAR(result.ate_translation_m.max, 1.0, 1e-9);
  // rmse = sqrt(90 / 100).
  EXPECT_NEAR(result.ate_translation_m.rmse, std::sqrt(0.9), 1e-9);
}

TEST(Evaluate, StartEndDiscrepancyOfClosedLoop) {
  // gt: a circle of radius 10 m in 100 chords of length c = 20 sin(pi / 100),
  // returning to its start (101 poses). est: the same, except pose k > 50
  // is lifted by 0.02 (k - 50) m, so its last pose is 1 m above its first.
  // est path = 50 c + 50 sqrt(c^2 + 0.02^2); est percent = 100 * 1 / path.
  const auto circle = [](int k) {
    const double a = 2.0 * kPi * k / 100.0;
    return Rigid3d(Eigen::Quaterniond::Identity(),
                   Eigen::Vector3d(10.0 * std::cos(a), 10.0 * std::sin(a), 0.0));
  };
  const Trajectory gt = MakeTrajectory(101, circle);
  Trajectory est = gt;
  for (int k = 51; k <= 100; ++k) est.poses[k].world_from_body.translation.z() += 0.02 * (k - 50);
  const EvalResult result = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kNone));
  const double c = 20.0 * std::sin(kPi / 100.0);
  const double est_path = 50.0 * c + 50.0 * std::sqrt(c * c + 0.0004);
  EXPECT_NEAR(result.start_end.est_distance_m, 1.0, 1e-12);
  EXPECT_NEAR(result.start_end.est_path_length_m, est_path, 1e-9);
  ASSERT_TRUE(result.start_end.est_percent.has_value());
  EXPECT_NEAR(*result.start_end.est_percent, 100.0 / est_path, 1e-9);
  EXPECT_NEAR(result.start_end.gt_distance_m, 0.0, 1e-12);
  EXPECT_NEAR(result.start_end.gt_path_length_m, 100.0 * c, 1e-9);
  ASSERT_TRUE(result.start_end.gt_percent.has_value());
  EXPECT_NEAR(*result.start_end.gt_percent, 0.0, 1e-12);
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Evaluate, InputErrorsNameTheFile) {
  const Trajectory gt = Helix(20);
  // No pose within 10 ms: est starts 1000 s later.
  const Trajectory late = MakeTrajectory(20, testing::HelixPose, 100000000, 1001000000000);
  const std::string no_match =
      ErrorOf([&] { EvaluateTrajectory(gt, late, EvalOptions(), "gt.tum", "est.tum"); });
  EXPECT_NE(no_match.find("est.tum"), std::string::npos) << no_match;
  EXPECT_NE(no_match.find("no pose matches"), std::string::npos) << no_match;

  // Two matches: enough for none, not for se3 / sim3.
  Trajectory two = gt;
  two.poses.resize(2);
  const std::string few = ErrorOf([&] { EvaluateTrajectory(gt, two, EvalOptions(), "gt.tum", "est.tum"); });
  EXPECT_NE(few.find("se3 alignment needs at least 3"), std::string::npos) << few;
  EXPECT_NO_THROW(EvaluateTrajectory(gt, two, WithAlign(AlignmentMode::kNone)));

  // NaN.
  Trajectory nan = gt;
  nan.poses[5].world_from_body.translation.y() = std::nan("");
  const std::string nan_error =
      ErrorOf([&] { EvaluateTrajectory(gt, nan, EvalOptions(), "gt.tum", "est.tum"); });
  EXPECT_NE(nan_error.find("est.tum: pose 5"), std::string::npos) << nan_error;

  // Empty.
  EXPECT_THROW(EvaluateTrajectory(gt, Trajectory(), EvalOptions()), InputError);
}

TEST(Evaluate, StepRpeSeesOnePoseThatJumps) {
  // gt: 20 poses 1 m apart along x, identity rotations. est = gt with pose 7
  // displaced by (0, 0.3, 0.4) (0.5 m). align none. Only the two steps that
  // touch pose 7 have an error, |t(E)| = 0.5 each (the relative motions are
  // translations): 19 steps, rmse sqrt(2 * 0.25 / 19), max 0.5, median 0.
  const auto line = [](int k) { return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(k, 0.0, 0.0)); };
  const Trajectory gt = MakeTrajectory(20, line);
  const Trajectory est = MakeTrajectory(20, [&line](int k) {
    Rigid3d pose = line(k);
    if (k == 7) pose.translation += Eigen::Vector3d(0.0, 0.3, 0.4);
    return pose;
  });
  const EvalResult result = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kNone));
  const ErrorStats& step = result.rpe.step.translation_m;
  EXPECT_EQ(step.count, 19u);
  EXPECT_NEAR(step.rmse, std::sqrt(2.0 * 0.25 / 19.0), 1e-12);
  EXPECT_NEAR(step.max, 0.5, 1e-12);
  EXPECT_NEAR(step.median, 0.0, 1e-12);
  EXPECT_NEAR(result.rpe.step.rotation_deg.max, 0.0, 1e-9);
  // The same trajectory without the jump: no step error.
  const EvalResult clean = EvaluateTrajectory(gt, gt, WithAlign(AlignmentMode::kNone));
  EXPECT_NEAR(clean.rpe.step.translation_m.max, 0.0, 1e-12);
  // A rotation of 2 deg about z between poses 3 and 4 of the estimate only:
  // from pose 4 on every pose turned by it (and moved with it); one step has
  // an error of 2 deg.
  const Trajectory turned = MakeTrajectory(20, [&line](int k) {
    return k < 4 ? line(k)
                 : Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(2.0 * kPi / 180.0, Eigen::Vector3d::UnitZ())),
                           Eigen::Vector3d(k, 0.0, 0.0));
  });
  const EvalResult rotated = EvaluateTrajectory(gt, turned, WithAlign(AlignmentMode::kNone));
  EXPECT_NEAR(rotated.rpe.step.rotation_deg.max, 2.0, 1e-9);
  EXPECT_NEAR(rotated.rpe.step.rotation_deg.median, 0.0, 1e-9);
}

TEST(Evaluate, ZeroLengthGroundTruthSkipsRpe) {
  // gt stands still; est moves. align none (se3 would be undetermined).
  const Trajectory gt = MakeTrajectory(10, [](int) { return Rigid3d(); });
  const Trajectory est = Helix(10);
  const EvalResult result = EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kNone));
  EXPECT_FALSE(result.rpe.computed);
  EXPECT_FALSE(result.rpe.skipped_reason.empty());
  EXPECT_FALSE(result.notes.empty());
  EXPECT_FALSE(result.scale.available);  // the gt positions coincide
  EXPECT_EQ(result.ate_translation_m.count, 10u);
  EXPECT_EQ(result.rpe.step.translation_m.count, 9u);  // the step error needs no path length
  // se3 on a point-like gt is an input error, not a crash.
  EXPECT_THROW(EvaluateTrajectory(gt, est, WithAlign(AlignmentMode::kSe3)), InputError);
}

TEST(Evaluate, OptionsCheck) {
  EvalOptions options;
  EXPECT_NO_THROW(options.Check());
  options.align_num_poses = 2;  // se3 needs 3
  EXPECT_THROW(options.Check(), UsageError);
  options.align_num_poses = -1;
  EXPECT_THROW(options.Check(), UsageError);
  options = EvalOptions();
  options.rpe_length_tolerance = 1.5;
  EXPECT_THROW(options.Check(), UsageError);
  options = EvalOptions();
  options.rpe_lengths_m = {100.0, -1.0};
  EXPECT_THROW(options.Check(), UsageError);
  options = EvalOptions();
  options.rpe_length_percents = {0.0};
  EXPECT_THROW(options.Check(), UsageError);
  EXPECT_EQ(AlignmentModeFromName("posyaw"), AlignmentMode::kPosYaw);
  EXPECT_FALSE(AlignmentModeFromName("SE3").has_value());
}

}  // namespace
}  // namespace mcvo
