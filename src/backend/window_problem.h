// The window's optimisation problem (estimator.h steps 3 and 5): bundle
// adjustment of the frames and landmarks of a LandmarkWindow (factors.h
// bearing residuals, robust loss, dense Schur, single-threaded), the
// marginalisation of the oldest keyframe into a prior (marginalization.h),
// and the prior itself. It owns the extrinsic parameter blocks (rig_from_cam,
// refined only with BackendOptions::refine_extrinsics, camera 0 always
// fixed) and adjusts the window's poses and inverse depths in place.
// Private to the back end (src/backend).
// Deterministic: the inverse depths are solved in a contiguous buffer in
// feature-id order and frame poses live in pool slots, so Ceres's
// elimination order, and every floating-point sum, is independent of where
// the heap put anything.
#pragma once

#include <array>
#include <memory>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Core>

#include "landmark_window.h"
#include "mcvo/backend/backend_options.h"
#include "mcvo/backend/estimator.h"
#include "mcvo/backend/marginalization.h"
#include "mcvo/camera/camera.h"

namespace mcvo::backend_internal {

class WindowProblem {
 public:
  WindowProblem(const Rig& rig, const BackendOptions& options);
  WindowProblem(const WindowProblem&) = delete;
  WindowProblem& operator=(const WindowProblem&) = delete;

  // Adjusts the window: its oldest frame is held fixed (the gauge; the
  // prior carries what was learnt before it). monocular: the scale gauge is
  // held too (estimator.h "Monocular"). Fills the BA fields of *estimate.
  // Returns false when there was nothing to solve.
  bool Solve(LandmarkWindow* window, bool monocular, FrameEstimate* estimate);
  // Folds the oldest frame and the landmarks anchored in it into the prior
  // (conditioned on that frame's pose: it is the gauge). The window itself
  // is not changed.
  void MarginalizeOldest(LandmarkWindow* window);
  // Scale correction: the prior's linearisation positions of the window's
  // poses, scaled by k about `origin` (as the poses themselves are).
  void RescalePriorPositions(const LandmarkWindow& window, const Eigen::Vector3d& origin, double k);
  // The prior is dropped (a new segment, a new initialisation).
  void ResetPrior() { prior_.reset(); }

 private:
  struct Blocks;  // the residual blocks of one build (window_problem.cc)
  std::unique_ptr<ceres::LossFunction> MakeLoss() const;
  void AddLandmarkBlocks(uint64_t id, WindowLandmark* lm, double* inv, Blocks* blocks);
  bool IsExtrinsicConstant(int camera) const { return !options_.refine_extrinsics || camera == 0; }

  const int num_cameras_;
  const std::vector<Rigid3d> cam_from_rig_;
  const BackendOptions options_;
  const double sqrt_information_;
  std::unique_ptr<ceres::Manifold> pose_manifold_;
  std::vector<std::array<double, kPoseParamSize>> extrinsics_;  // rig_from_cam parameter blocks
  std::unique_ptr<MarginalizationPrior> prior_;
};

}  // namespace mcvo::backend_internal
