// Similarity transform target_from_source: p_in_target = scale * rotation * p_in_source + translation.
//
// Used by trajectory alignment (eval/): an estimated trajectory, expressed in
// its own world frame and its own unit of length, is mapped into the
// ground-truth world frame by gt_world_from_est_world.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

struct Sim3d {
  double scale = 1.0;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // unit quaternion
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Sim3d() = default;
  Sim3d(double s, const Eigen::Quaterniond& q, const Eigen::Vector3d& t)
      : scale(s), rotation(q.normalized()), translation(t) {}
  explicit Sim3d(const Rigid3d& rigid)
      : scale(1.0), rotation(rigid.rotation), translation(rigid.translation) {}

  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }
  // [s R | t; 0 0 0 1].
  Eigen::Matrix4d ToMatrix4() const;

  // source_from_target: p = R^T (q - t) / s. The scale must be non-zero.
  Sim3d Inverse() const;

  Eigen::Vector3d operator*(const Eigen::Vector3d& p_in_source) const {
    return scale * (rotation * p_in_source) + translation;
  }

  // Re-expresses a pose source_from_body in the target frame:
  // target_from_body = (R R_b, s R t_b + t). The rotation composes, the body
  // position is mapped as a point (so it is scaled); the body frame itself
  // stays a rigid (unscaled) frame.
  Rigid3d TransformPose(const Rigid3d& source_from_body) const {
    return Rigid3d(rotation * source_from_body.rotation, (*this) * source_from_body.translation);
  }
};

// (a_from_b * b_from_c) = a_from_c.
inline Sim3d operator*(const Sim3d& a_from_b, const Sim3d& b_from_c) {
  return Sim3d(a_from_b.scale * b_from_c.scale, a_from_b.rotation * b_from_c.rotation,
               a_from_b * b_from_c.translation);
}

}  // namespace mcvo
