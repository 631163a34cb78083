#include <gtest/gtest.h>

#include "mcvo/geometry/sim3d.h"
#include "mcvo/geometry/so3.h"

namespace mcvo {
namespace {

Sim3d MakeSim3(double s, const Eigen::Vector3d& phi, const Eigen::Vector3d& t) {
  return Sim3d(s, So3Exp(phi), t);
}

TEST(Sim3d, AppliesScaleRotationTranslation) {
  // Rz(90 deg) (1, 0, 0) = (0, 1, 0); times 2, plus (1, 1, 1) = (1, 3, 1).
  const Sim3d b_from_a = MakeSim3(2.0, Eigen::Vector3d(0.0, 0.0, M_PI / 2.0), Eigen::Vector3d(1.0, 1.0, 1.0));
  EXPECT_LT((b_from_a * Eigen::Vector3d(1.0, 0.0, 0.0) - Eigen::Vector3d(1.0, 3.0, 1.0)).norm(), 1e-15);
  EXPECT_LT((b_from_a.ToMatrix4() * Eigen::Vector4d(1.0, 0.0, 0.0, 1.0) - Eigen::Vector4d(1.0, 3.0, 1.0, 1.0))
                .norm(),
            1e-15);
}

TEST(Sim3d, CompositionAndInverseIdentities) {
  const Sim3d a_from_b = MakeSim3(1.7, Eigen::Vector3d(0.1, -0.4, 0.9), Eigen::Vector3d(1.0, -2.0, 3.0));
  const Sim3d b_from_c = MakeSim3(0.3, Eigen::Vector3d(-1.0, 0.2, 0.5), Eigen::Vector3d(-0.5, 4.0, 0.1));
  const Eigen::Vector3d p(0.7, -1.3, 2.2);
  // (a_from_b * b_from_c) p = a_from_b (b_from_c p)
  EXPECT_LT(((a_from_b * b_from_c) * p - a_from_b * (b_from_c * p)).norm(), 1e-13);
  // Matrix form agrees.
  EXPECT_LT(((a_from_b * b_from_c).ToMatrix4() - a_from_b.ToMatrix4() * b_from_c.ToMatrix4()).norm(), 1e-13);
  // T * T^-1 = T^-1 * T = identity.
  for (const Sim3d& id : {a_from_b * a_from_b.Inverse(), a_from_b.Inverse() * a_from_b}) {
    EXPECT_NEAR(id.scale, 1.0, 1e-15);
    EXPECT_LT(RotationAngle(id.rotation), 1e-15);
    EXPECT_LT(id.translation.norm(), 1e-14);
  }
  // (AB)^-1 = B^-1 A^-1
  const Sim3d lhs = (a_from_b * b_from_c).Inverse();
  const Sim3d rhs = b_from_c.Inverse() * a_from_b.Inverse();
  EXPECT_LT((lhs.ToMatrix4() - rhs.ToMatrix4()).norm(), 1e-12);
}

TEST(Sim3d, TransformPoseScalesPositionOnly) {
  const Sim3d gt_from_est =
      MakeSim3(2.0, Eigen::Vector3d(0.0, 0.0, M_PI / 2.0), Eigen::Vector3d(0.0, 0.0, 1.0));
  const Rigid3d est_from_body(So3Exp(Eigen::Vector3d(0.3, 0.0, 0.0)), Eigen::Vector3d(1.0, 0.0, 0.0));
  const Rigid3d gt_from_body = gt_from_est.TransformPose(est_from_body);
  EXPECT_LT((gt_from_body.translation - Eigen::Vector3d(0.0, 2.0, 1.0)).norm(), 1e-15);
  const Eigen::Quaterniond expected_rotation = gt_from_est.rotation * est_from_body.rotation;
  EXPECT_LT(RotationAngle(gt_from_body.rotation.conjugate() * expected_rotation), 1e-15);
  // With scale 1 it equals rigid composition.
  const Rigid3d rigid(So3Exp(Eigen::Vector3d(0.2, 0.1, -0.3)), Eigen::Vector3d(3.0, 2.0, 1.0));
  const Rigid3d composed = rigid * est_from_body;
  const Rigid3d via_sim = Sim3d(rigid).TransformPose(est_from_body);
  EXPECT_LT((composed.ToMatrix4() - via_sim.ToMatrix4()).norm(), 1e-14);
}

}  // namespace
}  // namespace mcvo
