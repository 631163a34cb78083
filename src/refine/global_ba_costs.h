// The Ceres cost functions of the global rig bundle adjustment besides the
// bearing factor (backend/factors.h): loop and relative pose constraints,
// the straight-route scale hold, the extrinsic prior and the landmark tie
// (refine/global_ba.h). Internal to src/refine.
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mcvo/geometry/rigid3d.h"
#include "mcvo/refine/global_ba.h"

namespace mcvo::refine_internal {

// A relative pose constraint. Parameter blocks: world_from_rig of `from` and
// of `to` [7 each]. Residual (6): the rotation error 2 vec(q_meas^-1 q_from^-1
// q_to) / sigma_r and the translation error (R_from^T (t_to - t_from) -
// t_meas) / sigma_t.
class RelativePoseCost {
 public:
  explicit RelativePoseCost(const GlobalBaPoseConstraint& c)
      : rotation_(c.from_T_to.rotation),
        translation_(c.from_T_to.translation),
        rotation_weight_(1.0 / c.rotation_sigma_rad),
        translation_weight_(1.0 / c.translation_sigma_m) {}

  template <typename T>
  bool operator()(const T* from, const T* to, T* residual) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_from(from), t_to(to);
    const Eigen::Map<const Eigen::Quaternion<T>> q_from(from + 3), q_to(to + 3);
    const Eigen::Quaternion<T> error = rotation_.cast<T>().conjugate() * q_from.conjugate() * q_to;
    const Eigen::Matrix<T, 3, 1> dt = q_from.conjugate() * (t_to - t_from) - translation_.cast<T>();
    const T sign = error.w() < T(0) ? T(-1) : T(1);  // the short way round
    for (int i = 0; i < 3; ++i) {
      residual[i] = T(2.0 * rotation_weight_) * sign * error.vec()[i];
      residual[3 + i] = T(translation_weight_) * dt[i];
    }
    return true;
  }

 private:
  Eigen::Quaterniond rotation_;
  Eigen::Vector3d translation_;
  double rotation_weight_, translation_weight_;
};

// Straight-road scale hold (global_ba.h "Scale on straights"): the change
// of log scale from interval (a, b) to interval (b, c), each relative to its
// input length, over sigma.
class StraightScaleCost {
 public:
  StraightScaleCost(double length_ab, double length_bc, double sigma)
      : log_ab_(std::log(length_ab)), log_bc_(std::log(length_bc)), weight_(1.0 / sigma) {}

  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* residual) const {
    using std::log;
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> ta(a), tb(b), tc(c);
    // log |v| = 0.5 log |v|^2: differentiable everywhere but at 0.
    const T ab = T(0.5) * log((tb - ta).squaredNorm() + T(1e-18));
    const T bc = T(0.5) * log((tc - tb).squaredNorm() + T(1e-18));
    residual[0] = T(weight_) * ((bc - T(log_bc_)) - (ab - T(log_ab_)));
    return true;
  }

 private:
  double log_ab_, log_bc_, weight_;
};

// Prior of a refined extrinsic (global_ba.h "Extrinsics"). Parameter block:
// cam_from_rig[7]. Residual (6): 2 vec(q0^-1 q) / sigma_r (the short way
// round) and (c - c0) / sigma_t, c = -R^T t the camera centre in the rig.
class ExtrinsicPriorCost {
 public:
  ExtrinsicPriorCost(const Rigid3d& cam_from_rig, double sigma_rad, double sigma_m)
      : rotation_(cam_from_rig.rotation),
        centre_(cam_from_rig.Inverse().translation),
        rotation_weight_(1.0 / sigma_rad),
        translation_weight_(1.0 / sigma_m) {}

  template <typename T>
  bool operator()(const T* extrinsic, T* residual) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(extrinsic);
    const Eigen::Map<const Eigen::Quaternion<T>> q(extrinsic + 3);
    const Eigen::Quaternion<T> error = rotation_.cast<T>().conjugate() * q;
    const T sign = error.w() < T(0) ? T(-1) : T(1);
    const Eigen::Matrix<T, 3, 1> centre = -(q.conjugate() * t);
    for (int i = 0; i < 3; ++i) {
      residual[i] = T(2.0 * rotation_weight_) * sign * error.vec()[i];
      residual[3 + i] = T(translation_weight_) * (centre[i] - T(centre_[i]));
    }
    return true;
  }

 private:
  Eigen::Quaterniond rotation_;
  Eigen::Vector3d centre_;
  double rotation_weight_, translation_weight_;
};

// global_ba.h GlobalBaLandmarkTie: (a - b) / sigma.
class LandmarkTieCost {
 public:
  explicit LandmarkTieCost(double sigma_m) : inverse_sigma_(1.0 / sigma_m) {}
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const {
    for (int i = 0; i < 3; ++i) residual[i] = (a[i] - b[i]) * inverse_sigma_;
    return true;
  }

 private:
  double inverse_sigma_;
};

}  // namespace mcvo::refine_internal
