#include "mcvo/initializer/rig_consistency.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {

CameraConsistency MeasureCameraConsistency(const std::vector<Rigid3d>& world_from_rig,
                                           const Rigid3d& cam_from_rig,
                                           const std::vector<Rigid3d>& anchor_from_cam, double scale,
                                           double relative_sigma, int landmarks) {
  MCVO_CHECK_MSG(!world_from_rig.empty() && world_from_rig.size() == anchor_from_cam.size(),
                 "MeasureCameraConsistency: ", world_from_rig.size(), " rig poses, ", anchor_from_cam.size(),
                 " camera poses");
  CameraConsistency out;
  out.scale = scale;
  out.relative_sigma = relative_sigma;
  out.landmarks = landmarks;
  const Rigid3d rig_from_cam = cam_from_rig.Inverse();
  const Rigid3d anchor_cam_from_world = (world_from_rig.front() * rig_from_cam).Inverse();
  double pq = 0.0, qq = 0.0, pp = 0.0;
  std::vector<Eigen::Vector3d> p(world_from_rig.size());
  for (size_t t = 0; t < world_from_rig.size(); ++t) {
    p[t] = anchor_cam_from_world * (world_from_rig[t] * rig_from_cam).translation;
    const Eigen::Vector3d& q = anchor_from_cam[t].translation;
    pq += p[t].dot(q);
    qq += q.squaredNorm();
    pp += p[t].squaredNorm();
  }
  out.ba_scale = qq > 0.0 ? pq / qq : 0.0;
  out.disagreement = scale > 0.0 ? out.ba_scale / scale - 1.0 : std::numeric_limits<double>::infinity();
  double residual = 0.0;
  for (size_t t = 0; t < p.size(); ++t) {
    residual += (p[t] - out.ba_scale * anchor_from_cam[t].translation).squaredNorm();
  }
  out.shape_residual = pp > 0.0 ? std::sqrt(residual / pp) : std::numeric_limits<double>::infinity();
  return out;
}

std::optional<std::string> CameraConsistencyFailure(const CameraConsistency& c,
                                                    const RigConsistencyOptions& options) {
  if (!(c.scale > 0.0) || !std::isfinite(c.scale)) {
    return StrCat("scale ", FormatDouble(c.scale), " is not positive and finite");
  }
  if (c.landmarks < options.min_landmarks) {
    return StrCat(c.landmarks, " landmarks < ", options.min_landmarks);
  }
  const double bound = std::max(options.disagreement_sigmas * c.relative_sigma, options.min_disagreement);
  if (!(std::abs(c.disagreement) <= bound)) {
    return StrCat("its scale disagrees with the rig: the rig BA implies ", FormatFixed(1.0 + c.disagreement, 3),
                  " x the scale solve's (bound ", FormatFixed(100.0 * bound, 1), " %)");
  }
  if (!(c.shape_residual <= options.max_shape_residual)) {
    return StrCat("its motion disagrees with the rig: residual ", FormatFixed(100.0 * c.shape_residual, 1),
                  " % of its travel > ", FormatFixed(100.0 * options.max_shape_residual, 1), " %");
  }
  return std::nullopt;
}

double CameraConsistencyBadness(const CameraConsistency& c, const RigConsistencyOptions& options) {
  if (!(c.scale > 0.0) || !std::isfinite(c.scale)) return std::numeric_limits<double>::infinity();
  const double bound = std::max(options.disagreement_sigmas * c.relative_sigma, options.min_disagreement);
  double badness = std::abs(c.disagreement) / bound;
  badness = std::max(badness, c.shape_residual / options.max_shape_residual);
  if (c.landmarks < options.min_landmarks) {
    badness = std::max(badness, 1.0 + static_cast<double>(options.min_landmarks - c.landmarks) /
                                          std::max(1, options.min_landmarks));
  }
  return std::isfinite(badness) ? badness : std::numeric_limits<double>::infinity();
}

}  // namespace mcvo
