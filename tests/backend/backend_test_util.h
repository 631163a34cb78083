// Shared helpers of the back-end tests: seeded random rotations, bearing
// noise, tangent-space finite differences and dense evaluation of a Ceres
// problem.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo::test {

constexpr double kDeg = M_PI / 180.0;

inline Eigen::Vector3d RandomUnit(std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector3d v;
  do {
    v = Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng));
  } while (v.norm() < 1e-3);
  return v.normalized();
}

inline Eigen::Quaterniond RandomRotation(std::mt19937* rng, double max_angle_rad) {
  std::uniform_real_distribution<double> uniform(0.0, max_angle_rad);
  return Eigen::Quaterniond(Eigen::AngleAxisd(uniform(*rng), RandomUnit(rng)));
}

inline double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

// Unit bearing `b` rotated by an angle drawn from a 2D isotropic Gaussian of
// standard deviation sigma_rad per axis, in a random tangent direction.
inline Eigen::Vector3d NoisyBearing(const Eigen::Vector3d& b, double sigma_rad, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, sigma_rad);
  Eigen::Vector3d e1 = b.unitOrthogonal();
  Eigen::Vector3d e2 = b.cross(e1);
  const Eigen::Vector3d axis_angle = normal(*rng) * e1 + normal(*rng) * e2;
  const double angle = axis_angle.norm();
  if (angle == 0.0) return b;
  return (Eigen::AngleAxisd(angle, axis_angle / angle) * b).normalized();
}

// Tangent Jacobian of a cost function block by central differences through
// the manifold: d r(x_i [+] d) / d d. `manifold` null: Euclidean.
inline Eigen::MatrixXd NumericTangentJacobian(const ceres::CostFunction& cost, std::vector<double*> params,
                                              int block, const ceres::Manifold* manifold, double step) {
  const int ambient = cost.parameter_block_sizes()[static_cast<size_t>(block)];
  const int tangent = manifold == nullptr ? ambient : manifold->TangentSize();
  const int rows = cost.num_residuals();
  const std::vector<double> x(params[static_cast<size_t>(block)],
                              params[static_cast<size_t>(block)] + ambient);
  std::vector<double> moved(static_cast<size_t>(ambient)), delta(static_cast<size_t>(tangent), 0.0);
  Eigen::VectorXd plus(rows), minus(rows);
  Eigen::MatrixXd jacobian(rows, tangent);
  params[static_cast<size_t>(block)] = moved.data();
  for (int k = 0; k < tangent; ++k) {
    for (int sign : {1, -1}) {
      delta[static_cast<size_t>(k)] = sign * step;
      if (manifold == nullptr) {
        for (int a = 0; a < ambient; ++a) moved[a] = x[a] + delta[a];
      } else {
        manifold->Plus(x.data(), delta.data(), moved.data());
      }
      cost.Evaluate(params.data(), sign > 0 ? plus.data() : minus.data(), nullptr);
    }
    delta[static_cast<size_t>(k)] = 0.0;
    jacobian.col(k) = (plus - minus) / (2.0 * step);
  }
  return jacobian;
}

// Analytic (Ceres) tangent Jacobian of a block: ambient Jacobian times the
// manifold's PlusJacobian.
inline Eigen::MatrixXd AnalyticTangentJacobian(const ceres::CostFunction& cost,
                                               const std::vector<double*>& params, int block,
                                               const ceres::Manifold* manifold) {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const size_t n = params.size();
  std::vector<RowMajor> ambient(n);
  std::vector<double*> ptrs(n);
  for (size_t i = 0; i < n; ++i) {
    ambient[i].resize(cost.num_residuals(), cost.parameter_block_sizes()[i]);
    ptrs[i] = ambient[i].data();
  }
  Eigen::VectorXd r(cost.num_residuals());
  cost.Evaluate(params.data(), r.data(), ptrs.data());
  const RowMajor& j = ambient[static_cast<size_t>(block)];
  if (manifold == nullptr) return j;
  RowMajor plus(manifold->AmbientSize(), manifold->TangentSize());
  manifold->PlusJacobian(params[static_cast<size_t>(block)], plus.data());
  return j * plus;
}

// Dense tangent Jacobian and residuals of a problem (robust loss applied, as
// the solver sees them), columns in the order of `blocks`.
inline Eigen::MatrixXd DenseJacobian(ceres::Problem* problem, const std::vector<double*>& blocks,
                                     Eigen::VectorXd* residuals) {
  ceres::Problem::EvaluateOptions options;
  options.parameter_blocks = blocks;
  std::vector<double> r;
  ceres::CRSMatrix crs;
  problem->Evaluate(options, nullptr, &r, nullptr, &crs);
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int row = 0; row < crs.num_rows; ++row) {
    for (int k = crs.rows[row]; k < crs.rows[row + 1]; ++k) j(row, crs.cols[k]) = crs.values[k];
  }
  *residuals = Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
  return j;
}

inline ceres::Solver::Options TightSolverOptions() {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.num_threads = 1;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-16;
  options.gradient_tolerance = 1e-16;
  options.parameter_tolerance = 1e-16;
  options.logging_type = ceres::SILENT;
  return options;
}

}  // namespace mcvo::test
