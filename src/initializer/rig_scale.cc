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
  CheckAtLeast("rig_scale.max_num_iterations", max_num_iterations, 1);
}

namespace {

// Stacked Eq. (eq:multi_residual): rows 3k..3k+2 hold block k = (t, i, j).
struct StackedSystem {
  Eigen::MatrixXd f;                       // F, (3 * blocks) x N
  Eigen::VectorXd theta;                   // theta, 3 * blocks
  std::vector<std::pair<int, int>> pairs;  // (i, j) of each block
};

void CheckWindow(const std::vector<CameraWindowTrack>& cameras) {
  MCVO_CHECK_MSG(cameras.size() >= 2, "rig scale needs at least 2 cameras, got ", cameras.size());
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

// Final acceptance of a solution: positive scales and a small residual.
void Accept(const StackedSystem& sys, const Eigen::VectorXd& scales, const RigScaleOptions& options,
            RigScaleResult* result) {
  const Eigen::VectorXd residual = sys.f * scales + sys.theta;
  result->rms_residual_m = std::sqrt(residual.squaredNorm() / static_cast<double>(residual.size()));
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
  const Eigen::VectorXd normalised_scales = svd.solve(-sys.theta);
  Accept(sys, normalised_scales.cwiseQuotient(column_norms), options, &result);
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
  Accept(sys, scales, options, &result);
  return result;
}

}  // namespace mcvo
