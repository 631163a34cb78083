// Metric bundle adjustment of one window of rig poses and landmarks, every
// camera observing through its known extrinsic: the last step of the
// initializer (initializer.h), which starts it from the per-camera SfM scaled
// by the rig scale solve (rig_scale.h).
//
// Why: each camera's monocular SfM has its own, correlated errors, and the
// linear rig scale solve takes them as given. Here one rig trajectory
// explains all cameras' observations at once, so the scale is estimated
// from everything that constrains it: the rotation of the lever arms seen by
// several cameras, and overlapping views (a landmark of camera a observed by
// camera b in the same frame: the metric baseline between them).
//
// Residual (as camera_sfm.cc and the back end): for a bearing f of landmark X
// seen by camera c in frame t,
//   d = cam_from_rig_c * (world_from_rig_t^-1 * X),   e = focal_c * B_f^T d / |d|,
// B_f an orthonormal basis of the plane orthogonal to f, focal_c the camera's
// pixels per radian (RigWindowBaOptions::camera_focal_px; the thresholds and
// the Huber loss are in those pixels). Huber loss,
// Levenberg-Marquardt, single-threaded, iteration limit only. The pose of
// `fixed_frame` is held (the gauge); the scale is free, so the problem must
// only be given windows whose scale is observable (the initializer runs the
// rig scale solve's tests first).
//
// Uncertainty: the marginal covariance of the rig position at the last frame
// (Schur complement of the normal equations onto the poses, residual variance
// from the inlier residuals), reported as the relative standard deviation of
// the distance travelled over the window: the uncertainty of the metric scale.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

struct RigWindowObservation {
  int frame = 0;   // window frame
  int camera = 0;  // index into cam_from_rig
  uint64_t landmark = 0;
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();  // unit, camera frame
};

struct RigWindowBaOptions {
  double focal_px = 460.0;  // pixel values are angles at this virtual focal
  // Per camera (index of cam_from_rig): its pixels per radian (Camera::MeanFocalLength).
  // Each camera's residuals are scaled to its own pixels, so a camera that sees
  // fewer pixels per radian (a fisheye) weighs less: pixel noise is what is equal
  // over cameras, not angular noise. Empty: focal_px for every camera.
  std::vector<double> camera_focal_px;
  double huber_px = 1.0;
  // A first pass drops only observations beyond 3x this (the initial state
  // may be a few % off in scale: a tight filter against it would bias the
  // result to it); then those beyond it, and the adjustment runs again.
  double max_reprojection_px = 4.0;
  int max_iterations = 50;
};

struct RigWindowBaResult {
  bool ok = false;
  std::string reason;                          // why not ok
  std::vector<Rigid3d> world_from_rig;         // refined, per window frame
  std::map<uint64_t, Eigen::Vector3d> points;  // refined landmarks with >= 2 inlier observations
  int num_observations = 0;                    // inlier observations used
  double rms_reprojection_px = 0.0;            // of the inliers, at focal_px
  double travel_m = 0.0;                       // distance of the last frame's rig from the fixed frame's
  double travel_relative_sigma = 0.0;          // its estimated relative std (the scale uncertainty)
};

// world_from_rig: initial poses, one per window frame (the fixed frame's is
// kept as given); points: initial landmarks by id. Observations of unknown
// landmarks are ignored. MCVO_CHECKs the frame and camera indices. Failure
// (non-finite result, too few observations) is ok = false with the reason.
RigWindowBaResult AdjustRigWindow(const std::vector<Rigid3d>& cam_from_rig, int fixed_frame,
                                  const std::vector<Rigid3d>& world_from_rig,
                                  const std::map<uint64_t, Eigen::Vector3d>& points,
                                  const std::vector<RigWindowObservation>& observations,
                                  const RigWindowBaOptions& options = RigWindowBaOptions());

}  // namespace mcvo
