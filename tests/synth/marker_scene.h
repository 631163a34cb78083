// Marker fixture of the renderer tests: small kMarker discs at known 3-D
// points spread over a camera's field of view, each facing the camera, and a
// detector that finds a rendered disc by its intensity-weighted centroid.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "camera/test_cameras.h"
#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/synth/scene.h"

namespace mcvo::test {

// Disc radius of a kMarker quad relative to its side (material.h).
constexpr double kMarkerDiscRatio = 0.35;

struct Marker {
  Eigen::Vector3d point_in_world;  // disc centre
  double disc_radius_m = 0.0;
  double off_axis_deg = 0.0;  // angle from the optical axis
};

struct MarkerScene {
  synth::Scene scene;  // built
  std::vector<Marker> markers;
};

// Non-trivial poses for the tests: the rig somewhere in the world, turned
// about a tilted axis, and the camera offset and turned in the rig.
inline Rigid3d TestWorldFromRig() {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.3, 1.0).normalized())),
                 Eigen::Vector3d(12.0, -4.0, 1.6));
}
inline Rigid3d TestCamFromRig() {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(-1.9, Eigen::Vector3d(0.9, 0.1, -0.3).normalized())),
                 Eigen::Vector3d(0.3, -0.15, 0.8));
}

// Markers whose discs are about `disc_diameter_px` pixels across (along the
// image's least stretched direction), at angles up to `max_off_axis_deg`
// (and inside the image with a margin), distances 3..9 m, facing the camera
// centre. `camera.cam_from_rig` must be set.
inline MarkerScene MakeMarkerScene(const Camera& camera, const Rigid3d& world_from_rig,
                                   double max_off_axis_deg, double disc_diameter_px = 11.0) {
  MarkerScene result;
  const Rigid3d world_from_cam = world_from_rig * camera.cam_from_rig.Inverse();
  const double margin_px = 2.0 * disc_diameter_px;
  std::vector<Eigen::Vector2d> placed;
  const double thetas_deg[] = {0.0, 12.0, 25.0, 38.0, 50.0, 62.0, 72.0, 80.0, 88.0, 96.0, 104.0};
  int index = 0;
  for (double theta_deg : thetas_deg) {
    if (theta_deg > max_off_axis_deg) continue;
    const int num_phi = theta_deg == 0.0 ? 1 : 12;
    for (int k = 0; k < num_phi; ++k) {
      const double phi = (k + 0.5 * (index % 2)) * 2.0 * M_PI / num_phi + 0.1;
      const Eigen::Vector3d direction = Direction(theta_deg * M_PI / 180.0, phi);
      const double distance = 3.0 + (index % 7);
      ++index;
      const Eigen::Vector3d centre_in_cam = distance * direction;
      Eigen::Matrix<double, 2, 3> jacobian;
      const auto pixel = camera.Project(centre_in_cam, &jacobian);
      if (!pixel || pixel->x() < margin_px || pixel->y() < margin_px ||
          pixel->x() > camera.width - margin_px || pixel->y() > camera.height - margin_px) {
        continue;
      }
      bool too_close = false;
      for (const Eigen::Vector2d& other : placed)
        too_close |= (other - *pixel).norm() < 3.0 * disc_diameter_px;
      if (too_close) continue;
      // e_u x e_v = -direction: the front face looks at the camera.
      const Eigen::Vector3d helper =
          std::abs(direction.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
      const Eigen::Vector3d e_v = direction.cross(helper).normalized();
      const Eigen::Vector3d e_u = e_v.cross(direction).normalized();
      const double px_per_m = std::min((jacobian * e_u).norm(), (jacobian * e_v).norm());
      const double side_m = disc_diameter_px / (2.0 * kMarkerDiscRatio * px_per_m);
      bool corners_ok = true;
      for (double a : {-0.5, 0.5}) {
        for (double b : {-0.5, 0.5})
          corners_ok &= camera.Project(centre_in_cam + side_m * (a * e_u + b * e_v)).has_value();
      }
      if (!corners_ok) continue;
      synth::Quad quad;
      const Eigen::Matrix3d world_from_cam_rotation = world_from_cam.RotationMatrix();
      quad.origin = world_from_cam * (centre_in_cam - 0.5 * side_m * (e_u + e_v));
      quad.axis_u = world_from_cam_rotation * (side_m * e_u);
      quad.axis_v = world_from_cam_rotation * (side_m * e_v);
      quad.material = synth::Material::kMarker;
      quad.texture_seed = static_cast<uint32_t>(index);
      result.scene.AddQuad(quad);
      result.markers.push_back({world_from_cam * centre_in_cam, kMarkerDiscRatio * side_m, theta_deg});
      placed.push_back(*pixel);
    }
  }
  result.scene.Build();
  return result;
}

// Intensity-weighted centroid of a rendered marker. The window is the set of
// pixels whose centre ray meets the marker's plane within 1.27 disc radii of
// the disc centre (inside the quad, whose half side is 1.43 radii); the
// background level is the median of the pixels between 1.17 and 1.3 radii,
// subtracted before weighting. nullopt when the window holds no signal.
inline std::optional<Eigen::Vector2d> MarkerCentroid(const cv::Mat& image, const Camera& camera,
                                                     const Rigid3d& world_from_rig, const Marker& marker) {
  const Rigid3d cam_from_world = camera.cam_from_rig * world_from_rig.Inverse();
  const Eigen::Vector3d centre = cam_from_world * marker.point_in_world;
  const Eigen::Vector3d normal = centre.normalized();  // the disc faces the camera centre
  const auto predicted = camera.Project(centre);
  if (!predicted) return std::nullopt;
  const int half = 40;
  std::vector<Eigen::Vector3d> inside;  // x, y, intensity
  std::vector<double> ring;
  for (int y = static_cast<int>(predicted->y()) - half; y <= static_cast<int>(predicted->y()) + half; ++y) {
    for (int x = static_cast<int>(predicted->x()) - half; x <= static_cast<int>(predicted->x()) + half; ++x) {
      if (x < 0 || y < 0 || x >= image.cols || y >= image.rows) continue;
      const auto bearing = camera.Unproject(Eigen::Vector2d(x, y));
      if (!bearing || bearing->dot(normal) <= 0.0) continue;
      const double rho =
          ((centre.dot(normal) / bearing->dot(normal)) * *bearing - centre).norm() / marker.disc_radius_m;
      const double value = image.at<uint8_t>(y, x);
      if (rho < 1.27) inside.emplace_back(x, y, value);
      if (rho > 1.17 && rho < 1.3) ring.push_back(value);
    }
  }
  if (ring.empty() || inside.empty()) return std::nullopt;
  std::nth_element(ring.begin(), ring.begin() + ring.size() / 2, ring.end());
  const double background = ring[ring.size() / 2];
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double weight = 0.0;
  for (const Eigen::Vector3d& p : inside) {
    const double w = std::max(0.0, p.z() - background);
    sum += w * p.head<2>();
    weight += w;
  }
  if (weight <= 0.0) return std::nullopt;
  return Eigen::Vector2d(sum / weight);
}

// Centroid of the image of a uniform disc: the projections of the disc's
// points weighted by the image area they cover, |det d(pixel)/d(disc
// coordinates)|, integrated on a polar grid. It differs from the projection
// of the disc centre by the perspective (and lens) bias of a disc centroid,
// O(r^2) times the relative change of the image scale across the disc.
inline Eigen::Vector2d ExpectedDiscCentroid(const Camera& camera, const Rigid3d& world_from_rig,
                                            const Marker& marker) {
  const Rigid3d cam_from_world = camera.cam_from_rig * world_from_rig.Inverse();
  const Eigen::Vector3d centre = cam_from_world * marker.point_in_world;
  const Eigen::Vector3d normal = centre.normalized();
  const Eigen::Vector3d helper =
      std::abs(normal.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  Eigen::Matrix<double, 3, 2> plane_axes;
  plane_axes.col(0) = normal.cross(helper).normalized();
  plane_axes.col(1) = normal.cross(plane_axes.col(0));
  constexpr int kRadial = 64;
  constexpr int kAngular = 128;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double total = 0.0;
  for (int i = 0; i < kRadial; ++i) {
    const double rho = (i + 0.5) / kRadial * marker.disc_radius_m;
    for (int j = 0; j < kAngular; ++j) {
      const double phi = (j + 0.5) / kAngular * 2.0 * M_PI;
      Eigen::Matrix<double, 2, 3> jacobian;
      const auto pixel = camera.Project(
          centre + plane_axes * Eigen::Vector2d(rho * std::cos(phi), rho * std::sin(phi)), &jacobian);
      if (!pixel) continue;
      const double weight = rho * std::abs((jacobian * plane_axes).determinant());
      sum += weight * *pixel;
      total += weight;
    }
  }
  return sum / total;
}

}  // namespace mcvo::test
