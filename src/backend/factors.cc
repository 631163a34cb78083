#include "mcvo/backend/factors.h"

#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "mcvo/geometry/so3.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

// p_in_target = q * p + t * s for a pose block {t, q} (Eigen order) and a
// scale s on the translation (the inverse depth, see BearingResidualCore).
// Eigen's quaternion-vector product assumes a unit quaternion; off the unit
// sphere its derivative is irrelevant, since Ceres projects the Jacobian with
// the manifold's PlusJacobian.
template <typename T>
Eigen::Matrix<T, 3, 1> Apply(const T* pose, const Eigen::Matrix<T, 3, 1>& p, const T& s) {
  const Eigen::Map<const Eigen::Quaternion<T>> q(pose + 3);
  const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(pose);
  return q * p + t * s;
}

// The inverse of Apply: q^-1 (p - t * s).
template <typename T>
Eigen::Matrix<T, 3, 1> ApplyInverse(const T* pose, const Eigen::Matrix<T, 3, 1>& p, const T& s) {
  const Eigen::Map<const Eigen::Quaternion<T>> q(pose + 3);
  const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(pose);
  return q.conjugate() * (p - t * s);
}

// The one residual of the window BA (factors.h). With rho the inverse depth
// and a the anchor bearing, the landmark in the anchor camera is a / rho.
// Every transform on the way to the observing camera is affine, so
//
//   rho * p_obs = cam_from_rig_obs * rig_from_world_obs * world_from_rig_anchor
//                 * rig_from_cam_anchor (a), with every translation times rho,
//
// which has the direction of p_obs for rho > 0 and stays finite at rho = 0
// (a point at infinity: only the rotations act on a). The residual is
//
//   r = sqrt_information * B(b) (u - b),  u = (rho p_obs) / |rho p_obs|,
//
// where B(b) = TangentBasis(b); B(b) b = 0, so |r| = sqrt_information *
// sin(angle(u, b)). Null pose pointers mean the anchor and observing frame
// coincide (the rig pose cancels exactly, it is not evaluated).
struct BearingResidualCore {
  Eigen::Vector3d anchor_bearing;
  Eigen::Vector3d observed_bearing;
  Eigen::Matrix<double, 2, 3> basis;
  double sqrt_information = 1.0;

  BearingResidualCore(const Eigen::Vector3d& anchor, const Eigen::Vector3d& observed, double sqrt_info)
      : anchor_bearing(anchor.normalized()),
        observed_bearing(observed.normalized()),
        basis(TangentBasis(observed_bearing)),
        sqrt_information(sqrt_info) {}

  template <typename T>
  bool operator()(const T* pose_anchor, const T* pose_obs, const T* rig_from_cam_anchor,
                  const T* rig_from_cam_obs, const T* inverse_depth, T* residuals) const {
    const T& rho = inverse_depth[0];
    Eigen::Matrix<T, 3, 1> p = Apply(rig_from_cam_anchor, anchor_bearing.cast<T>().eval(), rho);
    if (pose_anchor != nullptr) {
      p = ApplyInverse(pose_obs, Apply(pose_anchor, p, rho), rho);
    }
    p = ApplyInverse(rig_from_cam_obs, p, rho);
    return TangentResidual(p, observed_bearing, basis, sqrt_information, residuals);
  }
};

// The three factor kinds: which of the core's quantities are parameter blocks.
struct OtherCameraFunctor {
  BearingResidualCore core;
  template <typename T>
  bool operator()(const T* pose_anchor, const T* pose_obs, const T* ext_anchor, const T* ext_obs,
                  const T* inverse_depth, T* residuals) const {
    return core(pose_anchor, pose_obs, ext_anchor, ext_obs, inverse_depth, residuals);
  }
};

struct SameCameraFunctor {
  BearingResidualCore core;
  template <typename T>
  bool operator()(const T* pose_anchor, const T* pose_obs, const T* ext, const T* inverse_depth,
                  T* residuals) const {
    return core(pose_anchor, pose_obs, ext, ext, inverse_depth, residuals);
  }
};

struct SameFrameFunctor {
  BearingResidualCore core;
  template <typename T>
  bool operator()(const T* ext_anchor, const T* ext_obs, const T* inverse_depth, T* residuals) const {
    return core(static_cast<const T*>(nullptr), static_cast<const T*>(nullptr), ext_anchor, ext_obs,
                inverse_depth, residuals);
  }
};

// ---------------------------------------------------------------- analytic

using Matrix23 = Eigen::Matrix<double, 2, 3>;
using PoseJacobian = Eigen::Matrix<double, 2, kPoseParamSize, Eigen::RowMajor>;

// A pose or extrinsic block {t, q} (Eigen order) with its rotation matrix.
// Eigen's toRotationMatrix is the matrix of the product q * v above, also
// for a quaternion that is unit only to rounding.
struct RigidParams {
  Eigen::Quaterniond q;
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;

  explicit RigidParams(const double* params)
      : q(Eigen::Map<const Eigen::Quaterniond>(params + 3)),
        rotation(q.toRotationMatrix()),
        translation(params[0], params[1], params[2]) {}
  explicit RigidParams(const Rigid3d& pose) : RigidParams(ToParams(pose).data()) {}

 private:
  static std::array<double, kPoseParamSize> ToParams(const Rigid3d& pose) {
    std::array<double, kPoseParamSize> params{};
    PoseToParams(pose, params.data());
    return params;
  }
};

// Ambient Jacobian outputs of the analytic residual, row-major 2 x 7 for
// pose and extrinsic blocks and 2 x 1 for the inverse depth; null: not
// wanted (a constant block, or not a parameter block).
struct JacobianOutputs {
  double* pose_anchor = nullptr;
  double* pose_obs = nullptr;
  double* ext_anchor = nullptr;
  double* ext_obs = nullptr;
  double* inverse_depth = nullptr;

  bool Any() const {
    return pose_anchor != nullptr || pose_obs != nullptr || ext_anchor != nullptr || ext_obs != nullptr ||
           inverse_depth != nullptr;
  }
};

// The residual of BearingResidualCore with analytic Jacobians. Forward:
//   p1 = R_ea a + rho t_ea                 (anchor rig)
//   p2 = R_a p1 + rho t_a                  (world)
//   p3 = R_o^T (p2 - rho t_o)              (observing rig)
//   p  = R_eo^T (p3 - rho t_eo)            (observing camera)
// (p3 = p1 without poses: same frame). With J = d r / d p = s B (I - u u^T)
// / |p| and J3 = J R_eo^T, J2 = J3 R_o^T, J1 = J2 R_a (J1 = J3 without
// poses), the translations enter with -rho J3 (t_eo), -rho J2 (t_o),
// rho J2 (t_a), rho J1 (t_ea); the quaternions through
// QuaternionRotateJacobian / QuaternionInverseRotateJacobian (geometry/so3.h)
// of the vector each rotation acts on; and
// d r / d rho = J1 t_ea + J2 (t_a - t_o) - J3 t_eo.
bool EvaluateAnalytic(const BearingResidualCore& core, const RigidParams* pose_anchor,
                      const RigidParams* pose_obs, const RigidParams& ext_anchor, const RigidParams& ext_obs,
                      double rho, double* residuals, const JacobianOutputs& out) {
  const Eigen::Vector3d p1 = ext_anchor.rotation * core.anchor_bearing + rho * ext_anchor.translation;
  Eigen::Vector3d p2 = Eigen::Vector3d::Zero(), w_obs = Eigen::Vector3d::Zero(), p3 = p1;
  if (pose_anchor != nullptr) {
    p2 = pose_anchor->rotation * p1 + rho * pose_anchor->translation;
    w_obs = p2 - rho * pose_obs->translation;
    p3 = pose_obs->rotation.transpose() * w_obs;
  }
  const Eigen::Vector3d w_ext = p3 - rho * ext_obs.translation;
  const Eigen::Vector3d p = ext_obs.rotation.transpose() * w_ext;
  const double norm = p.norm();
  if (!(norm > 0.0)) return false;
  const Eigen::Vector3d u = p / norm;
  const Eigen::Vector2d r = core.basis * (u - core.observed_bearing);
  residuals[0] = core.sqrt_information * r[0];
  residuals[1] = core.sqrt_information * r[1];
  if (!out.Any()) return true;

  const Matrix23 j_p = (core.sqrt_information / norm) * (core.basis - (core.basis * u) * u.transpose());
  const Matrix23 j_p3 = j_p * ext_obs.rotation.transpose();
  Matrix23 j_p2 = Matrix23::Zero(), j_p1 = j_p3;
  if (pose_anchor != nullptr) {
    j_p2 = j_p3 * pose_obs->rotation.transpose();
    j_p1 = j_p2 * pose_anchor->rotation;
  }
  if (out.ext_obs != nullptr) {
    Eigen::Map<PoseJacobian> j(out.ext_obs);
    j.leftCols<3>() = -rho * j_p3;
    j.rightCols<4>() = j_p * QuaternionInverseRotateJacobian(ext_obs.q, w_ext);
  }
  if (pose_anchor != nullptr && out.pose_obs != nullptr) {
    Eigen::Map<PoseJacobian> j(out.pose_obs);
    j.leftCols<3>() = -rho * j_p2;
    j.rightCols<4>() = j_p3 * QuaternionInverseRotateJacobian(pose_obs->q, w_obs);
  }
  if (pose_anchor != nullptr && out.pose_anchor != nullptr) {
    Eigen::Map<PoseJacobian> j(out.pose_anchor);
    j.leftCols<3>() = rho * j_p2;
    j.rightCols<4>() = j_p2 * QuaternionRotateJacobian(pose_anchor->q, p1);
  }
  if (out.ext_anchor != nullptr) {
    Eigen::Map<PoseJacobian> j(out.ext_anchor);
    j.leftCols<3>() = rho * j_p1;
    j.rightCols<4>() = j_p1 * QuaternionRotateJacobian(ext_anchor.q, core.anchor_bearing);
  }
  if (out.inverse_depth != nullptr) {
    Eigen::Vector2d d = j_p1 * ext_anchor.translation - j_p3 * ext_obs.translation;
    if (pose_anchor != nullptr) d += j_p2 * (pose_anchor->translation - pose_obs->translation);
    out.inverse_depth[0] = d[0];
    out.inverse_depth[1] = d[1];
  }
  return true;
}

double* BlockJacobian(double** jacobians, int block) {
  return jacobians == nullptr ? nullptr : jacobians[block];
}

// Extrinsics as parameter blocks.

class OtherCameraFactor final
    : public ceres::SizedCostFunction<2, kPoseParamSize, kPoseParamSize, kPoseParamSize, kPoseParamSize, 1> {
 public:
  explicit OtherCameraFactor(const BearingResidualCore& core) : core_(core) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const RigidParams pose_anchor(parameters[0]), pose_obs(parameters[1]);
    const RigidParams ext_anchor(parameters[2]), ext_obs(parameters[3]);
    JacobianOutputs out;
    out.pose_anchor = BlockJacobian(jacobians, 0);
    out.pose_obs = BlockJacobian(jacobians, 1);
    out.ext_anchor = BlockJacobian(jacobians, 2);
    out.ext_obs = BlockJacobian(jacobians, 3);
    out.inverse_depth = BlockJacobian(jacobians, 4);
    return EvaluateAnalytic(core_, &pose_anchor, &pose_obs, ext_anchor, ext_obs, parameters[4][0], residuals,
                            out);
  }

 private:
  BearingResidualCore core_;
};

// The extrinsic block is both the anchor's and the observer's: its Jacobian
// is the sum of the two.
class SameCameraFactor final
    : public ceres::SizedCostFunction<2, kPoseParamSize, kPoseParamSize, kPoseParamSize, 1> {
 public:
  explicit SameCameraFactor(const BearingResidualCore& core) : core_(core) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const RigidParams pose_anchor(parameters[0]), pose_obs(parameters[1]), ext(parameters[2]);
    PoseJacobian ext_obs_jacobian;
    JacobianOutputs out;
    out.pose_anchor = BlockJacobian(jacobians, 0);
    out.pose_obs = BlockJacobian(jacobians, 1);
    out.ext_anchor = BlockJacobian(jacobians, 2);
    out.ext_obs = out.ext_anchor != nullptr ? ext_obs_jacobian.data() : nullptr;
    out.inverse_depth = BlockJacobian(jacobians, 3);
    if (!EvaluateAnalytic(core_, &pose_anchor, &pose_obs, ext, ext, parameters[3][0], residuals, out)) {
      return false;
    }
    if (out.ext_anchor != nullptr) Eigen::Map<PoseJacobian>(out.ext_anchor) += ext_obs_jacobian;
    return true;
  }

 private:
  BearingResidualCore core_;
};

class SameFrameFactor final : public ceres::SizedCostFunction<2, kPoseParamSize, kPoseParamSize, 1> {
 public:
  explicit SameFrameFactor(const BearingResidualCore& core) : core_(core) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const RigidParams ext_anchor(parameters[0]), ext_obs(parameters[1]);
    JacobianOutputs out;
    out.ext_anchor = BlockJacobian(jacobians, 0);
    out.ext_obs = BlockJacobian(jacobians, 1);
    out.inverse_depth = BlockJacobian(jacobians, 2);
    return EvaluateAnalytic(core_, nullptr, nullptr, ext_anchor, ext_obs, parameters[2][0], residuals, out);
  }

 private:
  BearingResidualCore core_;
};

// Constant extrinsics, converted once.

class OtherCameraConstExtrinsicsFactor final
    : public ceres::SizedCostFunction<2, kPoseParamSize, kPoseParamSize, 1> {
 public:
  OtherCameraConstExtrinsicsFactor(const BearingResidualCore& core, const Rigid3d& rig_from_cam_anchor,
                                   const Rigid3d& rig_from_cam_obs)
      : core_(core), ext_anchor_(rig_from_cam_anchor), ext_obs_(rig_from_cam_obs) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const RigidParams pose_anchor(parameters[0]), pose_obs(parameters[1]);
    JacobianOutputs out;
    out.pose_anchor = BlockJacobian(jacobians, 0);
    out.pose_obs = BlockJacobian(jacobians, 1);
    out.inverse_depth = BlockJacobian(jacobians, 2);
    return EvaluateAnalytic(core_, &pose_anchor, &pose_obs, ext_anchor_, ext_obs_, parameters[2][0],
                            residuals, out);
  }

 private:
  BearingResidualCore core_;
  RigidParams ext_anchor_, ext_obs_;
};

class SameFrameConstExtrinsicsFactor final : public ceres::SizedCostFunction<2, 1> {
 public:
  SameFrameConstExtrinsicsFactor(const BearingResidualCore& core, const Rigid3d& rig_from_cam_anchor,
                                 const Rigid3d& rig_from_cam_obs)
      : core_(core), ext_anchor_(rig_from_cam_anchor), ext_obs_(rig_from_cam_obs) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    JacobianOutputs out;
    out.inverse_depth = BlockJacobian(jacobians, 0);
    return EvaluateAnalytic(core_, nullptr, nullptr, ext_anchor_, ext_obs_, parameters[0][0], residuals, out);
  }

 private:
  BearingResidualCore core_;
  RigidParams ext_anchor_, ext_obs_;
};

void CheckBearings(const Eigen::Vector3d& anchor_bearing, const Eigen::Vector3d& observed_bearing,
                   double sqrt_information) {
  MCVO_CHECK_MSG(anchor_bearing.allFinite() && anchor_bearing.norm() > 0.5, "anchor bearing ",
                 anchor_bearing.transpose(), " is not a unit vector");
  MCVO_CHECK_MSG(observed_bearing.allFinite() && observed_bearing.norm() > 0.5, "observed bearing ",
                 observed_bearing.transpose(), " is not a unit vector");
  MCVO_CHECK_MSG(std::isfinite(sqrt_information) && sqrt_information > 0.0, "sqrt_information ",
                 sqrt_information, " must be > 0");
}

}  // namespace

ceres::Manifold* NewPoseManifold() {
  return new ceres::ProductManifold<ceres::EuclideanManifold<3>, ceres::EigenQuaternionManifold>();
}

void PoseToParams(const Rigid3d& pose, double* params) {
  const Eigen::Quaterniond q = pose.rotation.normalized();
  params[0] = pose.translation.x();
  params[1] = pose.translation.y();
  params[2] = pose.translation.z();
  params[3] = q.x();
  params[4] = q.y();
  params[5] = q.z();
  params[6] = q.w();
}

Rigid3d PoseFromParams(const double* params) {
  // Rigid3d's constructor normalises the quaternion.
  return Rigid3d(Eigen::Quaterniond(params[6], params[3], params[4], params[5]),
                 Eigen::Vector3d(params[0], params[1], params[2]));
}

Eigen::Matrix<double, 2, 3> TangentBasis(const Eigen::Vector3d& bearing) {
  const Eigen::Vector3d b = bearing.normalized();
  const double x = b.x(), y = b.y(), z = b.z();
  Eigen::Matrix<double, 2, 3> basis;
  if (z > -0.5) {
    // Rotation of +z onto b about the axis z x b, applied to x and y (Frisvad
    // 2012): smooth for every bearing within 120 deg of the optical axis.
    const double a = 1.0 / (1.0 + z);
    const double c = -x * y * a;
    basis.row(0) << 1.0 - x * x * a, c, -x;
    basis.row(1) << c, 1.0 - y * y * a, -y;
  } else {
    // The same construction about -z (a = 1 / (1 - z) <= 2/3 here), with the
    // second vector flipped so that the basis stays right-handed.
    const double a = 1.0 / (1.0 - z);
    const double c = x * y * a;
    basis.row(0) << 1.0 - x * x * a, -c, x;
    basis.row(1) << c, y * y * a - 1.0, -y;
  }
  return basis;
}

ceres::CostFunction* NewReprojectionFactorOtherCamera(const Eigen::Vector3d& anchor_bearing,
                                                      const Eigen::Vector3d& observed_bearing,
                                                      double sqrt_information) {
  CheckBearings(anchor_bearing, observed_bearing, sqrt_information);
  return new OtherCameraFactor(BearingResidualCore(anchor_bearing, observed_bearing, sqrt_information));
}

ceres::CostFunction* NewReprojectionFactorSameCamera(const Eigen::Vector3d& anchor_bearing,
                                                     const Eigen::Vector3d& observed_bearing,
                                                     double sqrt_information) {
  CheckBearings(anchor_bearing, observed_bearing, sqrt_information);
  return new SameCameraFactor(BearingResidualCore(anchor_bearing, observed_bearing, sqrt_information));
}

ceres::CostFunction* NewReprojectionFactorSameFrame(const Eigen::Vector3d& anchor_bearing,
                                                    const Eigen::Vector3d& observed_bearing,
                                                    double sqrt_information) {
  CheckBearings(anchor_bearing, observed_bearing, sqrt_information);
  return new SameFrameFactor(BearingResidualCore(anchor_bearing, observed_bearing, sqrt_information));
}

ceres::CostFunction* NewReprojectionFactorOtherCameraConstExtrinsics(const Eigen::Vector3d& anchor_bearing,
                                                                     const Eigen::Vector3d& observed_bearing,
                                                                     const Rigid3d& rig_from_cam_anchor,
                                                                     const Rigid3d& rig_from_cam_obs,
                                                                     double sqrt_information) {
  CheckBearings(anchor_bearing, observed_bearing, sqrt_information);
  return new OtherCameraConstExtrinsicsFactor(
      BearingResidualCore(anchor_bearing, observed_bearing, sqrt_information), rig_from_cam_anchor,
      rig_from_cam_obs);
}

ceres::CostFunction* NewReprojectionFactorSameCameraConstExtrinsics(const Eigen::Vector3d& anchor_bearing,
                                                                    const Eigen::Vector3d& observed_bearing,
                                                                    const Rigid3d& rig_from_cam,
                                                                    double sqrt_information) {
  // The same computation as the other-camera factor, with one extrinsic.
  return NewReprojectionFactorOtherCameraConstExtrinsics(anchor_bearing, observed_bearing, rig_from_cam,
                                                         rig_from_cam, sqrt_information);
}

ceres::CostFunction* NewReprojectionFactorSameFrameConstExtrinsics(const Eigen::Vector3d& anchor_bearing,
                                                                   const Eigen::Vector3d& observed_bearing,
                                                                   const Rigid3d& rig_from_cam_anchor,
                                                                   const Rigid3d& rig_from_cam_obs,
                                                                   double sqrt_information) {
  CheckBearings(anchor_bearing, observed_bearing, sqrt_information);
  return new SameFrameConstExtrinsicsFactor(
      BearingResidualCore(anchor_bearing, observed_bearing, sqrt_information), rig_from_cam_anchor,
      rig_from_cam_obs);
}

ceres::CostFunction* NewReprojectionFactorOtherCameraAutoDiff(const Eigen::Vector3d& anchor_bearing,
                                                              const Eigen::Vector3d& observed_bearing,
                                                              double sqrt_information) {
  CheckBearings(anchor_bearing, observed_bearing, sqrt_information);
  return new ceres::AutoDiffCostFunction<OtherCameraFunctor, 2, kPoseParamSize, kPoseParamSize,
                                         kPoseParamSize, kPoseParamSize, 1>(
      new OtherCameraFunctor{BearingResidualCore(anchor_bearing, observed_bearing, sqrt_information)});
}

ceres::CostFunction* NewReprojectionFactorSameCameraAutoDiff(const Eigen::Vector3d& anchor_bearing,
                                                             const Eigen::Vector3d& observed_bearing,
                                                             double sqrt_information) {
  CheckBearings(anchor_bearing, observed_bearing, sqrt_information);
  return new ceres::AutoDiffCostFunction<SameCameraFunctor, 2, kPoseParamSize, kPoseParamSize, kPoseParamSize,
                                         1>(
      new SameCameraFunctor{BearingResidualCore(anchor_bearing, observed_bearing, sqrt_information)});
}

ceres::CostFunction* NewReprojectionFactorSameFrameAutoDiff(const Eigen::Vector3d& anchor_bearing,
                                                            const Eigen::Vector3d& observed_bearing,
                                                            double sqrt_information) {
  CheckBearings(anchor_bearing, observed_bearing, sqrt_information);
  return new ceres::AutoDiffCostFunction<SameFrameFunctor, 2, kPoseParamSize, kPoseParamSize, 1>(
      new SameFrameFunctor{BearingResidualCore(anchor_bearing, observed_bearing, sqrt_information)});
}

namespace {

// A world point X seen from camera c of a rig pose {t, q}:
//   w = X - t,  p_rig = R^T w,  p = R_c p_rig + t_c   (R_c, t_c: cam_from_rig),
// r = s B (u - b), u = p / |p|. With J = s B (I - u u^T) / |p| and
// J_rig = J R_c: d r / d X = J_rig R^T, d r / d t = -J_rig R^T, d r / d q =
// J_rig QuaternionInverseRotateJacobian(q, w).
class WorldPointFactor final : public ceres::SizedCostFunction<2, kPoseParamSize, 3> {
 public:
  WorldPointFactor(const Eigen::Vector3d& observed_bearing, const Rigid3d& cam_from_rig, double sqrt_information)
      : bearing_(observed_bearing.normalized()),
        basis_(TangentBasis(bearing_)),
        cam_rotation_(cam_from_rig.RotationMatrix()),
        cam_translation_(cam_from_rig.translation),
        sqrt_information_(sqrt_information) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const RigidParams pose(parameters[0]);
    const Eigen::Vector3d w = Eigen::Map<const Eigen::Vector3d>(parameters[1]) - pose.translation;
    const Eigen::Matrix3d rig_from_world = pose.rotation.transpose();
    const Eigen::Vector3d p = cam_rotation_ * (rig_from_world * w) + cam_translation_;
    const double norm = p.norm();
    if (!(norm > 0.0)) return false;
    const Eigen::Vector3d u = p / norm;
    const Eigen::Vector2d r = basis_ * (u - bearing_);
    residuals[0] = sqrt_information_ * r[0];
    residuals[1] = sqrt_information_ * r[1];
    double* j_pose = BlockJacobian(jacobians, 0);
    double* j_point = BlockJacobian(jacobians, 1);
    if (j_pose == nullptr && j_point == nullptr) return true;
    const Matrix23 j_p = (sqrt_information_ / norm) * (basis_ - (basis_ * u) * u.transpose());
    const Matrix23 j_rig = j_p * cam_rotation_;
    const Matrix23 j_world = j_rig * rig_from_world;
    if (j_pose != nullptr) {
      Eigen::Map<PoseJacobian> j(j_pose);
      j.leftCols<3>() = -j_world;
      j.rightCols<4>() = j_rig * QuaternionInverseRotateJacobian(pose.q, w);
    }
    if (j_point != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(j_point);
      j = j_world;
    }
    return true;
  }

 private:
  const Eigen::Vector3d bearing_;
  const Matrix23 basis_;
  const Eigen::Matrix3d cam_rotation_;
  const Eigen::Vector3d cam_translation_;
  const double sqrt_information_;
};

struct WorldPointFunctor {
  Eigen::Vector3d bearing;
  Matrix23 basis;
  Eigen::Matrix3d cam_rotation;
  Eigen::Vector3d cam_translation;
  double sqrt_information;

  template <typename T>
  bool operator()(const T* pose, const T* point, T* residual) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(pose), x(point);
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose + 3);
    const Eigen::Matrix<T, 3, 1> p =
        cam_rotation.cast<T>() * (q.toRotationMatrix().transpose() * (x - t)) + cam_translation.cast<T>();
    return TangentResidual(p, bearing, basis, sqrt_information, residual);
  }
};

struct WorldPointExtrinsicFunctor {
  Eigen::Vector3d bearing;
  Matrix23 basis;
  double sqrt_information;

  template <typename T>
  bool operator()(const T* pose, const T* extrinsic, const T* point, T* residual) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(pose), x(point), tc(extrinsic);
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose + 3), qc(extrinsic + 3);
    const Eigen::Matrix<T, 3, 1> p = qc * (q.conjugate() * (x - t)) + tc;
    return TangentResidual(p, bearing, basis, sqrt_information, residual);
  }
};

void CheckWorldPointInputs(const Eigen::Vector3d& observed_bearing, double sqrt_information) {
  MCVO_CHECK_MSG(observed_bearing.allFinite() && observed_bearing.norm() > 0.0 && sqrt_information > 0.0,
                 "world point factor: bearing must be finite and non-zero, sqrt_information > 0");
}

}  // namespace

ceres::CostFunction* NewWorldPointFactor(const Eigen::Vector3d& observed_bearing, const Rigid3d& cam_from_rig,
                                         double sqrt_information) {
  CheckWorldPointInputs(observed_bearing, sqrt_information);
  return new WorldPointFactor(observed_bearing, cam_from_rig, sqrt_information);
}

ceres::CostFunction* NewWorldPointFactorAutoDiff(const Eigen::Vector3d& observed_bearing,
                                                 const Rigid3d& cam_from_rig, double sqrt_information) {
  CheckWorldPointInputs(observed_bearing, sqrt_information);
  const Eigen::Vector3d b = observed_bearing.normalized();
  return new ceres::AutoDiffCostFunction<WorldPointFunctor, 2, kPoseParamSize, 3>(new WorldPointFunctor{
      b, TangentBasis(b), cam_from_rig.RotationMatrix(), cam_from_rig.translation, sqrt_information});
}

ceres::CostFunction* NewWorldPointExtrinsicFactor(const Eigen::Vector3d& observed_bearing, double sqrt_information) {
  CheckWorldPointInputs(observed_bearing, sqrt_information);
  const Eigen::Vector3d b = observed_bearing.normalized();
  return new ceres::AutoDiffCostFunction<WorldPointExtrinsicFunctor, 2, kPoseParamSize, kPoseParamSize, 3>(
      new WorldPointExtrinsicFunctor{b, TangentBasis(b), sqrt_information});
}

namespace {

class DistanceAnchorCost final : public ceres::SizedCostFunction<1, kPoseParamSize> {
 public:
  DistanceAnchorCost(const Eigen::Vector3d& origin, double distance, double sigma)
      : origin_(origin), distance_(distance), inverse_sigma_(1.0 / sigma) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Vector3d d = Eigen::Map<const Eigen::Vector3d>(parameters[0]) - origin_;
    const double norm = d.norm();
    residuals[0] = (norm - distance_) * inverse_sigma_;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 1, kPoseParamSize>> j(jacobians[0]);
      j.setZero();
      if (norm > 0.0) j.head<3>() = (inverse_sigma_ / norm) * d.transpose();
    }
    return true;
  }

 private:
  const Eigen::Vector3d origin_;
  const double distance_;
  const double inverse_sigma_;
};

}  // namespace

std::unique_ptr<ceres::LossFunction> NewRobustLoss(LossType type, double scale) {
  switch (type) {
    case LossType::kHuber:
      return std::make_unique<ceres::HuberLoss>(scale);
    case LossType::kCauchy:
      return std::make_unique<ceres::CauchyLoss>(scale);
    case LossType::kTrivial:
      break;
  }
  return nullptr;
}

ceres::CostFunction* NewDistanceAnchorCost(const Eigen::Vector3d& origin, double distance, double sigma) {
  MCVO_CHECK_MSG(sigma > 0.0 && distance > 0.0 && origin.allFinite(), "distance anchor: distance ", distance,
                 ", sigma ", sigma);
  return new DistanceAnchorCost(origin, distance, sigma);
}

Eigen::Vector2d ReprojectionResidual(const Rigid3d& world_from_rig_anchor, const Rigid3d& world_from_rig_obs,
                                     const Rigid3d& rig_from_cam_anchor, const Rigid3d& rig_from_cam_obs,
                                     const Eigen::Vector3d& anchor_bearing, double inverse_depth,
                                     const Eigen::Vector3d& observed_bearing, double sqrt_information) {
  CheckBearings(anchor_bearing, observed_bearing, sqrt_information);
  double pose_anchor[kPoseParamSize], pose_obs[kPoseParamSize];
  double ext_anchor[kPoseParamSize], ext_obs[kPoseParamSize];
  PoseToParams(world_from_rig_anchor, pose_anchor);
  PoseToParams(world_from_rig_obs, pose_obs);
  PoseToParams(rig_from_cam_anchor, ext_anchor);
  PoseToParams(rig_from_cam_obs, ext_obs);
  const BearingResidualCore core(anchor_bearing, observed_bearing, sqrt_information);
  Eigen::Vector2d residual = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  core(pose_anchor, pose_obs, ext_anchor, ext_obs, &inverse_depth, residual.data());
  return residual;
}

}  // namespace mcvo
