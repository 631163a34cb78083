// The cross-camera part of the initializer's scale solve (cross_camera_scale.h).
#include "cross_camera_scale.h"

#include "bearing_residual.h"

namespace mcvo::initializer_internal {
namespace {
constexpr double kRadToDeg = 180.0 / M_PI;
}  // namespace

// Step 4, cross-camera part: one scale measurement per usable cross-camera
// observation of a feature that camera a's SfM triangulated. The metric
// distance of the point from camera a comes from midpoint triangulation
// with camera b through the extrinsics; its SfM distance from a's SfM.
// Weights and the minimum angle use the angle the SfM point predicts
// (scaled by the median ratio of the camera), not the measured one: noise
// that widens a measured angle also shortens the measured distance, so
// weighting by it would bias the scale low.
std::vector<ScaleMeasurement> CrossCameraMeasurements(const Rig& rig,
                                                      const std::deque<RigFrameObservations>& window,
                                                      const InitializerOptions& options, int anchor,
                                                      const std::vector<int>& used,
                                                      const std::vector<CameraSfmResult>& sfm_of_used,
                                                      int* num_matches, double* spread) {
  std::vector<int> solve_index(static_cast<size_t>(rig.NumCameras()), -1);
  for (size_t k = 0; k < used.size(); ++k) solve_index[static_cast<size_t>(used[k])] = static_cast<int>(k);
  const double sigma_angle = 1.0 / options.virtual_focal_px;  // a-priori: 1 px; rescaled by the solve
  const double min_angle = options.min_cross_camera_angle_deg / kRadToDeg;
  struct Match {
    double ratio;              // metric / SfM distance
    Eigen::Vector3d p_sfm;     // SfM point in camera a at the frame
    Eigen::Vector3d centre_b;  // camera b's centre in camera a, metres
    double metric_length;
  };
  std::vector<std::vector<Match>> per_camera(used.size());
  const int newest = static_cast<int>(window.size()) - 1;
  for (int t = anchor; t <= newest; ++t) {
    const RigFrameObservations& frame = window[static_cast<size_t>(t)];
    std::map<int, std::map<uint64_t, Eigen::Vector3d>> own;  // camera a -> id -> bearing, built on demand
    for (const CrossCameraObservation& x : frame.cross_camera) {
      if (x.camera_a < 0 || x.camera_a >= rig.NumCameras() || x.camera_b < 0 || x.camera_b >= rig.NumCameras() ||
          x.camera_a == x.camera_b) {
        continue;
      }
      const int k = solve_index[static_cast<size_t>(x.camera_a)];
      if (k < 0) continue;
      const CameraSfmResult& sfm = sfm_of_used[static_cast<size_t>(k)];
      const auto point = sfm.points.find(x.id);
      if (point == sfm.points.end()) continue;
      auto own_it = own.find(x.camera_a);
      if (own_it == own.end()) {
        own_it =
            own.emplace(x.camera_a, BearingsById(frame.cameras[static_cast<size_t>(x.camera_a)])).first;
      }
      const auto bearing_a = own_it->second.find(x.id);
      if (bearing_a == own_it->second.end()) continue;
      const Eigen::Vector3d f_a = bearing_a->second.normalized();
      const Rigid3d& anchor_from_cam = sfm.anchor_from_cam[static_cast<size_t>(t - anchor)];
      const Eigen::Vector3d p_sfm =
          anchor_from_cam.rotation.conjugate() * (point->second - anchor_from_cam.translation);
      if (!(p_sfm.dot(f_a) > 0.0)) continue;
      const Camera& cam_a = rig.cameras[static_cast<size_t>(x.camera_a)];
      const Camera& cam_b = rig.cameras[static_cast<size_t>(x.camera_b)];
      const Rigid3d a_from_b = cam_a.cam_from_rig * cam_b.cam_from_rig.Inverse();
      const Eigen::Vector3d f_b = a_from_b.rotation * x.bearing_b.normalized();
      const std::optional<Eigen::Vector3d> p_metric = TriangulateMidpoint(
          Eigen::Vector3d::Zero(), f_a, a_from_b.translation, f_b);
      if (!p_metric || !p_metric->allFinite() || !(p_sfm.norm() > 0.0)) continue;
      per_camera[static_cast<size_t>(k)].push_back(
          {p_metric->norm() / p_sfm.norm(), p_sfm, a_from_b.translation, p_metric->norm()});
    }
  }
  // Per camera: predicted angles, then a robust filter: normalised
  // deviations from the median ratio beyond 3.5 robust stds are wrong
  // matches or bad SfM points.
  std::vector<ScaleMeasurement> out;
  std::vector<double> deviations;
  *num_matches = 0;
  for (size_t k = 0; k < per_camera.size(); ++k) {
    const std::vector<Match>& matches = per_camera[k];
    if (matches.empty()) continue;
    std::vector<double> ratios;
    ratios.reserve(matches.size());
    for (const Match& m : matches) ratios.push_back(m.ratio);
    const double median = Median(ratios);
    std::vector<ScaleMeasurement> candidates;
    std::vector<double> z, deviation;
    for (const Match& m : matches) {
      const Eigen::Vector3d predicted = median * m.p_sfm;
      const double angle = AngleBetween(predicted, predicted - m.centre_b);
      if (!(angle >= min_angle)) continue;
      ScaleMeasurement sm;
      sm.camera = static_cast<int>(k);
      sm.sfm_length = m.p_sfm.norm();
      sm.metric_length = m.metric_length;
      sm.relative_sigma = sigma_angle / angle;
      candidates.push_back(sm);
      deviation.push_back(m.ratio / median - 1.0);
      z.push_back(deviation.back() / sm.relative_sigma);
    }
    const double z_sigma = std::max(RobustSpread(z), 0.1);
    // The kept matches are averaged into one measurement of the camera:
    // a_i = sfm_length / metric_length (proportional to the triangulation
    // angle, so its noise is near zero-mean) has the weighted mean
    // m = 1 / s, unbiased; one row per match would put the noise of each
    // a_i into the coefficient of s and bias the least squares low by about
    // the relative variance of a_i (several % at 2 px).
    double sum_w = 0.0, sum_wa = 0.0;
    std::vector<std::pair<double, double>> kept;  // (a_i, weight)
    for (size_t i = 0; i < candidates.size(); ++i) {
      if (std::abs(z[i]) > 3.5 * z_sigma) continue;
      const double a = candidates[i].sfm_length / candidates[i].metric_length;
      const double w = 1.0 / (candidates[i].relative_sigma * candidates[i].relative_sigma);
      kept.emplace_back(a, w);
      sum_w += w;
      sum_wa += w * a;
      deviations.push_back(deviation[i]);
    }
    const int n = static_cast<int>(kept.size());
    if (n < options.min_cross_camera_matches || n < 2) continue;
    const double mean = sum_wa / sum_w;
    // Std of the weighted mean from the scatter (matches in the same frame
    // share the SfM pose error, so this is optimistic like every estimate here).
    double scatter = 0.0;
    for (const auto& [a, w] : kept) scatter += w * (a - mean) * (a - mean);
    const double sigma_mean = std::sqrt(scatter / (n - 1) / sum_w);
    ScaleMeasurement sm;
    sm.camera = static_cast<int>(k);
    sm.sfm_length = mean;
    sm.metric_length = 1.0;
    sm.relative_sigma = std::max(sigma_mean / mean, 1e-9);
    out.push_back(sm);
    *num_matches += n;
  }
  *spread = RobustSpread(deviations);
  return out;
}

}  // namespace mcvo::initializer_internal
