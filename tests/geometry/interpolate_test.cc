#include <gtest/gtest.h>

#include "mcvo/geometry/interpolate.h"
#include "mcvo/geometry/so3.h"

namespace mcvo {
namespace {

TEST(Interpolate, EndpointsAndMidpoint) {
  const Rigid3d a(So3Exp(Eigen::Vector3d(0.0, 0.0, 0.2)), Eigen::Vector3d(0.0, 0.0, 0.0));
  const Rigid3d b(So3Exp(Eigen::Vector3d(0.0, 0.0, 1.0)), Eigen::Vector3d(2.0, 4.0, -6.0));
  const int64_t t_a = 1000000000;
  const int64_t t_b = 1100000000;

  const Rigid3d at_a = InterpolatePose(a, t_a, b, t_b, t_a);
  const Rigid3d at_b = InterpolatePose(a, t_a, b, t_b, t_b);
  EXPECT_LT((at_a.ToMatrix4() - a.ToMatrix4()).norm(), 1e-15);
  EXPECT_LT((at_b.ToMatrix4() - b.ToMatrix4()).norm(), 1e-15);

  // Midpoint: yaw (0.2 + 1.0) / 2 = 0.6 about z; position (1, 2, -3).
  const Rigid3d mid = InterpolatePose(a, t_a, b, t_b, 1050000000);
  EXPECT_LT((mid.translation - Eigen::Vector3d(1.0, 2.0, -3.0)).norm(), 1e-15);
  EXPECT_LT((So3Log(mid.rotation) - Eigen::Vector3d(0.0, 0.0, 0.6)).norm(), 1e-15);

  // A quarter of the way.
  const Rigid3d quarter = InterpolatePose(a, t_a, b, t_b, 1025000000);
  EXPECT_LT((So3Log(quarter.rotation) - Eigen::Vector3d(0.0, 0.0, 0.4)).norm(), 1e-15);
}

TEST(Interpolate, ShortestArcWhateverTheQuaternionSign) {
  const Rigid3d a(So3Exp(Eigen::Vector3d(0.0, 0.0, 3.0)), Eigen::Vector3d::Zero());
  Eigen::Quaterniond b_q = So3Exp(Eigen::Vector3d(0.0, 0.0, -3.0));
  b_q.coeffs() = -b_q.coeffs();  // same rotation, other sign
  const Rigid3d b(b_q, Eigen::Vector3d::Zero());
  // From +3 rad to -3 rad the short way passes through pi (2 pi - 6 = 0.283 rad apart).
  const Rigid3d mid = InterpolatePose(a, b, 0.5);
  EXPECT_NEAR(RotationAngle(mid.rotation), M_PI, 1e-12);
}

TEST(Interpolate, EqualTimesReturnFirst) {
  const Rigid3d a(So3Exp(Eigen::Vector3d(0.1, 0.0, 0.0)), Eigen::Vector3d(1.0, 0.0, 0.0));
  const Rigid3d b(So3Exp(Eigen::Vector3d(0.5, 0.0, 0.0)), Eigen::Vector3d(3.0, 0.0, 0.0));
  EXPECT_EQ(InterpolatePose(a, 5, b, 5, 5).ToMatrix4(), a.ToMatrix4());
}

}  // namespace
}  // namespace mcvo
