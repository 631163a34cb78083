// Ceres factors of the sliding-window bundle adjustment.
//
// Parameter blocks:
//  * pose: world_from_rig as double[7] = {tx, ty, tz, qx, qy, qz, qw}
//    (Eigen's quaternion coefficient order), manifold NewPoseManifold();
//  * extrinsic: rig_from_cam in the same layout and manifold (constant unless
//    extrinsics are refined);
//  * inverse depth: double[1], the inverse of the distance along the anchor
//    bearing (not a z depth: fisheye bearings go beyond 90 deg), so the point
//    in the anchor camera is anchor_bearing / inverse_depth.
//
// Residual: the predicted bearing p/|p| of the landmark in the observing
// camera, minus the observed unit bearing b, projected on the tangent plane
// of the unit sphere at b (two orthonormal vectors orthogonal to b, chosen
// deterministically from b), times sqrt_information = focal / sigma (the
// release: 460 / 1.5). Fisheye-safe (no pinhole projection) and the same for
// every camera model, since the camera model only enters through the
// observed bearings (Camera::Unproject). Derivation: every transform from the
// anchor camera to the observing camera is affine, so with rho the inverse
// depth and a the anchor bearing,
//   rho p_obs = R a + rho t,   R, t: rotation and translation of
//   cam_from_rig_obs * rig_from_world_obs * world_from_rig_anchor *
//   rig_from_cam_anchor,
// which has the direction of p_obs for rho > 0 and is finite at rho = 0 (a
// point at infinity); the residual is computed on it:
//   r = sqrt_information * B(b) (u - b),  u = (R a + rho t) / |R a + rho t|,
// B(b) = TangentBasis(b), so |r| = sqrt_information * sin(angle(u, b)).
// Inverse depths must stay positive (for rho < 0 the direction is not that
// of the point a / rho). The three factor kinds below differ only in which
// quantities are parameter blocks (Ceres forbids one block twice in a
// residual block), and each exists with the extrinsics as parameter blocks
// (refined) or as constants.
#pragma once

#include <memory>

#include <ceres/ceres.h>
#include <Eigen/Core>

#include "mcvo/backend/backend_options.h"
#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

inline constexpr int kPoseParamSize = 7;

// EuclideanManifold<3> x EigenQuaternionManifold. Caller owns it (Ceres
// problems take ownership unless Problem::Options says otherwise).
ceres::Manifold* NewPoseManifold();
void PoseToParams(const Rigid3d& pose, double* params);
Rigid3d PoseFromParams(const double* params);

// Orthonormal basis (rows) of the tangent plane of the unit sphere at
// `bearing`: deterministic, right-handed (row0 x row1 = bearing), the image
// axes x, y at +z, smooth within 120 deg of +z (one switch beyond, where the
// construction turns about -z); valid for any unit (or non-zero) bearing.
Eigen::Matrix<double, 2, 3> TangentBasis(const Eigen::Vector3d& bearing);

// The tangent-plane residual above for a point p in the observing camera:
// r = sqrt_information * basis (p / |p| - b), basis = TangentBasis(b);
// false at p = 0. Shared by every bearing factor (automatic differentiation
// included: T may be a Jet).
template <typename T>
bool TangentResidual(const Eigen::Matrix<T, 3, 1>& p, const Eigen::Vector3d& bearing,
                     const Eigen::Matrix<double, 2, 3>& basis, double sqrt_information, T* residual) {
  const T norm = p.norm();
  if (!(norm > T(0))) return false;
  const Eigen::Matrix<T, 2, 1> r = basis.cast<T>() * (p / norm - bearing.cast<T>());
  residual[0] = T(sqrt_information) * r[0];
  residual[1] = T(sqrt_information) * r[1];
  return true;
}

// The factories below return cost functions with analytic Jacobians
// (ceres::SizedCostFunction): Jacobians are with respect to the ambient
// parameters, as Ceres expects ({tx, ty, tz, qx, qy, qz, qw} for pose and
// extrinsic blocks, the exact derivative of Eigen's quaternion rotation
// q * v = v + 2 w (q_v x v) + 2 q_v x (q_v x v) in q; Ceres maps them to the
// tangent space with the manifold's PlusJacobian). They match the
// ...AutoDiff versions (the same templated residual differentiated by Ceres'
// Jets) to floating-point rounding, at several times the speed. Caller owns
// the returned cost function. Bearings need not be unit (they are
// normalised); sqrt_information must be > 0.

// Landmark anchored in (pose_anchor, extrinsic_anchor), observed in another
// frame (pose_obs) by camera extrinsic_obs, which may be the anchor camera or
// another one. Parameter blocks: pose_anchor[7], pose_obs[7],
// rig_from_cam_anchor[7], rig_from_cam_obs[7], inverse_depth[1]. For the
// anchor camera itself use NewReprojectionFactorSameCamera.
ceres::CostFunction* NewReprojectionFactorOtherCamera(const Eigen::Vector3d& anchor_bearing,
                                                      const Eigen::Vector3d& observed_bearing,
                                                      double sqrt_information);
// Observed in another frame by the anchor camera itself. Parameter blocks:
// pose_anchor[7], pose_obs[7], rig_from_cam[7], inverse_depth[1].
ceres::CostFunction* NewReprojectionFactorSameCamera(const Eigen::Vector3d& anchor_bearing,
                                                     const Eigen::Vector3d& observed_bearing,
                                                     double sqrt_information);
// Observed in the anchor frame by another camera (overlapping views): the rig
// pose cancels, only the baseline and the depth remain. Parameter blocks:
// rig_from_cam_anchor[7], rig_from_cam_obs[7], inverse_depth[1].
ceres::CostFunction* NewReprojectionFactorSameFrame(const Eigen::Vector3d& anchor_bearing,
                                                    const Eigen::Vector3d& observed_bearing,
                                                    double sqrt_information);

// Constant extrinsics (the usual case, extrinsics not refined): the same
// three residuals with rig_from_cam passed by value and stored in the cost
// function instead of being parameter blocks, so the residual blocks are
// smaller and the extrinsics are converted to rotation matrices once.
// Numerically the same residual and Jacobians as the variants above
// evaluated at PoseToParams(rig_from_cam) (rounding aside).
//
// Other camera. Parameter blocks: pose_anchor[7], pose_obs[7],
// inverse_depth[1].
ceres::CostFunction* NewReprojectionFactorOtherCameraConstExtrinsics(const Eigen::Vector3d& anchor_bearing,
                                                                     const Eigen::Vector3d& observed_bearing,
                                                                     const Rigid3d& rig_from_cam_anchor,
                                                                     const Rigid3d& rig_from_cam_obs,
                                                                     double sqrt_information);
// Same camera (rig_from_cam of the anchor and observing camera). Parameter
// blocks: pose_anchor[7], pose_obs[7], inverse_depth[1].
ceres::CostFunction* NewReprojectionFactorSameCameraConstExtrinsics(const Eigen::Vector3d& anchor_bearing,
                                                                    const Eigen::Vector3d& observed_bearing,
                                                                    const Rigid3d& rig_from_cam,
                                                                    double sqrt_information);
// Same frame, another camera. Parameter block: inverse_depth[1].
ceres::CostFunction* NewReprojectionFactorSameFrameConstExtrinsics(const Eigen::Vector3d& anchor_bearing,
                                                                   const Eigen::Vector3d& observed_bearing,
                                                                   const Rigid3d& rig_from_cam_anchor,
                                                                   const Rigid3d& rig_from_cam_obs,
                                                                   double sqrt_information);

// Reference versions with automatic differentiation (ceres::AutoDiffCostFunction
// of the same residual), same parameter blocks as the analytic factories of
// the same name; for tests.
ceres::CostFunction* NewReprojectionFactorOtherCameraAutoDiff(const Eigen::Vector3d& anchor_bearing,
                                                              const Eigen::Vector3d& observed_bearing,
                                                              double sqrt_information);
ceres::CostFunction* NewReprojectionFactorSameCameraAutoDiff(const Eigen::Vector3d& anchor_bearing,
                                                             const Eigen::Vector3d& observed_bearing,
                                                             double sqrt_information);
ceres::CostFunction* NewReprojectionFactorSameFrameAutoDiff(const Eigen::Vector3d& anchor_bearing,
                                                            const Eigen::Vector3d& observed_bearing,
                                                            double sqrt_information);

// A world point (the global bundle adjustment, refine/global_ba.h): the
// same tangent-plane residual of the point's direction in camera c of a rig
// pose, r = s B(b) (p/|p| - b), p = cam_from_rig * world_from_rig^-1 * X,
// the extrinsic fixed. Parameter blocks: world_from_rig[7], point[3] (world
// coordinates). Analytic Jacobians; the AutoDiff version for tests.
ceres::CostFunction* NewWorldPointFactor(const Eigen::Vector3d& observed_bearing, const Rigid3d& cam_from_rig,
                                         double sqrt_information);
ceres::CostFunction* NewWorldPointFactorAutoDiff(const Eigen::Vector3d& observed_bearing,
                                                 const Rigid3d& cam_from_rig, double sqrt_information);
// The same residual with the extrinsic refined: parameter blocks
// world_from_rig[7], cam_from_rig[7] (the same layout and manifold as a
// pose), point[3]. Automatic differentiation (an optional path).
ceres::CostFunction* NewWorldPointExtrinsicFactor(const Eigen::Vector3d& observed_bearing, double sqrt_information);

// The robust loss of a bearing residual in units of its sigma: Huber or
// Cauchy at `scale`, or none (nullptr) for kTrivial. The window BA and the
// global BA (refine/global_ba.h) both use it.
std::unique_ptr<ceres::LossFunction> NewRobustLoss(LossType type, double scale);

// Monocular scale gauge (estimator.h "Monocular"): one residual on a pose
// block, (|t - origin| - distance) / sigma, where t is the block's
// translation; origin is a fixed point (the oldest keyframe's position).
// sigma > 0, distance > 0. Analytic Jacobian (zero in the rotation).
ceres::CostFunction* NewDistanceAnchorCost(const Eigen::Vector3d& origin, double distance, double sigma);

// The residual without Ceres, for tests and for reporting errors (pixels at
// the focal of sqrt_information when sqrt_information = focal / 1).
Eigen::Vector2d ReprojectionResidual(const Rigid3d& world_from_rig_anchor, const Rigid3d& world_from_rig_obs,
                                     const Rigid3d& rig_from_cam_anchor, const Rigid3d& rig_from_cam_obs,
                                     const Eigen::Vector3d& anchor_bearing, double inverse_depth,
                                     const Eigen::Vector3d& observed_bearing, double sqrt_information);

}  // namespace mcvo
