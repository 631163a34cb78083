#include "landmark_window.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "mcvo/util/error.h"

namespace mcvo::backend_internal {
namespace {

// Smallest angle between two observation rays for a landmark to be
// triangulated: below it the depth is mostly noise.
constexpr double kDegToRad = M_PI / 180.0;
constexpr double kMinTriangulationAngleRad = 0.5 * kDegToRad;
// The least distance from the oldest keyframe worth anchoring the monocular scale to.
constexpr double kMinScaleAnchorDistance = 1e-9;

}  // namespace

LandmarkWindow::LandmarkWindow(std::vector<Rigid3d> cam_from_rig, const BackendOptions& options, int capacity)
    : cam_from_rig_(std::move(cam_from_rig)),
      options_(options),
      pool_(static_cast<size_t>(capacity)),
      slot_used_(static_cast<size_t>(capacity), false) {}

WindowFrame* LandmarkWindow::AcquireFrame() {
  for (size_t k = 0; k < pool_.size(); ++k) {
    if (slot_used_[k]) continue;
    slot_used_[k] = true;
    pool_[k] = WindowFrame();
    return &pool_[k];
  }
  MCVO_CHECK_MSG(false, "frame pool of ", pool_.size(), " slots exhausted");
  return nullptr;
}

void LandmarkWindow::ReleaseFrame(WindowFrame* frame) {
  const size_t k = static_cast<size_t>(frame - pool_.data());
  MCVO_CHECK(k < pool_.size() && slot_used_[k]);
  slot_used_[k] = false;
  pool_[k].obs = RigFrameObservations();
}

void LandmarkWindow::PopFront() {
  ReleaseFrame(frames_.front());
  frames_.pop_front();
}

void LandmarkWindow::PopBack() {
  ReleaseFrame(frames_.back());
  frames_.pop_back();
}

void LandmarkWindow::Clear() {
  while (!frames_.empty()) PopFront();
  landmarks_.clear();
}

int LandmarkWindow::NumKeyframes() const {
  int keyframes = 0;
  for (const WindowFrame* f : frames_) keyframes += f->keyframe ? 1 : 0;
  return keyframes;
}

Rigid3d LandmarkWindow::WorldFromCam(const WindowFrame& frame, int camera) const {
  return frame.WorldFromRig() * cam_from_rig_[camera].Inverse();
}

Eigen::Vector3d LandmarkWindow::LandmarkInWorld(const WindowLandmark& lm) const {
  return WorldFromCam(*lm.anchor_frame, lm.anchor_camera) * (lm.anchor_bearing / lm.inverse_depth);
}

double LandmarkWindow::ObservationErrorPx(const WindowLandmark& lm, const LandmarkObservation& ob) const {
  const Eigen::Vector2d r =
      ReprojectionResidual(lm.anchor_frame->WorldFromRig(), ob.frame->WorldFromRig(),
                           cam_from_rig_[lm.anchor_camera].Inverse(), cam_from_rig_[ob.camera].Inverse(),
                           lm.anchor_bearing, lm.inverse_depth, ob.bearing, options_.virtual_focal_px);
  return r.norm();
}

bool LandmarkWindow::UsableInBa(const WindowLandmark& lm) const {
  return lm.triangulated && static_cast<int>(lm.observations.size()) >= options_.min_observations &&
         lm.inverse_depth > 1.0 / kMaxLandmarkDistanceM && lm.inverse_depth < 1.0 / kMinLandmarkDistanceM;
}

bool LandmarkWindow::Triangulate(WindowLandmark* lm) const {
  if (lm->observations.size() < 2) return false;
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> directions;
  std::vector<Eigen::Vector3d> centres;
  for (const LandmarkObservation& ob : lm->observations) {
    const Rigid3d world_from_cam = WorldFromCam(*ob.frame, ob.camera);
    const Eigen::Vector3d d = (world_from_cam.rotation * ob.bearing).normalized();
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - d * d.transpose();
    a += p;
    b += p * world_from_cam.translation;
    directions.push_back(d);
    centres.push_back(world_from_cam.translation);
  }
  double max_angle = 0.0;
  for (size_t i = 0; i < directions.size(); ++i) {
    for (size_t j = i + 1; j < directions.size(); ++j) {
      if ((centres[i] - centres[j]).norm() < 1e-9) continue;  // same centre: no baseline
      max_angle = std::max(max_angle, std::acos(std::clamp(directions[i].dot(directions[j]), -1.0, 1.0)));
    }
  }
  if (max_angle < kMinTriangulationAngleRad) return false;
  Eigen::LDLT<Eigen::Matrix3d> ldlt(a);
  if (ldlt.info() != Eigen::Success) return false;
  const Eigen::Vector3d point = ldlt.solve(b);
  if (!point.allFinite()) return false;
  const Rigid3d anchor_from_world = WorldFromCam(*lm->anchor_frame, lm->anchor_camera).Inverse();
  const double depth = (anchor_from_world * point).dot(lm->anchor_bearing);
  if (!(depth > kMinLandmarkDistanceM && depth < kMaxLandmarkDistanceM)) return false;
  WindowLandmark candidate = *lm;
  candidate.inverse_depth = 1.0 / depth;
  for (const LandmarkObservation& ob : candidate.observations) {
    if (!(ObservationErrorPx(candidate, ob) <= options_.outlier_threshold_px)) return false;
  }
  lm->inverse_depth = candidate.inverse_depth;
  lm->triangulated = true;
  return true;
}

void LandmarkWindow::TriangulatePending() {
  for (auto& [id, lm] : landmarks_) {
    if (!lm.triangulated) Triangulate(&lm);
  }
}

std::vector<std::pair<uint64_t, LandmarkObservation>> LandmarkWindow::FrameObservations(
    WindowFrame* frame) const {
  std::vector<std::pair<uint64_t, LandmarkObservation>> out;
  for (int c = 0; c < static_cast<int>(frame->obs.cameras.size()); ++c) {
    for (const FeatureObservation& f : frame->obs.cameras[c]) out.push_back({f.id, {frame, c, f.bearing}});
  }
  for (const CrossCameraObservation& x : frame->obs.cross_camera) {
    out.push_back({x.id, {frame, x.camera_b, x.bearing_b}});
  }
  return out;
}

bool LandmarkWindow::HasObservation(const WindowLandmark& lm, const WindowFrame* frame, int camera) {
  for (const LandmarkObservation& ob : lm.observations) {
    if (ob.frame == frame && ob.camera == camera) return true;
  }
  return false;
}

void LandmarkWindow::CreateLandmarks(WindowFrame* frame) {
  for (int c = 0; c < static_cast<int>(frame->obs.cameras.size()); ++c) {
    for (const FeatureObservation& f : frame->obs.cameras[c]) {
      if (landmarks_.count(f.id) != 0) continue;
      WindowLandmark lm;
      lm.camera = c;
      lm.anchor_frame = frame;
      lm.anchor_camera = c;
      lm.anchor_bearing = f.bearing.normalized();
      lm.inverse_depth = 1.0 / options_.init_depth_m;
      lm.observations.push_back({frame, c, lm.anchor_bearing});
      landmarks_.emplace(f.id, std::move(lm));
    }
  }
  for (const CrossCameraObservation& x : frame->obs.cross_camera) {
    auto it = landmarks_.find(x.id);
    if (it == landmarks_.end() || it->second.anchor_frame != frame) continue;
    if (HasObservation(it->second, frame, x.camera_b)) continue;
    it->second.observations.push_back({frame, x.camera_b, x.bearing_b.normalized()});
  }
}

void LandmarkWindow::RemoveFrameObservations(const WindowFrame* frame) {
  for (auto it = landmarks_.begin(); it != landmarks_.end();) {
    WindowLandmark& lm = it->second;
    const bool anchored_here = lm.anchor_frame == frame;
    std::optional<Eigen::Vector3d> point;
    if (anchored_here && lm.triangulated) point = LandmarkInWorld(lm);
    lm.observations.erase(std::remove_if(lm.observations.begin(), lm.observations.end(),
                                         [&](const LandmarkObservation& ob) { return ob.frame == frame; }),
                          lm.observations.end());
    if (lm.observations.empty()) {
      if (point) {
        finished_landmarks_.push_back({static_cast<int64_t>(it->first), *point});
      } else if (lm.map_position) {
        finished_landmarks_.push_back({static_cast<int64_t>(it->first), *lm.map_position});
      }
      it = landmarks_.erase(it);
      continue;
    }
    if (anchored_here) {
      // Earliest remaining observation: observations are appended in frame order.
      const LandmarkObservation& first = lm.observations.front();
      lm.anchor_frame = first.frame;
      lm.anchor_camera = first.camera;
      lm.anchor_bearing = first.bearing;
      lm.triangulated = false;
      if (point) {
        const double depth = (WorldFromCam(*first.frame, first.camera).Inverse() * *point).dot(first.bearing);
        if (depth > kMinLandmarkDistanceM && depth < kMaxLandmarkDistanceM) {
          lm.inverse_depth = 1.0 / depth;
          lm.triangulated = true;
        }
      }
    }
    ++it;
  }
}

void LandmarkWindow::RemoveOutliers() {
  for (auto& [id, lm] : landmarks_) {
    if (!lm.triangulated) continue;
    if (!(lm.inverse_depth > 1.0 / kMaxLandmarkDistanceM && lm.inverse_depth < 1.0 / kMinLandmarkDistanceM)) {
      lm.triangulated = false;
      lm.inverse_depth = 1.0 / options_.init_depth_m;
      continue;
    }
    // The anchor observation defines the landmark and always stays.
    std::vector<LandmarkObservation> kept;
    for (const LandmarkObservation& ob : lm.observations) {
      const bool is_anchor = ob.frame == lm.anchor_frame && ob.camera == lm.anchor_camera;
      if (is_anchor || ObservationErrorPx(lm, ob) <= options_.outlier_threshold_px) kept.push_back(ob);
    }
    lm.observations = std::move(kept);
    if (lm.observations.size() < 2) lm.triangulated = false;
  }
}

double LandmarkWindow::RotationDeg() const {
  double best = 0.0;
  const Eigen::Quaterniond first = frames_.front()->WorldFromRig().rotation;
  for (const WindowFrame* frame : frames_) {
    best = std::max(best, first.angularDistance(frame->WorldFromRig().rotation));
  }
  return best / kDegToRad;
}

WindowFrame* LandmarkWindow::FarthestFromOldest() const {
  if (frames_.size() < 2) return nullptr;
  const Eigen::Vector3d origin = frames_.front()->WorldFromRig().translation;
  WindowFrame* best = nullptr;
  double best_distance = 0.0;
  const size_t last = frames_.size() > 2 ? frames_.size() - 1 : frames_.size();
  for (size_t k = 1; k < last; ++k) {
    const double d = (frames_[k]->WorldFromRig().translation - origin).norm();
    if (d > best_distance) {
      best_distance = d;
      best = frames_[k];
    }
  }
  return best_distance > kMinScaleAnchorDistance ? best : nullptr;
}

KeyframeEstimate LandmarkWindow::FinishedKeyframe(const WindowFrame* frame) {
  KeyframeEstimate out{frame->frame_index, frame->t_ns, frame->segment, frame->WorldFromRig(), {}, {}};
  const int num_cameras = static_cast<int>(frame->obs.cameras.size());
  for (int c = 0; c < num_cameras; ++c) {
    for (const FeatureObservation& f : frame->obs.cameras[c]) {
      auto it = landmarks_.find(f.id);
      if (it == landmarks_.end() || !UsableInBa(it->second)) continue;
      if (!HasObservation(it->second, frame, c)) continue;
      out.observations.push_back({c, static_cast<int64_t>(f.id), f.pixel});
      out.observation_points.push_back(LandmarkInWorld(it->second));
      it->second.map_position = out.observation_points.back();
    }
    // Camera c's observations of other cameras' landmarks (cross-camera
    // matches): in the map they tie the cameras' landmarks together, so a
    // global bundle adjustment sees the baseline (the metric scale).
    for (const CrossCameraObservation& x : frame->obs.cross_camera) {
      if (x.camera_b != c) continue;
      auto it = landmarks_.find(x.id);
      if (it == landmarks_.end() || !UsableInBa(it->second)) continue;
      if (!HasObservation(it->second, frame, c)) continue;
      out.observations.push_back({c, static_cast<int64_t>(x.id), x.pixel_b});
      out.observation_points.push_back(LandmarkInWorld(it->second));
    }
  }
  return out;
}

void LandmarkWindow::FinishAllLandmarks() {
  for (const auto& [id, lm] : landmarks_) {
    if (lm.triangulated) {
      finished_landmarks_.push_back({static_cast<int64_t>(id), LandmarkInWorld(lm)});
    } else if (lm.map_position) {
      finished_landmarks_.push_back({static_cast<int64_t>(id), *lm.map_position});
    }
  }
}

std::vector<MapLandmark> LandmarkWindow::TakeFinishedLandmarks() {
  std::vector<MapLandmark> out = std::move(finished_landmarks_);
  finished_landmarks_.clear();
  return out;
}

}  // namespace mcvo::backend_internal
