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
// Uncertainty. Every solver also estimates the standard deviation of each
// scale from the residual: cov(s) = sigma^2 (F^T F)^-1 with sigma^2 =
// |F s + theta|^2 / (rows - N), and refuses (observable = false, "scale
// poorly observable: ...") when the largest sigma_i / |s_i| exceeds
// RigScaleOptions::max_relative_scale_sigma. This test comes before the sign
// test: a negative scale that the data do not support is reported as poorly
// observable, not as inconsistent input. The estimate treats the residual
// components as independent; SfM errors are correlated over the frames of a
// window, so it underestimates the real uncertainty (by about 2x on the
// initializer's windows, whose final uncertainty comes from the rig window
// bundle adjustment instead: rig_window_ba.h).
//
// Direct scale measurements (SolveRigScalesCombined). A length known both in
// camera c's SfM units (sfm_length) and in metres (metric_length), e.g. the
// depth of a point of c triangulated with another camera through the known
// baseline (cross-camera observations), gives one row
//   (sfm_length / metric_length) s_c = 1   with std relative_sigma
// (written with the inverse metric length: triangulation noise is near
// Gaussian in inverse depth, so the row is unbiased where a metric depth
// would not be). These rows fix the scale also under pure translation; the
// rig rows then still tie the scales of the other cameras to them.
// Combination: weighted least squares of both row sets, the rig rows with
// weight 1 / sigma_rig^2 and the measurement rows with 1 / (f relative_sigma)^2,
// sigma_rig (metres) and the factor f estimated from the residuals of each row
// set (Helmert variance component estimation, a fixed number of rounds:
// sigma_set^2 = |r_set|^2 / redundancy_set, redundancy from the hat matrix;
// f stays 1 when RigScaleOptions::estimate_measurement_sigma is off).
// The observability test and the uncertainty test run on the weighted
// combined system; the residual test on the rig rows only.
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
  // Largest accepted estimated relative standard deviation sigma_i / s_i of a
  // scale (see Uncertainty above).
  double max_relative_scale_sigma = 0.05;
  // Combined solve only: a-priori std of one rig residual component (metres),
  // the starting weight of the variance component estimation.
  double rig_sigma_m = 0.01;
  // Combined solve only: rescale the measurements' relative_sigma by a factor
  // estimated from their residuals (off: take them as given, e.g. when each
  // measurement already averages many and carries its own empirical sigma).
  bool estimate_measurement_sigma = true;
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
  // Estimated standard deviation of each scale (same order as scales); empty unless observable.
  std::vector<double> scale_sigmas;
  // The least-squares solution and its estimated stds whenever one was
  // computed, also when the tests rejected it (scales and scale_sigmas are
  // empty then): for diagnostics, and for callers that accept per camera.
  std::vector<double> solution;
  std::vector<double> solution_sigmas;
  double max_relative_scale_sigma = 0.0;  // max_i sigma_i / |s_i| (0 until a solution exists)
  double rig_sigma_m = 0.0;               // estimated std of one rig residual component, metres
  // Combined solve: the measurement rows' estimated std over their relative_sigma
  // (1 when they are as noisy as stated), and how many rows there were.
  double measurement_sigma_factor = 0.0;
  int num_measurements = 0;
};

// One direct measurement of a camera's scale (see "Direct scale measurements"):
// s_camera * sfm_length = metric_length.
struct ScaleMeasurement {
  int camera = 0;                // index into the cameras of the solve
  double sfm_length = 0.0;       // in the camera's SfM units, > 0
  double metric_length = 0.0;    // metres, > 0
  double relative_sigma = 0.01;  // a-priori std of the measurement, relative (> 0)
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

// Weighted least squares of the rig rows and the direct measurements together
// (see "Direct scale measurements"). Needs at least one camera (one camera:
// measurements only) and 2 frames; without measurements it gives the scales
// of SolveRigScalesLinear (the weighting is then uniform). MCVO_CHECKs the
// window (as above) and each measurement's camera index and relative_sigma;
// lengths that are not positive and finite are an expected failure.
RigScaleResult SolveRigScalesCombined(const std::vector<CameraWindowTrack>& cameras,
                                      const std::vector<ScaleMeasurement>& measurements,
                                      const RigScaleOptions& options = RigScaleOptions());

}  // namespace mcvo
