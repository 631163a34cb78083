// Metric rig window bundle adjustment (see rig_window_ba.h).
#include "mcvo/initializer/rig_window_ba.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <utility>

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>
#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "bearing_residual.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

using initializer_internal::FromPoseBlock;
using initializer_internal::PoseBlock;
using initializer_internal::ReprojectionPx;
using initializer_internal::TangentBearingCost;
using initializer_internal::ToPoseBlock;
using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;

constexpr double kFirstPassFactor = 3.0;  // first-pass outlier threshold, in max_reprojection_px

struct State {
  std::vector<PoseBlock> poses;  // world_from_rig
  std::map<uint64_t, Eigen::Vector3d> points;
};

Rigid3d PoseOf(const State& state, size_t t) { return FromPoseBlock(state.poses[t]); }
Eigen::Vector3d PositionOf(const State& state, size_t t) { return state.poses[t].tail<3>(); }

class RigWindowBa {
 public:
  RigWindowBa(const std::vector<Rigid3d>& cam_from_rig, int fixed_frame, const RigWindowBaOptions& options)
      : cam_from_rig_(cam_from_rig), fixed_frame_(fixed_frame), options_(options) {}

  double Focal(int camera) const {
    return options_.camera_focal_px.empty() ? options_.focal_px
                                            : options_.camera_focal_px[static_cast<size_t>(camera)];
  }

  // Error of one observation at the current state, pixels of its camera.
  double ErrorPx(const State& state, const RigWindowObservation& obs) const {
    const Rigid3d world_from_cam = PoseOf(state, static_cast<size_t>(obs.frame)) *
                                   cam_from_rig_[static_cast<size_t>(obs.camera)].Inverse();
    return ReprojectionPx(world_from_cam, state.points.at(obs.landmark), obs.bearing, Focal(obs.camera));
  }

  // Observations within threshold_px, of landmarks that keep at least two.
  std::vector<RigWindowObservation> Select(const State& state, const std::vector<RigWindowObservation>& all,
                                           double threshold_px) const {
    std::vector<RigWindowObservation> kept;
    std::map<uint64_t, int> count;
    for (const auto& obs : all) {
      if (state.points.count(obs.landmark) == 0) continue;
      if (!(ErrorPx(state, obs) <= threshold_px)) continue;
      kept.push_back(obs);
      ++count[obs.landmark];
    }
    std::vector<RigWindowObservation> out;
    for (const auto& obs : kept) {
      if (count[obs.landmark] >= 2) out.push_back(obs);
    }
    return out;
  }

  bool Solve(const std::vector<RigWindowObservation>& observations, State* state) const {
    PoseManifold pose_manifold;
    ceres::HuberLoss huber(options_.huber_px);
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    for (const auto& obs : observations) {
      auto* cost =
          new TangentBearingCost(obs.bearing, Focal(obs.camera), cam_from_rig_[static_cast<size_t>(obs.camera)]);
      problem.AddResidualBlock(cost, &huber, state->poses[static_cast<size_t>(obs.frame)].data(),
                               state->points.at(obs.landmark).data());
    }
    for (size_t t = 0; t < state->poses.size(); ++t) {
      double* block = state->poses[t].data();
      if (!problem.HasParameterBlock(block)) continue;
      if (static_cast<int>(t) == fixed_frame_) {
        problem.SetParameterBlockConstant(block);
      } else {
        problem.SetManifold(block, &pose_manifold);
      }
    }
    const ceres::Solver::Options solver_options =
        initializer_internal::DeterministicBaOptions(options_.max_iterations);
    ceres::Solver::Summary summary;
    if (options_.max_iterations > 0) ceres::Solve(solver_options, &problem, &summary);
    for (const PoseBlock& pose : state->poses) {
      if (!pose.allFinite()) return false;
    }
    for (const auto& [id, point] : state->points) {
      if (!point.allFinite()) return false;
    }
    return true;
  }

  // Relative std of |position of the last frame| from the Schur complement of
  // J^T J onto the free poses (tangent coordinates: 3 rotation, 3 position).
  double TravelRelativeSigma(const State& state, const std::vector<RigWindowObservation>& observations,
                             double* travel) const {
    const int num_frames = static_cast<int>(state.poses.size());
    const int last = num_frames - 1;
    const Eigen::Vector3d displacement =
        PositionOf(state, static_cast<size_t>(last)) - PositionOf(state, static_cast<size_t>(fixed_frame_));
    *travel = displacement.norm();
    if (last == fixed_frame_ || !(*travel > 0.0)) return std::numeric_limits<double>::infinity();
    std::vector<int> slot(static_cast<size_t>(num_frames), -1);
    int num_free = 0;
    for (int t = 0; t < num_frames; ++t) {
      if (t != fixed_frame_) slot[static_cast<size_t>(t)] = num_free++;
    }
    const int dim = 6 * num_free;
    Eigen::MatrixXd reduced = Eigen::MatrixXd::Zero(dim, dim);
    PoseManifold manifold;
    // Per landmark: C (3x3) and B (dim x 3, sparse in frames: kept dense per landmark).
    struct PointBlocks {
      Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
      std::map<int, Eigen::Matrix<double, 6, 3>> b;  // by pose slot
    };
    std::map<uint64_t, PointBlocks> blocks;
    double sum_sq = 0.0;
    for (const auto& obs : observations) {
      const size_t t = static_cast<size_t>(obs.frame);
      const TangentBearingCost cost(obs.bearing, Focal(obs.camera), cam_from_rig_[static_cast<size_t>(obs.camera)]);
      const double* params[2] = {state.poses[t].data(), state.points.at(obs.landmark).data()};
      Eigen::Vector2d residual;
      Eigen::Matrix<double, 2, 7, Eigen::RowMajor> j_pose_ambient;
      Eigen::Matrix<double, 2, 3, Eigen::RowMajor> j_point;
      double* jacobians[2] = {j_pose_ambient.data(), j_point.data()};
      if (!cost.Evaluate(params, residual.data(), jacobians)) continue;
      sum_sq += residual.squaredNorm();
      PointBlocks& pb = blocks[obs.landmark];
      pb.c += j_point.transpose() * j_point;
      const int s = slot[t];
      if (s < 0) continue;
      Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus;
      manifold.PlusJacobian(state.poses[t].data(), plus.data());
      const Eigen::Matrix<double, 2, 6> j_pose = j_pose_ambient * plus;
      reduced.block<6, 6>(Eigen::Index{6} * s, Eigen::Index{6} * s) += j_pose.transpose() * j_pose;
      auto it = pb.b.find(s);
      if (it == pb.b.end()) it = pb.b.emplace(s, Eigen::Matrix<double, 6, 3>::Zero()).first;
      it->second += j_pose.transpose() * j_point;
    }
    for (const auto& [id, pb] : blocks) {
      const Eigen::FullPivLU<Eigen::Matrix3d> lu(pb.c);
      if (!lu.isInvertible()) continue;
      const Eigen::Matrix3d c_inv = lu.inverse();
      for (const auto& [s1, b1] : pb.b) {
        for (const auto& [s2, b2] : pb.b) {
          reduced.block<6, 6>(Eigen::Index{6} * s1, Eigen::Index{6} * s2) -= b1 * c_inv * b2.transpose();
        }
      }
    }
    const double dof =
        2.0 * static_cast<double>(observations.size()) - dim - 3.0 * static_cast<double>(blocks.size());
    if (!(dof > 0.0)) return std::numeric_limits<double>::infinity();
    const double variance = sum_sq / dof;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(reduced);
    if (ldlt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
    Eigen::VectorXd direction = Eigen::VectorXd::Zero(dim);
    const Eigen::Vector3d u = displacement / *travel;
    direction.segment<3>(6 * slot[static_cast<size_t>(last)] + 3) = u;
    const double quad = direction.dot(ldlt.solve(direction));
    if (!(quad >= 0.0) || !std::isfinite(quad)) return std::numeric_limits<double>::infinity();
    return std::sqrt(variance * quad) / *travel;
  }

 private:
  const std::vector<Rigid3d>& cam_from_rig_;
  const int fixed_frame_;
  const RigWindowBaOptions& options_;
};

}  // namespace

RigWindowBaResult AdjustRigWindow(const std::vector<Rigid3d>& cam_from_rig, int fixed_frame,
                                  const std::vector<Rigid3d>& world_from_rig,
                                  const std::map<uint64_t, Eigen::Vector3d>& points,
                                  const std::vector<RigWindowObservation>& observations,
                                  const RigWindowBaOptions& options) {
  const int num_frames = static_cast<int>(world_from_rig.size());
  MCVO_CHECK_MSG(fixed_frame >= 0 && fixed_frame < num_frames, "fixed frame ", fixed_frame, " of ",
                 num_frames);
  MCVO_CHECK_MSG(options.camera_focal_px.empty() || options.camera_focal_px.size() == cam_from_rig.size(),
                 "got ", options.camera_focal_px.size(), " camera focals for ", cam_from_rig.size(),
                 " cameras");
  for (double f : options.camera_focal_px) MCVO_CHECK_MSG(f > 0.0, "camera focal must be > 0, got ", f);
  for (const auto& obs : observations) {
    MCVO_CHECK_MSG(obs.frame >= 0 && obs.frame < num_frames, "observation in frame ", obs.frame, " of ",
                   num_frames);
    MCVO_CHECK_MSG(obs.camera >= 0 && obs.camera < static_cast<int>(cam_from_rig.size()),
                   "observation by camera ", obs.camera, " of ", cam_from_rig.size());
  }
  RigWindowBaResult result;
  State state;
  for (const Rigid3d& pose : world_from_rig) state.poses.push_back(ToPoseBlock(pose));
  state.points = points;
  RigWindowBa ba(cam_from_rig, fixed_frame, options);
  // First pass: only gross outliers out. The initial state can be off in
  // scale by a few %; filtering tightly against it would keep the
  // observations that agree with the wrong scale and bias the result to it.
  const std::vector<RigWindowObservation> first =
      ba.Select(state, observations, kFirstPassFactor * options.max_reprojection_px);
  if (first.size() < 10) {
    result.reason = StrCat("rig bundle adjustment: ", first.size(), " usable observations");
    return result;
  }
  if (!ba.Solve(first, &state)) {
    result.reason = "rig bundle adjustment failed (non-finite result)";
    return result;
  }
  std::vector<RigWindowObservation> kept = ba.Select(state, observations, options.max_reprojection_px);
  if (kept.size() != first.size()) {
    if (!ba.Solve(kept, &state)) {
      result.reason = "rig bundle adjustment failed (non-finite result)";
      return result;
    }
    kept = ba.Select(state, observations, options.max_reprojection_px);
  }
  std::map<uint64_t, int> count;
  double sum_sq = 0.0;
  for (const auto& obs : kept) {
    ++count[obs.landmark];
    const double e = ba.ErrorPx(state, obs);
    sum_sq += e * e;
  }
  result.num_observations = static_cast<int>(kept.size());
  result.rms_reprojection_px = kept.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(kept.size()));
  result.travel_relative_sigma = ba.TravelRelativeSigma(state, kept, &result.travel_m);
  for (size_t t = 0; t < state.poses.size(); ++t) result.world_from_rig.push_back(PoseOf(state, t));
  for (const auto& [id, point] : state.points) {
    if (count[id] >= 2) result.points.emplace(id, point);
  }
  result.ok = true;
  return result;
}

}  // namespace mcvo
