#include <random>

#include <gtest/gtest.h>

#include "mcvo/geometry/so3.h"
#include "mcvo/geometry/umeyama.h"

namespace mcvo {
namespace {

std::vector<Eigen::Vector3d> RandomPoints(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-10.0, 10.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) points.emplace_back(uni(rng), uni(rng), uni(rng));
  return points;
}

std::vector<Eigen::Vector3d> Apply(const Sim3d& t, const std::vector<Eigen::Vector3d>& points) {
  std::vector<Eigen::Vector3d> out;
  for (const Eigen::Vector3d& p : points) out.push_back(t * p);
  return out;
}

void ExpectSim3Near(const Sim3d& a, const Sim3d& b, double tol) {
  EXPECT_NEAR(a.scale, b.scale, tol);
  EXPECT_LT(RotationAngle(a.rotation.conjugate() * b.rotation), tol);
  EXPECT_LT((a.translation - b.translation).norm(), tol * (1.0 + b.translation.norm()));
}

TEST(Umeyama, RecoversRandomSim3Exactly) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Sim3d truth(0.2 + 3.0 * (uni(rng) + 1.0),
                      So3Exp(3.0 * Eigen::Vector3d(uni(rng), uni(rng), uni(rng))),
                      50.0 * Eigen::Vector3d(uni(rng), uni(rng), uni(rng)));
    const std::vector<Eigen::Vector3d> src = RandomPoints(3 + trial, 100 + trial);
    UmeyamaInfo info;
    const std::optional<Sim3d> estimate =
        AlignUmeyama(src, Apply(truth, src), /*estimate_scale=*/true, &info);
    ASSERT_TRUE(estimate.has_value());
    EXPECT_FALSE(info.collinear);
    ExpectSim3Near(*estimate, truth, 1e-9);
  }
}

TEST(Umeyama, RecoversRandomRigidWithoutScale) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Sim3d truth(1.0, So3Exp(3.0 * Eigen::Vector3d(uni(rng), uni(rng), uni(rng))),
                      50.0 * Eigen::Vector3d(uni(rng), uni(rng), uni(rng)));
    const std::vector<Eigen::Vector3d> src = RandomPoints(3 + trial, 200 + trial);
    const std::optional<Sim3d> estimate = AlignUmeyama(src, Apply(truth, src), /*estimate_scale=*/false);
    ASSERT_TRUE(estimate.has_value());
    EXPECT_EQ(estimate->scale, 1.0);
    ExpectSim3Near(*estimate, truth, 1e-9);
  }
}

TEST(Umeyama, PlanarPointsNoReflection) {
  // Points in the z = 0 plane: rank(C) = 2, the reflection must be rejected.
  std::vector<Eigen::Vector3d> src = {{0, 0, 0}, {1, 0, 0}, {0, 2, 0}, {3, 1, 0}};
  const Sim3d truth(1.5, So3Exp(Eigen::Vector3d(0.3, 1.0, -0.2)), Eigen::Vector3d(1, 2, 3));
  const std::optional<Sim3d> estimate = AlignUmeyama(src, Apply(truth, src), true);
  ASSERT_TRUE(estimate.has_value());
  ExpectSim3Near(*estimate, truth, 1e-9);
}

TEST(Umeyama, WithoutScaleGivesLeastSquaresUnderScaledTarget) {
  // dst = 2 src: the rigid fit keeps scale 1 and the centroids match.
  const std::vector<Eigen::Vector3d> src = RandomPoints(10, 5);
  const Sim3d doubling(2.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
  const std::vector<Eigen::Vector3d> dst = Apply(doubling, src);
  const std::optional<Sim3d> rigid = AlignUmeyama(src, dst, false);
  ASSERT_TRUE(rigid.has_value());
  EXPECT_EQ(rigid->scale, 1.0);
  EXPECT_LT(RotationAngle(rigid->rotation), 1e-9);
  Eigen::Vector3d mu_s = Eigen::Vector3d::Zero();
  for (const auto& p : src) mu_s += p;
  mu_s /= 10.0;
  EXPECT_LT((rigid->translation - mu_s).norm(), 1e-9);  // t = mu_d - mu_s = mu_s
}

TEST(Umeyama, DegenerateInputs) {
  const std::vector<Eigen::Vector3d> one = {{1, 2, 3}};
  EXPECT_FALSE(AlignUmeyama(one, one, true).has_value());
  const std::vector<Eigen::Vector3d> same = {{1, 2, 3}, {1, 2, 3}, {1, 2, 3}};
  EXPECT_FALSE(AlignUmeyama(same, RandomPoints(3, 1), true).has_value());
  EXPECT_FALSE(AlignUmeyama(RandomPoints(3, 1), same, false).has_value());
  EXPECT_FALSE(AlignUmeyama(RandomPoints(3, 1), RandomPoints(4, 1), false).has_value());
  std::vector<Eigen::Vector3d> nan_points = RandomPoints(3, 2);
  nan_points[1].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(AlignUmeyama(nan_points, RandomPoints(3, 1), false).has_value());
}

TEST(Umeyama, CollinearFallbackAlignsTheLine) {
  // Points on a line: rotation about the line is not observable. The
  // fallback maps the line onto the line with the minimal rotation and
  // recovers scale and translation.
  std::vector<Eigen::Vector3d> src;
  for (int i = 0; i < 5; ++i) src.emplace_back(1.0 * i, 0.0, 0.0);
  const Sim3d truth(2.0, So3Exp(Eigen::Vector3d(0.0, 0.0, M_PI / 2.0)), Eigen::Vector3d(1.0, 1.0, 1.0));
  const std::vector<Eigen::Vector3d> dst = Apply(truth, src);
  UmeyamaInfo info;
  const std::optional<Sim3d> estimate = AlignUmeyama(src, dst, true, &info);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_TRUE(info.collinear);
  EXPECT_NEAR(estimate->scale, 2.0, 1e-12);
  for (size_t i = 0; i < src.size(); ++i) EXPECT_LT((*estimate * src[i] - dst[i]).norm(), 1e-12);
  // Minimal rotation from +x to +y: 90 degrees about +z.
  EXPECT_LT(RotationAngle(estimate->rotation.conjugate() * truth.rotation), 1e-12);
}

TEST(PosYaw, RecoversYawAndTranslation) {
  const std::vector<Eigen::Vector3d> src = RandomPoints(8, 9);
  for (double yaw : {0.0, 0.4, -2.5, 3.1}) {
    const Sim3d truth(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())),
                      Eigen::Vector3d(3.0, -4.0, 5.0));
    const std::optional<Sim3d> estimate = AlignPosYaw(src, Apply(truth, src));
    ASSERT_TRUE(estimate.has_value());
    ExpectSim3Near(*estimate, truth, 1e-12);
  }
}

TEST(PosYaw, TwoPointsSufficeVerticalOnlyFails) {
  // Yaw 90 deg and a z offset from two points; points without horizontal extent fail.
  const std::vector<Eigen::Vector3d> src = {{0, 0, 0}, {1, 0, 0}};
  const std::vector<Eigen::Vector3d> dst = {{0, 0, 2}, {0, 1, 2}};
  const std::optional<Sim3d> estimate = AlignPosYaw(src, dst);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_NEAR(So3Log(estimate->rotation).z(), M_PI / 2.0, 1e-12);
  EXPECT_LT((*estimate * src[1] - dst[1]).norm(), 1e-12);
  const std::vector<Eigen::Vector3d> vertical = {{0, 0, 0}, {0, 0, 1}, {0, 0, 2}};
  EXPECT_FALSE(AlignPosYaw(vertical, vertical).has_value());
}

}  // namespace
}  // namespace mcvo
