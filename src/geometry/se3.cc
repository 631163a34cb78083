#include "mcvo/geometry/se3.h"

#include "mcvo/geometry/so3.h"

namespace mcvo {

Rigid3d Se3Exp(const Vector6d& rho_phi) {
  const Eigen::Vector3d rho = rho_phi.head<3>();
  const Eigen::Vector3d phi = rho_phi.tail<3>();
  return Rigid3d(So3Exp(phi), Eigen::Vector3d(So3LeftJacobian(phi) * rho));
}

Vector6d Se3Log(const Rigid3d& transform) {
  const Eigen::Vector3d phi = So3Log(transform.rotation);
  Vector6d xi;
  xi.head<3>() = So3LeftJacobianInverse(phi) * transform.translation;
  xi.tail<3>() = phi;
  return xi;
}

}  // namespace mcvo
