// The initializer's consistency gate (initializer/rig_consistency.h): each
// test breaks one thing a broken rig solution can have and checks that the
// gate names it, and that a consistent camera passes.
#include "mcvo/initializer/rig_consistency.h"

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace mcvo {
namespace {

// A rig turning left while driving forward (x forward), 10 frames.
std::vector<Rigid3d> RigWindow() {
  std::vector<Rigid3d> poses;
  for (int t = 0; t < 10; ++t) {
    const double yaw = 0.05 * t;
    poses.emplace_back(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())),
                       Eigen::Vector3d(0.6 * t, 0.02 * t * t, 0.0));
  }
  return poses;
}

// A side-looking camera 0.8 m left of the rig origin.
Rigid3d SideCamFromRig() {
  const Rigid3d rig_from_cam(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())),
                             Eigen::Vector3d(0.2, 0.8, 0.3));
  return rig_from_cam.Inverse();
}

// The camera's SfM as it would come out: its poses in its anchor frame,
// scaled to unit travel of the last frame (returns that scale in *scale).
std::vector<Rigid3d> CameraSfm(const std::vector<Rigid3d>& world_from_rig, const Rigid3d& cam_from_rig,
                               double* scale) {
  const Rigid3d rig_from_cam = cam_from_rig.Inverse();
  const Rigid3d anchor_from_world = (world_from_rig.front() * rig_from_cam).Inverse();
  std::vector<Rigid3d> out;
  for (const Rigid3d& pose : world_from_rig) out.push_back(anchor_from_world * pose * rig_from_cam);
  *scale = out.back().translation.norm();
  for (Rigid3d& pose : out) pose.translation /= *scale;
  return out;
}

TEST(RigConsistencyTest, AConsistentCameraPasses) {
  const std::vector<Rigid3d> rig = RigWindow();
  double scale = 0.0;
  const std::vector<Rigid3d> sfm = CameraSfm(rig, SideCamFromRig(), &scale);
  const CameraConsistency c = MeasureCameraConsistency(rig, SideCamFromRig(), sfm, scale, 0.01, 100);
  EXPECT_NEAR(c.ba_scale, scale, 1e-9);
  EXPECT_NEAR(c.disagreement, 0.0, 1e-9);
  EXPECT_LT(c.shape_residual, 1e-9);
  EXPECT_FALSE(CameraConsistencyFailure(c, RigConsistencyOptions()));
}

TEST(RigConsistencyTest, AScaleThreeTimesOffFails) {
  const std::vector<Rigid3d> rig = RigWindow();
  double scale = 0.0;
  const std::vector<Rigid3d> sfm = CameraSfm(rig, SideCamFromRig(), &scale);
  const CameraConsistency c = MeasureCameraConsistency(rig, SideCamFromRig(), sfm, scale / 3.0, 0.01, 100);
  EXPECT_NEAR(c.disagreement, 2.0, 1e-9);
  const auto failure = CameraConsistencyFailure(c, RigConsistencyOptions());
  ASSERT_TRUE(failure);
  EXPECT_NE(failure->find("scale disagrees"), std::string::npos) << *failure;
  // Within the camera's own uncertainty (4 sigma of 10 %), 8 % off passes; beyond it, not.
  const CameraConsistency near = MeasureCameraConsistency(rig, SideCamFromRig(), sfm, scale / 1.08, 0.1, 100);
  EXPECT_FALSE(CameraConsistencyFailure(near, RigConsistencyOptions()));
  const CameraConsistency far = MeasureCameraConsistency(rig, SideCamFromRig(), sfm, scale / 1.08, 0.01, 100);
  EXPECT_TRUE(CameraConsistencyFailure(far, RigConsistencyOptions()));
}

TEST(RigConsistencyTest, AZeroNegativeOrNanScaleFails) {
  const std::vector<Rigid3d> rig = RigWindow();
  double scale = 0.0;
  const std::vector<Rigid3d> sfm = CameraSfm(rig, SideCamFromRig(), &scale);
  for (double bad : {0.0, -scale, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    const CameraConsistency c = MeasureCameraConsistency(rig, SideCamFromRig(), sfm, bad, 0.01, 100);
    const auto failure = CameraConsistencyFailure(c, RigConsistencyOptions());
    ASSERT_TRUE(failure) << bad;
    EXPECT_NE(failure->find("not positive and finite"), std::string::npos) << *failure;
  }
}

TEST(RigConsistencyTest, TooFewLandmarksFail) {
  const std::vector<Rigid3d> rig = RigWindow();
  double scale = 0.0;
  const std::vector<Rigid3d> sfm = CameraSfm(rig, SideCamFromRig(), &scale);
  const CameraConsistency c = MeasureCameraConsistency(rig, SideCamFromRig(), sfm, scale, 0.01, 14);
  const auto failure = CameraConsistencyFailure(c, RigConsistencyOptions());
  ASSERT_TRUE(failure);
  EXPECT_EQ(*failure, "14 landmarks < 15");
}

TEST(RigConsistencyTest, MotionOfAnotherShapeFails) {
  // The camera's SfM follows a rig turning right instead of left (what a
  // camera filled by a moving object, or a wrong SfM solution, gives).
  const std::vector<Rigid3d> rig = RigWindow();
  std::vector<Rigid3d> mirrored;
  for (const Rigid3d& pose : rig) {
    mirrored.emplace_back(pose.rotation.conjugate(),
                          Eigen::Vector3d(pose.translation.x(), -pose.translation.y(), 0.0));
  }
  double scale = 0.0;
  const std::vector<Rigid3d> sfm = CameraSfm(mirrored, SideCamFromRig(), &scale);
  const CameraConsistency c = MeasureCameraConsistency(rig, SideCamFromRig(), sfm, scale, 0.01, 100);
  std::printf("mirrored: disagreement %.3f, shape residual %.3f\n", c.disagreement, c.shape_residual);
  const auto failure = CameraConsistencyFailure(c, RigConsistencyOptions());
  ASSERT_TRUE(failure);
}

}  // namespace
}  // namespace mcvo
