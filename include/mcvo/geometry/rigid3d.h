// Rigid transform target_from_source: p_in_target = rotation * p_in_source + translation.
//
// Naming follows docs/ARCHITECTURE.md: a variable holding a Rigid3d is named
// `<target>_from_<source>` (cam_from_rig, world_from_rig), so composition reads
// right to left: world_from_cam = world_from_rig * rig_from_cam.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mcvo {

struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // unit quaternion
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) : rotation(q.normalized()), translation(t) {}
  Rigid3d(const Eigen::Matrix3d& r, const Eigen::Vector3d& t)
      : rotation(Eigen::Quaterniond(r).normalized()), translation(t) {}

  // From the top 3x4 block of a homogeneous matrix (rotation must be orthonormal).
  static Rigid3d FromMatrix(const Eigen::Matrix<double, 3, 4>& m) {
    return Rigid3d(Eigen::Matrix3d(m.leftCols<3>()), Eigen::Vector3d(m.col(3)));
  }

  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }
  Eigen::Matrix<double, 3, 4> ToMatrix3x4() const {
    Eigen::Matrix<double, 3, 4> m;
    m.leftCols<3>() = RotationMatrix();
    m.col(3) = translation;
    return m;
  }
  Eigen::Matrix4d ToMatrix4() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topRows<3>() = ToMatrix3x4();
    return m;
  }

  Rigid3d Inverse() const {
    const Eigen::Quaterniond q_inv = rotation.conjugate();
    return Rigid3d(q_inv, -(q_inv * translation));
  }

  Eigen::Vector3d operator*(const Eigen::Vector3d& p_in_source) const {
    return rotation * p_in_source + translation;
  }
};

// (a_from_b * b_from_c) = a_from_c.
inline Rigid3d operator*(const Rigid3d& a_from_b, const Rigid3d& b_from_c) {
  return Rigid3d(a_from_b.rotation * b_from_c.rotation,
                 a_from_b.rotation * b_from_c.translation + a_from_b.translation);
}

}  // namespace mcvo
