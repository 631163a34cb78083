// backend.cross_camera_min_angle_deg: which cross-camera matches the window
// BA keeps (src/backend/cross_camera_filter.h).
#include "../../src/backend/cross_camera_filter.h"

#include <cmath>

#include <gtest/gtest.h>

namespace mcvo {
namespace {

constexpr double kFocal = 700.0;
constexpr double kBaseline = 0.5;

// A rectified stereo pair: camera 1 is camera 0 moved by the baseline along x.
Rig StereoRig() {
  Rig rig;
  for (int c = 0; c < 2; ++c) {
    Camera camera;
    camera.name = c == 0 ? "left" : "right";
    camera.params = {kFocal, kFocal, 600.0, 180.0};
    camera.width = 1200;
    camera.height = 360;
    camera.cam_from_rig.translation = Eigen::Vector3d(-kBaseline * c, 0.0, 0.0);
    rig.cameras.push_back(camera);
  }
  return rig;
}

// Bearings of the point (x, 0, depth) of the rig frame in both cameras.
std::pair<Eigen::Vector3d, Eigen::Vector3d> Bearings(double x, double depth) {
  const Eigen::Vector3d point(x, 0.0, depth);
  return {point.normalized(), (point - Eigen::Vector3d(kBaseline, 0.0, 0.0)).normalized()};
}

RigFrameObservations Frame(const std::vector<double>& depths) {
  RigFrameObservations obs;
  obs.cameras.resize(2);
  for (size_t k = 0; k < depths.size(); ++k) {
    const auto [a, b] = Bearings(0.3, depths[k]);
    obs.cameras[0].push_back({100 + k, Eigen::Vector2d::Zero(), a});
    CrossCameraObservation x;
    x.camera_a = 0;
    x.id = 100 + k;
    x.camera_b = 1;
    x.bearing_b = b;
    obs.cross_camera.push_back(x);
  }
  return obs;
}

TEST(CrossCameraFilter, AngleIsTheStereoTriangulationAngle) {
  const Rig rig = StereoRig();
  for (const double depth : {2.0, 10.0, 40.0, 200.0}) {
    const auto [a, b] = Bearings(0.0, depth);
    // A point straight ahead of camera 0: the rays meet at atan(b / z).
    const double expected = std::atan(kBaseline / depth) * 180.0 / M_PI;
    EXPECT_NEAR(backend_internal::CrossCameraRayAngleDeg(rig.cameras[0], a, rig.cameras[1], b), expected,
                1e-9 * expected + 1e-12)
        << depth;
  }
}

TEST(CrossCameraFilter, DivergingOrParallelRaysHaveNoAngle) {
  const Rig rig = StereoRig();
  const Eigen::Vector3d ahead = Eigen::Vector3d::UnitZ();
  EXPECT_EQ(backend_internal::CrossCameraRayAngleDeg(rig.cameras[0], ahead, rig.cameras[1], ahead), 0.0);
  // Right camera's ray turned right, away from the left one's: they meet behind.
  const Eigen::Vector3d away = Eigen::Vector3d(0.1, 0.0, 1.0).normalized();
  EXPECT_EQ(backend_internal::CrossCameraRayAngleDeg(rig.cameras[0], ahead, rig.cameras[1], away), 0.0);
}

TEST(CrossCameraFilter, DropsMatchesFartherThanTheAngleAndKeepsOrder) {
  const Rig rig = StereoRig();
  // 1.43 deg with a 0.5 m baseline: about 20 m.
  RigFrameObservations obs = Frame({5.0, 30.0, 12.0, 80.0, 19.0});
  backend_internal::DropFarCrossCameraObservations(rig, 1.43, &obs);
  ASSERT_EQ(obs.cross_camera.size(), 3u);
  EXPECT_EQ(obs.cross_camera[0].id, 100u);
  EXPECT_EQ(obs.cross_camera[1].id, 102u);
  EXPECT_EQ(obs.cross_camera[2].id, 104u);
  EXPECT_EQ(obs.cameras[0].size(), 5u);  // the features stay, only the matches go
}

TEST(CrossCameraFilter, ZeroKeepsEveryMatch) {
  const Rig rig = StereoRig();
  RigFrameObservations obs = Frame({5.0, 300.0});
  backend_internal::DropFarCrossCameraObservations(rig, 0.0, &obs);
  EXPECT_EQ(obs.cross_camera.size(), 2u);
}

TEST(CrossCameraFilter, MatchOfAnUnlistedFeatureIsDropped) {
  const Rig rig = StereoRig();
  RigFrameObservations obs = Frame({5.0});
  obs.cross_camera[0].id = 999;  // camera 0 has no feature 999
  backend_internal::DropFarCrossCameraObservations(rig, 0.5, &obs);
  EXPECT_TRUE(obs.cross_camera.empty());
}

}  // namespace
}  // namespace mcvo
