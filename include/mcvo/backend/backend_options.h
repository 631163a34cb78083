// Options of the back end (sliding-window bundle adjustment, keyframes,
// marginalisation, scale correction). Defaults follow the published
// implementation (../shared/reference/mcvo-reference-notes.md) unless said
// otherwise. Every key: docs/config.md.
#pragma once

#include "mcvo/util/enum_names.h"

namespace mcvo {

enum class LossType { kHuber, kCauchy, kTrivial };
inline constexpr EnumName<LossType> kLossTypeNames[] = {
    {LossType::kHuber, "huber"}, {LossType::kCauchy, "cauchy"}, {LossType::kTrivial, "none"}};

enum class SolverType { kDogleg, kLevenbergMarquardt };
inline constexpr EnumName<SolverType> kSolverTypeNames[] = {
    {SolverType::kDogleg, "dogleg"}, {SolverType::kLevenbergMarquardt, "levenberg_marquardt"}};

struct BackendOptions {
  int window_size = 10;  // keyframes, plus the newest frame
  SolverType solver = SolverType::kDogleg;
  int max_iterations = 8;
  double max_solver_time_s = 0.0;      // 0: no limit (required in deterministic mode)
  LossType loss = LossType::kHuber;    // the paper's Huber; the release uses Cauchy(1)
  double loss_scale = 1.0;             // in units of reprojection_sigma_px
  double reprojection_sigma_px = 1.5;  // at virtual_focal_px (information 460 / 1.5)
  double virtual_focal_px = 460.0;
  double init_depth_m = 5.0;           // depth of a new landmark that cannot be triangulated yet
  int min_observations = 2;            // landmarks seen fewer times are not optimised
  double keyframe_parallax_px = 10.0;  // mean parallax to the last keyframe, at virtual_focal_px
  int keyframe_min_tracked = 20;       // fewer tracked landmarks in a camera, or fewer triangulated
                                       // ones per tracking camera over the rig: keyframe
  double outlier_threshold_px = 3.0;   // observations above this after BA are removed
  // A cross-camera match whose two rays meet at less than this angle (a far
  // point: on a rectified pair of baseline b, farther than b / tan(angle),
  // 57 b at 1 deg) is not an observation of the window BA, nor of the map
  // the global BA refines; the feature stays a landmark of its own camera,
  // triangulated over time (ORB-SLAM2's close / far split, there at 40 b).
  // The initializer still sees every match (its own angles, 0.5 deg).
  // Why (results/stereo_far_points.md): on real KITTI stereo the baseline
  // sets the scale (rig.json's baseline x 0.99 / 1.01 moves it -1.07 % /
  // +1.03 %), and the far matches made it too long (0.78 % on
  // kitti06_stereo, 9.1 % on kitti01_stereo, 0.64 % / 6.1 % at 1 deg),
  // while their disparities agree with an independent search to 0.03 px:
  // what a far point cannot afford is an offset of the images themselves, a
  // fraction of a pixel against a 5 px disparity. The initializer's angles
  // raised with it (1.43 deg) left a stereo pair in open country unable to
  // start (roof_open_s64_blackout: 0 of 300 frames posed). 0: every match.
  double cross_camera_min_angle_deg = 1.0;
  double pnp_threshold_px = 2.0;       // rig absolute pose inlier threshold, at virtual_focal_px
  int min_pnp_inliers = 8;  // fewer over all cameras: tracking is lost (a 6-DoF pose, RANSAC inliers)
  int scale_correction_period = 50;            // solves between scale corrections; 0: never
  double scale_correction_min_change = 0.002;  // relative change below which none is applied
  // Scale corrections are fused with the current scale, weighted by their
  // uncertainties (estimator.h): the current scale's relative std grows as
  // a random walk of this std per 100 m travelled, and a measurement whose
  // relative std exceeds scale_correction_max_sigma is not used.
  double scale_drift_per_100m = 0.01;
  double scale_correction_max_sigma = 0.05;
  // The rig BA's covariance sees only the pixel noise it measures, not
  // systematic tracking errors: its relative std is multiplied by this
  // factor before the tests and the fusion.
  double scale_correction_sigma_factor = 3.0;
  double scale_correction_min_rotation_deg =
      10.0;  // windows turning less are not used (no overlap: no scale)
  // ... nor windows whose first and newest frames are less far apart.
  double scale_correction_min_travel_m = 2.0;
  bool refine_extrinsics = false;  // camera 0's extrinsic stays fixed (gauge)
  // Offline completion (reverse_pass.h): the frames before each segment's
  // initialisation are posed by the estimator run backwards from it, at the
  // scale found later; it runs over this many posed frames too, to align.
  bool reverse_pass = true;
  int reverse_pass_overlap_frames = 40;
  // Start the reverse run at the forward segment's first keyframes (their
  // final poses, held fixed) instead of its own initialisation aligned
  // afterwards; the aligned run stays the fallback (reverse_pass.h).
  bool reverse_pass_seeded = true;

  // Throws InputError naming the field by its config path ("/backend/...").
  void Check() const;
};

}  // namespace mcvo
