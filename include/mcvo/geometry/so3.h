// Rotation group SO(3): exponential and logarithm maps, the left Jacobian,
// the rotation angle of a quaternion, and the derivative of a quaternion's
// action on a vector with respect to its four coefficients.
//
// Conventions: a tangent vector phi (axis * angle, radians) maps to the
// rotation Exp(phi) = exp(hat(phi)), the right-handed rotation by |phi| about
// phi / |phi|. Log returns phi with |phi| in [0, pi].
//
// Numerics: everything goes through the unit quaternion (w, v), never through
// acos of a trace, so Log is accurate near 0 (series) and near pi (the angle
// comes from atan2(|v|, w), whose derivative is bounded there).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mcvo {

// Skew-symmetric matrix with hat(a) * b = a x b.
Eigen::Matrix3d Hat(const Eigen::Vector3d& v);

// Exp: tangent (radians) -> unit quaternion.
Eigen::Quaterniond So3Exp(const Eigen::Vector3d& phi);

// Log: unit quaternion (either sign) -> tangent with |phi| in [0, pi]. The
// quaternion is normalised first. At exactly pi the axis sign is that of the
// vector part of the quaternion with w >= 0 (either is a valid logarithm).
Eigen::Vector3d So3Log(const Eigen::Quaterniond& q);
// As above, for an orthonormal rotation matrix.
Eigen::Vector3d So3Log(const Eigen::Matrix3d& rotation);

// Rotation angle in radians in [0, pi] of the rotation represented by q;
// robust to the sign of q and to |q| != 1 (2 atan2(|v|, |w|)).
double RotationAngle(const Eigen::Quaterniond& q);

// Left Jacobian of SO(3) (Barfoot, "State Estimation for Robotics", eq. 7.77a):
//   J(phi) = I + (1 - cos t) / t^2 hat(phi) + (t - sin t) / t^3 hat(phi)^2,  t = |phi|,
// with the Taylor series below t = 1e-4. Exp(phi + d) ~= Exp(J(phi) d) Exp(phi).
Eigen::Matrix3d So3LeftJacobian(const Eigen::Vector3d& phi);

// Inverse of the left Jacobian (Barfoot eq. 7.77b), valid for |phi| < 2 pi:
//   J^-1(phi) = I - 1/2 hat(phi) + (1/t^2 - cot(t/2) / (2 t)) hat(phi)^2.
Eigen::Matrix3d So3LeftJacobianInverse(const Eigen::Vector3d& phi);

// d (q * v) / d (qx, qy, qz, qw) of Eigen's quaternion-vector product,
//   q * v = v + 2 w (q_v x v) + 2 q_v x (q_v x v),
// exactly as written, so also off the unit sphere (what Ceres' Jets
// differentiate; a Ceres quaternion block is stored x, y, z, w):
//   d / d w   = 2 q_v x v,
//   d / d q_v = 2 (-w [v]x + (q_v . v) I + q_v v^T - 2 v q_v^T).
Eigen::Matrix<double, 3, 4> QuaternionRotateJacobian(const Eigen::Quaterniond& q, const Eigen::Vector3d& v);
// d (q^* * v) / d (qx, qy, qz, qw): the product with the conjugate (w, -q_v),
// so the q_v columns change sign.
Eigen::Matrix<double, 3, 4> QuaternionInverseRotateJacobian(const Eigen::Quaterniond& q, const Eigen::Vector3d& v);

}  // namespace mcvo
