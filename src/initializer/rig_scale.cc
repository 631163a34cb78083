#include "mcvo/initializer/rig_scale.h"

#include <cmath>
#include <limits>
#include <utility>

#include <ceres/ceres.h>
#include <Eigen/SVD>

#include "mcvo/util/error.h"
#include "mcvo/util/option_checks.h"
#include "mcvo/util/strings.h"

namespace mcvo {

void RigScaleOptions::Check() const {
  CheckInRange("rig_scale.min_singular_value_ratio", min_singular_value_ratio, 0.0, 1.0);
  CheckPositive("rig_scale.max_rms_residual_m", max_rms_residual_m);
  CheckPositive("rig_scale.max_relative_scale_sigma", max_relative_scale_sigma);
  CheckPositive("rig_scale.rig_sigma_m", rig_sigma_m);
  CheckAtLeast("rig_scale.max_num_iterations", max_num_iterations, 1);
}

namespace {

// Stacked Eq. (eq:multi_residual): rows 3k..3k+2 hold block k = (t, i, j).
struct StackedSystem {
  Eigen::MatrixXd f;                       // F, (3 * blocks) x N
  Eigen::VectorXd theta;                   // theta, 3 * blocks
  std::vector<std::pair<int, int>> pairs;  // (i, j) of each block
};

void CheckWindow(const std::vector<CameraWindowTrack>& cameras, size_t min_cameras = 2) {
  MCVO_CHECK_MSG(cameras.size() >= min_cameras, "rig scale needs at least ", min_cameras, " camera",
                 min_cameras == 1 ? "" : "s", ", got ", cameras.size());
  const size_t num_frames = cameras[0].position_up_to_scale.size();
  MCVO_CHECK_MSG(num_frames >= 2, "rig scale needs at least 2 frames, got ", num_frames);
  for (size_t c = 0; c < cameras.size(); ++c) {
    MCVO_CHECK_MSG(cameras[c].position_up_to_scale.size() == num_frames, "camera ", c, " has ",
                   cameras[c].position_up_to_scale.size(), " positions, camera 0 has ", num_frames);
    MCVO_CHECK_MSG(cameras[c].rotation.size() == num_frames, "camera ", c, " has ",
                   cameras[c].rotation.size(), " rotations, expected ", num_frames);
  }
}

// Empty when every value is finite, else the reason.
std::string NonFiniteReason(const std::vector<CameraWindowTrack>& cameras) {
  for (size_t c = 0; c < cameras.size(); ++c) {
    const CameraWindowTrack& cam = cameras[c];
    if (!cam.cam_from_rig.rotation.coeffs().allFinite() || !cam.cam_from_rig.translation.allFinite()) {
      return StrCat("camera ", c, ": extrinsic is not finite");
    }
    for (size_t t = 0; t < cam.position_up_to_scale.size(); ++t) {
      if (!cam.position_up_to_scale[t].allFinite() || !cam.rotation[t].allFinite()) {
        return StrCat("camera ", c, " frame ", t, ": SfM pose is not finite");
      }
    }
  }
  return "";
}

StackedSystem Stack(const std::vector<CameraWindowTrack>& cameras) {
  const int n = static_cast<int>(cameras.size());
  const int num_frames = static_cast<int>(cameras[0].position_up_to_scale.size());
  // Per camera: rig_from_cam rotation r_c and centre c_c = -R_cam_from_rig^T t_cam_from_rig.
  std::vector<Eigen::Matrix3d> cam_from_rig_rotation(n);
  std::vector<Eigen::Vector3d> centre_in_rig(n);
  for (int c = 0; c < n; ++c) {
    cam_from_rig_rotation[c] = cameras[c].cam_from_rig.RotationMatrix();
    centre_in_rig[c] = cameras[c].cam_from_rig.Inverse().translation;
  }
  const Eigen::Index num_blocks = static_cast<Eigen::Index>(num_frames) * n * (n - 1) / 2;
  StackedSystem sys;
  sys.f = Eigen::MatrixXd::Zero(3 * num_blocks, n);
  sys.theta = Eigen::VectorXd::Zero(3 * num_blocks);
  int row = 0;
  for (int t = 0; t < num_frames; ++t) {
    for (int i = 0; i < n; ++i) {
      // (I - Rb_i(t)) c_i with Rb_i(t) = R_i(t) r_i^T = R_i(t) * R_cam_from_rig.
      const Eigen::Vector3d lever_i =
          centre_in_rig[i] - cameras[i].rotation[t] * cam_from_rig_rotation[i] * centre_in_rig[i];
      for (int j = i + 1; j < n; ++j) {
        const Eigen::Vector3d lever_j =
            centre_in_rig[j] - cameras[j].rotation[t] * cam_from_rig_rotation[j] * centre_in_rig[j];
        sys.f.block<3, 1>(row, i) = cameras[i].position_up_to_scale[t];
        sys.f.block<3, 1>(row, j) = -cameras[j].position_up_to_scale[t];
        sys.theta.segment<3>(row) = lever_i - lever_j;
        sys.pairs.emplace_back(i, j);
        row += 3;
      }
    }
  }
  return sys;
}

// Fills the conditioning fields of `result`; returns false (with the reason
// set) when the scales are not observable from this window.
bool CheckObservable(const StackedSystem& sys, const RigScaleOptions& options, RigScaleResult* result,
                     Eigen::VectorXd* column_norms, Eigen::JacobiSVD<Eigen::MatrixXd>* svd) {
  result->num_residual_blocks = static_cast<int>(sys.f.rows() / 3);
  *column_norms = sys.f.colwise().norm().transpose();
  for (int c = 0; c < column_norms->size(); ++c) {
    if (!((*column_norms)(c) > std::numeric_limits<double>::min())) {
      result->reason = StrCat("camera ", c, " does not move in the window: its scale is not observable");
      return false;
    }
  }
  const Eigen::MatrixXd normalised = sys.f * column_norms->cwiseInverse().asDiagonal();
  svd->compute(normalised, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sigma = svd->singularValues();
  const double sigma_max = sigma(0);
  const double sigma_min = sigma(sigma.size() - 1);
  result->singular_value_ratio = sigma_min / sigma_max;
  result->condition_number =
      sigma_min > 0.0 ? sigma_max / sigma_min : std::numeric_limits<double>::infinity();
  if (!(result->singular_value_ratio >= options.min_singular_value_ratio)) {
    result->reason = StrCat(
        "rig motion is near pure translation (or rotates only about the lever differences): "
        "scale not observable (sigma_min/sigma_max = ",
        FormatDouble(result->singular_value_ratio), " < ", FormatDouble(options.min_singular_value_ratio),
        ")");
    return false;
  }
  return true;
}

// Standard deviations of the scales from the SVD of A D^-1 (A whitened,
// D = diag(column norms)): cov(s) = D^-1 V Sigma^-2 V^T D^-1, times
// `variance` (the residual variance when A is not whitened, else 1).
Eigen::VectorXd ScaleSigmas(const Eigen::JacobiSVD<Eigen::MatrixXd>& svd, const Eigen::VectorXd& column_norms,
                            double variance) {
  const Eigen::MatrixXd& v = svd.matrixV();
  const Eigen::VectorXd& sigma = svd.singularValues();
  Eigen::VectorXd out(v.rows());
  for (Eigen::Index i = 0; i < v.rows(); ++i) {
    double sum = 0.0;
    for (Eigen::Index k = 0; k < sigma.size(); ++k) {
      sum += sigma(k) > 0.0 ? (v(i, k) / sigma(k)) * (v(i, k) / sigma(k))
                            : std::numeric_limits<double>::infinity();
    }
    out(i) = std::sqrt(variance * sum) / column_norms(i);
  }
  return out;
}

// Residual variance of the unweighted rig system at `scales`: |r|^2 / (rows - N).
double RigResidualVariance(const StackedSystem& sys, const Eigen::VectorXd& scales) {
  const Eigen::VectorXd residual = sys.f * scales + sys.theta;
  const double dof = static_cast<double>(sys.f.rows() - sys.f.cols());
  return dof > 0.0 ? residual.squaredNorm() / dof : std::numeric_limits<double>::infinity();
}

// Final acceptance of a solution: positive scales, a small rig residual and a
// small relative uncertainty.
void Accept(const StackedSystem& sys, const Eigen::VectorXd& scales, const Eigen::VectorXd& sigmas,
            const RigScaleOptions& options, RigScaleResult* result) {
  const Eigen::VectorXd residual = sys.f * scales + sys.theta;
  result->rms_residual_m =
      residual.size() > 0 ? std::sqrt(residual.squaredNorm() / static_cast<double>(residual.size())) : 0.0;
  result->solution.assign(scales.data(), scales.data() + scales.size());
  result->solution_sigmas.assign(sigmas.data(), sigmas.data() + sigmas.size());
  // Uncertainty first: a scale that is not positive but also not supported
  // by the data is a matter of observability, not of inconsistent input.
  int worst = 0;
  result->max_relative_scale_sigma = 0.0;
  for (int c = 0; c < scales.size(); ++c) {
    const double relative = sigmas(c) / std::abs(scales(c));
    if (!(relative <= result->max_relative_scale_sigma)) {
      result->max_relative_scale_sigma = relative;
      worst = c;
    }
  }
  if (!(result->max_relative_scale_sigma <= options.max_relative_scale_sigma)) {
    result->reason = StrCat("scale poorly observable: camera ", worst, " scale sigma ",
                            FormatFixed(100.0 * result->max_relative_scale_sigma, 2), " % > ",
                            FormatFixed(100.0 * options.max_relative_scale_sigma, 2), " %");
    return;
  }
  for (int c = 0; c < scales.size(); ++c) {
    if (!(scales(c) > 0.0)) {
      result->reason = StrCat("camera ", c, ": scale is not positive (", FormatDouble(scales(c)), ")");
      return;
    }
  }
  if (!(result->rms_residual_m <= options.max_rms_residual_m)) {
    result->reason = StrCat("rig scale residual too large: rms ", FormatDouble(result->rms_residual_m),
                            " m > ", FormatDouble(options.max_rms_residual_m), " m");
    return;
  }
  result->observable = true;
  result->reason.clear();
  result->scales.assign(scales.data(), scales.data() + scales.size());
  result->scale_sigmas.assign(sigmas.data(), sigmas.data() + sigmas.size());
}

// One block of Eq. (eq:residual) with s = exp(u): e = exp(u_i) q_i - exp(u_j) q_j + theta.
struct ScalePairResidual {
  ScalePairResidual(const Eigen::Vector3d& q_i, const Eigen::Vector3d& q_j, const Eigen::Vector3d& theta)
      : q_i_(q_i), q_j_(q_j), theta_(theta) {}

  template <typename T>
  bool operator()(const T* const log_scale_i, const T* const log_scale_j, T* residual) const {
    const T s_i = ceres::exp(log_scale_i[0]);
    const T s_j = ceres::exp(log_scale_j[0]);
    for (int k = 0; k < 3; ++k) residual[k] = s_i * q_i_(k) - s_j * q_j_(k) + theta_(k);
    return true;
  }

  Eigen::Vector3d q_i_, q_j_, theta_;
};

// The part both solvers share: the input checks, the stacked system and the
// observability test (a property of the data, not of the solver). False when
// the window is rejected; `result` then holds the reason.
bool PrepareSolve(const std::vector<CameraWindowTrack>& cameras, const RigScaleOptions& options,
                  RigScaleResult* result, StackedSystem* sys, Eigen::VectorXd* column_norms,
                  Eigen::JacobiSVD<Eigen::MatrixXd>* svd) {
  result->reason = NonFiniteReason(cameras);
  if (!result->reason.empty()) return false;
  *sys = Stack(cameras);
  return CheckObservable(*sys, options, result, column_norms, svd);
}

}  // namespace

RigScaleResult SolveRigScalesLinear(const std::vector<CameraWindowTrack>& cameras,
                                    const RigScaleOptions& options) {
  options.Check();
  CheckWindow(cameras);
  RigScaleResult result;
  StackedSystem sys;
  Eigen::VectorXd column_norms;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd;
  if (!PrepareSolve(cameras, options, &result, &sys, &column_norms, &svd)) return result;
  // F D^-1 (D s) = -theta, D = diag(column norms).
  const Eigen::VectorXd scales = svd.solve(-sys.theta).cwiseQuotient(column_norms);
  const double variance = RigResidualVariance(sys, scales);
  result.rig_sigma_m = std::sqrt(variance);
  Accept(sys, scales, ScaleSigmas(svd, column_norms, variance), options, &result);
  return result;
}

RigScaleResult SolveRigScalesCeres(const std::vector<CameraWindowTrack>& cameras,
                                   const std::vector<double>& initial_scales,
                                   const RigScaleOptions& options) {
  options.Check();
  CheckWindow(cameras);
  MCVO_CHECK_MSG(initial_scales.size() == cameras.size(), "got ", initial_scales.size(),
                 " initial scales for ", cameras.size(), " cameras");
  for (double s : initial_scales)
    MCVO_CHECK_MSG(s > 0.0 && std::isfinite(s), "initial scale must be > 0, got ", s);
  RigScaleResult result;
  StackedSystem sys;
  Eigen::VectorXd column_norms;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd;
  if (!PrepareSolve(cameras, options, &result, &sys, &column_norms, &svd)) return result;

  const int n = static_cast<int>(cameras.size());
  std::vector<double> log_scales(n);
  for (int c = 0; c < n; ++c) log_scales[c] = std::log(initial_scales[c]);
  ceres::Problem problem;
  // Blocks in the order of Stack() (frame, then pair i < j): a deterministic parameter order.
  for (size_t b = 0; b < sys.pairs.size(); ++b) {
    const int i = sys.pairs[b].first;
    const int j = sys.pairs[b].second;
    const int row = 3 * static_cast<int>(b);
    auto* cost = new ceres::AutoDiffCostFunction<ScalePairResidual, 3, 1, 1>(new ScalePairResidual(
        sys.f.block<3, 1>(row, i), -sys.f.block<3, 1>(row, j), sys.theta.segment<3>(row)));
    problem.AddResidualBlock(cost, nullptr, &log_scales[i], &log_scales[j]);
  }

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.minimizer_type = ceres::TRUST_REGION;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver_options.max_num_iterations = options.max_num_iterations;
  solver_options.max_solver_time_in_seconds = 1e9;  // no time limit: iteration count only
  solver_options.num_threads = 1;
  solver_options.function_tolerance = 1e-16;
  solver_options.gradient_tolerance = 1e-16;
  solver_options.parameter_tolerance = 1e-14;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (summary.termination_type != ceres::CONVERGENCE) {
    result.reason = StrCat("rig scale solve did not converge after ", summary.iterations.size(),
                           " iterations: ", summary.message);
    return result;
  }
  Eigen::VectorXd scales(n);
  for (int c = 0; c < n; ++c) scales(c) = std::exp(log_scales[c]);
  const double variance = RigResidualVariance(sys, scales);
  result.rig_sigma_m = std::sqrt(variance);
  Accept(sys, scales, ScaleSigmas(svd, column_norms, variance), options, &result);
  return result;
}

RigScaleResult SolveRigScalesCombined(const std::vector<CameraWindowTrack>& cameras,
                                      const std::vector<ScaleMeasurement>& measurements,
                                      const RigScaleOptions& options) {
  options.Check();
  CheckWindow(cameras, 1);
  const int n = static_cast<int>(cameras.size());
  for (size_t k = 0; k < measurements.size(); ++k) {
    const ScaleMeasurement& m = measurements[k];
    MCVO_CHECK_MSG(m.camera >= 0 && m.camera < n, "measurement ", k, " names camera ", m.camera, " of ", n);
    MCVO_CHECK_MSG(m.relative_sigma > 0.0 && std::isfinite(m.relative_sigma), "measurement ", k,
                   ": relative_sigma must be > 0, got ", m.relative_sigma);
  }
  RigScaleResult result;
  result.num_measurements = static_cast<int>(measurements.size());
  result.reason = NonFiniteReason(cameras);
  if (!result.reason.empty()) return result;
  for (size_t k = 0; k < measurements.size(); ++k) {
    const ScaleMeasurement& m = measurements[k];
    if (!(m.sfm_length > 0.0 && std::isfinite(m.sfm_length) && m.metric_length > 0.0 &&
          std::isfinite(m.metric_length))) {
      result.reason =
          StrCat("scale measurement ", k, " (camera ", m.camera, "): lengths must be positive and finite");
      return result;
    }
  }
  const StackedSystem sys = Stack(cameras);
  result.num_residual_blocks = static_cast<int>(sys.f.rows() / 3);
  const Eigen::Index rig_rows = sys.f.rows();
  const Eigen::Index num_meas = static_cast<Eigen::Index>(measurements.size());
  // Measurement rows before weighting: C s = 1, with their a-priori sigmas.
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(num_meas, n);
  Eigen::VectorXd relative_sigma(num_meas);
  for (Eigen::Index k = 0; k < num_meas; ++k) {
    const ScaleMeasurement& m = measurements[static_cast<size_t>(k)];
    c(k, m.camera) = m.sfm_length / m.metric_length;
    relative_sigma(k) = m.relative_sigma;
  }
  const Eigen::Index rows = rig_rows + num_meas;
  if (rows < n) {
    result.reason = StrCat(rows, " equations for ", n, " scales: scale not observable");
    return result;
  }

  // Variance component estimation: solve, re-estimate each row set's sigma
  // from its residual and redundancy, solve again; kRounds re-weightings.
  constexpr int kRounds = 8;
  constexpr double kMinSigma = 1e-12;
  double sigma_rig = options.rig_sigma_m;
  double factor = 1.0;
  Eigen::VectorXd scales;
  Eigen::VectorXd column_norms;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd;
  for (int round = 0;; ++round) {
    Eigen::MatrixXd a(rows, n);
    Eigen::VectorXd b(rows);
    a.topRows(rig_rows) = sys.f / sigma_rig;
    b.head(rig_rows) = -sys.theta / sigma_rig;
    for (Eigen::Index k = 0; k < num_meas; ++k) {
      const double w = 1.0 / (factor * relative_sigma(k));
      a.row(rig_rows + k) = c.row(k) * w;
      b(rig_rows + k) = w;
    }
    column_norms = a.colwise().norm().transpose();
    for (int col = 0; col < n; ++col) {
      if (!(column_norms(col) > std::numeric_limits<double>::min())) {
        result.reason = StrCat("camera ", col,
                               " does not move in the window and has no scale measurement: its scale is not "
                               "observable");
        return result;
      }
    }
    svd.compute(a * column_norms.cwiseInverse().asDiagonal(), Eigen::ComputeThinU | Eigen::ComputeThinV);
    scales = svd.solve(b).cwiseQuotient(column_norms);
    if (round == kRounds) break;
    // Redundancy of each row set: its rows minus its share of the hat matrix's
    // trace (diagonal of U U^T; invariant to the column scaling).
    const Eigen::MatrixXd& u = svd.matrixU();
    const double hat_rig = rig_rows > 0 ? u.topRows(rig_rows).squaredNorm() : 0.0;
    const double hat_meas = num_meas > 0 ? u.bottomRows(num_meas).squaredNorm() : 0.0;
    const double redundancy_rig = static_cast<double>(rig_rows) - hat_rig;
    const double redundancy_meas = static_cast<double>(num_meas) - hat_meas;
    if (rig_rows > 0 && redundancy_rig > 0.5) {
      const Eigen::VectorXd r = sys.f * scales + sys.theta;
      sigma_rig = std::max(std::sqrt(r.squaredNorm() / redundancy_rig), kMinSigma);
    }
    if (options.estimate_measurement_sigma && num_meas > 0 && redundancy_meas > 0.5) {
      const Eigen::VectorXd r = (c * scales - Eigen::VectorXd::Ones(num_meas)).cwiseQuotient(relative_sigma);
      factor = std::max(std::sqrt(r.squaredNorm() / redundancy_meas), kMinSigma);
    }
  }
  result.rig_sigma_m = rig_rows > 0 ? sigma_rig : 0.0;
  result.measurement_sigma_factor = num_meas > 0 ? factor : 0.0;

  const Eigen::VectorXd& sigma = svd.singularValues();
  result.singular_value_ratio = sigma(sigma.size() - 1) / sigma(0);
  result.condition_number = sigma(sigma.size() - 1) > 0.0 ? sigma(0) / sigma(sigma.size() - 1)
                                                          : std::numeric_limits<double>::infinity();
  if (!(result.singular_value_ratio >= options.min_singular_value_ratio)) {
    result.reason =
        StrCat(num_meas > 0 ? "rig rotation and scale measurements together do not fix every scale"
                            : "rig motion is near pure translation (or rotates only about the lever "
                              "differences)",
               ": scale not observable (sigma_min/sigma_max = ", FormatDouble(result.singular_value_ratio),
               " < ", FormatDouble(options.min_singular_value_ratio), ")");
    return result;
  }
  Accept(sys, scales, ScaleSigmas(svd, column_norms, 1.0), options, &result);
  return result;
}

}  // namespace mcvo
