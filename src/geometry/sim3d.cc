#include "mcvo/geometry/sim3d.h"

#include "mcvo/util/error.h"

namespace mcvo {

Eigen::Matrix4d Sim3d::ToMatrix4() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = scale * RotationMatrix();
  m.topRightCorner<3, 1>() = translation;
  return m;
}

Sim3d Sim3d::Inverse() const {
  MCVO_CHECK_MSG(scale != 0.0, "Sim3d::Inverse of a transform with scale 0");
  const Eigen::Quaterniond q_inv = rotation.conjugate();
  const double s_inv = 1.0 / scale;
  return Sim3d(s_inv, q_inv, -s_inv * (q_inv * translation));
}

}  // namespace mcvo
