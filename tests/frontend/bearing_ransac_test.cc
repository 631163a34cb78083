#include "mcvo/frontend/bearing_ransac.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace mcvo {
namespace {

struct Correspondences {
  std::vector<Eigen::Vector3d> prev, cur;
  std::vector<bool> is_outlier;
};

Eigen::Vector3d RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::Vector3d v(normal(rng), normal(rng), normal(rng));
  return v.normalized();
}

// Adds angular noise of about sigma_rad to a unit vector.
Eigen::Vector3d Perturb(const Eigen::Vector3d& f, double sigma_rad, std::mt19937& rng) {
  std::normal_distribution<double> normal(0.0, sigma_rad);
  return (f + Eigen::Vector3d(normal(rng), normal(rng), normal(rng))).normalized();
}

// Points all around a fisheye-like camera (up to 110 degrees off-axis, i.e.
// bearings with negative z), a relative motion cur_from_prev, small noise
// (0.2 px per axis at focal 460, about LK's accuracy) and `outlier_ratio` gross outliers: the current
// bearing is replaced by a random direction at least 3 degrees off the
// epipolar plane of the true motion.
Correspondences MakeCorrespondences(const Eigen::Matrix3d& r_cur_from_prev,
                                    const Eigen::Vector3d& t_cur_from_prev, int n, double outlier_ratio,
                                    uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Correspondences c;
  const double noise = 0.2 / 460.0;
  for (int i = 0; i < n; ++i) {
    // Direction within 110 degrees of +z, depth 2..40 m.
    Eigen::Vector3d dir;
    do {
      dir = RandomUnit(rng);
    } while (std::acos(dir.z()) > 110.0 * M_PI / 180.0);
    const Eigen::Vector3d point_in_prev = dir * (2.0 + 38.0 * uniform(rng));
    const Eigen::Vector3d point_in_cur = r_cur_from_prev * point_in_prev + t_cur_from_prev;
    c.prev.push_back(Perturb(point_in_prev.normalized(), noise, rng));
    const bool outlier = uniform(rng) < outlier_ratio;
    if (outlier) {
      // Epipolar plane normal in the current frame: t x (R f_prev).
      const Eigen::Vector3d normal = t_cur_from_prev.cross(r_cur_from_prev * point_in_prev).normalized();
      Eigen::Vector3d f;
      do {
        f = RandomUnit(rng);
      } while (std::abs(f.dot(normal)) < std::sin(3.0 * M_PI / 180.0));
      c.cur.push_back(f);
    } else {
      c.cur.push_back(Perturb(point_in_cur.normalized(), noise, rng));
    }
    c.is_outlier.push_back(outlier);
  }
  return c;
}

void ExpectSeparated(const Correspondences& c, const std::vector<bool>& inliers) {
  ASSERT_EQ(inliers.size(), c.prev.size());
  int outliers_kept = 0, inliers_kept = 0, inliers_total = 0;
  for (size_t i = 0; i < inliers.size(); ++i) {
    if (c.is_outlier[i]) {
      outliers_kept += inliers[i] ? 1 : 0;
    } else {
      ++inliers_total;
      inliers_kept += inliers[i] ? 1 : 0;
    }
  }
  EXPECT_EQ(outliers_kept, 0);
  EXPECT_GE(inliers_kept, 0.95 * inliers_total) << inliers_kept << " of " << inliers_total;
}

TEST(BearingRansacTest, ThresholdFromPixels) {
  const double threshold = BearingThresholdFromPixels(1.0, 460.0);
  EXPECT_NEAR(threshold, 0.5 / (460.0 * 460.0), 1e-9);  // 1 - cos(a) ~ a^2 / 2
}

TEST(BearingRansacTest, RejectsOutliersWideFieldOfView) {
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.08, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
  const Correspondences c = MakeCorrespondences(rotation, Eigen::Vector3d(0.3, -0.05, -1.0), 300, 0.3, 7);
  BearingRansacOptions options;
  ExpectSeparated(c, RansacRelativePoseInliers(c.prev, c.cur, options));
}

TEST(BearingRansacTest, RejectsOutliersUnderPureRotation) {
  // No translation: the essential matrix is degenerate, the rotation model
  // takes over. Outliers: random directions at least 3 degrees off the truth.
  std::mt19937 rng(11);
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Correspondences c;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d f = RandomUnit(rng);
    c.prev.push_back(f);
    const bool outlier = i % 10 < 3;
    Eigen::Vector3d g = rotation * f;
    if (outlier) {
      Eigen::Vector3d h;
      do {
        h = RandomUnit(rng);
      } while (h.dot(g) > std::cos(3.0 * M_PI / 180.0));
      g = h;
    }
    c.cur.push_back(Perturb(g, 0.2 / 460.0, rng));
    c.is_outlier.push_back(outlier);
  }
  ExpectSeparated(c, RansacRelativePoseInliers(c.prev, c.cur, BearingRansacOptions()));
}

TEST(BearingRansacTest, Deterministic) {
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Correspondences c = MakeCorrespondences(rotation, Eigen::Vector3d(1.0, 0.0, 0.2), 150, 0.3, 3);
  const std::vector<bool> first = RansacRelativePoseInliers(c.prev, c.cur, 1.0 / 460.0, 200);
  for (int run = 0; run < 3; ++run)
    EXPECT_EQ(RansacRelativePoseInliers(c.prev, c.cur, 1.0 / 460.0, 200), first);
}

TEST(BearingRansacTest, TooFewCorrespondencesKeepsAll) {
  const Correspondences c =
      MakeCorrespondences(Eigen::Matrix3d::Identity(), Eigen::Vector3d::UnitX(), 7, 0.5, 5);
  const std::vector<bool> inliers = RansacRelativePoseInliers(c.prev, c.cur, BearingRansacOptions());
  EXPECT_EQ(inliers, std::vector<bool>(7, true));
  EXPECT_TRUE(RansacRelativePoseInliers({}, {}, BearingRansacOptions()).empty());
}

// The rotation fit (the tracker's prediction): exact on a pure rotation,
// the rotation part within the noise when the camera barely translates
// relative to the depths, nothing from degenerate input.
TEST(BearingRansacTest, FitBearingRotationRecoversTheRotation) {
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, 1.0, -0.2).normalized()).toRotationMatrix();
  const Correspondences pure = MakeCorrespondences(rotation, Eigen::Vector3d::Zero(), 100, 0.0, 7);
  const auto fitted = FitBearingRotation(pure.prev, pure.cur);
  ASSERT_TRUE(fitted.has_value());
  const double error_rad = Eigen::AngleAxisd(*fitted * rotation.transpose()).angle();
  EXPECT_LT(error_rad, 0.1 / 460.0);  // 0.1 px at 460 px: the noise averaged over 100 bearings
  EXPECT_NEAR(fitted->determinant(), 1.0, 1e-12);

  // 5 cm of translation against depths of 2-40 m: within 0.5 deg.
  const Correspondences moved = MakeCorrespondences(rotation, Eigen::Vector3d(0.05, 0.0, 0.0), 100, 0.0, 8);
  const auto approximate = FitBearingRotation(moved.prev, moved.cur);
  ASSERT_TRUE(approximate.has_value());
  EXPECT_LT(Eigen::AngleAxisd(*approximate * rotation.transpose()).angle(), 0.5 * M_PI / 180.0);

  EXPECT_FALSE(FitBearingRotation({}, {}).has_value());
  const std::vector<Eigen::Vector3d> same(5, Eigen::Vector3d::UnitZ());
  EXPECT_FALSE(FitBearingRotation(same, same).has_value());  // rank 1: the roll about the ray is free
}

}  // namespace
}  // namespace mcvo
