#include "window_problem.h"

#include <algorithm>
#include <chrono>
#include <utility>

#include "mcvo/backend/factors.h"

namespace mcvo::backend_internal {
namespace {

// Monocular scale gauge (estimator.h "Monocular"): the std of the anchored
// distance, relative to it.
constexpr double kScaleAnchorRelativeSigma = 1e-3;

}  // namespace

struct WindowProblem::Blocks {
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  std::unique_ptr<ceres::LossFunction> loss;
  struct Block {
    ceres::CostFunction* cost;
    std::vector<double*> params;
    uint64_t landmark;  // 0: prior
  };
  std::vector<Block> blocks;
};

WindowProblem::WindowProblem(const Rig& rig, const BackendOptions& options)
    : num_cameras_(rig.NumCameras()),
      cam_from_rig_(rig.CamFromRig()),
      options_(options),
      sqrt_information_(options.virtual_focal_px / options.reprojection_sigma_px),
      pose_manifold_(NewPoseManifold()),
      extrinsics_(static_cast<size_t>(rig.NumCameras())) {
  for (int c = 0; c < num_cameras_; ++c) PoseToParams(cam_from_rig_[c].Inverse(), extrinsics_[c].data());
}

std::unique_ptr<ceres::LossFunction> WindowProblem::MakeLoss() const {
  return NewRobustLoss(options_.loss, options_.loss_scale);
}

// Residual blocks of one landmark's observations (the anchor excluded).
// inv: the landmark's inverse depth parameter block (its own member, or a
// slot of the solve's contiguous buffer, see Solve).
void WindowProblem::AddLandmarkBlocks(uint64_t id, WindowLandmark* lm, double* inv, Blocks* blocks) {
  double* anchor_pose = lm->anchor_frame->pose.data();
  double* anchor_ext = extrinsics_[lm->anchor_camera].data();
  for (const LandmarkObservation& ob : lm->observations) {
    const bool same_frame = ob.frame == lm->anchor_frame;
    const bool same_camera = ob.camera == lm->anchor_camera;
    if (same_frame && same_camera) continue;
    ceres::CostFunction* cost = nullptr;
    std::vector<double*> params;
    if (!options_.refine_extrinsics) {
      // Constant extrinsics (the values of the extrinsic blocks, which are
      // then in no residual block; Ceres drops them from the solve).
      const Rigid3d rig_from_cam_anchor = cam_from_rig_[lm->anchor_camera].Inverse();
      const Rigid3d rig_from_cam_obs = cam_from_rig_[ob.camera].Inverse();
      if (same_frame) {
        cost = NewReprojectionFactorSameFrameConstExtrinsics(
            lm->anchor_bearing, ob.bearing, rig_from_cam_anchor, rig_from_cam_obs, sqrt_information_);
        params = {inv};
      } else if (same_camera) {
        cost = NewReprojectionFactorSameCameraConstExtrinsics(lm->anchor_bearing, ob.bearing,
                                                              rig_from_cam_anchor, sqrt_information_);
        params = {anchor_pose, ob.frame->pose.data(), inv};
      } else {
        cost = NewReprojectionFactorOtherCameraConstExtrinsics(
            lm->anchor_bearing, ob.bearing, rig_from_cam_anchor, rig_from_cam_obs, sqrt_information_);
        params = {anchor_pose, ob.frame->pose.data(), inv};
      }
    } else if (same_frame) {
      cost = NewReprojectionFactorSameFrame(lm->anchor_bearing, ob.bearing, sqrt_information_);
      params = {anchor_ext, extrinsics_[ob.camera].data(), inv};
    } else if (same_camera) {
      cost = NewReprojectionFactorSameCamera(lm->anchor_bearing, ob.bearing, sqrt_information_);
      params = {anchor_pose, ob.frame->pose.data(), anchor_ext, inv};
    } else {
      cost = NewReprojectionFactorOtherCamera(lm->anchor_bearing, ob.bearing, sqrt_information_);
      params = {anchor_pose, ob.frame->pose.data(), anchor_ext, extrinsics_[ob.camera].data(), inv};
    }
    blocks->costs.emplace_back(cost);
    blocks->blocks.push_back({cost, std::move(params), id});
  }
}

bool WindowProblem::Solve(LandmarkWindow* window, bool monocular, FrameEstimate* estimate) {
  // The inverse depths of the usable landmarks are copied into `depths` (in
  // id order, reserved so it never reallocates) and optimised there: Ceres
  // orders the blocks of an elimination group by address, so contiguous
  // storage in id order makes the elimination order, and with it every
  // floating-point sum, independent of where the heap put the landmarks.
  std::vector<double> depths;
  std::vector<WindowLandmark*> owners;
  Blocks problem;
  problem.loss = MakeLoss();
  depths.reserve(window->landmarks().size());
  for (auto& [id, lm] : window->landmarks()) {
    if (!window->UsableInBa(lm)) continue;
    depths.push_back(lm.inverse_depth);
    owners.push_back(&lm);
    AddLandmarkBlocks(id, &lm, &depths.back(), &problem);
  }
  if (prior_) problem.blocks.push_back({prior_.get(), prior_->kept_blocks(), 0});

  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  const std::deque<WindowFrame*>& frames = window->frames();
  for (WindowFrame* frame : frames) {
    ceres_problem.AddParameterBlock(frame->pose.data(), kPoseParamSize, pose_manifold_.get());
  }
  for (int c = 0; c < num_cameras_; ++c) {
    ceres_problem.AddParameterBlock(extrinsics_[c].data(), kPoseParamSize, pose_manifold_.get());
  }
  for (const Blocks::Block& block : problem.blocks) {
    ceres_problem.AddResidualBlock(block.cost, block.landmark == 0 ? nullptr : problem.loss.get(),
                                   block.params);
  }
  // Gauge: the oldest keyframe is held fixed (the prior carries what was learnt before it).
  ceres_problem.SetParameterBlockConstant(frames.front()->pose.data());
  for (WindowFrame* frame : frames) {
    if (frame->pose_fixed) ceres_problem.SetParameterBlockConstant(frame->pose.data());
  }
  // Monocular: the scale gauge too, as the distance from the oldest
  // keyframe to the farthest other one.
  std::unique_ptr<ceres::CostFunction> scale_anchor;
  if (monocular) {
    WindowFrame* reference = window->FarthestFromOldest();
    if (reference != nullptr) {
      const Eigen::Vector3d origin = frames.front()->WorldFromRig().translation;
      const double distance = (reference->WorldFromRig().translation - origin).norm();
      scale_anchor.reset(NewDistanceAnchorCost(origin, distance, kScaleAnchorRelativeSigma * distance));
      ceres_problem.AddResidualBlock(scale_anchor.get(), nullptr, reference->pose.data());
    }
  }
  for (int c = 0; c < num_cameras_; ++c) {
    if (IsExtrinsicConstant(c)) ceres_problem.SetParameterBlockConstant(extrinsics_[c].data());
  }
  // Landmarks first in the elimination order (Schur complement on the poses).
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (double& depth : depths) {
    if (ceres_problem.HasParameterBlock(&depth)) ordering->AddElementToGroup(&depth, 0);
  }
  for (WindowFrame* frame : frames) ordering->AddElementToGroup(frame->pose.data(), 1);
  for (int c = 0; c < num_cameras_; ++c) ordering->AddElementToGroup(extrinsics_[c].data(), 1);

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.linear_solver_ordering = ordering;
  solver_options.trust_region_strategy_type =
      options_.solver == SolverType::kDogleg ? ceres::DOGLEG : ceres::LEVENBERG_MARQUARDT;
  solver_options.max_num_iterations = options_.max_iterations;
  if (options_.max_solver_time_s > 0.0)
    solver_options.max_solver_time_in_seconds = options_.max_solver_time_s;
  solver_options.num_threads = 1;  // Schur reductions in parallel change summation order
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  if (problem.blocks.empty()) return false;
  ceres::Solve(solver_options, &ceres_problem, &summary);
  for (size_t k = 0; k < owners.size(); ++k) owners[k]->inverse_depth = depths[k];
  estimate->ba_iterations = static_cast<int>(summary.iterations.size()) - 1;
  estimate->ba_initial_cost = summary.initial_cost;
  estimate->ba_final_cost = summary.final_cost;
  return true;
}

void WindowProblem::MarginalizeOldest(LandmarkWindow* window) {
  WindowFrame* oldest = window->frames().front();
  Blocks problem;
  problem.loss = MakeLoss();
  std::vector<double*> drop;
  for (auto& [id, lm] : window->landmarks()) {
    if (lm.anchor_frame != oldest || !window->UsableInBa(lm)) continue;
    const size_t before = problem.blocks.size();
    AddLandmarkBlocks(id, &lm, &lm.inverse_depth, &problem);
    if (problem.blocks.size() > before) drop.push_back(&lm.inverse_depth);
  }
  Marginalizer marginalizer;
  for (WindowFrame* frame : window->frames())
    marginalizer.SetManifold(frame->pose.data(), pose_manifold_.get());
  for (int c = 0; c < num_cameras_; ++c) {
    marginalizer.SetManifold(extrinsics_[c].data(), pose_manifold_.get());
    if (IsExtrinsicConstant(c)) marginalizer.SetConstant(extrinsics_[c].data());
  }
  // The oldest pose is the gauge: constant, so conditioning on it turns
  // the relative information of its observations into information on the
  // kept poses.
  marginalizer.SetConstant(oldest->pose.data());
  for (WindowFrame* frame : window->frames()) {
    if (frame->pose_fixed) marginalizer.SetConstant(frame->pose.data());
  }
  for (const Blocks::Block& block : problem.blocks) {
    marginalizer.AddResidualBlock(block.cost, problem.loss.get(), block.params);
  }
  if (prior_) marginalizer.AddResidualBlock(prior_.get(), nullptr, prior_->kept_blocks());
  std::unique_ptr<MarginalizationPrior> next_prior;
  if (!drop.empty() || prior_) next_prior = marginalizer.Marginalize(drop);
  prior_ = std::move(next_prior);
}

void WindowProblem::RescalePriorPositions(const LandmarkWindow& window, const Eigen::Vector3d& origin,
                                          double k) {
  if (!prior_) return;
  const std::vector<double*>& blocks = prior_->kept_blocks();
  for (size_t b = 0; b < blocks.size(); ++b) {
    const bool is_pose =
        std::any_of(window.frames().begin(), window.frames().end(),
                    [&](const WindowFrame* frame) { return frame->pose.data() == blocks[b]; });
    if (!is_pose) continue;
    std::vector<double> x0 = prior_->x0(static_cast<int>(b));
    for (int i = 0; i < 3; ++i) x0[i] = origin[i] + k * (x0[i] - origin[i]);
    prior_->SetX0(static_cast<int>(b), x0);
  }
}

}  // namespace mcvo::backend_internal
