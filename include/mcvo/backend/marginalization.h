// Marginalisation of old states into a Gaussian prior (Schur complement), as
// in sliding-window estimators (VINS-Mono's marginalisation factor; Sibley et
// al. 2010), built on Ceres' cost functions and manifolds:
//
//  1. Every residual block added is evaluated at the current values
//     (Jacobians mapped to the tangent space of each block's manifold,
//     robust loss applied with Triggs' correction, as Ceres does
//     internally). Add the residual blocks that touch the blocks to drop
//     (VINS-Mono), and the previous prior: every block added becomes part of
//     the new prior, so a residual block that stays in the next problem must
//     not be added (it would count twice). Blocks held constant
//     (SetConstant) are conditioned on: their values are fixed.
//  2. H = J^T J and b = -J^T r over the blocks involved, ordered: blocks to
//     drop first, then kept blocks in the order they were first added.
//  3. Schur complement onto the kept blocks: H* = Hkk - Hkm Hmm^-1 Hmk,
//     b* = bk - Hkm Hmm^-1 bm (Hmm inverted by a symmetric eigen
//     decomposition with eigenvalues below eps treated as 0, group by group
//     of blocks to drop that share a residual block: Hmm is block diagonal
//     over those groups, e.g. one group per inverse depth).
//  4. H* = J*^T J* (eigen decomposition H* = V S V^T, eigenvalues below eps
//     dropped: J* = S^1/2 V^T, one row per kept eigenvalue), r0 = -S^-1/2 V^T
//     b*, and the prior residual r(x) = r0 + J* (x [-] x0), where [-] is the
//     kept block's Manifold::Minus and x0 the values at marginalisation. Then
//     0.5 |r(x)|^2 = 0.5 |r0|^2 - b*^T dx + 0.5 dx^T H* dx: the Schur
//     complement's quadratic model of the dropped residuals.
//
// Jacobians of the prior. Ceres asks for d r / d x in the ambient
// coordinates and multiplies them by the manifold's PlusJacobian(x). With
// M(x) = d ((x [+] d) [-] x0) / d d at d = 0 (tangent x tangent), the prior
// returns J* M(x) MinusJacobian(x); since MinusJacobian(x) PlusJacobian(x)
// = I, Ceres then sees exactly J* M(x), the true tangent Jacobian of r at x.
// M(x0) = I (manifold axiom); elsewhere M is computed by central differences
// of Plus and Minus (Euclidean blocks: M = I, no differences), so the
// Jacobian stays consistent with the residual as the window moves away from
// x0 (VINS-Mono keeps J* alone, which is exact only at x0).
//
// The result is a ceres::CostFunction over the kept blocks; the caller keeps
// those blocks at stable addresses and adds the prior to the next problem.
// A prior of an earlier marginalisation is added like any residual block, so
// information accumulates. Deterministic: fixed ordering, no threads.
#pragma once

#include <memory>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Core>

namespace mcvo {

class MarginalizationPrior;

class Marginalizer {
 public:
  Marginalizer();
  ~Marginalizer();
  Marginalizer(const Marginalizer&) = delete;
  Marginalizer& operator=(const Marginalizer&) = delete;

  // Tangent space of a block (null or never set: Euclidean of its size).
  // The manifold must outlive Marginalize() and the priors it returns (their
  // Evaluate uses it).
  void SetManifold(double* block, const ceres::Manifold* manifold);
  // A block held constant in the problem (the extrinsics unless they are
  // refined): not a variable of the linear system (its Jacobian columns are
  // not formed) and never a block of the prior.
  void SetConstant(double* block);
  // A residual block; cost and loss (nullable) must outlive Marginalize().
  // It becomes part of the prior (see 1. above); the values are read when
  // Marginalize() runs. A residual block whose evaluation fails or is not
  // finite there is left out (logged).
  void AddResidualBlock(const ceres::CostFunction* cost, const ceres::LossFunction* loss,
                        const std::vector<double*>& parameter_blocks);
  // Marginalises the listed blocks out of the residual blocks added (`drop`
  // may be empty: the residual blocks are then only re-linearised, e.g. to
  // condition a prior on a block that became constant). Kept blocks: every
  // other non-constant block of those residual blocks, ordered by first
  // appearance in AddResidualBlock order. Returns null when nothing remains
  // to keep or no eigenvalue of H* exceeds eps. May be called more than once
  // (each call reads the current values).
  std::unique_ptr<MarginalizationPrior> Marginalize(const std::vector<double*>& drop, double eps = 1e-8);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class MarginalizationPrior : public ceres::CostFunction {
 public:
  // The kept blocks, in the order of the prior's parameter blocks: add it
  // with problem.AddResidualBlock(prior, nullptr, prior->kept_blocks()).
  const std::vector<double*>& kept_blocks() const { return kept_blocks_; }
  // r0 + J* (x [-] x0) and the ambient Jacobians described above.
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;
  // Linearisation point and factors, for tests.
  const Eigen::MatrixXd& jacobian() const { return jacobian_; }
  const Eigen::VectorXd& residual0() const { return residual0_; }
  const std::vector<double>& x0(int block) const { return x0_[static_cast<size_t>(block)]; }
  // Moves the linearisation point of a kept block (index into kept_blocks()).
  // The scale correction uses it: when the window is rescaled about the
  // gauge, the prior's positions are rescaled with it, so the prior keeps
  // its shape information without pulling the window back to the old scale.
  void SetX0(int block, const std::vector<double>& x0);

 private:
  friend class Marginalizer;
  MarginalizationPrior() = default;
  std::vector<double*> kept_blocks_;
  std::vector<int> ambient_sizes_, tangent_sizes_, tangent_offsets_;
  std::vector<const ceres::Manifold*> manifolds_;  // null: Euclidean
  std::vector<std::vector<double>> x0_;
  Eigen::MatrixXd jacobian_;   // J*, rows x total tangent size
  Eigen::VectorXd residual0_;  // r0
};

}  // namespace mcvo
