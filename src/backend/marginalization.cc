#include "mcvo/backend/marginalization.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include <Eigen/Eigenvalues>

#include "mcvo/util/error.h"
#include "mcvo/util/logging.h"

namespace mcvo {
namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Ceres' robust-loss correction (Triggs et al., "Bundle Adjustment: A Modern
// Synthesis", eq. 11; ceres/internal/corrector.cc): the residual block's
// Gauss-Newton model of rho(|r|^2) / 2 with the curvature correction only in
// the convex part (rho'' > 0), as the solver does. Corrects `jacobian`
// (rows x cols, row-major) with the uncorrected residual first, then the
// residual.
void ApplyLossCorrection(const ceres::LossFunction& loss, Eigen::VectorXd* residual,
                         RowMajorMatrix* jacobian) {
  const double sq_norm = residual->squaredNorm();
  double rho[3];
  loss.Evaluate(sq_norm, rho);
  const double sqrt_rho1 = std::sqrt(std::max(rho[1], 0.0));
  double residual_scaling = sqrt_rho1;
  double alpha_sq_norm = 0.0;
  if (sq_norm > 0.0 && rho[2] > 0.0 && rho[1] > 0.0) {
    const double alpha = 1.0 - std::sqrt(1.0 + 2.0 * sq_norm * rho[2] / rho[1]);
    residual_scaling = sqrt_rho1 / (1.0 - alpha);
    alpha_sq_norm = alpha / sq_norm;
  }
  if (alpha_sq_norm == 0.0) {
    *jacobian *= sqrt_rho1;
  } else {
    const Eigen::RowVectorXd r_transpose_j = residual->transpose() * (*jacobian);
    *jacobian = sqrt_rho1 * (*jacobian - alpha_sq_norm * (*residual) * r_transpose_j);
  }
  *residual *= residual_scaling;
}

// Pseudo-inverse of a symmetric matrix, eigenvalues <= eps treated as 0.
Eigen::MatrixXd SymmetricPseudoInverse(const Eigen::MatrixXd& a, double eps) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(0.5 * (a + a.transpose()));
  const Eigen::VectorXd& s = solver.eigenvalues();
  Eigen::VectorXd s_inv(s.size());
  for (Eigen::Index i = 0; i < s.size(); ++i) s_inv[i] = s[i] > eps ? 1.0 / s[i] : 0.0;
  return solver.eigenvectors() * s_inv.asDiagonal() * solver.eigenvectors().transpose();
}

// Union-find over the blocks to drop (path halving; the smaller index is the
// root, so groups are deterministic).
int Find(std::vector<int>* parent, int i) {
  while ((*parent)[static_cast<size_t>(i)] != i) {
    (*parent)[static_cast<size_t>(i)] = (*parent)[static_cast<size_t>((*parent)[static_cast<size_t>(i)])];
    i = (*parent)[static_cast<size_t>(i)];
  }
  return i;
}

void Unite(std::vector<int>* parent, int a, int b) {
  const int ra = Find(parent, a), rb = Find(parent, b);
  if (ra == rb) return;
  (*parent)[static_cast<size_t>(std::max(ra, rb))] = std::min(ra, rb);
}

// Step of the central differences for M(x) (see marginalization.h), in tangent
// units: truncation error ~h^2 on rotations, rounding ~1e-16 |x| / h.
constexpr double kTangentStep = 1e-5;

// M(x) = d ((x [+] d) [-] x0) / d d at d = 0, tangent x tangent, row-major.
bool MinusPlusJacobian(const ceres::Manifold& manifold, const double* x, const double* x0,
                       RowMajorMatrix* m) {
  const int ambient = manifold.AmbientSize();
  const int tangent = manifold.TangentSize();
  m->resize(tangent, tangent);
  if (std::memcmp(x, x0, sizeof(double) * static_cast<size_t>(ambient)) == 0) {
    m->setIdentity();
    return true;
  }
  std::vector<double> delta(static_cast<size_t>(tangent), 0.0), moved(static_cast<size_t>(ambient));
  std::vector<double> plus(static_cast<size_t>(tangent)), minus(static_cast<size_t>(tangent));
  for (int k = 0; k < tangent; ++k) {
    delta[static_cast<size_t>(k)] = kTangentStep;
    if (!manifold.Plus(x, delta.data(), moved.data()) || !manifold.Minus(moved.data(), x0, plus.data())) {
      return false;
    }
    delta[static_cast<size_t>(k)] = -kTangentStep;
    if (!manifold.Plus(x, delta.data(), moved.data()) || !manifold.Minus(moved.data(), x0, minus.data())) {
      return false;
    }
    delta[static_cast<size_t>(k)] = 0.0;
    for (int row = 0; row < tangent; ++row) {
      (*m)(row, k) =
          (plus[static_cast<size_t>(row)] - minus[static_cast<size_t>(row)]) / (2.0 * kTangentStep);
    }
  }
  return true;
}

// A residual block given to the marginaliser.
struct ResidualBlock {
  const ceres::CostFunction* cost = nullptr;
  const ceres::LossFunction* loss = nullptr;
  std::vector<double*> blocks;
};

// A variable of the linearisation: a parameter block that is not constant,
// its sizes and offset in the tangent vector.
struct Variable {
  double* block = nullptr;
  int ambient = 0, tangent = 0, offset = 0;
  const ceres::Manifold* manifold = nullptr;
  RowMajorMatrix plus_jacobian;  // at the current value (manifold blocks)
};

// Adds one residual block to H = J^T J and b = -J^T r in the tangent spaces
// (after the robust loss's correction), and unites in *drop_parent the
// blocks to drop that it couples. A block that fails to evaluate or has a
// non-finite Jacobian is left out with a warning.
void AddToNormalEquations(const ResidualBlock& residual, const std::vector<Variable>& variables,
                          const std::map<const double*, int>& index, size_t num_drop,
                          std::vector<int>* drop_parent, Eigen::MatrixXd* h, Eigen::VectorXd* b) {
  const int num_residuals = residual.cost->num_residuals();
  const size_t num_blocks = residual.blocks.size();
  std::vector<RowMajorMatrix> ambient_jacobians(num_blocks);
  std::vector<double*> jacobian_ptrs(num_blocks, nullptr);
  std::vector<const double*> parameters(residual.blocks.begin(), residual.blocks.end());
  for (size_t i = 0; i < num_blocks; ++i) {
    if (index.count(residual.blocks[i]) == 0) continue;  // constant
    ambient_jacobians[i].resize(num_residuals, residual.cost->parameter_block_sizes()[i]);
    jacobian_ptrs[i] = ambient_jacobians[i].data();
  }
  Eigen::VectorXd r(num_residuals);
  if (!residual.cost->Evaluate(parameters.data(), r.data(), jacobian_ptrs.data()) || !r.allFinite()) {
    MCVO_LOG(kWarning, "marginalisation: a residual block failed to evaluate; left out");
    return;
  }
  // Tangent Jacobians, side by side: [block 0 | block 1 | ...].
  std::vector<int> cols;  // variables index of each column group
  int total_cols = 0;
  for (size_t i = 0; i < num_blocks; ++i) {
    if (jacobian_ptrs[i] == nullptr) continue;
    cols.push_back(index.at(residual.blocks[i]));
    total_cols += variables[static_cast<size_t>(cols.back())].tangent;
  }
  RowMajorMatrix jacobian(num_residuals, total_cols);
  int col = 0;
  for (size_t i = 0, k = 0; i < num_blocks; ++i) {
    if (jacobian_ptrs[i] == nullptr) continue;
    const Variable& v = variables[static_cast<size_t>(cols[k++])];
    if (v.manifold == nullptr) {
      jacobian.middleCols(col, v.tangent) = ambient_jacobians[i];
    } else {
      jacobian.middleCols(col, v.tangent) = ambient_jacobians[i] * v.plus_jacobian;
    }
    col += v.tangent;
  }
  if (!jacobian.allFinite()) {
    MCVO_LOG(kWarning, "marginalisation: a residual block has a non-finite Jacobian; left out");
    return;
  }
  if (residual.loss != nullptr) ApplyLossCorrection(*residual.loss, &r, &jacobian);
  // Blocks to drop that share a residual block are coupled in Hmm.
  int first_drop = -1;
  for (int vi : cols) {
    if (vi >= static_cast<int>(num_drop)) continue;
    if (first_drop < 0) {
      first_drop = vi;
    } else {
      Unite(drop_parent, first_drop, vi);
    }
  }
  int col_i = 0;
  for (int vi : cols) {
    const Variable& a = variables[static_cast<size_t>(vi)];
    int col_j = 0;
    for (int vj : cols) {
      const Variable& c = variables[static_cast<size_t>(vj)];
      h->block(a.offset, c.offset, a.tangent, c.tangent) +=
          jacobian.middleCols(col_i, a.tangent).transpose() * jacobian.middleCols(col_j, c.tangent);
      col_j += c.tangent;
    }
    b->segment(a.offset, a.tangent) -= jacobian.middleCols(col_i, a.tangent).transpose() * r;
    col_i += a.tangent;
  }
}

// The Schur complement of H, b onto the kept blocks (the variables after the
// first num_drop). Hmm is block diagonal over the groups of coupled blocks
// to drop (each inverse depth alone, when only landmarks are dropped): its
// pseudo-inverse, and the complement, are taken group by group, in the order
// of the groups' first block.
void SchurComplement(const Eigen::MatrixXd& h, const Eigen::VectorXd& b,
                     const std::vector<Variable>& variables, size_t num_drop, std::vector<int>* drop_parent,
                     int dim_keep, double eps, Eigen::MatrixXd* h_schur_out, Eigen::VectorXd* b_schur_out) {
  Eigen::MatrixXd& h_schur = *h_schur_out;
  Eigen::VectorXd& b_schur = *b_schur_out;
  h_schur = h.bottomRightCorner(dim_keep, dim_keep);
  b_schur = b.tail(dim_keep);
  std::map<int, std::vector<int>> groups;  // root -> tangent indices
  for (size_t i = 0; i < num_drop; ++i) {
    std::vector<int>& group = groups[Find(drop_parent, static_cast<int>(i))];
    for (int k = 0; k < variables[i].tangent; ++k) group.push_back(variables[i].offset + k);
  }
  for (const auto& [root, group] : groups) {
    const Eigen::Index n = static_cast<Eigen::Index>(group.size());
    Eigen::MatrixXd hmm(n, n), hkm(dim_keep, n);
    Eigen::VectorXd bm(n);
    for (Eigen::Index a = 0; a < n; ++a) {
      for (Eigen::Index c = 0; c < n; ++c)
        hmm(a, c) = h(group[static_cast<size_t>(a)], group[static_cast<size_t>(c)]);
      hkm.col(a) = h.col(group[static_cast<size_t>(a)]).tail(dim_keep);
      bm[a] = b[group[static_cast<size_t>(a)]];
    }
    const Eigen::MatrixXd hkm_hmm_inv = hkm * SymmetricPseudoInverse(hmm, eps);
    h_schur -= hkm_hmm_inv * hkm.transpose();
    b_schur -= hkm_hmm_inv * bm;
  }
  h_schur = 0.5 * (h_schur + h_schur.transpose()).eval();
}

}  // namespace

struct Marginalizer::Impl {
  using Residual = ResidualBlock;
  std::vector<Residual> residuals;
  std::map<const double*, const ceres::Manifold*> manifolds;
  std::set<const double*> constant;
};

Marginalizer::Marginalizer() : impl_(std::make_unique<Impl>()) {}
Marginalizer::~Marginalizer() = default;

void Marginalizer::SetManifold(double* block, const ceres::Manifold* manifold) {
  MCVO_CHECK(block != nullptr);
  impl_->manifolds[block] = manifold;
}

void Marginalizer::SetConstant(double* block) {
  MCVO_CHECK(block != nullptr);
  impl_->constant.insert(block);
}

void Marginalizer::AddResidualBlock(const ceres::CostFunction* cost, const ceres::LossFunction* loss,
                                    const std::vector<double*>& parameter_blocks) {
  MCVO_CHECK(cost != nullptr);
  MCVO_CHECK_MSG(cost->parameter_block_sizes().size() == parameter_blocks.size(), "cost function has ",
                 cost->parameter_block_sizes().size(), " parameter blocks, got ", parameter_blocks.size());
  for (size_t i = 0; i < parameter_blocks.size(); ++i) {
    MCVO_CHECK(parameter_blocks[i] != nullptr);
    for (size_t j = 0; j < i; ++j) {
      MCVO_CHECK_MSG(parameter_blocks[i] != parameter_blocks[j], "parameter block ", i, " repeats block ", j,
                     " (Ceres forbids it)");
    }
  }
  impl_->residuals.push_back({cost, loss, parameter_blocks});
}

std::unique_ptr<MarginalizationPrior> Marginalizer::Marginalize(const std::vector<double*>& drop,
                                                                double eps) {
  const std::set<const double*> drop_set(drop.begin(), drop.end());
  for (const double* block : drop_set) {
    MCVO_CHECK_MSG(impl_->constant.count(block) == 0, "a block to marginalise is held constant");
  }

  // Residual blocks with at least one variable, in the order they were added.
  std::vector<const Impl::Residual*> selected;
  for (const Impl::Residual& residual : impl_->residuals) {
    const bool has_variable = std::any_of(residual.blocks.begin(), residual.blocks.end(),
                                          [&](const double* b) { return impl_->constant.count(b) == 0; });
    if (has_variable) selected.push_back(&residual);
  }
  if (selected.empty()) return nullptr;

  // Variables: blocks to drop (in `drop` order, those touched), then kept
  // blocks by first appearance; constant blocks are not variables.
  std::vector<Variable> variables;
  std::map<const double*, int> index;  // block -> variables index
  auto add_variable = [&](double* block, int ambient) {
    auto it = impl_->manifolds.find(block);
    const ceres::Manifold* manifold = it == impl_->manifolds.end() ? nullptr : it->second;
    const int tangent = manifold == nullptr ? ambient : manifold->TangentSize();
    if (manifold != nullptr) {
      MCVO_CHECK_MSG(manifold->AmbientSize() == ambient, "manifold of ambient size ", manifold->AmbientSize(),
                     " on a block of size ", ambient);
    }
    const int offset = variables.empty() ? 0 : variables.back().offset + variables.back().tangent;
    index[block] = static_cast<int>(variables.size());
    variables.push_back({block, ambient, tangent, offset, manifold, RowMajorMatrix()});
    if (manifold != nullptr) {
      variables.back().plus_jacobian.resize(ambient, tangent);
      MCVO_CHECK(manifold->PlusJacobian(block, variables.back().plus_jacobian.data()));
    }
  };
  std::map<const double*, int> sizes;
  for (const Impl::Residual* residual : selected) {
    for (size_t i = 0; i < residual->blocks.size(); ++i) {
      const int size = residual->cost->parameter_block_sizes()[i];
      auto [it, inserted] = sizes.emplace(residual->blocks[i], size);
      MCVO_CHECK_MSG(inserted || it->second == size, "a parameter block is used with sizes ", it->second,
                     " and ", size);
    }
  }
  for (double* block : drop) {
    if (sizes.count(block) > 0 && index.count(block) == 0) add_variable(block, sizes.at(block));
  }
  const size_t num_drop = variables.size();
  for (const Impl::Residual* residual : selected) {
    for (double* block : residual->blocks) {
      if (index.count(block) == 0 && impl_->constant.count(block) == 0) add_variable(block, sizes.at(block));
    }
  }
  if (variables.size() == num_drop) return nullptr;
  const int dim = variables.back().offset + variables.back().tangent;
  const int dim_drop = num_drop == 0 ? 0 : variables[num_drop - 1].offset + variables[num_drop - 1].tangent;
  const int dim_keep = dim - dim_drop;

  // H = J^T J and b = -J^T r in the tangent spaces.
  std::vector<int> drop_parent(num_drop);
  for (size_t i = 0; i < num_drop; ++i) drop_parent[i] = static_cast<int>(i);
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(dim, dim);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(dim);
  for (const Impl::Residual* residual : selected) {
    AddToNormalEquations(*residual, variables, index, num_drop, &drop_parent, &h, &b);
  }

  // Schur complement onto the kept blocks.
  Eigen::MatrixXd h_schur;
  Eigen::VectorXd b_schur;
  SchurComplement(h, b, variables, num_drop, &drop_parent, dim_keep, eps, &h_schur, &b_schur);

  // H* = J*^T J*, J*^T r0 = -b*.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(h_schur);
  const Eigen::VectorXd& s = solver.eigenvalues();
  std::vector<Eigen::Index> kept_eigen;
  for (Eigen::Index i = 0; i < s.size(); ++i) {
    if (s[i] > eps) kept_eigen.push_back(i);
  }
  if (kept_eigen.empty()) return nullptr;

  std::unique_ptr<MarginalizationPrior> prior(new MarginalizationPrior());
  const Eigen::Index rows = static_cast<Eigen::Index>(kept_eigen.size());
  prior->jacobian_.resize(rows, dim_keep);
  prior->residual0_.resize(rows);
  for (Eigen::Index row = 0; row < rows; ++row) {
    const Eigen::Index e = kept_eigen[static_cast<size_t>(row)];
    const double sqrt_s = std::sqrt(s[e]);
    prior->jacobian_.row(row) = sqrt_s * solver.eigenvectors().col(e).transpose();
    prior->residual0_[row] = -solver.eigenvectors().col(e).dot(b_schur) / sqrt_s;
  }
  for (size_t i = num_drop; i < variables.size(); ++i) {
    const Variable& v = variables[i];
    prior->kept_blocks_.push_back(v.block);
    prior->ambient_sizes_.push_back(v.ambient);
    prior->tangent_sizes_.push_back(v.tangent);
    prior->tangent_offsets_.push_back(v.offset - dim_drop);
    prior->manifolds_.push_back(v.manifold);
    prior->x0_.emplace_back(v.block, v.block + v.ambient);
    prior->mutable_parameter_block_sizes()->push_back(v.ambient);
  }
  prior->set_num_residuals(static_cast<int>(rows));
  return prior;
}

bool MarginalizationPrior::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const Eigen::Index rows = jacobian_.rows();
  Eigen::Map<Eigen::VectorXd> r(residuals, rows);
  r = residual0_;
  for (size_t i = 0; i < kept_blocks_.size(); ++i) {
    const int tangent = tangent_sizes_[i];
    const int ambient = ambient_sizes_[i];
    const double* x = parameters[i];
    const double* x0 = x0_[i].data();
    Eigen::VectorXd dx(tangent);
    if (manifolds_[i] == nullptr) {
      for (int k = 0; k < tangent; ++k) dx[k] = x[k] - x0[k];
    } else if (!manifolds_[i]->Minus(x, x0, dx.data())) {
      return false;
    }
    const auto j_block = jacobian_.middleCols(tangent_offsets_[i], tangent);
    r += j_block * dx;
    if (jacobians == nullptr || jacobians[i] == nullptr) continue;
    Eigen::Map<RowMajorMatrix> out(jacobians[i], rows, ambient);
    if (manifolds_[i] == nullptr) {
      out = j_block;
      continue;
    }
    RowMajorMatrix m, minus_jacobian(tangent, ambient);
    if (!MinusPlusJacobian(*manifolds_[i], x, x0, &m) ||
        !manifolds_[i]->MinusJacobian(x, minus_jacobian.data())) {
      return false;
    }
    out = j_block * m * minus_jacobian;
  }
  return r.allFinite();
}

void MarginalizationPrior::SetX0(int block, const std::vector<double>& x0) {
  MCVO_CHECK(block >= 0 && block < static_cast<int>(x0_.size()));
  MCVO_CHECK(x0.size() == x0_[static_cast<size_t>(block)].size());
  x0_[static_cast<size_t>(block)] = x0;
}

}  // namespace mcvo
