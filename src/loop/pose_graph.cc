#include "mcvo/loop/pose_graph.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Geometry>

#include "mcvo/util/error.h"
#include "mcvo/util/option_checks.h"

namespace mcvo {
namespace {

constexpr int kPoseSize = 7;  // {tx, ty, tz, qx, qy, qz, qw}
constexpr double kDegToRad = M_PI / 180.0;

using PoseParams = std::array<double, kPoseSize>;

PoseParams ToParams(const Rigid3d& pose) {
  return {pose.translation.x(), pose.translation.y(), pose.translation.z(), pose.rotation.x(),
          pose.rotation.y(),    pose.rotation.z(),    pose.rotation.w()};
}

Rigid3d FromParams(const PoseParams& p) {
  return Rigid3d(Eigen::Quaterniond(p[6], p[3], p[4], p[5]), Eigen::Vector3d(p[0], p[1], p[2]));
}

// The residual of one edge, r = W log(M^-1 T_ij) (pose_graph.h):
//   R_ij = R_i^T R_j,  t_ij = R_i^T (t_j - t_i) / s_i,
//   r_rot   = Log(R_m^T R_ij) / sigma_rot,
//   r_trans = R_m^T (t_ij - t_m) / s_m / sigma_trans,
//   r_scale = (log s_j - log s_i - log s_m) / sigma_scale   (Sim3 only).
// Log through ceres::QuaternionToAngleAxis, which is Jet-safe at the
// identity (no square root of zero) and takes either quaternion sign.
class EdgeResidual {
 public:
  EdgeResidual(const PoseGraphEdge& edge, double sigma_rotation, double sigma_translation, double sigma_scale)
      : measured_rotation_inverse_(edge.from_T_to.rotation.conjugate()),
        measured_translation_(edge.from_T_to.translation),
        inverse_measured_scale_(1.0 / edge.scale),
        log_measured_scale_(std::log(edge.scale)),
        inverse_sigma_rotation_(1.0 / sigma_rotation),
        inverse_sigma_translation_(1.0 / sigma_translation),
        inverse_sigma_scale_(1.0 / sigma_scale) {}

  // Writes 6 residuals, and a 7th when `sim3`.
  template <typename T>
  void Evaluate(const T* pose_i, const T* pose_j, const T& log_scale_i, const T& log_scale_j, bool sim3,
                T* residuals) const {
    using std::exp;
    const Eigen::Map<const Eigen::Quaternion<T>> q_i(pose_i + 3);
    const Eigen::Map<const Eigen::Quaternion<T>> q_j(pose_j + 3);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_i(pose_i);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_j(pose_j);
    const Eigen::Quaternion<T> q_i_inverse = q_i.conjugate();
    const Eigen::Quaternion<T> q_ij = q_i_inverse * q_j;
    const Eigen::Matrix<T, 3, 1> t_ij = (q_i_inverse * (t_j - t_i)) * exp(-log_scale_i);

    const Eigen::Quaternion<T> q_m_inverse = measured_rotation_inverse_.cast<T>();
    const Eigen::Quaternion<T> q_error = q_m_inverse * q_ij;
    const Eigen::Matrix<T, 3, 1> t_error =
        (q_m_inverse * (t_ij - measured_translation_.cast<T>())) * T(inverse_measured_scale_);
    const T q_wxyz[4] = {q_error.w(), q_error.x(), q_error.y(), q_error.z()};
    T phi[3];
    ceres::QuaternionToAngleAxis(q_wxyz, phi);
    for (int k = 0; k < 3; ++k) {
      residuals[k] = phi[k] * T(inverse_sigma_rotation_);
      residuals[3 + k] = t_error[k] * T(inverse_sigma_translation_);
    }
    if (sim3) {
      residuals[6] = (log_scale_j - log_scale_i - T(log_measured_scale_)) * T(inverse_sigma_scale_);
    }
  }

 private:
  Eigen::Quaterniond measured_rotation_inverse_;
  Eigen::Vector3d measured_translation_;
  double inverse_measured_scale_;
  double log_measured_scale_;
  double inverse_sigma_rotation_;
  double inverse_sigma_translation_;
  double inverse_sigma_scale_;
};

// Parameter blocks: pose_i[7], pose_j[7].
struct Se3EdgeFunctor {
  EdgeResidual residual;
  template <typename T>
  bool operator()(const T* pose_i, const T* pose_j, T* residuals) const {
    residual.Evaluate(pose_i, pose_j, T(0.0), T(0.0), /*sim3=*/false, residuals);
    return true;
  }
};

// Parameter blocks: pose_i[7], log_scale_i[1], pose_j[7], log_scale_j[1].
struct Sim3EdgeFunctor {
  EdgeResidual residual;
  template <typename T>
  bool operator()(const T* pose_i, const T* log_scale_i, const T* pose_j, const T* log_scale_j,
                  T* residuals) const {
    residual.Evaluate(pose_i, pose_j, log_scale_i[0], log_scale_j[0], /*sim3=*/true, residuals);
    return true;
  }
};

EdgeResidual MakeResidual(const PoseGraphEdge& edge, const PoseGraphOptions& options) {
  if (edge.loop) {
    return EdgeResidual(edge, options.loop_rotation_sigma_deg * kDegToRad, options.loop_translation_sigma_m,
                        options.loop_scale_sigma);
  }
  const double length = edge.from_T_to.translation.norm();
  return EdgeResidual(
      edge,
      (options.odometry_rotation_sigma_deg_per_m * length + options.odometry_rotation_sigma_floor_deg) *
          kDegToRad,
      options.odometry_translation_sigma_per_m * length + options.odometry_translation_sigma_floor_m,
      options.odometry_scale_sigma_per_m * length + options.odometry_scale_sigma_floor);
}

}  // namespace

void PoseGraphOptions::Check() const {
  CheckAtLeast("/loop/pose_graph/odometry_rotation_sigma_deg_per_m", odometry_rotation_sigma_deg_per_m, 0.0);
  CheckAtLeast("/loop/pose_graph/odometry_translation_sigma_per_m", odometry_translation_sigma_per_m, 0.0);
  CheckPositive("/loop/pose_graph/odometry_rotation_sigma_floor_deg", odometry_rotation_sigma_floor_deg);
  CheckPositive("/loop/pose_graph/odometry_translation_sigma_floor_m", odometry_translation_sigma_floor_m);
  CheckAtLeast("/loop/pose_graph/odometry_scale_sigma_per_m", odometry_scale_sigma_per_m, 0.0);
  CheckPositive("/loop/pose_graph/odometry_scale_sigma_floor", odometry_scale_sigma_floor);
  CheckPositive("/loop/pose_graph/loop_rotation_sigma_deg", loop_rotation_sigma_deg);
  CheckPositive("/loop/pose_graph/loop_translation_sigma_m", loop_translation_sigma_m);
  CheckPositive("/loop/pose_graph/loop_scale_sigma", loop_scale_sigma);
  CheckPositive("/loop/pose_graph/loop_loss_scale", loop_loss_scale);
  CheckAtLeast("/loop/pose_graph/loop_loss_stages", loop_loss_stages, 1);
  CheckAtLeast("/loop/pose_graph/loop_loss_stage_factor", loop_loss_stage_factor, 1.0);
  CheckAtLeast("/loop/pose_graph/max_iterations", max_iterations, 1);
}

PoseGraphResult OptimizePoseGraph(const std::vector<Rigid3d>& world_from_node,
                                  const std::vector<PoseGraphEdge>& edges, const PoseGraphOptions& options) {
  options.Check();
  const int num_nodes = static_cast<int>(world_from_node.size());
  bool any_loop = false;
  for (const PoseGraphEdge& edge : edges) {
    MCVO_CHECK_MSG(edge.from >= 0 && edge.from < num_nodes && edge.to >= 0 && edge.to < num_nodes, "edge ",
                   edge.from, " -> ", edge.to, " with ", num_nodes, " nodes");
    MCVO_CHECK_MSG(edge.from != edge.to, "edge from node ", edge.from, " to itself");
    MCVO_CHECK_MSG(edge.scale > 0.0 && std::isfinite(edge.scale), "edge scale ", edge.scale);
    any_loop = any_loop || edge.loop;
  }

  PoseGraphResult result;
  result.world_from_node = world_from_node;
  result.node_scale.assign(world_from_node.size(), 1.0);
  if (!any_loop) {
    result.ok = true;
    return result;
  }

  // Storage first (pre-sized: Ceres keeps the pointers), then the loss and
  // manifold, which the problem does not own and must outlive it.
  std::vector<PoseParams> poses(world_from_node.size());
  for (int i = 0; i < num_nodes; ++i) poses[i] = ToParams(world_from_node[i]);
  std::vector<double> log_scales(world_from_node.size(), 0.0);
  ceres::ProductManifold<ceres::EuclideanManifold<3>, ceres::EigenQuaternionManifold> pose_manifold;
  ceres::LossFunctionWrapper loop_loss(nullptr, ceres::TAKE_OWNERSHIP);

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  // Blocks in node order (the parameter order does not depend on the edges).
  for (int i = 0; i < num_nodes; ++i) {
    problem.AddParameterBlock(poses[i].data(), kPoseSize, &pose_manifold);
    if (options.sim3) problem.AddParameterBlock(&log_scales[i], 1);
  }
  for (const PoseGraphEdge& edge : edges) {
    ceres::LossFunction* loss = edge.loop ? &loop_loss : nullptr;
    double* pose_i = poses[edge.from].data();
    double* pose_j = poses[edge.to].data();
    if (options.sim3) {
      auto* cost = new ceres::AutoDiffCostFunction<Sim3EdgeFunctor, 7, kPoseSize, 1, kPoseSize, 1>(
          new Sim3EdgeFunctor{MakeResidual(edge, options)});
      problem.AddResidualBlock(cost, loss, pose_i, &log_scales[edge.from], pose_j, &log_scales[edge.to]);
    } else {
      auto* cost = new ceres::AutoDiffCostFunction<Se3EdgeFunctor, 6, kPoseSize, kPoseSize>(
          new Se3EdgeFunctor{MakeResidual(edge, options)});
      problem.AddResidualBlock(cost, loss, pose_i, pose_j);
    }
  }
  problem.SetParameterBlockConstant(poses[0].data());
  if (options.sim3) problem.SetParameterBlockConstant(&log_scales[0]);

  loop_loss.Reset(new ceres::CauchyLoss(options.loop_loss_scale), ceres::TAKE_OWNERSHIP);
  ceres::Problem::EvaluateOptions evaluate_options;
  evaluate_options.num_threads = 1;
  problem.Evaluate(evaluate_options, &result.initial_cost, nullptr, nullptr, nullptr);

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.sparse_linear_algebra_library_type =
      ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ? ceres::SUITE_SPARSE
                                                                            : ceres::EIGEN_SPARSE;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;

  const int stages = options.loop_loss_stages;
  for (int stage = 0; stage < stages; ++stage) {
    if (stages > 1 && stage == 0) {
      loop_loss.Reset(nullptr, ceres::TAKE_OWNERSHIP);  // least squares
    } else {
      const double scale =
          options.loop_loss_scale * std::pow(options.loop_loss_stage_factor, stages - 1 - stage);
      loop_loss.Reset(new ceres::CauchyLoss(scale), ceres::TAKE_OWNERSHIP);
    }
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    result.iterations += static_cast<int>(summary.iterations.size()) - 1;
    if (!summary.IsSolutionUsable()) {
      result.reason = StrCat("pose graph: Ceres found no usable solution in stage ", stage + 1, " of ",
                             stages, ": ", summary.message);
      return result;
    }
    result.final_cost = summary.final_cost;
  }

  for (int i = 0; i < num_nodes; ++i) {
    result.world_from_node[i] = FromParams(poses[i]);
    if (options.sim3) result.node_scale[i] = std::exp(log_scales[i]);
  }
  for (const PoseGraphEdge& edge : edges) {
    if (!edge.loop) continue;
    double residuals[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    MakeResidual(edge, options)
        .Evaluate(poses[edge.from].data(), poses[edge.to].data(), log_scales[edge.from], log_scales[edge.to],
                  options.sim3, residuals);
    result.loop_residual_sigmas.push_back(Eigen::Map<const Eigen::Matrix<double, 7, 1>>(residuals).norm());
  }
  result.ok = true;
  return result;
}

namespace {

// Node `node`'s prediction of a pose (CorrectPoses' rule) with scale `scale`.
Rigid3d CarriedBy(const Rigid3d& node_before, const Rigid3d& node_after, double scale, const Rigid3d& pose) {
  const Rigid3d node_from_pose = node_before.Inverse() * pose;
  return Rigid3d(node_after.rotation * node_from_pose.rotation,
                 node_after.rotation * (scale * node_from_pose.translation) + node_after.translation);
}

}  // namespace

std::vector<Rigid3d> CorrectPoses(const std::vector<int64_t>& node_t_ns,
                                  const std::vector<Rigid3d>& node_before,
                                  const std::vector<Rigid3d>& node_after,
                                  const std::vector<double>& node_scale,
                                  const std::vector<int64_t>& pose_t_ns,
                                  const std::vector<Rigid3d>& poses_before) {
  MCVO_CHECK(node_before.size() == node_t_ns.size() && node_after.size() == node_t_ns.size() &&
             node_scale.size() == node_t_ns.size());
  MCVO_CHECK(poses_before.size() == pose_t_ns.size());
  for (size_t i = 1; i < node_t_ns.size(); ++i) {
    MCVO_CHECK_MSG(node_t_ns[i] > node_t_ns[i - 1], "node times not strictly increasing at node ", i);
  }
  for (double s : node_scale) MCVO_CHECK_MSG(s > 0.0 && std::isfinite(s), "node scale ", s);
  if (node_t_ns.empty()) return poses_before;

  std::vector<Rigid3d> poses_after(poses_before.size());
  for (size_t p = 0; p < poses_before.size(); ++p) {
    const auto later = std::upper_bound(node_t_ns.begin(), node_t_ns.end(), pose_t_ns[p]);
    const size_t node = later == node_t_ns.begin() ? 0 : static_cast<size_t>(later - node_t_ns.begin()) - 1;
    poses_after[p] = CarriedBy(node_before[node], node_after[node], node_scale[node], poses_before[p]);
  }
  return poses_after;
}

std::vector<Rigid3d> CorrectPoses(const std::vector<int64_t>& node_t_ns,
                                  const std::vector<Rigid3d>& node_before,
                                  const std::vector<Rigid3d>& node_after,
                                  const std::vector<int64_t>& pose_t_ns,
                                  const std::vector<Rigid3d>& poses_before) {
  return CorrectPoses(node_t_ns, node_before, node_after, std::vector<double>(node_t_ns.size(), 1.0),
                      pose_t_ns, poses_before);
}

std::vector<Rigid3d> InterpolateCorrections(const std::vector<int64_t>& node_t_ns, const std::vector<int>& node_segment,
                                            const std::vector<Rigid3d>& node_before,
                                            const std::vector<Rigid3d>& node_after,
                                            const std::vector<double>& node_scale,
                                            const std::vector<int64_t>& pose_t_ns,
                                            const std::vector<int>& pose_segment,
                                            const std::vector<Rigid3d>& poses_before) {
  MCVO_CHECK(node_segment.size() == node_t_ns.size() && pose_segment.size() == pose_t_ns.size());
  // Checks the rest (sizes, increasing times, scales).
  std::vector<Rigid3d> poses_after = CorrectPoses(node_t_ns, node_before, node_after, node_scale, pose_t_ns, poses_before);
  const size_t n = node_t_ns.size();
  for (size_t p = 0; p < poses_before.size(); ++p) {
    const size_t b = static_cast<size_t>(std::upper_bound(node_t_ns.begin(), node_t_ns.end(), pose_t_ns[p]) -
                                         node_t_ns.begin());  // first node after t
    const bool has_a = b > 0 && node_segment[b - 1] == pose_segment[p];
    const bool has_b = b < n && node_segment[b] == pose_segment[p];
    if (has_a && has_b) {
      const size_t a = b - 1;
      const double tau = static_cast<double>(pose_t_ns[p] - node_t_ns[a]) /
                         static_cast<double>(node_t_ns[b] - node_t_ns[a]);
      const Rigid3d from_a = CarriedBy(node_before[a], node_after[a], node_scale[a], poses_before[p]);
      const Rigid3d from_b = CarriedBy(node_before[b], node_after[b], node_scale[a], poses_before[p]);
      poses_after[p] = Rigid3d(from_a.rotation.slerp(tau, from_b.rotation),
                               (1.0 - tau) * from_a.translation + tau * from_b.translation);
    } else if (has_b) {
      poses_after[p] = CarriedBy(node_before[b], node_after[b], node_scale[b], poses_before[p]);
    }
    // has_a alone, or neither: CorrectPoses' rule (latest node at or before).
  }
  return poses_after;
}

}  // namespace mcvo
