#include <gtest/gtest.h>

#include "eval/trajectory_fixtures.h"
#include "mcvo/eval/associate.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

using testing::MakeTrajectory;

Trajectory AtTimesMs(const std::vector<double>& times_ms) {
  Trajectory trajectory;
  trajectory.has_time = true;
  for (double t : times_ms) {
    StampedPose pose;
    pose.t_ns = static_cast<int64_t>(std::llround(t * 1e6));
    trajectory.poses.push_back(pose);
  }
  return trajectory;
}

TEST(Associate, NearestWithinToleranceOneToOne) {
  // gt at 100 Hz: 0, 10, ..., 990 ms. est at 20 Hz shifted by +3 ms: the
  // nearest gt of 50 k + 3 ms is 50 k ms (3 ms away, the next is 7 ms away).
  std::vector<double> gt_ms, est_ms;
  for (int k = 0; k < 100; ++k) gt_ms.push_back(10.0 * k);
  for (int k = 0; k < 20; ++k) est_ms.push_back(50.0 * k + 3.0);
  est_ms.push_back(1500.0);  // 510 ms after the last gt: unmatched
  const Association a =
      AssociatePoses(AtTimesMs(gt_ms), AtTimesMs(est_ms), AssociationOptions(), "gt", "est");
  ASSERT_EQ(a.pairs.size(), 20u);
  for (size_t k = 0; k < 20; ++k) {
    EXPECT_EQ(a.pairs[k].est_index, k);
    EXPECT_EQ(a.pairs[k].gt_index, 5 * k);
  }
  EXPECT_EQ(a.num_est_unmatched, 1u);
  EXPECT_EQ(a.num_gt_unmatched, 80u);
  EXPECT_EQ(a.max_abs_dt_ns, 3000000);
}

TEST(Associate, OffsetOutsideToleranceMatchesNothing) {
  // est 12 ms after every gt pose of a 40 ms grid: |dt| >= 12 ms > 10 ms.
  const Association a =
      AssociatePoses(AtTimesMs({0, 40, 80}), AtTimesMs({12, 52, 92}), AssociationOptions(), "gt", "est");
  EXPECT_TRUE(a.pairs.empty());
  EXPECT_EQ(a.num_est_unmatched, 3u);
  // With a 15 ms tolerance all match.
  AssociationOptions wide;
  wide.max_dt_s = 0.015;
  EXPECT_EQ(AssociatePoses(AtTimesMs({0, 40, 80}), AtTimesMs({12, 52, 92}), wide, "gt", "est").pairs.size(),
            3u);
}

TEST(Associate, ToleranceIsInclusive) {
  EXPECT_EQ(AssociatePoses(AtTimesMs({0}), AtTimesMs({10}), AssociationOptions(), "gt", "est").pairs.size(),
            1u);
  EXPECT_EQ(
      AssociatePoses(AtTimesMs({0}), AtTimesMs({10.000001}), AssociationOptions(), "gt", "est").pairs.size(),
      0u);
}

TEST(Associate, GreedyByTimeDifferenceAndTieBreaking) {
  // gt 0 and 10 ms; est 4 and 5 ms. Candidates by |dt|: (4: e0-g0), (5: e1-g0),
  // (5: e1-g1), (6: e0-g1). e0 takes g0; e1 cannot, takes g1.
  const Association a =
      AssociatePoses(AtTimesMs({0, 10}), AtTimesMs({4, 5}), AssociationOptions(), "gt", "est");
  ASSERT_EQ(a.pairs.size(), 2u);
  EXPECT_EQ(a.pairs[0].gt_index, 0u);
  EXPECT_EQ(a.pairs[1].gt_index, 1u);
  // Exactly between two gt poses: the smaller gt index.
  const Association tie =
      AssociatePoses(AtTimesMs({0, 10}), AtTimesMs({5}), AssociationOptions(), "gt", "est");
  ASSERT_EQ(tie.pairs.size(), 1u);
  EXPECT_EQ(tie.pairs[0].gt_index, 0u);
  // Two est poses equally near one gt pose and nothing else: the smaller est index wins.
  const Association shared =
      AssociatePoses(AtTimesMs({100}), AtTimesMs({95, 105}), AssociationOptions(), "gt", "est");
  ASSERT_EQ(shared.pairs.size(), 1u);
  EXPECT_EQ(shared.pairs[0].est_index, 0u);
  EXPECT_EQ(shared.num_est_unmatched, 1u);
}

TEST(Associate, ByFrameIndex) {
  // gt has frames 0, 2, 4, ..., 18 (KITTI-360 poses.txt style), est 0..9.
  Trajectory gt;
  gt.has_frame_index = true;
  for (int k = 0; k < 10; ++k) {
    StampedPose pose;
    pose.frame_index = 2 * k;
    gt.poses.push_back(pose);
  }
  Trajectory est;
  est.has_frame_index = true;
  for (int k = 0; k < 10; ++k) {
    StampedPose pose;
    pose.frame_index = k;
    est.poses.push_back(pose);
  }
  AssociationOptions options;
  options.mode = AssociationMode::kIndex;
  const Association a = AssociatePoses(gt, est, options, "gt", "est");
  ASSERT_EQ(a.pairs.size(), 5u);  // frames 0, 2, 4, 6, 8
  for (size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(a.pairs[k].gt_index, k);
    EXPECT_EQ(a.pairs[k].est_index, 2 * k);
  }
  EXPECT_EQ(a.num_gt_unmatched, 5u);
  EXPECT_EQ(a.num_est_unmatched, 5u);

  // A trajectory without frame indices uses its pose order.
  Trajectory ordered = AtTimesMs({0, 1, 2, 3});
  const Association by_order = AssociatePoses(gt, ordered, options, "gt", "est");
  ASSERT_EQ(by_order.pairs.size(), 2u);  // order 0 and 2
  EXPECT_EQ(by_order.pairs[1].est_index, 2u);
  EXPECT_EQ(by_order.pairs[1].gt_index, 1u);

  // Duplicate frame index: an error naming the file.
  est.poses[3].frame_index = 2;
  try {
    AssociatePoses(gt, est, options, "gt.txt", "est.txt");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("est.txt"), std::string::npos);
  }
}

TEST(Associate, TimeModeNeedsTimeStamps) {
  Trajectory no_time;
  no_time.poses.resize(3);
  EXPECT_THROW(AssociatePoses(AtTimesMs({0}), no_time, AssociationOptions(), "gt", "est"), InputError);
  AssociationOptions bad;
  bad.max_dt_s = -1.0;
  EXPECT_THROW(AssociatePoses(AtTimesMs({0}), AtTimesMs({0}), bad, "gt", "est"), UsageError);
}

}  // namespace
}  // namespace mcvo
