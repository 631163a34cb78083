// RPE and scale drift on trajectories with hand-computable errors.
#include <gtest/gtest.h>

#include <algorithm>

#include "eval/trajectory_fixtures.h"
#include "mcvo/eval/evaluate.h"
#include "mcvo/eval/rpe.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

using testing::kPi;
using testing::MakeTrajectory;

// 101 poses along +x, 1 m apart (path 100 m), identity rotations; the
// estimate travels `est_per_m` metres per true metre and yaws by
// `yaw_per_m` rad per metre.
void StraightLine(double est_per_m, double yaw_per_m, Trajectory* gt, Trajectory* est) {
  *gt = MakeTrajectory(
      101, [](int k) { return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(k, 0, 0)); });
  *est = MakeTrajectory(101, [&](int k) {
    return Rigid3d(So3Exp(Eigen::Vector3d(0.0, 0.0, yaw_per_m * k)), Eigen::Vector3d(est_per_m * k, 0, 0));
  });
}

TEST(Rpe, ConstantScaleDriftOnStraightLine) {
  // 1 % too long: a segment of D metres has est_i^-1 est_j = (I, (1.01 D, 0, 0)),
  // gt (I, (D, 0, 0)), E = (I, (0.01 D, 0, 0)): |t(E)| = 0.01 D.
  // d = 10 m: for i = 0 .. 90 the end is j = i + 10 (D = 10, error 0.1 m,
  // 1 % of d). Near the end the closest pose is the last one: i = 91 gives
  // D = 9 and i = 92 gives D = 8, both within 20 % of d and so accepted (0.9
  // and 0.8 % of d); i = 93 (D = 7) is not. 93 segments, mean error
  // (91 * 0.1 + 0.09 + 0.08) / 93 m.
  Trajectory gt, est;
  StraightLine(1.01, 0.0, &gt, &est);
  EvalOptions options;
  options.align = AlignmentMode::kNone;
  options.rpe_lengths_m = {10.0, 20.0};
  const EvalResult result = EvaluateTrajectory(gt, est, options);
  ASSERT_TRUE(result.rpe.computed);
  ASSERT_EQ(result.rpe.lengths.size(), 2u);
  const RpeLengthResult& ten = result.rpe.lengths[0];
  EXPECT_EQ(ten.translation_m.count, 93u);
  EXPECT_NEAR(ten.translation_m.mean, (91 * 0.1 + 0.09 + 0.08) / 93.0, 1e-12);
  EXPECT_NEAR(ten.translation_percent.max, 1.0, 1e-10);
  EXPECT_NEAR(ten.translation_percent.median, 1.0, 1e-10);
  EXPECT_NEAR(ten.translation_percent.min, 0.8, 1e-10);
  EXPECT_NEAR(ten.rotation_deg.max, 0.0, 1e-12);
  EXPECT_FALSE(ten.length_percent.has_value());
  // d = 20 m: i = 0 .. 80 exact (81 segments at 1 %), then D = 19, 18, 17, 16
  // (0.95, 0.9, 0.85, 0.8 %): 85 segments, mean (81 + 3.5) / 85 %.
  const RpeLengthResult& twenty = result.rpe.lengths[1];
  EXPECT_EQ(twenty.translation_m.count, 85u);
  EXPECT_NEAR(twenty.translation_percent.mean, (81.0 + 3.5) / 85.0, 1e-10);
  // The average over lengths is the mean of the two per-length means.
  EXPECT_NEAR(result.rpe.average.translation_percent, 0.5 * ((91.0 + 1.7) / 93.0 + (81.0 + 3.5) / 85.0),
              1e-10);
  EXPECT_EQ(result.rpe.average.num_lengths, 2u);
  // Scale drift: every segment's est / gt distance is 1.01 (truncated ones
  // too: the ratio uses the actual distances); the Sim3 scale is
  // 1 / 1.01, so the normalised ratio is 1 and the scale error 1 %.
  EXPECT_NEAR(ten.scale_ratio.min, 1.01, 1e-12);
  EXPECT_NEAR(ten.scale_ratio.max, 1.01, 1e-12);
  EXPECT_NEAR(ten.scale_ratio_sim3_normalized.mean, 1.0, 1e-12);
  ASSERT_TRUE(result.scale.available);
  EXPECT_NEAR(result.scale.sim3_scale, 1.0 / 1.01, 1e-12);
  EXPECT_NEAR(result.scale.scale_error_percent, 1.0, 1e-9);

  // Default lengths: 10 .. 50 % of the 100 m path = 10 .. 50 m; the full-length
  // segments (the majority, so the median) are at 1 %.
  options.rpe_lengths_m.clear();
  const EvalResult by_percent = EvaluateTrajectory(gt, est, options);
  ASSERT_EQ(by_percent.rpe.lengths.size(), 5u);
  EXPECT_NEAR(by_percent.gt_matched_path_length_m, 100.0, 1e-12);
  for (size_t l = 0; l < 5; ++l) {
    EXPECT_NEAR(by_percent.rpe.lengths[l].length_m, 10.0 * (l + 1), 1e-12);
    EXPECT_NEAR(*by_percent.rpe.lengths[l].length_percent, 10.0 * (l + 1), 1e-12);
    EXPECT_NEAR(by_percent.rpe.lengths[l].translation_percent.median, 1.0, 1e-10);
    EXPECT_NEAR(by_percent.rpe.lengths[l].translation_percent.max, 1.0, 1e-10);
  }

  // sim3 alignment scales the estimate by 1 / 1.01: the drift is gone. The
  // positions are collinear (a line), which the result says.
  options.align = AlignmentMode::kSim3;
  const EvalResult sim3 = EvaluateTrajectory(gt, est, options);
  EXPECT_TRUE(sim3.alignment_collinear);
  EXPECT_LT(sim3.rpe.average.translation_percent, 1e-9);
  EXPECT_LT(sim3.ate_translation_m.max, 1e-9);
}

TEST(Rpe, ConstantHeadingDrift) {
  // Yaw drift 0.002 rad per metre, positions exact: over d = 10 m the
  // relative rotation error is 0.02 rad = 1.14591559 deg, 0.114591559 deg/m
  // (the truncated segments at the end, D = 9 and 8 m, have less).
  Trajectory gt, est;
  StraightLine(1.0, 0.002, &gt, &est);
  EvalOptions options;
  options.align = AlignmentMode::kNone;
  options.rpe_lengths_m = {10.0};
  const EvalResult result = EvaluateTrajectory(gt, est, options);
  const RpeLengthResult& ten = result.rpe.lengths[0];
  const double expected_deg = 0.02 * 180.0 / kPi;
  EXPECT_NEAR(ten.rotation_deg.median, expected_deg, 1e-9);
  EXPECT_NEAR(ten.rotation_deg.max, expected_deg, 1e-9);
  EXPECT_NEAR(ten.rotation_deg.min, 0.8 * expected_deg, 1e-9);
  EXPECT_NEAR(ten.rotation_deg_per_m.max, expected_deg / 10.0, 1e-10);
}

TEST(Rpe, LengthLongerThanPathHasNoSegments) {
  Trajectory gt, est;
  StraightLine(1.0, 0.0, &gt, &est);
  EvalOptions options;
  options.align = AlignmentMode::kNone;
  options.rpe_lengths_m = {10.0, 500.0};
  const EvalResult result = EvaluateTrajectory(gt, est, options);
  EXPECT_EQ(result.rpe.lengths[1].translation_m.count, 0u);
  EXPECT_EQ(result.rpe.average.num_lengths, 1u);
  EXPECT_FALSE(result.notes.empty());
}

std::vector<std::pair<size_t, size_t>> Segments(const std::vector<double>& xs, double d) {
  std::vector<Rigid3d> poses;
  std::vector<Eigen::Vector3d> positions;
  for (double x : xs) {
    poses.emplace_back(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, 0, 0));
    positions.emplace_back(x, 0, 0);
  }
  std::vector<std::pair<size_t, size_t>> out;
  for (const RpeSegment& s : ComputeRpeSegments(poses, poses, positions, d, 0.2))
    out.emplace_back(s.start, s.end);
  return out;
}

using PairList = std::vector<std::pair<size_t, size_t>>;

TEST(Rpe, EndPoseSelection) {
  // Steps of 3 m, d = 10: from 0 the candidates are 9 (off by 1) and 12 (off
  // by 2): 9 wins. From 3: 12 vs 15 -> 12. From 6: only 15 (9 m) -> ok. From 9:
  // 15 is 6 m away, outside 10 +- 2.
  EXPECT_EQ(Segments({0, 3, 6, 9, 12, 15}, 10.0), (PairList{{0, 3}, {1, 4}, {2, 5}}));
  // Steps of 7 m: 7 is off by 3 > 2 (20 % of 10) and 14 by 4: nothing.
  EXPECT_EQ(Segments({0, 7, 14}, 10.0), PairList{});
  // Tie (8 and 12 are both 2 m off, and 2 <= 2 is accepted): the smaller index.
  EXPECT_EQ(Segments({0, 8, 12}, 10.0), (PairList{{0, 1}}));
  // Standing still: among equal distances the first pose.
  EXPECT_EQ(Segments({0, 0, 10, 10, 20}, 10.0), (PairList{{0, 2}, {1, 2}, {2, 4}, {3, 4}}));
  EXPECT_EQ(Segments({0, 9, 9, 13}, 10.0), (PairList{{0, 1}}));
}

TEST(LocalScale, WindowsFollowAScaleThatChangesHalfway) {
  // 101 poses 1 m apart along +x; the estimate steps 1.02 m for the first
  // 50 and 0.99 m after. Windows of 20 poses: [0,20], [20,40] at 1.02,
  // [40,60] straddles (10 * 1.02 + 10 * 0.99) / 20, [60,80], [80,100] at
  // 0.99; no aligned window of 20 poses fits after 100.
  const Trajectory gt = MakeTrajectory(
      101, [](int k) { return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(k, 0, 0)); });
  const Trajectory est = MakeTrajectory(101, [](int k) {
    const double x = k <= 50 ? 1.02 * k : 1.02 * 50 + 0.99 * (k - 50);
    return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, 0, 0));
  });
  EvalOptions options;
  options.align = AlignmentMode::kNone;
  options.local_scale_window = 20;
  const EvalResult result = EvaluateTrajectory(gt, est, options);
  const LocalScaleResult& local = result.local_scale;
  ASSERT_EQ(local.ratios.size(), 5u);
  EXPECT_NEAR(local.ratios[0], 1.02, 1e-12);
  EXPECT_NEAR(local.ratios[1], 1.02, 1e-12);
  EXPECT_NEAR(local.ratios[2], 1.005, 1e-12);
  EXPECT_NEAR(local.ratios[3], 0.99, 1e-12);
  EXPECT_NEAR(local.ratios[4], 0.99, 1e-12);
  EXPECT_NEAR(local.worst_deviation_percent, 2.0, 1e-9);
  EXPECT_NEAR(local.median_deviation_percent, 1.0, 1e-9);
  EXPECT_EQ(local.windows_skipped, 0u);
}

TEST(LocalScale, ShortWindowsAreSkippedAndAlignmentScaleRemoved) {
  // Standing still for the first 40 poses, then 1 m per pose; the estimate
  // is the truth at twice the size. With sim3 the global factor 2 is
  // removed: every counted ratio is 1. Windows of 20 poses whose ends are
  // under 5 m apart ([0,20], [20,40]) are skipped.
  const Trajectory gt = MakeTrajectory(81, [](int k) {
    return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(std::max(0, k - 40), 0.1 * k, 0));
  });
  const Trajectory est = MakeTrajectory(81, [](int k) {
    return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(2.0 * std::max(0, k - 40), 0.2 * k, 0));
  });
  EvalOptions options;
  options.align = AlignmentMode::kSim3;
  options.local_scale_window = 20;
  options.local_scale_min_distance_m = 5.0;
  const EvalResult result = EvaluateTrajectory(gt, est, options);
  const LocalScaleResult& local = result.local_scale;
  EXPECT_EQ(local.windows_skipped, 2u);
  ASSERT_EQ(local.ratios.size(), 2u);
  for (double ratio : local.ratios) EXPECT_NEAR(ratio, 1.0, 1e-9);
  EXPECT_LT(local.worst_deviation_percent, 1e-7);

  options.local_scale_window = 0;
  EXPECT_THROW(EvaluateTrajectory(gt, est, options), UsageError);
}

}  // namespace
}  // namespace mcvo
