// Monocular structure from motion of one camera over the initialisation
// window, on unit bearing vectors (every camera model, fisheyes beyond 90 deg
// included):
//   1. relative pose between the anchor frame l and the reference frame r
//      (the newest frame of the window) by RANSAC on the 5-point essential
//      matrix (OpenGV Stewenius, fixed seed, ransac_threshold_px), refined
//      non-linearly on the inliers;
//   2. triangulation of the l-r inliers (midpoint on bearings; rejected when
//      the triangulation angle is below min_triangulation_angle_deg, behind
//      either camera, or with a reprojection error above max_reprojection_px);
//   3. every other frame, nearest to l first, by absolute pose (OpenGV
//      P3P-Kneip RANSAC on the triangulated points it sees, fixed seed,
//      threshold max_reprojection_px, refined on the inliers' fixed points
//      by Ceres with the bundle adjustment's bearing error), then
//      triangulation of the features now seen in two posed frames (the pair
//      of frames whose rays are furthest apart);
//   4. bundle adjustment (Ceres, tangent-plane bearing residual, Huber,
//      Levenberg-Marquardt, iteration limit only, single-threaded) over all
//      poses and points, the anchor pose fixed and the scale fixed by
//      |centre of camera at r in anchor coordinates| = 1 (r's centre on the
//      unit sphere); then observations beyond max_reprojection_px are
//      dropped, with the whole point when fewer than two or fewer than half
//      of its observations remain (a drifting track), and the adjustment
//      runs once more.
// Deterministic: same input, same output, whatever the order of the
// observations (no clocks, fixed RANSAC seeds, features processed in id order).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

// One observation of feature `id` in window frame `frame` (0-based).
struct WindowObservation {
  int frame = 0;
  uint64_t id = 0;
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();  // unit, camera frame
};

// Pixel values are angles expressed as pixels at a virtual pinhole of focal
// focal_px: e px is the angle atan(e / focal_px) on the unit sphere, the same
// for every camera model.
struct CameraSfmOptions {
  // 5-point RANSAC inlier threshold (OpenGV's error: both views' reprojection
  // errors after two-view triangulation). The frontend uses 1 px at 460 between
  // consecutive frames; between l and r (up to a window apart) 2 px keeps the
  // noise of tracked points (0.5-2 px) inside the threshold.
  double ransac_threshold_px = 2.0;
  double focal_px = 460.0;
  int ransac_max_iterations = 200;
  int min_correspondences = 20;  // l-r correspondences needed to start
  int min_inliers = 15;          // 5-point inliers needed
  double min_triangulation_angle_deg = 1.0;
  int min_points_for_pnp = 10;  // triangulated points a frame needs to be posed (and inliers it keeps)
  // Largest reprojection error of an observation used for triangulation, the
  // P3P RANSAC threshold, and the error above which an observation is dropped
  // after bundle adjustment.
  double max_reprojection_px = 4.0;
  int max_ba_iterations = 50;
  double ba_huber_px = 1.0;  // at focal_px
  // Checked by InitializerOptions::Check (config path /initializer/sfm/...).
};

struct CameraSfmResult {
  bool ok = false;
  std::string reason;  // why not ok: "too few correspondences (12 < 20)", ...
  // Per window frame: pose of the camera at that frame in the coordinates of
  // the camera at the anchor frame l (anchor_from_cam), scale fixed so that
  // |anchor_from_cam[r].translation| = 1; identity at l. Empty unless ok.
  std::vector<Rigid3d> anchor_from_cam;
  // Triangulated points in anchor-camera coordinates (same scale), by feature id.
  std::map<uint64_t, Eigen::Vector3d> points;
  int num_inliers = 0;             // 5-point inliers between l and r
  double rms_reprojection_px = 0;  // after BA, tangent-plane error at focal_px
  double mean_parallax_deg = 0;    // mean angle between l and r bearings after derotation
};

// observations: every observation of the camera in frames 0..num_frames-1
// (any order). MCVO_CHECKs 0 <= anchor_frame < reference_frame < num_frames,
// frame indices in range, bearings non-zero and finite and each feature at
// most once per frame; an observation that is not a unit vector is
// normalised. Failure (too few correspondences, too little parallax, a frame
// that cannot be posed) is ok = false with the reason, never an exception.
CameraSfmResult SolveCameraWindowSfm(int num_frames, int anchor_frame, int reference_frame,
                                     const std::vector<WindowObservation>& observations,
                                     const CameraSfmOptions& options = CameraSfmOptions());

}  // namespace mcvo
