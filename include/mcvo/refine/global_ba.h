// Offline global refinement: one rig bundle adjustment over every keyframe
// and landmark of a run (the sliding window only ever saw 10 keyframes at a
// time; after loop closure every keyframe still keeps its window-era pose
// relative to its neighbours).
//
// Unknowns: each keyframe's world_from_rig (one pose per frame shared by all
// cameras: the rig constraint) and each landmark's world position. Residual:
// the tangent-plane bearing error of backend/factors.h (the same for every
// camera model, fisheye beyond 90 deg included), here of a world point seen
// from camera c of keyframe k:
//   p = cam_from_rig_c * rig_from_world_k * X,
//   r = sqrt_information * TangentBasis(b) (p / |p| - b),
// sqrt_information = virtual_focal_px / reprojection_sigma_px, under a
// robust loss. Intrinsics are fixed (the calibration is given); so are the
// extrinsics unless refine_extrinsics ("Extrinsics" below). Solved by Ceres with the sparse Schur complement (landmarks
// eliminated first, SuiteSparse's CHOLMOD on the reduced camera system) on
// one thread: Ceres' multi-threaded Schur reduction sums in an order that
// depends on scheduling, and the result must be byte-identical at any
// thread count. CHOLMOD's supernodal factorisation runs on the machine's
// BLAS (mcvo/util/blas.h; OpenBLAS, serial, after `make deps`): the reduced
// camera system is wide (on the 1.18 km route each keyframe shares points
// with 140 others), and with ATLAS the factorisations were a third of the
// linear solver's time (Ceres' linear solver 55.3 s against 34.9 s with
// OpenBLAS, results/global_ba_blas.md).
//
// Gauge: keyframes that share landmarks (directly or through others) form a
// component; each component's first keyframe is held fixed. With a metric
// rig the scale is observed through the extrinsics (the cross-camera
// baselines, or the rig rotating for cameras without overlap) and stays
// free, so the BA refines it along the whole route; with scale_free (one
// camera, or a rig whose scale the run could not observe) the distance from
// the component's first to its last keyframe is held too.
//
// Loops: a relative pose measured between two keyframes (loop closure's
// verified rig pose) enters as a 6-dof constraint with the given sigmas
// under a Cauchy loss, so that a loop the pose graph closed stays closed
// (the observations alone only hold each keyframe to its neighbours); it
// also joins the two keyframes' gauge components.
//
// Scale on straights: where the rig drives straight, a rig without
// overlapping views observes no scale (only its small rotations move the
// cameras' centres differently), and the scale profile along the route is
// held only by the chain of landmarks. On rendered images the BA's minimum
// bent that profile: on two 400-frame sequences with 320 frames of straight
// road before one corner, the 3-camera rig's scale error went from 5.3 %
// (odometry) to 14.4 % after the BA at convergence (4.3 % after 5
// iterations; 0.76 of the true scale at the start, 0.92 at the corner,
// results/robustness_seed11.md). So the input's profile is held there as a
// prior: the used keyframes in order are cut into spans of
// straight_window_keyframes (w); for consecutive spans (a, b), (b, c) of one
// segment that turn at most straight_max_rotation_deg from a to c and whose
// keyframes see fewer than straight_overlap_min_landmarks landmarks each
// (mean) in two or more of their cameras (overlapping views observe the
// scale through their baselines), the residual is
//   (log(|t_c - t_b| / |t0_c - t0_b|) - log(|t_b - t_a| / |t0_b - t0_a|)) / sigma,
//   sigma = straight_scale_sigma * sqrt(((d_ab + d_bc) / 2) / 100 m),
// t0 the input positions (the odometry's, after the pose graph): a random
// walk of the log scale. The BA still moves the level of a straight's scale
// with the turns at its ends, and is free where the rig turns. It is a
// trade: where the images are clean and the input's profile is wrong, the
// free BA would have corrected it (tests/refine/global_ba_test.cc keeps
// half of a 4 % step that the free BA removes). Spans under 1 cm are skipped.
//
// Extrinsics (refine_extrinsics, off by default): the rig's first camera is
// the reference and keeps its calibration (the images cannot tell a common
// motion of every camera from a motion of the rig: as COLMAP's and
// Kalibr's reference sensor, it defines the rig frame). Every other
// camera's cam_from_rig becomes a parameter block shared by all keyframes,
// with a prior that holds it to the given calibration: the rotation error
// 2 vec(q0^-1 q) over extrinsic_rotation_sigma_deg and the camera centre's
// displacement in the rig over extrinsic_translation_sigma_m. The
// observations fix the cameras' rotations relative to the reference well,
// and their positions where views overlap or the rig turns; on a straight
// road without overlap the centres stay near the calibration, held by the
// prior (which also keeps the baselines' length, the metric scale).
//
// Robust loss: Cauchy. The first solve's knee is loss_scale x
// reprojection_sigma_px (1.5 px at virtual_focal_px: the odometry's input
// may be off by that much). Each later solve measures the noise of the
// tracks in the residuals of the solve before it, sigma = median |e| /
// 1.1774 (the median of a 2-D Gaussian error's norm is 1.1774 sigma), over
// the observations kept, and puts its knee at adaptive_loss_sigmas x sigma,
// at most the first solve's and at least adaptive_loss_min_px. Anchored
// tracks have a median error of 0.1-0.25 px after 9 frames
// (results/anchor_tracking.md); with the knee at 1.5 px their tails of
// 1-3 px (features on depth edges, tracks that slid) kept nearly full
// weight, and on the 3-camera rig without overlap (5 suite sequences, 300
// frames) they pulled the scale short: scale error median / worst 1.53 /
// 1.77 % with every solve at 1.5 px, 1.15 / 1.52 % at 0.75 px, 0.96 / 1.35 %
// at 0.5 px, ATE lower on all 5 (a Huber loss was worse: 2.1 % against
// 1.7 % on k3_block_s11). A fixed knee of 0.5 px is too tight for noisier
// input (tests/refine/global_ba_test.cc, 1 px of noise: the refined
// extrinsics' positions got worse than the fixed ones'); measured from the
// residuals it follows the input. run.json: global_ba.loss_knee_px per
// solve. The knee does not move the observations' weight against the loop
// constraints and the straight-road hold (reprojection_sigma_px does).
//
// Outliers: after a solve, observations whose error exceeds
// outlier_threshold_px (at virtual_focal_px) or whose point lies behind the
// camera are removed, landmarks left with fewer than min_observations
// observations go with them, and the problem is solved again
// (outlier_rounds times at most, stopping early when none is removed and
// the measured knee would not tighten).
//
// Solves: every solve that another follows stops when an iteration lowers
// the cost by less than first_solve_function_tolerance (0.1 %) of it, the
// last at function_tolerance (or after max_iterations, each). The first
// solve only has to bring the errors near their final size for the outlier
// test and the measured knee. Measured with first solves of 20 iterations
// against this, on 8 suite sequences (4-, 2-, 3-, 6-, 5-camera, triple and
// roof rigs, 300 frames each, no loop): ATE and scale error as they were
// (largest change 0.002 % of the path), 6-13 first-solve iterations
// instead of 20, global BA time -13 to -40 %; on an 808-keyframe block
// driven 1.5 times (269 loops, 14 px rms after the pose graph): 12
// iterations, ATE 0.075 against 0.074 m. Fixed cuts were worse there: 4
// iterations gave 0.078 m (more observations removed as outliers before
// the loops' corrections had settled), 8 gave 0.076 m. The second solve
// needs its 20 (at 10 the 3-camera scale error on k3_open_s14 went -0.58
// -> -1.10 %; at 40 nothing changed). A loose solve is never the last:
// when it removes nothing and the knee would not tighten, the next solve
// continues it at function_tolerance.
//
// Inner iterations (inner_iterations, off by default): in the last solve,
// between the LM steps, Ceres moves every eliminated point alone to its own
// minimum. The points are one group, given explicitly (an independent set
// by construction; Ceres' automatic grouping walks a hash set of block
// addresses). Measured 2026-11-28: on k360_block_s3_expo (4 cameras) the
// last solve converged after 10 LM steps where it stopped at 20, final cost
// 1552.05 against 1552.23, ATE 0.0217 against 0.0218 m; on k3_block_s108
// (3 cameras without overlap) it still stopped at 20 (its slow direction is
// the scale along the route, a pose direction), ATE 0.1312 against
// 0.1314 %. In every solve instead, the first solve stopped after 2-3 steps
// (11 without): ATE over 14 suite runs median 1.00 (0.98-1.02), but 1.21 on
// k3_block_s108, its outliers judged on poses the short first solve had
// not settled; hence the last solve only. On the 1.18 km route (4
// cameras, rematch_every 1): 24 LM steps in all instead of 32, ATE 0.208
// against 0.207 m. With rematch_every 2 (the default since) the route's last
// solve stopped at 20 with and without them, and the global BA took 91.7 s
// instead of 81.8 s (the same machine, the same hour, replayed tracks):
// off.
//
// Long tracks (thin_tracks_longer_than, off by default): the Schur
// elimination's work grows with the square of the keyframes a landmark is
// seen in, and on the 1.18 km route a few landmarks seen in 25-60 keyframes
// (the fisheyes keep far points in view) make most of it: the sum of
// squared track lengths is 6.0 million with 4 cameras. Seen in more than
// thin_tracks_longer_than keyframes, a landmark enters the solves through
// every thin_track_stride-th of them and its last (at 10 and 2: 2.2
// million; 29 % fewer observations). The others stay in the map, are
// tested as outliers after the last solve and reach the COLMAP model.
// Consecutive observations of one LK track err together (its drift), so
// they are not independent measurements either. Measured 2026-11-28 at 10 and 2 against
// every observation: ATE ratio median 1.03 (0.76-1.17, lower in 7) over the
// 14 runs of the suite subset, 0.98 (0.88-1.42, lower in 5) over the 8
// held-out runs; on the route 4 cameras 0.204 -> 0.192 m, 3 cameras 0.201
// -> 0.182 m (local scale worst 0.34 -> 0.41 %); the 4-camera route's
// global BA 64.0 -> 48.7 s (-24 %, idle machine, replayed tracks). Off:
// a quarter of the global BA's time, with the suite's ATE no better in the
// median and up to 1.42 times worse (results/global_ba_blas.md).
#pragma once

#include <string>
#include <vector>

#include "mcvo/geometry/rigid3d.h"
#include "mcvo/backend/backend_options.h"
#include "mcvo/camera/camera.h"
#include "mcvo/map/sparse_map.h"

namespace mcvo {

struct GlobalBaOptions {
  bool enabled = true;
  // Also for a run at an arbitrary scale (one camera). Off: on the
  // monocular suite (16 sequences) the bundle adjustment made ATE worse on
  // 10 (median ratio 1.05, worst 6.2: the scale along a single camera's
  // route is held only by its chain of tracks, and the bundle adjustment
  // bends it where the window's prior kept it).
  bool monocular = false;
  int max_iterations = 20;             // Levenberg-Marquardt iterations per solve
  int outlier_rounds = 1;              // solves after the first one, each after removing outliers
  double first_solve_function_tolerance = 1e-3;  // "Solves" above: each solve but the last
  bool inner_iterations = false;                 // "Solves" above: inner iterations over the points, last solve
  LossType loss = LossType::kCauchy;   // on every observation
  double loss_scale = 1.0;             // in units of reprojection_sigma_px: the first solve's knee
  // "Robust loss" above: each later solve's Cauchy knee is this many times
  // the noise measured in the residuals of the solve before it, never more
  // than the first solve's knee nor less than adaptive_loss_min_px. 0: off
  // (every solve at loss_scale).
  double adaptive_loss_sigmas = 2.0;
  double adaptive_loss_min_px = 0.2;  // at virtual_focal_px
  double reprojection_sigma_px = 1.5;  // at virtual_focal_px
  double virtual_focal_px = 460.0;
  double outlier_threshold_px = 3.0;  // at virtual_focal_px
  int min_observations = 2;           // per landmark (any camera, any keyframe)
  double function_tolerance = 1e-7;   // Ceres' relative cost change to stop at
  // "Long tracks" above: landmarks seen in more keyframes than this enter
  // the solves through every thin_track_stride-th of them and their last. 0: off.
  int thin_tracks_longer_than = 0;
  int thin_track_stride = 2;
  // Straight-road scale hold ("Scale on straights" above): the input's
  // log scale profile as a random walk of straight_scale_sigma per
  // sqrt(100 m), over spans of straight_window_keyframes keyframes that
  // turn at most straight_max_rotation_deg over two spans. 0 sigma: off.
  double straight_scale_sigma = 0.002;
  double straight_max_rotation_deg = 5.0;
  int straight_window_keyframes = 5;
  // Spans whose keyframes see at least this many landmarks each (mean) in
  // two or more of their cameras (overlapping views, whose baselines
  // observe the scale) get no hold.
  int straight_overlap_min_landmarks = 1;
  // Before the BA, fuse the landmarks that accepted loops saw again
  // (refine/landmark_fusion.h); used by `mcvo run`'s refinement stage.
  bool fuse_loop_landmarks = true;
  // The cross-camera links across time (loop/cross_camera_links.h), fused
  // with the loops' landmarks: 0 merges each link's two landmarks into one;
  // > 0 keeps both and ties them (GlobalBaLandmarkTie) with a sigma of this
  // many px at virtual_focal_px at the linked camera's distance to the point.
  double cross_camera_link_sigma_px = 0.0;
  // "Extrinsics" above: refine every camera's cam_from_rig with a prior of
  // these sigmas around the calibration.
  bool refine_extrinsics = false;
  double extrinsic_rotation_sigma_deg = 0.5;
  double extrinsic_translation_sigma_m = 0.02;

  // Throws InputError naming the field by its config path ("/refine/...").
  void Check() const;
};

// A measured relative pose between two keyframes of the map (indices into
// SparseMap::keyframes): from_T_to = world_from_rig[from]^-1 * world_from_rig[to].
struct GlobalBaPoseConstraint {
  int from = 0;
  int to = 0;
  Rigid3d from_T_to;
  double rotation_sigma_rad = 0.0035;  // > 0
  double translation_sigma_m = 0.1;    // > 0
  double loss_scale = 3.0;             // Cauchy scale on the whitened residual's norm, in sigmas
};

// Two landmarks that are one point up to the matching error of the pixels
// that found them (a cross-camera link across time, loop/
// cross_camera_links.h), kept as two points tied by a residual
// (a - b) / sigma_m under a Cauchy loss of loss_scale sigmas, instead of
// merged into one: a merge makes every observation of both tracks carry
// the two detections' offset.
struct GlobalBaLandmarkTie {
  int64_t landmark_a = 0;
  int64_t landmark_b = 0;
  double sigma_m = 0.0;     // > 0
  double loss_scale = 3.0;  // > 0, in sigmas
};

struct GlobalBaResult {
  bool ran = false;     // false: nothing to refine (no landmark seen twice)
  std::string message;  // why it did not run, or Ceres' final message
  // The input map refined: keyframe poses and landmark positions moved,
  // observations removed as outliers gone, landmarks left without any
  // observation gone. Keyframes without a refined observation keep their
  // pose, landmarks not refined their position.
  SparseMap map;
  std::vector<bool> refined;  // per keyframe: it had a pose block in the last solve
  int keyframes_refined = 0;
  int components = 0;            // gauge components (one fixed keyframe each)
  int constraints_used = 0;      // pose constraints in the last solve
  int straight_scale_residuals = 0;  // straight-road scale hold residuals in the last solve
  int ties_used = 0;                 // landmark ties in the last solve (both landmarks refined)
  int landmarks_refined = 0;     // in the last solve
  int observations_used = 0;     // in the last solve
  int observations_removed = 0;  // as outliers or behind the camera, over all rounds
  int solves = 0;
  std::vector<double> loss_knee_px;  // per solve: the Cauchy knee ("Robust loss"), px at virtual_focal_px
  int iterations = 0;                // summed over the solves
  double initial_cost = 0.0;         // Ceres cost (robust) before the first solve
  double final_cost = 0.0;           // after the last solve
  double rms_error_px_before = 0.0;  // over the first solve's observations, at virtual_focal_px
  double rms_error_px_after = 0.0;   // over the last solve's observations
  // Per camera of the rig: cam_from_rig after the BA (the input's unless
  // refine_extrinsics), and how far it moved: rotation angle (deg) and the
  // camera centre's displacement in the rig (m).
  std::vector<Rigid3d> cam_from_rig;
  std::vector<double> extrinsic_rotation_change_deg;
  std::vector<double> extrinsic_translation_change_m;
  double seconds = 0.0;              // wall clock (not deterministic)
};

// Refines the keyframes and landmarks of `map` (cameras are indices into
// rig.cameras; observations of a landmark the map does not hold, of an
// unknown camera or of a pixel the camera cannot unproject are left out of
// the problem and kept as they are). Deterministic: the same input gives
// the same output bit for bit.
GlobalBaResult RunGlobalBundleAdjustment(const Rig& rig, const SparseMap& map, bool scale_free,
                                         const GlobalBaOptions& options,
                                         const std::vector<GlobalBaPoseConstraint>& constraints = {},
                                         const std::vector<GlobalBaLandmarkTie>& ties = {});

}  // namespace mcvo
