// Camera fixtures and helpers shared by the camera tests.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mcvo/camera/camera.h"
#include "mcvo/camera/models.h"

namespace mcvo::test {

inline Camera MakeCamera(const std::string& name, CameraModelId model, std::vector<double> params, int width,
                         int height) {
  Camera camera;
  camera.name = name;
  camera.model = model;
  camera.params = std::move(params);
  camera.width = width;
  camera.height = height;
  return camera;
}

// KITTI-360 calibration/image_02.yaml and image_03.yaml (MEI), in the order
// xi k1 k2 p1 p2 gamma1 gamma2 u0 v0 (shared/reference/kitti360.md).
inline Camera Kitti360Image02() {
  return MakeCamera("image_02", CameraModelId::kMei,
                    {2.2134047507854890, 1.6798235660113681e-02, 1.6548773243373522, 4.2223943394772046e-04,
                     4.2462134260997584e-04, 1336.3220825849971, 1335.7883350012958, 716.94323510126321,
                     705.76498308221585},
                    1400, 1400);
}
inline Camera Kitti360Image03() {
  return MakeCamera("image_03", CameraModelId::kMei,
                    {2.5535139132482758, 4.9370396274089505e-02, 4.5068455478645308, 1.3477698472982495e-03,
                     -7.0340482615055284e-04, 1485.4388981875156, 1484.9477411748708, 698.88316784030962,
                     698.14541887723055},
                    1400, 1400);
}

// One or more cameras per model, chosen to exercise every domain limit:
// radtan_kitti folds (negative k3) inside its image, kb_fold folds at ~77
// degrees, mei_fold's distortion folds just past 90 degrees, the KITTI-360
// MEI cameras and both DS cameras see beyond 90 degrees.
inline std::vector<Camera> AllTestCameras() {
  return {
      MakeCamera("pinhole", CameraModelId::kPinhole, {500.0, 490.0, 320.0, 240.0}, 640, 480),
      // KITTI-360 raw image_00 (perspective.txt K_00, D_00).
      MakeCamera("radtan_kitti", CameraModelId::kRadTan,
                 {788.629315, 786.382230, 687.158398, 317.752196, -0.344441, 0.141678, 0.000414, -0.000222,
                  -0.029608},
                 1392, 512),
      MakeCamera("radtan_barrel_free", CameraModelId::kRadTan,
                 {460.0, 455.0, 376.0, 240.0, 0.08, 0.01, 0.0012, -0.0009, 0.002}, 752, 480),
      // TUM VI-like equidistant fisheye (monotonic up to 180 degrees).
      MakeCamera(
          "kb_tumvi", CameraModelId::kKannalaBrandt,
          {190.97847715128717, 190.9733070521226, 254.93170605935475, 256.8974428996504,
           0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202, 0.00020293673591811182},
          512, 512),
      MakeCamera("kb_fold", CameraModelId::kKannalaBrandt, {300.0, 301.0, 320.0, 240.0, 0.0, 0.0, 0.0, -0.01},
                 640, 480),
      Kitti360Image02(),
      Kitti360Image03(),
      MakeCamera("mei_fold", CameraModelId::kMei, {0.9, -0.3, 0.02, 1e-4, -2e-4, 400.0, 401.0, 320.0, 240.0},
                 640, 480),
      // Double sphere as in Usenko et al. 2018 (195 degree lens: xi < 0, alpha > 0.5).
      MakeCamera("ds_wide", CameraModelId::kDoubleSphere, {313.0, 313.5, 638.0, 514.0, -0.18, 0.59}, 1280,
                 1024),
      MakeCamera("ds_low_alpha", CameraModelId::kDoubleSphere, {250.0, 251.0, 320.0, 240.0, 0.1, 0.4}, 640,
                 480),
  };
}

inline bool IsInDomain(const Camera& camera, const Eigen::Vector3d& point) {
  return VisitCameraModel(
      camera.model, [&](auto m) { return decltype(m)::IsInDomain(camera.params.data(), point.data()); });
}

// Unit vector at angle theta from the optical axis (+z), azimuth phi.
inline Eigen::Vector3d Direction(double theta, double phi) {
  return Eigen::Vector3d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
}

// Largest angle from the axis still in the domain along azimuth phi
// (bisection; the domains are cones around the axis, up to tangential terms).
inline double DomainEdgeAngle(const Camera& camera, double phi) {
  double inside = 0.0;
  double outside = M_PI;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (inside + outside);
    (IsInDomain(camera, Direction(mid, phi)) ? inside : outside) = mid;
  }
  return inside;
}

inline double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

}  // namespace mcvo::test
