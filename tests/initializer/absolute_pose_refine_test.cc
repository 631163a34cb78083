// The window SfM's absolute pose refinement (src/initializer/
// absolute_pose_refine.h): from a pose off the truth it reaches the truth on
// exact bearings, uses only the rows it is given, and on noisy bearings ends
// at least as low in the tangent-plane error as the true pose (the least
// squares optimum is never above it).
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "../../src/initializer/absolute_pose_refine.h"
#include "../../src/initializer/bearing_residual.h"
#include "mcvo/geometry/so3.h"

namespace mcvo {
namespace {

using initializer_internal::RefineAbsolutePose;
using initializer_internal::TangentBasis;

constexpr double kFocal = 500.0;

Eigen::Vector3d RandomUnit(std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  return Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng)).normalized();
}

// Points all around a camera (fisheye-like: half behind it), 3-40 m away,
// and their exact bearings from world_from_cam.
struct Scene {
  Rigid3d world_from_cam;
  opengv::bearingVectors_t bearings;
  opengv::points_t points;
};

Scene MakeScene(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Scene s;
  s.world_from_cam = Rigid3d(So3Exp(2.0 * RandomUnit(rng)), 10.0 * RandomUnit(rng));
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d in_cam = (3.0 + 37.0 * uniform(*rng)) * RandomUnit(rng);
    s.points.push_back(s.world_from_cam * in_cam);
    s.bearings.push_back(in_cam.normalized());
  }
  return s;
}

Rigid3d Perturbed(const Rigid3d& pose, double angle, double shift, std::mt19937* rng) {
  return Rigid3d(pose.rotation * So3Exp(angle * RandomUnit(rng)), pose.translation + shift * RandomUnit(rng));
}

double RotationError(const Rigid3d& a, const Rigid3d& b) { return a.rotation.angularDistance(b.rotation); }

// Sum of squared tangent-plane errors (pixels at kFocal) over `rows`.
double Cost(const Scene& s, const std::vector<int>& rows, const Rigid3d& world_from_cam) {
  double sum = 0.0;
  for (const int i : rows) {
    const Eigen::Vector3d f = s.bearings[static_cast<size_t>(i)];
    const Eigen::Vector3d d = (world_from_cam.rotation.conjugate() *
                               (s.points[static_cast<size_t>(i)] - world_from_cam.translation))
                                  .normalized();
    sum += (kFocal * TangentBasis(f).transpose() * d).squaredNorm();
  }
  return sum;
}

std::vector<int> AllRows(size_t n) {
  std::vector<int> rows(n);
  for (size_t i = 0; i < n; ++i) rows[i] = static_cast<int>(i);
  return rows;
}

TEST(RefineAbsolutePose, ReachesTheTruthOnExactBearings) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const Scene s = MakeScene(30, &rng);
    const Rigid3d start = Perturbed(s.world_from_cam, 0.05, 0.5, &rng);
    const Rigid3d refined = RefineAbsolutePose(s.bearings, s.points, AllRows(s.points.size()), kFocal, start);
    ASSERT_GT(RotationError(start, s.world_from_cam), 1e-3);
    EXPECT_LT(RotationError(refined, s.world_from_cam), 1e-9) << "trial " << trial;
    EXPECT_LT((refined.translation - s.world_from_cam.translation).norm(), 1e-8) << "trial " << trial;
  }
}

// Rows outside `rows` (here gross outliers) take no part.
TEST(RefineAbsolutePose, UsesOnlyTheGivenRows) {
  std::mt19937 rng(6);
  Scene s = MakeScene(40, &rng);
  std::vector<int> rows;
  for (size_t i = 0; i < s.points.size(); ++i) {
    if (i % 4 == 3) {
      s.points[i] += 5.0 * RandomUnit(&rng);  // wrong by metres
    } else {
      rows.push_back(static_cast<int>(i));
    }
  }
  const Rigid3d start = Perturbed(s.world_from_cam, 0.03, 0.3, &rng);
  const Rigid3d refined = RefineAbsolutePose(s.bearings, s.points, rows, kFocal, start);
  EXPECT_LT(RotationError(refined, s.world_from_cam), 1e-9);
  EXPECT_LT((refined.translation - s.world_from_cam.translation).norm(), 1e-8);
  // With every row the outliers pull it away.
  const Rigid3d all = RefineAbsolutePose(s.bearings, s.points, AllRows(s.points.size()), kFocal, start);
  EXPECT_GT((all.translation - s.world_from_cam.translation).norm(), 1e-3);
}

// Bearings with 0.5 px of noise: the refined pose's cost is at most the true
// pose's (the optimum is below the truth) and under a twentieth of the start's;
// the pose
// is within what the noise allows.
TEST(RefineAbsolutePose, MinimisesTheTangentPlaneErrorOnNoisyBearings) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.5 / kFocal);
  for (int trial = 0; trial < 10; ++trial) {
    Scene s = MakeScene(60, &rng);
    for (Eigen::Vector3d& f : s.bearings)
      f = (f + TangentBasis(f) * Eigen::Vector2d(noise(rng), noise(rng))).normalized();
    const std::vector<int> rows = AllRows(s.points.size());
    const Rigid3d start = Perturbed(s.world_from_cam, 0.02, 0.2, &rng);
    const Rigid3d refined = RefineAbsolutePose(s.bearings, s.points, rows, kFocal, start);
    const double at_truth = Cost(s, rows, s.world_from_cam);
    EXPECT_LE(Cost(s, rows, refined), at_truth * (1.0 + 1e-9)) << "trial " << trial;
    EXPECT_LT(Cost(s, rows, refined), 0.05 * Cost(s, rows, start)) << "trial " << trial;
    EXPECT_LT(RotationError(refined, s.world_from_cam), 2e-3) << "trial " << trial;
    EXPECT_LT((refined.translation - s.world_from_cam.translation).norm(), 0.05) << "trial " << trial;
  }
}

TEST(RefineAbsolutePose, NoRowsLeavesTheStart) {
  std::mt19937 rng(8);
  const Scene s = MakeScene(10, &rng);
  const Rigid3d start = Perturbed(s.world_from_cam, 0.05, 0.5, &rng);
  const Rigid3d refined = RefineAbsolutePose(s.bearings, s.points, {}, kFocal, start);
  EXPECT_EQ(refined.rotation.coeffs(), start.rotation.coeffs());
  EXPECT_EQ(refined.translation, start.translation);
}

}  // namespace
}  // namespace mcvo
