// Rigid-motion group SE(3): exponential and logarithm maps on the tangent
// xi = (rho, phi) (translation part first, rotation part second).
//
//   Exp(rho, phi) = Rigid3d(So3Exp(phi), J(phi) rho)     J: So3LeftJacobian
//   Log(T)        = (J^-1(phi) t, phi),  phi = So3Log(T.rotation)
//
// (Barfoot, "State Estimation for Robotics", eq. 7.83 and 7.85.)
#pragma once

#include <Eigen/Core>

#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

using Vector6d = Eigen::Matrix<double, 6, 1>;

Rigid3d Se3Exp(const Vector6d& rho_phi);
// |phi| of the result is in [0, pi].
Vector6d Se3Log(const Rigid3d& transform);

}  // namespace mcvo
