#include "cross_camera_filter.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace mcvo {
namespace backend_internal {

double CrossCameraRayAngleDeg(const Camera& a, const Eigen::Vector3d& bearing_a, const Camera& b,
                              const Eigen::Vector3d& bearing_b) {
  const Rigid3d rig_from_a = a.cam_from_rig.Inverse();
  const Rigid3d rig_from_b = b.cam_from_rig.Inverse();
  const Eigen::Vector3d da = (rig_from_a.rotation * bearing_a).normalized();
  const Eigen::Vector3d db = (rig_from_b.rotation * bearing_b).normalized();
  // Closest points c_a + s da and c_b + t db: the rays must meet in front
  // of both cameras.
  const Eigen::Vector3d w = rig_from_a.translation - rig_from_b.translation;
  const double k = da.dot(db);
  const double denominator = 1.0 - k * k;
  if (!(denominator > 1e-15)) return 0.0;  // parallel
  const double s = (k * db.dot(w) - da.dot(w)) / denominator;
  const double t = (db.dot(w) - k * da.dot(w)) / denominator;
  if (!(s > 0.0 && t > 0.0)) return 0.0;
  constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;
  return std::acos(std::clamp(k, -1.0, 1.0)) * kRadToDeg;
}

void DropFarCrossCameraObservations(const Rig& rig, double min_angle_deg, RigFrameObservations* obs) {
  if (!(min_angle_deg > 0.0) || obs->cross_camera.empty()) return;
  std::vector<std::unordered_map<uint64_t, const FeatureObservation*>> by_id(obs->cameras.size());
  const auto bearing_of = [&](int camera, uint64_t id) -> const FeatureObservation* {
    if (camera < 0 || static_cast<size_t>(camera) >= obs->cameras.size()) return nullptr;
    auto& index = by_id[static_cast<size_t>(camera)];
    if (index.empty()) {
      for (const FeatureObservation& f : obs->cameras[static_cast<size_t>(camera)]) index.emplace(f.id, &f);
    }
    const auto it = index.find(id);
    return it == index.end() ? nullptr : it->second;
  };
  std::vector<CrossCameraObservation> kept;
  kept.reserve(obs->cross_camera.size());
  for (const CrossCameraObservation& x : obs->cross_camera) {
    const FeatureObservation* fa = bearing_of(x.camera_a, x.id);
    if (fa == nullptr || x.camera_b < 0 || x.camera_b >= rig.NumCameras()) continue;
    const double angle = CrossCameraRayAngleDeg(rig.cameras[static_cast<size_t>(x.camera_a)], fa->bearing,
                                                 rig.cameras[static_cast<size_t>(x.camera_b)], x.bearing_b);
    if (angle >= min_angle_deg) kept.push_back(x);
  }
  obs->cross_camera = std::move(kept);
}

}  // namespace backend_internal
}  // namespace mcvo
