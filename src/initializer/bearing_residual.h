// Geometry on unit bearings shared by the window SfM (camera_sfm.cc) and the
// rig window bundle adjustment (rig_window_ba.cc). Internal to the module.
#pragma once

#include <cmath>
#include <limits>
#include <optional>

#include <ceres/ceres.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mcvo/geometry/rigid3d.h"
#include "mcvo/geometry/so3.h"

namespace mcvo::initializer_internal {

// Angle between two directions (any lengths), radians, accurate for small angles.
inline double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Orthonormal basis of the plane orthogonal to the unit vector f.
inline Eigen::Matrix<double, 3, 2> TangentBasis(const Eigen::Vector3d& f) {
  const Eigen::Vector3d helper = std::abs(f.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  Eigen::Matrix<double, 3, 2> basis;
  basis.col(0) = f.cross(helper).normalized();
  basis.col(1) = f.cross(basis.col(0));
  return basis;
}

// Angular error, in pixels at `focal`, of observing `point_in_world` at
// `bearing` from the camera world_from_cam. Infinity at the camera centre.
inline double ReprojectionPx(const Rigid3d& world_from_cam, const Eigen::Vector3d& point_in_world,
                             const Eigen::Vector3d& bearing, double focal) {
  const Eigen::Vector3d d =
      world_from_cam.rotation.conjugate() * (point_in_world - world_from_cam.translation);
  if (!(d.norm() > 0.0)) return std::numeric_limits<double>::infinity();
  return AngleBetween(d, bearing) * focal;
}

// Midpoint triangulation of the rays centre_i + lambda_i dir_i (unit
// directions, one frame). std::nullopt when the rays are parallel or the point
// is not in front of both (lambda_i <= 0).
inline std::optional<Eigen::Vector3d> TriangulateMidpoint(const Eigen::Vector3d& centre1,
                                                          const Eigen::Vector3d& dir1,
                                                          const Eigen::Vector3d& centre2,
                                                          const Eigen::Vector3d& dir2) {
  const double b = dir1.dot(dir2);
  const double denom = 1.0 - b * b;
  if (!(denom > 1e-12)) return std::nullopt;
  const Eigen::Vector3d w = centre1 - centre2;
  const double d = dir1.dot(w);
  const double e = dir2.dot(w);
  const double lambda1 = (b * e - d) / denom;
  const double lambda2 = (e - b * d) / denom;
  if (!(lambda1 > 0.0) || !(lambda2 > 0.0)) return std::nullopt;
  return 0.5 * (centre1 + lambda1 * dir1 + centre2 + lambda2 * dir2);
}

// A pose world_from_body as one Ceres parameter block: the rotation as an
// Eigen quaternion (x, y, z, w), then the position (x, y, z). One block per
// pose (rather than two) halves the cells of the reduced camera system and
// lets the Schur eliminator use its fixed-size (2, 3, 6) kernels.
using PoseBlock = Eigen::Matrix<double, 7, 1>;

inline PoseBlock ToPoseBlock(const Rigid3d& world_from_body) {
  PoseBlock block;
  block.head<4>() = world_from_body.rotation.coeffs();
  block.tail<3>() = world_from_body.translation;
  return block;
}

inline Rigid3d FromPoseBlock(const PoseBlock& block) {
  return Rigid3d(Eigen::Quaterniond(block(3), block(0), block(1), block(2)),
                 Eigen::Vector3d(block.tail<3>()));
}

// Tangent-plane bearing residual of a body (rig, or the camera itself) with
// pose world_from_body = (q, p) carrying a camera at cam_from_body:
//   d = cam_from_body * (q^-1 (X - p)),   e = focal * B_f^T d / |d|.
// Parameters: the pose block (q, p) and X. For small errors e is the angle
// between d and f in pixels at `focal`, for any direction of f. The
// template is the reference (AutoDiff); the solvers use TangentBearingCost.
struct TangentBearingResidual {
  TangentBearingResidual(const Eigen::Vector3d& bearing, double focal_px,
                         const Rigid3d& cam_from_body = Rigid3d())
      : basis(TangentBasis(bearing)),
        focal(focal_px),
        cam_rotation(cam_from_body.RotationMatrix()),
        cam_translation(cam_from_body.translation) {}

  template <typename T>
  bool operator()(const T* const world_from_body, const T* const point, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(world_from_body);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p(world_from_body + 4);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> x(point);
    const Eigen::Matrix<T, 3, 1> d_body = q.conjugate() * (x - p);
    const Eigen::Matrix<T, 3, 1> d = cam_rotation.cast<T>() * d_body + cam_translation.cast<T>();
    const T norm = d.norm();
    if (!(norm > T(0))) return false;
    residual[0] = T(focal) * basis.col(0).cast<T>().dot(d) / norm;
    residual[1] = T(focal) * basis.col(1).cast<T>().dot(d) / norm;
    return true;
  }

  Eigen::Matrix<double, 3, 2> basis;
  double focal;
  Eigen::Matrix3d cam_rotation;
  Eigen::Vector3d cam_translation;
};

// TangentBearingResidual with analytic Jacobians (the same ambient
// Jacobians as AutoDiff's, to rounding; bearing_residual_test). With
// w = X - p, u = d / |d| and J = focal B^T (I - u u^T) / |d|:
//   d e / d X = J R_c R_q^T,  d e / d p = -d e / d X,
//   d e / d q = J R_c QuaternionInverseRotateJacobian(q, w).
// Jets cost several times this in the initializer's many small solves.
class TangentBearingCost final : public ceres::SizedCostFunction<2, 7, 3> {
 public:
  TangentBearingCost(const Eigen::Vector3d& bearing, double focal_px, const Rigid3d& cam_from_body = Rigid3d())
      : basis_t_(TangentBasis(bearing).transpose()),
        focal_(focal_px),
        cam_rotation_(cam_from_body.RotationMatrix()),
        cam_translation_(cam_from_body.translation) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Eigen::Quaterniond> q(parameters[0]);
    const Eigen::Map<const Eigen::Vector3d> p(parameters[0] + 4);
    const Eigen::Map<const Eigen::Vector3d> x(parameters[1]);
    const Eigen::Vector3d w = x - p;
    const Eigen::Vector3d d = cam_rotation_ * (q.conjugate() * w) + cam_translation_;
    const double norm = d.norm();
    if (!(norm > 0.0)) return false;
    const Eigen::Vector3d u = d / norm;
    const Eigen::Vector2d e = (focal_ / norm) * (basis_t_ * d);
    residuals[0] = e[0];
    residuals[1] = e[1];
    if (jacobians == nullptr || (jacobians[0] == nullptr && jacobians[1] == nullptr)) return true;
    const Eigen::Matrix<double, 2, 3> j_d = (focal_ / norm) * (basis_t_ - (basis_t_ * u) * u.transpose());
    const Eigen::Matrix<double, 2, 3> j_body = j_d * cam_rotation_;
    const Eigen::Matrix<double, 2, 3> j_x = j_body * q.conjugate().toRotationMatrix();
    if (jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> j(jacobians[0]);
      j.leftCols<4>() = j_body * QuaternionInverseRotateJacobian(Eigen::Quaterniond(q), w);
      j.rightCols<3>() = -j_x;
    }
    if (jacobians[1] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[1]);
      j = j_x;
    }
    return true;
  }

 private:
  Eigen::Matrix<double, 2, 3> basis_t_;
  double focal_;
  Eigen::Matrix3d cam_rotation_;
  Eigen::Vector3d cam_translation_;
};

// Solver options of the initializer's small bundle adjustments: Levenberg-
// Marquardt on a dense Schur complement, single-threaded, stopped by the
// iteration count only (no clock), so results are the same on any machine.
inline ceres::Solver::Options DeterministicBaOptions(int max_iterations) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  // Some damping always: weakly triangulated points (angles near the minimum)
  // make the undamped reduced system lose positive definiteness numerically.
  options.max_trust_region_radius = 1e6;
  options.max_num_iterations = max_iterations;
  options.max_solver_time_in_seconds = 1e9;  // iteration count only: determinism
  options.num_threads = 1;
  options.function_tolerance = 1e-10;
  options.gradient_tolerance = 1e-14;
  options.parameter_tolerance = 1e-10;
  options.logging_type = ceres::SILENT;
  return options;
}

}  // namespace mcvo::initializer_internal
