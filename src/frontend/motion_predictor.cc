// Rig motion from tracked stereo points and the constant-velocity start of
// LK (see motion_predictor.h).
#include "motion_predictor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <utility>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Geometry>

#include "mcvo/frontend/cross_camera.h"
#include "mcvo/geometry/so3.h"

namespace mcvo::frontend_internal {
namespace {

// The bearing error of one correspondence in pixels at focal_px: the
// predicted direction's components along two axes orthogonal to the
// observed bearing (the sine of the angle, per axis), bounded and smooth
// for any direction.
struct MotionResidual {
  Eigen::Vector3d point;  // earlier rig frame
  Eigen::Matrix3d cam_rotation;
  Eigen::Vector3d cam_translation;
  Eigen::Vector3d axis1, axis2;
  double focal_px = 460.0;

  template <typename T>
  bool operator()(const T* angle_axis, const T* translation, T* residual) const {
    const T p[3] = {T(point.x()), T(point.y()), T(point.z())};
    T q[3];
    ceres::AngleAxisRotatePoint(angle_axis, p, q);
    const Eigen::Matrix<T, 3, 1> in_rig(q[0] + translation[0], q[1] + translation[1], q[2] + translation[2]);
    const Eigen::Matrix<T, 3, 1> in_cam = cam_rotation.cast<T>() * in_rig + cam_translation.cast<T>();
    const T norm = in_cam.norm();
    residual[0] = T(focal_px) * axis1.cast<T>().dot(in_cam) / norm;
    residual[1] = T(focal_px) * axis2.cast<T>().dot(in_cam) / norm;
    return true;
  }
};

MotionResidual MakeResidual(const Rigid3d& cam_from_rig, const MotionCorrespondence& c, double focal_px) {
  MotionResidual r;
  r.point = c.point_in_prev_rig;
  r.cam_rotation = cam_from_rig.RotationMatrix();
  r.cam_translation = cam_from_rig.translation;
  const Eigen::Vector3d u = c.bearing.normalized();
  r.axis1 = u.unitOrthogonal();
  r.axis2 = u.cross(r.axis1);
  r.focal_px = focal_px;
  return r;
}

// Error in pixels at focal_px (the residual's norm), or infinity when the
// point lands behind the observed direction.
double ErrorPx(const MotionResidual& r, const Rigid3d& next_from_prev, const Eigen::Vector3d& bearing) {
  const Eigen::Vector3d in_cam = r.cam_rotation * (next_from_prev * r.point) + r.cam_translation;
  if (!(in_cam.dot(bearing) > 0.0)) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d d = in_cam.normalized();
  return r.focal_px * std::hypot(r.axis1.dot(d), r.axis2.dot(d));
}

// One Ceres solve of next_from_prev over the residuals `use`.
Rigid3d Solve(const std::vector<MotionResidual>& residuals, const std::vector<int>& use, const Rigid3d& initial,
              double huber_px) {
  const Eigen::Vector3d phi = So3Log(initial.rotation);
  double angle_axis[3] = {phi.x(), phi.y(), phi.z()};
  double translation[3] = {initial.translation.x(), initial.translation.y(), initial.translation.z()};
  ceres::Problem problem;
  for (int i : use) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<MotionResidual, 2, 3, 3>(new MotionResidual(residuals[static_cast<size_t>(i)])),
        new ceres::HuberLoss(huber_px), angle_axis, translation);
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 10;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return Rigid3d(So3Exp(Eigen::Vector3d(angle_axis[0], angle_axis[1], angle_axis[2])),
                 Eigen::Vector3d(translation[0], translation[1], translation[2]));
}

// `motion` for a time step `ratio` times its own (rotation angle and
// translation scaled: constant velocity).
Rigid3d ScaledMotion(const Rigid3d& motion, double ratio) {
  if (ratio == 1.0) return motion;
  return Rigid3d(So3Exp(ratio * So3Log(motion.rotation)), motion.translation * ratio);
}

}  // namespace

RigMotionFit EstimateRigMotion(const std::vector<Rigid3d>& cam_from_rig,
                               const std::vector<MotionCorrespondence>& correspondences, const Rigid3d& initial,
                               double focal_px, int min_inliers) {
  RigMotionFit fit;
  std::vector<MotionResidual> residuals;
  std::vector<Eigen::Vector3d> bearings;
  for (const MotionCorrespondence& c : correspondences) {
    if (c.camera < 0 || c.camera >= static_cast<int>(cam_from_rig.size())) continue;
    if (!c.point_in_prev_rig.allFinite() || !c.bearing.allFinite() || c.bearing.norm() < 1e-12) continue;
    // A point at a camera centre has no direction.
    if ((cam_from_rig[static_cast<size_t>(c.camera)] * c.point_in_prev_rig).norm() < 1e-6) continue;
    residuals.push_back(MakeResidual(cam_from_rig[static_cast<size_t>(c.camera)], c, focal_px));
    bearings.push_back(c.bearing.normalized());
  }
  const int needed = std::max(min_inliers, 3);
  if (static_cast<int>(residuals.size()) < needed) return fit;
  std::vector<int> all(residuals.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  Rigid3d motion = Solve(residuals, all, initial, kMotionInlierPx);
  std::vector<int> inliers;
  for (int i : all) {
    if (ErrorPx(residuals[static_cast<size_t>(i)], motion, bearings[static_cast<size_t>(i)]) <= kMotionInlierPx) {
      inliers.push_back(i);
    }
  }
  if (static_cast<int>(inliers.size()) < needed) return fit;
  motion = Solve(residuals, inliers, motion, 1.0);
  for (int i : all) {
    fit.inliers += ErrorPx(residuals[static_cast<size_t>(i)], motion, bearings[static_cast<size_t>(i)]) <=
                   kMotionInlierPx;
  }
  fit.next_from_prev = motion;
  fit.ok = fit.inliers >= needed && 2 * fit.inliers >= static_cast<int>(residuals.size());
  return fit;
}

RigMotionPredictor::RigMotionPredictor(const Rig& rig, double focal_px, int min_points)
    : rig_(rig), cam_from_rig_(rig.CamFromRig()), focal_px_(focal_px), min_points_(min_points),
      points_(rig.cameras.size()) {}

size_t RigMotionPredictor::NumPoints() const {
  size_t n = 0;
  for (const auto& camera_points : points_) n += camera_points.size();
  return n;
}

std::vector<FeaturePredictions> RigMotionPredictor::Predict(int64_t t_ns) const {
  std::vector<FeaturePredictions> predictions(rig_.cameras.size());
  if (!motion_ || last_dt_ns_ <= 0) return predictions;
  const double ratio = static_cast<double>(t_ns - last_t_ns_) / static_cast<double>(last_dt_ns_);
  // A frame far off the last time step (a gap, a clock jump): no guess.
  if (!(ratio > 0.0 && ratio <= 3.0)) return predictions;
  const Rigid3d motion = ScaledMotion(*motion_, ratio);
  for (size_t c = 0; c < rig_.cameras.size(); ++c) {
    const Camera& camera = rig_.cameras[c];
    for (const auto& [id, point] : points_[c]) {
      const Eigen::Vector3d in_cam = cam_from_rig_[c] * (motion * point);
      const std::optional<Eigen::Vector2d> pixel = camera.Project(in_cam);
      if (!pixel || !pixel->allFinite() || !camera.IsInImage(*pixel)) continue;
      predictions[c].emplace(id, pixel->cast<float>());
    }
  }
  return predictions;
}

void RigMotionPredictor::Update(const MultiCameraFrame& frame) {
  const size_t n = rig_.cameras.size();
  // Each camera's features of this frame by id.
  std::vector<std::unordered_map<uint64_t, Eigen::Vector2f>> pixels(n);
  for (size_t c = 0; c < n && c < frame.cameras.size(); ++c) {
    for (const TrackedFeature& f : frame.cameras[c].features) pixels[c].emplace(f.id, f.pixel);
  }

  // 1. The motion from the last frame to this one.
  std::optional<Rigid3d> fitted;
  if (has_frame_) {
    std::vector<MotionCorrespondence> correspondences;
    for (size_t c = 0; c < n && c < frame.cameras.size(); ++c) {
      for (const TrackedFeature& f : frame.cameras[c].features) {
        const auto point = points_[c].find(f.id);
        if (point == points_[c].end()) continue;
        const std::optional<Eigen::Vector3d> bearing = rig_.cameras[c].Unproject(f.pixel.cast<double>());
        if (!bearing) continue;
        correspondences.push_back({static_cast<int>(c), point->second, *bearing});
      }
    }
    if (static_cast<int>(correspondences.size()) >= min_points_) {
      const Rigid3d initial = motion_ ? *motion_ : Rigid3d();
      const RigMotionFit fit = EstimateRigMotion(cam_from_rig_, correspondences, initial, focal_px_, min_points_);
      if (fit.ok) fitted = fit.next_from_prev;
    }
  }

  // 2. The points of this frame: triangulated where matched (the first
  // pair's match of a feature), else carried by the motion.
  std::vector<std::map<uint64_t, Eigen::Vector3d>> points(n);
  for (const CrossCameraMatch& m : frame.cross_matches) {
    const size_t a = static_cast<size_t>(m.camera_a), b = static_cast<size_t>(m.camera_b);
    if (a >= n || b >= n || points[a].count(m.id_a) != 0) continue;
    const auto pixel_a = pixels[a].find(m.id_a);
    if (pixel_a == pixels[a].end()) continue;
    const std::optional<Eigen::Vector3d> bearing_a = rig_.cameras[a].Unproject(pixel_a->second.cast<double>());
    const std::optional<Eigen::Vector3d> bearing_b = rig_.cameras[b].Unproject(m.pixel_b.cast<double>());
    if (!bearing_a || !bearing_b) continue;
    const Rigid3d b_from_a = cam_from_rig_[b] * cam_from_rig_[a].Inverse();
    double depth = 0.0;
    if (CheckCrossCameraBearings(*bearing_a, *bearing_b, b_from_a, 1.0, 0.0, &depth) != CrossCameraCheck::kOk) {
      continue;
    }
    points[a].emplace(m.id_a, cam_from_rig_[a].Inverse() * (depth * bearing_a->normalized()));
  }
  if (fitted) {
    for (size_t c = 0; c < n; ++c) {
      for (const auto& [id, point] : points_[c]) {
        if (pixels[c].count(id) != 0) points[c].emplace(id, *fitted * point);
      }
    }
  }
  points_ = std::move(points);
  motion_ = fitted;
  last_dt_ns_ = has_frame_ ? frame.t_ns - last_t_ns_ : 0;
  last_t_ns_ = frame.t_ns;
  has_frame_ = true;
}

}  // namespace mcvo::frontend_internal
