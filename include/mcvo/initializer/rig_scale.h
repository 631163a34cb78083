// Metric scale of each camera's monocular SfM from the rigid-rig constraint
// (paper Sec. "Multi-Camera Initialization", Eq. (eq:body), (eq:residual),
// (eq:multi_residual), (SO); reference notes "Initialisation (as released)", step 3).
//
// Frames. A = the rig (body) frame at the anchor frame l of the window: the
// frame in which every camera's SfM was anchored through its extrinsic. For
// camera i, with rig_from_cam_i = (r_i, c_i) (c_i = camera centre in the rig,
// metric, known):
//   R_i(t)  = rotation of A_from_cam_i(t)                 (scale free)
//   q_i(t)  = up-to-scale displacement of camera i's centre since the anchor
//             frame, in A axes; q_i(l) = 0. The metric centre is
//             C_i(t) = c_i + s_i q_i(t), s_i > 0 the unknown scale.
//
// Body pose implied by camera i (Eq. eq:body, A_from_rig = A_from_cam * cam_from_rig):
//   Rb_i(t) = R_i(t) r_i^T
//   Pb_i(t) = C_i(t) - Rb_i(t) c_i = s_i q_i(t) + (I - Rb_i(t)) c_i.
//
// Residual, one per frame t and camera pair i < j (Eq. eq:residual), metres:
//   e_ij(t) = Pb_i(t) - Pb_j(t) = [q_i(t)  -q_j(t)] [s_i s_j]^T + theta_ij(t),
//   theta_ij(t) = (I - Rb_i(t)) c_i - (I - Rb_j(t)) c_j.
// This is the paper's residual with T^c_t = q_c(t); the paper's theta
// (-Rb_i c_i + Rb_j c_j) lacks the constant c_i - c_j because it takes the SfM
// origin at the rig origin, which cannot hold for every camera at once: each
// camera's SfM origin is its own centre at the anchor frame, which is c_i.
// Stacked over t and all pairs: e = F s + theta (Eq. eq:multi_residual), and
// min_s ||F s + theta||^2 (Eq. SO) is the linear least squares F s = -theta.
//
// Observability. Without rotation Rb(t) = I, so theta = 0 and the true s is a
// null vector of F: only the ratios of the scales are known, not their size.
// Generally the size comes only from theta, i.e. from (I - Rb) times the lever
// differences: the rig must rotate, about an axis not parallel to all of
// c_i - c_j. The test: sigma_min / sigma_max of F with unit-norm columns (the
// columns hold different, arbitrary SfM scales) must exceed
// RigScaleOptions::min_singular_value_ratio. Both solvers run this test on
// the same stacked system, and report observable = false with the reason and
// no scales when it fails, when a scale is not positive, or when the rms
// residual is too large. They never hand out a scale they cannot support.
//
// Errors. The window is assembled by the initializer itself, so a malformed
// window (fewer than 2 cameras or frames, per-camera sizes that differ, a
// non-positive initial guess) is a programmer error: MCVO_CHECK aborts with
// file:line. Values that are not finite come from upstream estimation and
// are an expected failure: observable = false with the reason.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

// One camera's monocular SfM over the window, anchored as described above.
struct CameraWindowTrack {
  std::vector<Eigen::Vector3d> position_up_to_scale;  // q_i(t), zero at the anchor frame
  std::vector<Eigen::Matrix3d> rotation;              // rotation of A_from_cam_i(t)
  Rigid3d cam_from_rig;                               // extrinsic
};

struct RigScaleOptions {
  // Smallest accepted sigma_min / sigma_max of the column-normalised stacked
  // system. Its inverse bounds the amplification of relative input noise into
  // relative scale error; below 1e-3 the solution is dominated by noise (pure
  // translation gives ~1e-16 noise free, ~noise/displacement with noise).
  double min_singular_value_ratio = 1e-3;
  // Largest accepted rms of the residual components (metres). The release
  // rejects a solve whose final cost is high; this is that test, per component.
  double max_rms_residual_m = 0.1;
  // Ceres only: Levenberg-Marquardt iteration limit (no time limit: determinism).
  int max_num_iterations = 100;

  // Throws InputError naming the bad field ("rig_scale.<field>: must be ...").
  void Check() const;
};

struct RigScaleResult {
  bool observable = false;            // scales are valid only when true
  std::string reason;                 // why not observable; empty when observable
  std::vector<double> scales;         // s_i per camera, in input order; empty unless observable
  double rms_residual_m = 0.0;        // sqrt(mean of squared residual components) at the solution
  double singular_value_ratio = 0.0;  // sigma_min / sigma_max of the column-normalised F
  double condition_number = 0.0;      // sigma_max / sigma_min (inf when sigma_min = 0)
  int num_residual_blocks = 0;        // frames x camera pairs
};

// Closed-form least squares of F s = -theta: SVD of F with unit-norm columns.
RigScaleResult SolveRigScalesLinear(const std::vector<CameraWindowTrack>& cameras,
                                    const RigScaleOptions& options = RigScaleOptions());

// The same problem with Ceres (paper: Levenberg-Marquardt, automatic
// differentiation), scales parameterised as s = exp(u) so they stay positive,
// DENSE_QR, single-threaded, iteration limit only. initial_scales: one per
// camera, positive (the release starts at 10; the linear solution is better).
RigScaleResult SolveRigScalesCeres(const std::vector<CameraWindowTrack>& cameras,
                                   const std::vector<double>& initial_scales,
                                   const RigScaleOptions& options = RigScaleOptions());

}  // namespace mcvo
