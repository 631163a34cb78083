// Marginalisation (include/mcvo/backend/marginalization.h): exactness on
// linear least squares, Jacobians and cost of the prior on pose manifolds,
// chaining of priors, robust losses.
#include "mcvo/backend/marginalization.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "backend/backend_test_util.h"
#include "mcvo/backend/factors.h"

namespace mcvo {
namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// r = A [x_0; x_1; ...] - c over Euclidean blocks of the given sizes.
class LinearCost : public ceres::CostFunction {
 public:
  LinearCost(const std::vector<int>& sizes, int rows, std::mt19937* rng) {
    int cols = 0;
    for (int s : sizes) {
      mutable_parameter_block_sizes()->push_back(s);
      cols += s;
    }
    set_num_residuals(rows);
    std::normal_distribution<double> normal(0.0, 1.0);
    a_.resize(rows, cols);
    c_.resize(rows);
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) a_(i, j) = normal(*rng);
      c_[i] = normal(*rng);
    }
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    Eigen::Map<Eigen::VectorXd> r(residuals, num_residuals());
    r = -c_;
    int col = 0;
    for (size_t b = 0; b < parameter_block_sizes().size(); ++b) {
      const int size = parameter_block_sizes()[b];
      r += a_.middleCols(col, size) * Eigen::Map<const Eigen::VectorXd>(parameters[b], size);
      if (jacobians != nullptr && jacobians[b] != nullptr) {
        Eigen::Map<RowMajor>(jacobians[b], num_residuals(), size) = a_.middleCols(col, size);
      }
      col += size;
    }
    return true;
  }

 private:
  Eigen::MatrixXd a_;
  Eigen::VectorXd c_;
};

// One Gauss-Newton step from the current values (exact for a linear
// problem), applied to `blocks` (Euclidean).
void GaussNewtonSolve(ceres::Problem* problem, const std::vector<double*>& blocks) {
  Eigen::VectorXd r;
  const Eigen::MatrixXd j = test::DenseJacobian(problem, blocks, &r);
  const Eigen::VectorXd step = (j.transpose() * j).ldlt().solve(-j.transpose() * r);
  int offset = 0;
  for (double* block : blocks) {
    const int size = problem->ParameterBlockSize(block);
    for (int k = 0; k < size; ++k) block[k] += step[offset + k];
    offset += size;
  }
}

ceres::Problem::Options NonOwning() {
  ceres::Problem::Options options;
  options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

struct LinearBlock {
  std::unique_ptr<LinearCost> cost;
  std::vector<double*> blocks;
};

LinearBlock MakeLinear(const std::vector<double*>& blocks, const std::vector<int>& sizes, int rows,
                       std::mt19937* rng) {
  return {std::make_unique<LinearCost>(sizes, rows, rng), blocks};
}

double MaxDiff(const std::vector<double>& a, const std::vector<double>& b) {
  double worst = 0.0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
  return worst;
}

TEST(Marginalization, LinearProblemKeepsTheFullSolution) {
  std::mt19937 rng(1);
  std::vector<double> x0(2), x1(3), x2(2), x3(1);
  std::vector<LinearBlock> residuals;
  residuals.push_back(MakeLinear({x0.data()}, {2}, 3, &rng));
  residuals.push_back(MakeLinear({x0.data(), x1.data()}, {2, 3}, 4, &rng));
  residuals.push_back(MakeLinear({x2.data(), x0.data()}, {2, 2}, 3, &rng));
  residuals.push_back(MakeLinear({x1.data(), x2.data()}, {3, 2}, 3, &rng));
  residuals.push_back(MakeLinear({x2.data(), x3.data()}, {2, 1}, 2, &rng));
  residuals.push_back(MakeLinear({x1.data()}, {3}, 2, &rng));

  // Full solution.
  ceres::Problem full(NonOwning());
  for (auto& r : residuals) full.AddResidualBlock(r.cost.get(), nullptr, r.blocks);
  GaussNewtonSolve(&full, {x0.data(), x1.data(), x2.data(), x3.data()});
  const std::vector<double> s1 = x1, s2 = x2, s3 = x3;

  // Linearise somewhere else (a linear problem's prior does not depend on it).
  for (auto* x : {&x0, &x1, &x2, &x3}) {
    for (double& v : *x) v = std::normal_distribution<double>(0.0, 3.0)(rng);
  }
  Marginalizer marginalizer;
  for (size_t i = 0; i < 3; ++i)
    marginalizer.AddResidualBlock(residuals[i].cost.get(), nullptr, residuals[i].blocks);
  const std::unique_ptr<MarginalizationPrior> prior = marginalizer.Marginalize({x0.data()});
  ASSERT_NE(prior, nullptr);
  EXPECT_EQ(prior->kept_blocks(), (std::vector<double*>{x1.data(), x2.data()}));
  EXPECT_EQ(prior->num_residuals(), 5);  // full rank: 3 + 2 kept dimensions

  ceres::Problem reduced(NonOwning());
  reduced.AddResidualBlock(prior.get(), nullptr, prior->kept_blocks());
  for (size_t i = 3; i < residuals.size(); ++i)
    reduced.AddResidualBlock(residuals[i].cost.get(), nullptr, residuals[i].blocks);
  GaussNewtonSolve(&reduced, {x1.data(), x2.data(), x3.data()});
  const double worst = std::max({MaxDiff(x1, s1), MaxDiff(x2, s2), MaxDiff(x3, s3)});
  std::printf("linear: max |x_reduced - x_full| = %.3g\n", worst);
  EXPECT_LT(worst, 1e-10);
}

TEST(Marginalization, SeveralDroppedGroupsLinear) {
  // Dropped blocks a, b (coupled through a residual) and c (alone): Hmm is
  // inverted group by group; the kept solution must not change.
  std::mt19937 rng(11);
  std::vector<double> a(2), b(1), c(1), k1(2), k2(3);
  std::vector<LinearBlock> dropped, remaining;
  dropped.push_back(MakeLinear({a.data(), k1.data()}, {2, 2}, 3, &rng));
  dropped.push_back(MakeLinear({a.data(), b.data()}, {2, 1}, 2, &rng));
  dropped.push_back(MakeLinear({b.data(), k2.data()}, {1, 3}, 2, &rng));
  dropped.push_back(MakeLinear({c.data(), k1.data()}, {1, 2}, 1, &rng));
  dropped.push_back(MakeLinear({k2.data(), c.data()}, {3, 1}, 2, &rng));
  remaining.push_back(MakeLinear({k1.data(), k2.data()}, {2, 3}, 2, &rng));
  remaining.push_back(MakeLinear({k2.data()}, {3}, 2, &rng));
  ceres::Problem full(NonOwning());
  for (auto* set : {&dropped, &remaining}) {
    for (auto& r : *set) full.AddResidualBlock(r.cost.get(), nullptr, r.blocks);
  }
  GaussNewtonSolve(&full, {a.data(), b.data(), c.data(), k1.data(), k2.data()});
  const std::vector<double> s1 = k1, s2 = k2;
  for (auto* x : {&a, &b, &c, &k1, &k2}) {
    for (double& v : *x) v = std::normal_distribution<double>(0.0, 3.0)(rng);
  }
  Marginalizer marginalizer;
  for (auto& r : dropped) marginalizer.AddResidualBlock(r.cost.get(), nullptr, r.blocks);
  const std::unique_ptr<MarginalizationPrior> prior =
      marginalizer.Marginalize({c.data(), a.data(), b.data()});
  ASSERT_NE(prior, nullptr);
  EXPECT_EQ(prior->kept_blocks(), (std::vector<double*>{k1.data(), k2.data()}));
  ceres::Problem reduced(NonOwning());
  reduced.AddResidualBlock(prior.get(), nullptr, prior->kept_blocks());
  for (auto& r : remaining) reduced.AddResidualBlock(r.cost.get(), nullptr, r.blocks);
  GaussNewtonSolve(&reduced, {k1.data(), k2.data()});
  const double worst = std::max(MaxDiff(k1, s1), MaxDiff(k2, s2));
  std::printf("linear, three dropped blocks in two groups: max difference %.3g\n", worst);
  EXPECT_LT(worst, 1e-10);
}

// ---------------------------------------------------------------- pose problems

// Pose blocks world_from_body {t, q}. Relative: residual of a measured
// a_from_b (Ceres' pose_graph_3d): [p_ab - p_meas; 2 vec(q_meas q_ab^-1)]
// times a weight. Absolute: the same against a measured world_from_body.
struct RelativePoseError {
  Eigen::Quaterniond q_meas;
  Eigen::Vector3d p_meas;
  double weight;
  template <typename T>
  bool operator()(const T* a, const T* b, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> qa(a + 3), qb(b + 3);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> pa(a), pb(b);
    const Eigen::Quaternion<T> qa_inv = qa.conjugate();
    const Eigen::Quaternion<T> q_ab = qa_inv * qb;
    const Eigen::Matrix<T, 3, 1> p_ab = qa_inv * (pb - pa);
    const Eigen::Quaternion<T> dq = q_meas.template cast<T>() * q_ab.conjugate();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residuals);
    r.template head<3>() = T(weight) * (p_ab - p_meas.template cast<T>());
    r.template tail<3>() = T(2.0 * weight) * dq.vec();
    return true;
  }
};

struct AbsolutePoseError {
  Eigen::Quaterniond q_meas;
  Eigen::Vector3d p_meas;
  double weight;
  template <typename T>
  bool operator()(const T* x, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(x + 3);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p(x);
    const Eigen::Quaternion<T> dq = q_meas.template cast<T>() * q.conjugate();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residuals);
    r.template head<3>() = T(weight) * (p - p_meas.template cast<T>());
    r.template tail<3>() = T(2.0 * weight) * dq.vec();
    return true;
  }
};

struct PoseGraph {
  std::vector<std::array<double, kPoseParamSize>> poses;
  std::vector<Rigid3d> truth;
  std::unique_ptr<ceres::Manifold> manifold{NewPoseManifold()};
  struct Edge {
    std::unique_ptr<ceres::CostFunction> cost;
    std::vector<double*> blocks;
    int first = 0;  // lowest pose index it touches
  };
  std::vector<Edge> edges;
};

// A chain of `n` poses with relative edges (i, i+1) and (i, i+2) and an
// absolute edge on pose 0, measurements with noise (the optimum has
// non-zero residuals), values initialised at the noisy truth.
PoseGraph MakePoseGraph(int n, std::mt19937* rng) {
  PoseGraph g;
  g.poses.resize(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    g.truth.emplace_back(test::RandomRotation(rng, M_PI),
                         Eigen::Vector3d(1.0 * i, 0.3 * std::sin(i), 0.1 * i));
  }
  auto noisy = [&](const Rigid3d& pose) {
    return Rigid3d(test::RandomRotation(rng, 0.02) * pose.rotation,
                   pose.translation + 0.02 * test::RandomUnit(rng));
  };
  {
    const Rigid3d m = noisy(g.truth[0]);
    g.edges.push_back(
        {std::unique_ptr<ceres::CostFunction>(new ceres::AutoDiffCostFunction<AbsolutePoseError, 6, 7>(
             new AbsolutePoseError{m.rotation, m.translation, 10.0})),
         {g.poses[0].data()},
         0});
  }
  for (int i = 0; i < n; ++i) {
    for (int j : {i + 1, i + 2}) {
      if (j >= n) continue;
      const Rigid3d m = noisy(g.truth[static_cast<size_t>(i)].Inverse() * g.truth[static_cast<size_t>(j)]);
      g.edges.push_back(
          {std::unique_ptr<ceres::CostFunction>(new ceres::AutoDiffCostFunction<RelativePoseError, 6, 7, 7>(
               new RelativePoseError{m.rotation, m.translation, 5.0 + i})),
           {g.poses[static_cast<size_t>(i)].data(), g.poses[static_cast<size_t>(j)].data()},
           i});
    }
  }
  for (int i = 0; i < n; ++i)
    PoseToParams(noisy(g.truth[static_cast<size_t>(i)]), g.poses[static_cast<size_t>(i)].data());
  return g;
}

void SolvePoses(ceres::Problem* problem, PoseGraph* g, const std::vector<int>& indices) {
  for (int i : indices) problem->SetManifold(g->poses[static_cast<size_t>(i)].data(), g->manifold.get());
  ceres::Solver::Summary summary;
  ceres::Solve(test::TightSolverOptions(), problem, &summary);
  EXPECT_TRUE(summary.IsSolutionUsable());
}

void Perturb(PoseGraph* g, int i, std::mt19937* rng, double amount) {
  std::array<double, 6> delta;
  for (double& d : delta) d = std::uniform_real_distribution<double>(-amount, amount)(*rng);
  std::array<double, kPoseParamSize> moved;
  g->manifold->Plus(g->poses[static_cast<size_t>(i)].data(), delta.data(), moved.data());
  g->poses[static_cast<size_t>(i)] = moved;
}

double PoseDistance(const std::array<double, kPoseParamSize>& a,
                    const std::array<double, kPoseParamSize>& b) {
  const Rigid3d pa = PoseFromParams(a.data()), pb = PoseFromParams(b.data());
  return std::max((pa.translation - pb.translation).norm(), test::RotationAngle(pa.rotation, pb.rotation));
}

TEST(Marginalization, PosePriorCostAndJacobians) {
  std::mt19937 rng(2);
  PoseGraph g = MakePoseGraph(4, &rng);
  Marginalizer marginalizer;
  for (auto& pose : g.poses) marginalizer.SetManifold(pose.data(), g.manifold.get());
  for (auto& e : g.edges) {
    if (e.first == 0) marginalizer.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
  }
  const std::unique_ptr<MarginalizationPrior> prior = marginalizer.Marginalize({g.poses[0].data()});
  ASSERT_NE(prior, nullptr);
  ASSERT_EQ(prior->kept_blocks(), (std::vector<double*>{g.poses[1].data(), g.poses[2].data()}));
  EXPECT_EQ(prior->num_residuals(), 12);

  // Independent Schur complement from Ceres' own tangent Jacobian.
  ceres::Problem dropped(NonOwning());
  for (auto& e : g.edges) {
    if (e.first == 0) dropped.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
  }
  for (int i = 0; i < 3; ++i) dropped.SetManifold(g.poses[static_cast<size_t>(i)].data(), g.manifold.get());
  Eigen::VectorXd r;
  const Eigen::MatrixXd j =
      test::DenseJacobian(&dropped, {g.poses[0].data(), g.poses[1].data(), g.poses[2].data()}, &r);
  const Eigen::MatrixXd h = j.transpose() * j;
  const Eigen::VectorXd b = -j.transpose() * r;
  const Eigen::MatrixXd hmm_inv = h.topLeftCorner(6, 6).inverse();
  const Eigen::MatrixXd h_schur =
      h.bottomRightCorner(12, 12) - h.bottomLeftCorner(12, 6) * hmm_inv * h.topRightCorner(6, 12);
  const Eigen::VectorXd b_schur = b.tail(12) - h.bottomLeftCorner(12, 6) * hmm_inv * b.head(6);
  const Eigen::MatrixXd& js = prior->jacobian();
  EXPECT_LT((js.transpose() * js - h_schur).norm(), 1e-9 * h_schur.norm());
  EXPECT_LT((js.transpose() * prior->residual0() + b_schur).norm(), 1e-9 * b_schur.norm());

  // At x0: r = r0, cost 0.5 |r0|^2.
  std::vector<const double*> params = {g.poses[1].data(), g.poses[2].data()};
  Eigen::VectorXd r_at_x0(prior->num_residuals());
  ASSERT_TRUE(prior->Evaluate(params.data(), r_at_x0.data(), nullptr));
  // Minus(x0, x0) is zero up to rounding (quaternion log of q q^-1).
  EXPECT_LT((r_at_x0 - prior->residual0()).norm(), 1e-12);
  ceres::Problem prior_only(NonOwning());
  prior_only.AddResidualBlock(prior.get(), nullptr, prior->kept_blocks());
  double cost = 0.0;
  prior_only.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
  EXPECT_NEAR(cost, 0.5 * prior->residual0().squaredNorm(), 1e-12 * (1.0 + cost));
  EXPECT_GT(cost, 0.0);

  // Jacobians against central differences through the manifold, at x0 and
  // away from it (0.3 rad, 0.3 m).
  std::vector<double*> mutable_params = {g.poses[1].data(), g.poses[2].data()};
  for (double amount : {0.0, 0.3}) {
    if (amount > 0.0) {
      Perturb(&g, 1, &rng, amount);
      Perturb(&g, 2, &rng, amount);
    }
    double worst = 0.0, scale = 0.0;
    for (int block = 0; block < 2; ++block) {
      const Eigen::MatrixXd analytic =
          test::AnalyticTangentJacobian(*prior, mutable_params, block, g.manifold.get());
      const Eigen::MatrixXd numeric =
          test::NumericTangentJacobian(*prior, mutable_params, block, g.manifold.get(), 1e-6);
      worst = std::max(worst, (analytic - numeric).cwiseAbs().maxCoeff());
      scale = std::max(scale, analytic.cwiseAbs().maxCoeff());
    }
    std::printf("prior Jacobian, %.1f from x0: max error %.3g of max entry %.3g\n", amount, worst, scale);
    EXPECT_LT(worst, 1e-6 * scale);
  }
}

TEST(Marginalization, NonlinearOptimumIsKept) {
  // Marginalising at the full optimum keeps it a stationary point of the
  // reduced problem: solving from a perturbed start returns to it.
  std::mt19937 rng(3);
  PoseGraph g = MakePoseGraph(5, &rng);
  {
    ceres::Problem full(NonOwning());
    for (auto& e : g.edges) full.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
    SolvePoses(&full, &g, {0, 1, 2, 3, 4});
  }
  const auto optimum = g.poses;
  Marginalizer marginalizer;
  for (auto& pose : g.poses) marginalizer.SetManifold(pose.data(), g.manifold.get());
  for (auto& e : g.edges) {
    if (e.first == 0) marginalizer.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
  }
  const std::unique_ptr<MarginalizationPrior> prior = marginalizer.Marginalize({g.poses[0].data()});
  ASSERT_NE(prior, nullptr);
  for (int i = 1; i < 5; ++i) Perturb(&g, i, &rng, 0.2);
  ceres::Problem reduced(NonOwning());
  reduced.AddResidualBlock(prior.get(), nullptr, prior->kept_blocks());
  for (auto& e : g.edges) {
    if (e.first != 0) reduced.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
  }
  SolvePoses(&reduced, &g, {1, 2, 3, 4});
  double worst = 0.0;
  for (size_t i = 1; i < 5; ++i) worst = std::max(worst, PoseDistance(g.poses[i], optimum[i]));
  std::printf("nonlinear: max pose difference to the full optimum %.3g\n", worst);
  EXPECT_LT(worst, 1e-8);
}

TEST(Marginalization, ChainedPriorsCarryInformationLinear) {
  // x0 .. x4 (2-vectors); marginalise x0, then x1 with the first prior.
  std::mt19937 rng(4);
  std::vector<std::vector<double>> x(5, std::vector<double>(2, 0.0));
  std::vector<LinearBlock> residuals;
  std::vector<int> first;  // lowest index touched
  residuals.push_back(MakeLinear({x[0].data()}, {2}, 2, &rng));
  first.push_back(0);
  for (int i = 0; i < 5; ++i) {
    for (int j : {i + 1, i + 2}) {
      if (j >= 5) continue;
      residuals.push_back(
          MakeLinear({x[static_cast<size_t>(i)].data(), x[static_cast<size_t>(j)].data()}, {2, 2}, 2, &rng));
      first.push_back(i);
    }
  }
  std::vector<double*> all;
  for (auto& v : x) all.push_back(v.data());
  ceres::Problem full(NonOwning());
  for (auto& r : residuals) full.AddResidualBlock(r.cost.get(), nullptr, r.blocks);
  GaussNewtonSolve(&full, all);
  const auto solution = x;

  for (auto& v : x) {
    for (double& e : v) e = std::normal_distribution<double>(0.0, 2.0)(rng);
  }
  Marginalizer first_marginalizer;
  for (size_t k = 0; k < residuals.size(); ++k) {
    if (first[k] == 0)
      first_marginalizer.AddResidualBlock(residuals[k].cost.get(), nullptr, residuals[k].blocks);
  }
  const std::unique_ptr<MarginalizationPrior> prior1 = first_marginalizer.Marginalize({x[0].data()});
  ASSERT_NE(prior1, nullptr);

  auto second = [&](bool with_prior) {
    Marginalizer marginalizer;
    if (with_prior) marginalizer.AddResidualBlock(prior1.get(), nullptr, prior1->kept_blocks());
    for (size_t k = 0; k < residuals.size(); ++k) {
      if (first[k] == 1) marginalizer.AddResidualBlock(residuals[k].cost.get(), nullptr, residuals[k].blocks);
    }
    return marginalizer.Marginalize({x[1].data()});
  };
  for (bool with_prior : {true, false}) {
    const std::unique_ptr<MarginalizationPrior> prior2 = second(with_prior);
    ASSERT_NE(prior2, nullptr);
    EXPECT_EQ(prior2->kept_blocks(), (std::vector<double*>{x[2].data(), x[3].data()}));
    ceres::Problem reduced(NonOwning());
    reduced.AddResidualBlock(prior2.get(), nullptr, prior2->kept_blocks());
    for (size_t k = 0; k < residuals.size(); ++k) {
      if (first[k] >= 2) reduced.AddResidualBlock(residuals[k].cost.get(), nullptr, residuals[k].blocks);
    }
    auto saved = x;
    GaussNewtonSolve(&reduced, {x[2].data(), x[3].data(), x[4].data()});
    double worst = 0.0;
    for (size_t i = 2; i < 5; ++i) worst = std::max(worst, MaxDiff(x[i], solution[i]));
    std::printf("chained linear (%s the first prior): max difference %.3g\n", with_prior ? "with" : "without",
                worst);
    if (with_prior) {
      EXPECT_LT(worst, 1e-10);
    } else {
      EXPECT_GT(worst, 1e-3);  // the first prior's information is needed
    }
    x = saved;
  }
}

TEST(Marginalization, ChainedPriorsNonlinearPoses) {
  std::mt19937 rng(5);
  PoseGraph g = MakePoseGraph(6, &rng);
  {
    ceres::Problem full(NonOwning());
    for (auto& e : g.edges) full.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
    SolvePoses(&full, &g, {0, 1, 2, 3, 4, 5});
  }
  const auto optimum = g.poses;
  std::unique_ptr<MarginalizationPrior> prior;
  for (int dropped = 0; dropped < 2; ++dropped) {
    Marginalizer marginalizer;
    for (auto& pose : g.poses) marginalizer.SetManifold(pose.data(), g.manifold.get());
    if (prior) marginalizer.AddResidualBlock(prior.get(), nullptr, prior->kept_blocks());
    for (auto& e : g.edges) {
      if (e.first == dropped) marginalizer.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
    }
    prior = marginalizer.Marginalize({g.poses[static_cast<size_t>(dropped)].data()});
    ASSERT_NE(prior, nullptr);
  }
  EXPECT_EQ(prior->kept_blocks(), (std::vector<double*>{g.poses[2].data(), g.poses[3].data()}));
  for (int i = 2; i < 6; ++i) Perturb(&g, i, &rng, 0.2);
  ceres::Problem reduced(NonOwning());
  reduced.AddResidualBlock(prior.get(), nullptr, prior->kept_blocks());
  for (auto& e : g.edges) {
    if (e.first >= 2) reduced.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
  }
  SolvePoses(&reduced, &g, {2, 3, 4, 5});
  double worst = 0.0;
  for (size_t i = 2; i < 6; ++i) worst = std::max(worst, PoseDistance(g.poses[i], optimum[i]));
  std::printf("chained nonlinear: max pose difference to the full optimum %.3g\n", worst);
  EXPECT_LT(worst, 1e-8);
}

TEST(Marginalization, ConstantBlocksAreConditionedOn) {
  // The lead's use: pose 0 constant, nothing dropped: the prior re-linearises
  // the residual blocks over the non-constant poses only.
  std::mt19937 rng(6);
  PoseGraph g = MakePoseGraph(3, &rng);
  Marginalizer marginalizer;
  for (auto& pose : g.poses) marginalizer.SetManifold(pose.data(), g.manifold.get());
  marginalizer.SetConstant(g.poses[0].data());
  for (auto& e : g.edges) marginalizer.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
  const std::unique_ptr<MarginalizationPrior> prior = marginalizer.Marginalize({});
  ASSERT_NE(prior, nullptr);
  EXPECT_EQ(prior->kept_blocks(), (std::vector<double*>{g.poses[1].data(), g.poses[2].data()}));

  ceres::Problem problem(NonOwning());
  for (auto& e : g.edges) problem.AddResidualBlock(e.cost.get(), nullptr, e.blocks);
  for (auto& pose : g.poses) problem.SetManifold(pose.data(), g.manifold.get());
  Eigen::VectorXd r;
  const Eigen::MatrixXd j = test::DenseJacobian(&problem, {g.poses[1].data(), g.poses[2].data()}, &r);
  const Eigen::MatrixXd& js = prior->jacobian();
  EXPECT_LT((js.transpose() * js - j.transpose() * j).norm(), 1e-9 * (j.transpose() * j).norm());
  EXPECT_LT((js.transpose() * prior->residual0() - j.transpose() * r).norm(),
            1e-9 * (j.transpose() * r).norm());
  // The prior's cost equals the problem's at the linearisation point up to
  // the part of r outside the range of J (a constant).
  EXPECT_LE(0.5 * prior->residual0().squaredNorm(), 0.5 * r.squaredNorm() + 1e-9);
}

TEST(Marginalization, NullWhenNothingToDoOrKeep) {
  std::mt19937 rng(7);
  std::vector<double> x0(2), x1(2);
  LinearBlock only_x0 = MakeLinear({x0.data()}, {2}, 3, &rng);
  {
    Marginalizer marginalizer;
    EXPECT_EQ(marginalizer.Marginalize({x0.data()}), nullptr);  // no residual blocks
  }
  {
    Marginalizer marginalizer;
    marginalizer.AddResidualBlock(only_x0.cost.get(), nullptr, only_x0.blocks);
    EXPECT_EQ(marginalizer.Marginalize({x0.data()}), nullptr);  // nothing to keep
  }
  {
    Marginalizer marginalizer;
    marginalizer.AddResidualBlock(only_x0.cost.get(), nullptr, only_x0.blocks);
    marginalizer.SetConstant(x0.data());
    EXPECT_EQ(marginalizer.Marginalize({x1.data()}), nullptr);  // only constants
  }
}

TEST(Marginalization, WindowLandmarksIntoPosePrior) {
  // The estimator's use on the BA factors: frame 0 (the gauge) and the
  // extrinsics constant, every landmark anchored in frame 0 dropped, Huber
  // loss. Marginalised at the full optimum, the prior alone keeps poses 1
  // and 2 there.
  std::mt19937 rng(12);
  const double sqrt_info = 460.0 / 1.5;
  Eigen::Matrix3d forward_cam;
  forward_cam << 0, 0, 1, 1, 0, 0, 0, 1, 0;  // camera z = rig x, camera x = rig y
  const std::vector<Rigid3d> rig_from_cam = {
      Rigid3d(forward_cam, Eigen::Vector3d(1.5, 0.0, -0.6)),
      Rigid3d(Eigen::Matrix3d(Eigen::AngleAxisd(-0.8, Eigen::Vector3d::UnitZ()) * forward_cam),
              Eigen::Vector3d(1.0, -0.6, -0.9))};
  std::vector<Rigid3d> world_from_rig;
  for (int f = 0; f < 3; ++f) {
    world_from_rig.emplace_back(Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * f, Eigen::Vector3d::UnitZ())),
                                Eigen::Vector3d(1.2 * f, 0.1 * f, 0.0));
  }
  std::vector<std::array<double, kPoseParamSize>> poses(3), extrinsics(2);
  for (size_t f = 0; f < 3; ++f) PoseToParams(world_from_rig[f], poses[f].data());
  for (size_t c = 0; c < 2; ++c) PoseToParams(rig_from_cam[c], extrinsics[c].data());
  std::unique_ptr<ceres::Manifold> manifold(NewPoseManifold());
  const ceres::HuberLoss loss(1.0);

  struct Block {
    std::unique_ptr<ceres::CostFunction> cost;
    std::vector<double*> blocks;
  };
  std::vector<Block> blocks;
  std::vector<double> inverse_depths(150);
  for (size_t l = 0; l < inverse_depths.size(); ++l) {
    const size_t anchor_cam = l % 2;
    Eigen::Vector3d bearing;
    do {
      bearing = test::RandomUnit(&rng);
    } while (bearing.z() < 0.6);
    const double distance = std::uniform_real_distribution<double>(4.0, 25.0)(rng);
    const Eigen::Vector3d point = world_from_rig[0] * (rig_from_cam[anchor_cam] * (distance * bearing));
    inverse_depths[l] = 1.0 / distance * std::uniform_real_distribution<double>(0.9, 1.1)(rng);
    const Eigen::Vector3d anchor_bearing = test::NoisyBearing(bearing, 1.0 / 460.0, &rng);
    for (size_t f = 0; f < 3; ++f) {
      for (size_t c = 0; c < 2; ++c) {
        if (f == 0 && c == anchor_cam) continue;
        const Eigen::Vector3d in_cam = rig_from_cam[c].Inverse() * (world_from_rig[f].Inverse() * point);
        if (in_cam.normalized().z() < 0.3) continue;
        Eigen::Vector3d observed = test::NoisyBearing(in_cam.normalized(), 1.0 / 460.0, &rng);
        if (l % 37 == 0) observed = (observed + Eigen::Vector3d(0.05, 0.0, 0.0)).normalized();  // outliers
        Block b;
        if (f == 0) {
          b.cost.reset(NewReprojectionFactorSameFrame(anchor_bearing, observed, sqrt_info));
          b.blocks = {extrinsics[anchor_cam].data(), extrinsics[c].data(), &inverse_depths[l]};
        } else if (c == anchor_cam) {
          b.cost.reset(NewReprojectionFactorSameCamera(anchor_bearing, observed, sqrt_info));
          b.blocks = {poses[0].data(), poses[f].data(), extrinsics[c].data(), &inverse_depths[l]};
        } else {
          b.cost.reset(NewReprojectionFactorOtherCamera(anchor_bearing, observed, sqrt_info));
          b.blocks = {poses[0].data(), poses[f].data(), extrinsics[anchor_cam].data(), extrinsics[c].data(),
                      &inverse_depths[l]};
        }
        blocks.push_back(std::move(b));
      }
    }
  }
  ceres::Problem full(NonOwning());
  for (auto& b : blocks) full.AddResidualBlock(b.cost.get(), const_cast<ceres::HuberLoss*>(&loss), b.blocks);
  for (auto& pose : poses) full.SetManifold(pose.data(), manifold.get());
  for (auto& ext : extrinsics) {
    full.SetManifold(ext.data(), manifold.get());
    full.SetParameterBlockConstant(ext.data());
  }
  full.SetParameterBlockConstant(poses[0].data());
  ceres::Solver::Options options = test::TightSolverOptions();
  options.linear_solver_type = ceres::DENSE_SCHUR;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &full, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable());
  const auto optimum = poses;

  Marginalizer marginalizer;
  for (auto& pose : poses) marginalizer.SetManifold(pose.data(), manifold.get());
  for (auto& ext : extrinsics) {
    marginalizer.SetManifold(ext.data(), manifold.get());
    marginalizer.SetConstant(ext.data());
  }
  marginalizer.SetConstant(poses[0].data());
  for (auto& b : blocks) marginalizer.AddResidualBlock(b.cost.get(), &loss, b.blocks);
  std::vector<double*> drop;
  for (double& d : inverse_depths) drop.push_back(&d);
  const std::unique_ptr<MarginalizationPrior> prior = marginalizer.Marginalize(drop);
  ASSERT_NE(prior, nullptr);
  EXPECT_EQ(prior->kept_blocks(), (std::vector<double*>{poses[1].data(), poses[2].data()}));
  EXPECT_EQ(prior->num_residuals(), 12);

  for (size_t f = 1; f < 3; ++f) {
    std::array<double, 6> delta = {0.05, -0.03, 0.02, 0.01, -0.02, 0.015};
    std::array<double, kPoseParamSize> moved;
    manifold->Plus(poses[f].data(), delta.data(), moved.data());
    poses[f] = moved;
  }
  ceres::Problem reduced(NonOwning());
  reduced.AddResidualBlock(prior.get(), nullptr, prior->kept_blocks());
  for (size_t f = 1; f < 3; ++f) reduced.SetManifold(poses[f].data(), manifold.get());
  ceres::Solve(test::TightSolverOptions(), &reduced, &summary);
  double worst = 0.0;
  for (size_t f = 1; f < 3; ++f) worst = std::max(worst, PoseDistance(poses[f], optimum[f]));
  std::printf("window landmarks (%zu residual blocks) into a pose prior: max pose difference %.3g\n",
              blocks.size(), worst);
  EXPECT_LT(worst, 1e-8);
}

// ---------------------------------------------------------------- robust losses

TEST(Marginalization, RobustLossMatchesCeresCorrectedJacobian) {
  // Nothing dropped: J*^T J* and J*^T r0 must equal those of Ceres' own
  // robustified Jacobian (its Corrector), for losses with rho'' < 0 (Huber,
  // Cauchy: first-order branch) and rho'' > 0 (Tolerant: Triggs branch).
  std::mt19937 rng(8);
  std::vector<double> x0(2), x1(3);
  for (double& v : x0) v = 2.0;
  for (double& v : x1) v = -1.0;
  std::vector<LinearBlock> residuals;
  for (int k = 0; k < 6; ++k) residuals.push_back(MakeLinear({x0.data(), x1.data()}, {2, 3}, 2, &rng));
  const ceres::HuberLoss huber(1.0);
  const ceres::CauchyLoss cauchy(1.0);
  const ceres::TolerantLoss tolerant(4.0, 2.0);
  for (const ceres::LossFunction* loss :
       std::vector<const ceres::LossFunction*>{&huber, &cauchy, &tolerant}) {
    Marginalizer marginalizer;
    ceres::Problem problem(NonOwning());
    for (auto& r : residuals) {
      marginalizer.AddResidualBlock(r.cost.get(), loss, r.blocks);
      problem.AddResidualBlock(r.cost.get(), const_cast<ceres::LossFunction*>(loss), r.blocks);
    }
    const std::unique_ptr<MarginalizationPrior> prior = marginalizer.Marginalize({});
    ASSERT_NE(prior, nullptr);
    Eigen::VectorXd r;
    const Eigen::MatrixXd j = test::DenseJacobian(&problem, {x0.data(), x1.data()}, &r);
    const Eigen::MatrixXd& js = prior->jacobian();
    const double h_error = (js.transpose() * js - j.transpose() * j).norm() / (j.transpose() * j).norm();
    const double g_error =
        (js.transpose() * prior->residual0() - j.transpose() * r).norm() / (j.transpose() * r).norm();
    std::printf("robust: relative errors H %.3g, g %.3g\n", h_error, g_error);
    EXPECT_LT(h_error, 1e-10);
    EXPECT_LT(g_error, 1e-10);
  }
}

// r = (x - value) / sigma on one block, or (b - a - value) / sigma on two.
struct Unary {
  double value, sigma;
  template <typename T>
  bool operator()(const T* x, T* r) const {
    r[0] = (x[0] - T(value)) / T(sigma);
    return true;
  }
};
struct Binary {
  double value, sigma;
  template <typename T>
  bool operator()(const T* a, const T* b, T* r) const {
    r[0] = (b[0] - a[0] - T(value)) / T(sigma);
    return true;
  }
};

TEST(Marginalization, RobustOptimumIsKeptAndOutlierIsDownWeighted) {
  // 1D blocks: x0 (dropped) and x1 (kept), with an outlier on x0. Cauchy
  // loss. Marginalising at the robust optimum keeps it; the outlier adds
  // little information, unlike without the loss.
  std::mt19937 rng(9);
  std::vector<double> x0(1, 0.0), x1(1, 0.0);
  struct Obs {
    std::unique_ptr<ceres::CostFunction> cost;
    std::vector<double*> blocks;
  };
  std::vector<Obs> obs;
  for (double v : {1.0, 1.1, 0.9, 1.05, 25.0 /* outlier */}) {
    obs.push_back({std::unique_ptr<ceres::CostFunction>(
                       new ceres::AutoDiffCostFunction<Unary, 1, 1>(new Unary{v, 0.1})),
                   {x0.data()}});
  }
  obs.push_back({std::unique_ptr<ceres::CostFunction>(
                     new ceres::AutoDiffCostFunction<Binary, 1, 1, 1>(new Binary{2.0, 0.1})),
                 {x0.data(), x1.data()}});
  Obs kept_obs{
      std::unique_ptr<ceres::CostFunction>(new ceres::AutoDiffCostFunction<Unary, 1, 1>(new Unary{3.1, 0.2})),
      {x1.data()}};
  const ceres::CauchyLoss loss(1.0);
  ceres::Problem full(NonOwning());
  for (auto& o : obs) full.AddResidualBlock(o.cost.get(), const_cast<ceres::CauchyLoss*>(&loss), o.blocks);
  full.AddResidualBlock(kept_obs.cost.get(), const_cast<ceres::CauchyLoss*>(&loss), kept_obs.blocks);
  x0[0] = 1.0;
  x1[0] = 3.0;
  ceres::Solver::Summary summary;
  ceres::Solve(test::TightSolverOptions(), &full, &summary);
  const double x1_full = x1[0];
  EXPECT_LT(std::abs(x0[0] - 1.0), 0.1);  // the outlier did not pull x0

  auto information = [&](const ceres::LossFunction* l, bool with_outlier) {
    Marginalizer marginalizer;
    for (size_t k = 0; k < obs.size(); ++k) {
      if (!with_outlier && k == 4) continue;
      marginalizer.AddResidualBlock(obs[k].cost.get(), l, obs[k].blocks);
    }
    auto prior = marginalizer.Marginalize({x0.data()});
    EXPECT_NE(prior, nullptr);
    return prior;
  };
  const auto prior = information(&loss, true);
  // Reduced problem from a perturbed start.
  ceres::Problem reduced(NonOwning());
  reduced.AddResidualBlock(prior.get(), nullptr, prior->kept_blocks());
  reduced.AddResidualBlock(kept_obs.cost.get(), const_cast<ceres::CauchyLoss*>(&loss), kept_obs.blocks);
  x1[0] += 0.3;
  ceres::Solve(test::TightSolverOptions(), &reduced, &summary);
  std::printf("robust: x1 full %.12f, reduced %.12f\n", x1_full, x1[0]);
  EXPECT_NEAR(x1[0], x1_full, 1e-8);

  x1[0] = x1_full;
  const double info_with = prior->jacobian().squaredNorm();
  const double info_without = information(&loss, false)->jacobian().squaredNorm();
  const double info_plain = information(nullptr, true)->jacobian().squaredNorm();
  std::printf("robust: prior information with outlier %.4g, without %.4g, no loss %.4g\n", info_with,
              info_without, info_plain);
  EXPECT_NEAR(info_with, info_without, 0.01 * info_without);
  EXPECT_TRUE(std::isfinite(prior->residual0().norm()));
}

}  // namespace
}  // namespace mcvo
