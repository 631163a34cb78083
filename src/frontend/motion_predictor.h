// Where a rig's features will be in the next frame, from the rig's own
// motion (frontend.lk.predict_motion; private to src/frontend).
//
// LK from a feature's previous position (or from its position rotated by
// the camera's last rotation, lk.predict_rotation) cannot follow a near
// point under fast forward motion: on the real KITTI 01 motorway frames (27
// m per second, 10 Hz) a stereo point 5-10 m ahead moves 100-200 px from one
// frame to the next and only 29 % of those that stay in view were tracked
// (10-20 m: 60 %), so the points that fix the metric scale best never
// linked two keyframes. Every feature of a camera pair that has a
// cross-camera match has a metric depth (the rig's known baseline), so:
//  1. Update(frame), after the frame is tracked and matched: the rig's
//     motion from the previous frame to this one is fitted to the features
//     that had a 3D point in the previous frame and are tracked in this one
//     (EstimateRigMotion: 6 DOF, Ceres, Huber on the bearing error in pixels
//     at ransac_focal_px), then the points are renewed: a feature matched in
//     this frame gets its triangulated point, one only tracked keeps its
//     point moved by the fitted motion, the others have none.
//  2. Predict(t_ns): every point moved by that motion again (constant
//     velocity, scaled to the next frame's time step) and projected into the
//     feature's camera: the pixel LK starts at (camera_tracker.h).
// A feature without a point keeps the start it had (rotation prediction or
// its previous position); a rig without overlapping cameras has no points,
// so nothing changes there. When the fit fails (too few points, too few
// inliers) nothing is predicted for the next frame and the points lapse.
// Deterministic: a single-threaded Ceres solve on correspondences in camera
// and feature order.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "mcvo/camera/camera.h"
#include "mcvo/frontend/camera_tracker.h"
#include "mcvo/frontend/multi_camera_tracker.h"
#include "mcvo/geometry/rigid3d.h"

namespace mcvo::frontend_internal {

struct MotionCorrespondence {
  int camera = 0;
  Eigen::Vector3d point_in_prev_rig = Eigen::Vector3d::Zero();  // the rig frame of the earlier frame
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();            // in `camera`, the later frame
};

struct RigMotionFit {
  bool ok = false;
  Rigid3d next_from_prev;  // rig of the later frame from rig of the earlier one
  int inliers = 0;         // correspondences within kMotionInlierPx after the fit
};

// Beyond this many pixels at focal_px after the first solve a
// correspondence is an outlier.
inline constexpr double kMotionInlierPx = 3.0;

// next_from_prev fitted from `initial` (robust: a Huber solve, the
// correspondences beyond kMotionInlierPx dropped, a second solve). ok when at
// least max(min_inliers, half of the correspondences) are inliers.
RigMotionFit EstimateRigMotion(const std::vector<Rigid3d>& cam_from_rig,
                               const std::vector<MotionCorrespondence>& correspondences, const Rigid3d& initial,
                               double focal_px, int min_inliers);

class RigMotionPredictor {
 public:
  // focal_px: the pixel unit of the fit (FrontendOptions::ransac_focal_px);
  // min_points: the fewest inliers of a usable fit. A cross-camera match
  // (a, b) gives camera a's feature its depth.
  RigMotionPredictor(const Rig& rig, double focal_px, int min_points);

  // Starting pixels for the frame at t_ns, per camera (feature id -> pixel
  // in that camera's image); empty when there is no motion to follow.
  std::vector<FeaturePredictions> Predict(int64_t t_ns) const;
  // After `frame` is tracked, its ids assigned and its cross-camera matches made.
  void Update(const MultiCameraFrame& frame);

  // The last fit (for tests and logs): none before two frames or after a failed fit.
  const std::optional<Rigid3d>& LastMotion() const { return motion_; }
  // Features with a 3D point after the last Update, over all cameras.
  size_t NumPoints() const;

 private:
  Rig rig_;
  std::vector<Rigid3d> cam_from_rig_;
  double focal_px_ = 460.0;
  int min_points_ = 12;
  // Per camera: feature id -> its point in the rig frame of the last frame.
  std::vector<std::map<uint64_t, Eigen::Vector3d>> points_;
  std::optional<Rigid3d> motion_;  // last frame from the one before
  int64_t last_t_ns_ = 0;
  int64_t last_dt_ns_ = 0;  // time step of motion_
  bool has_frame_ = false;
};

}  // namespace mcvo::frontend_internal
