// Double-precision parts of the camera models: domain tests, parameter
// checks, analytic Jacobians and the iterative inverses. Derivations are in
// the comments; the formulas themselves are documented in camera/models.h.
#include "mcvo/camera/models.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mcvo/camera/distortion.h"
#include "mcvo/camera/polynomial.h"

namespace mcvo {
namespace {

bool AllFinite(const double* values, int n) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(values[i])) return false;
  }
  return true;
}

// fx fy cx cy first: shared by pinhole, radtan, KB and DS.
std::string_view FocalError(const double* params, int num_params) {
  if (!AllFinite(params, num_params)) return "parameters must be finite";
  if (!(params[0] > 0.0) || !(params[1] > 0.0)) return "fx and fy must be > 0";
  return "";
}

// d(x/z, y/z)/dP for a perspective division: rows of a 2x3 row-major matrix.
void PerspectiveJacobian(const double* point, double* j) {
  const double inv_z = 1.0 / point[2];
  const double x = point[0] * inv_z;
  const double y = point[1] * inv_z;
  j[0] = inv_z, j[1] = 0.0, j[2] = -x * inv_z;
  j[3] = 0.0, j[4] = inv_z, j[5] = -y * inv_z;
}

// out (2x3) = diag(f0, f1) * a (2x2) * b (2x3), all row-major.
void ScaledProduct(double f0, double f1, const double* a, const double* b, double* out) {
  for (int c = 0; c < 3; ++c) {
    out[c] = f0 * (a[0] * b[c] + a[1] * b[3 + c]);
    out[3 + c] = f1 * (a[2] * b[c] + a[3] * b[3 + c]);
  }
}

double Norm3(const double* p) { return std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]); }

}  // namespace

// ----------------------------------------------------------------- pinhole

std::string_view PinholeModel::ParamsError(const double* params) { return FocalError(params, kNumParams); }

bool PinholeModel::IsInDomain(const double* /*params*/, const double* point) {
  return AllFinite(point, 3) && point[2] > kMinPerspectiveCos * Norm3(point);
}

bool PinholeModel::ProjectWithJacobian(const double* params, const double* point, double* pixel,
                                       double* jacobian) {
  if (!Project(params, point, pixel)) return false;
  if (jacobian != nullptr) {
    PerspectiveJacobian(point, jacobian);
    for (int c = 0; c < 3; ++c) {
      jacobian[c] *= params[0];
      jacobian[3 + c] *= params[1];
    }
  }
  return true;
}

// ------------------------------------------------------------------ radtan

std::string_view RadTanModel::ParamsError(const double* params) { return FocalError(params, kNumParams); }

bool RadTanModel::IsInDomain(const double* params, const double* point) {
  if (!PinholeModel::IsInDomain(nullptr, point)) return false;
  const double r2 = (point[0] * point[0] + point[1] * point[1]) / (point[2] * point[2]);
  return camera_internal::RadTanIsMonotonicAt(params + 4, r2);
}

bool RadTanModel::ProjectWithJacobian(const double* params, const double* point, double* pixel,
                                      double* jacobian) {
  if (!IsInDomain(params, point)) return false;
  // pixel = f * distort(x / z, y / z) + c: chain rule through the three maps.
  double xd, yd, distortion_jacobian[4], perspective_jacobian[6];
  camera_internal::DistortRadTanWithJacobian(params + 4, point[0] / point[2], point[1] / point[2], &xd, &yd,
                                             distortion_jacobian);
  pixel[0] = params[0] * xd + params[2];
  pixel[1] = params[1] * yd + params[3];
  if (jacobian != nullptr) {
    PerspectiveJacobian(point, perspective_jacobian);
    ScaledProduct(params[0], params[1], distortion_jacobian, perspective_jacobian, jacobian);
  }
  return true;
}

bool RadTanModel::Undistort(const double* params, double xd, double yd, double* x, double* y) {
  const double* k = params + 4;
  if (!camera_internal::UndistortRadTan(k, camera_internal::RadTanMaxRadiusSquared(k), xd, yd, x, y)) {
    return false;
  }
  const double point[3] = {*x, *y, 1.0};
  return IsInDomain(params, point);
}

// ---------------------------------------------------------- Kannala-Brandt

namespace {
// d theta_d / d theta as a polynomial in s = theta^2.
void KannalaBrandtMonotonicPoly(const double* params, double* c) {
  c[0] = 1.0;
  for (int i = 1; i <= 4; ++i) c[i] = (2 * i + 1) * params[3 + i];
}
}  // namespace

std::string_view KannalaBrandtModel::ParamsError(const double* params) {
  return FocalError(params, kNumParams);
}

double KannalaBrandtModel::MaxTheta(const double* params) {
  double c[5];
  KannalaBrandtMonotonicPoly(params, c);
  const double root = camera_internal::FirstRootInInterval(c, 4, 0.0, M_PI * M_PI);
  return std::min(M_PI, std::sqrt(root));
}

double KannalaBrandtModel::DistortThetaDerivative(const double* params, double theta) {
  double c[5];
  KannalaBrandtMonotonicPoly(params, c);
  return camera_internal::EvalPoly(c, 4, theta * theta);
}

bool KannalaBrandtModel::IsInDomain(const double* params, const double* point) {
  if (!AllFinite(point, 3)) return false;
  const double r = std::hypot(point[0], point[1]);
  if (!(r > 0.0 || point[2] > 0.0)) return false;  // origin, or on the axis behind
  const double theta = std::atan2(r, point[2]);
  if (!(theta < M_PI)) return false;
  double c[5];
  KannalaBrandtMonotonicPoly(params, c);
  return camera_internal::PositiveOnInterval(c, 4, theta * theta);
}

bool KannalaBrandtModel::SolveTheta(const double* params, double theta_d, double* theta) {
  if (!(theta_d >= 0.0) || !std::isfinite(theta_d)) return false;
  if (theta_d == 0.0) {
    *theta = 0.0;
    return true;
  }
  const double max_theta = MaxTheta(params);
  if (!(theta_d < DistortTheta(params, max_theta))) return false;
  // theta_d(theta) = theta + k1 theta^3 + ... + k4 theta^9 increases on [0, max_theta].
  const double poly[10] = {0.0, 1.0, 0.0, params[4], 0.0, params[5], 0.0, params[6], 0.0, params[7]};
  const double t = camera_internal::SolveIncreasingPoly(poly, 9, theta_d, 0.0, max_theta);
  if (!(t < max_theta) || !(std::abs(DistortTheta(params, t) - theta_d) <= 1e-12 * (1.0 + theta_d))) {
    return false;
  }
  *theta = t;
  return true;
}

bool KannalaBrandtModel::ProjectWithJacobian(const double* params, const double* point, double* pixel,
                                             double* jacobian) {
  if (!IsInDomain(params, point)) return false;
  const double x = point[0], y = point[1], z = point[2];
  const double r2 = x * x + y * y;
  if (NearAxis(r2, z)) return PinholeModel::ProjectWithJacobian(params, point, pixel, jacobian);
  // s = theta_d(theta) / r, pixel = f s (x, y) + c.
  //   d theta / dP = (z x / (r rho^2), z y / (r rho^2), -r / rho^2),  dr / dP = (x, y, 0) / r,
  //   ds / dP = (theta_d'(theta) d theta / dP - s dr / dP) / r.
  const double r = std::sqrt(r2);
  const double rho2 = r2 + z * z;
  const double theta = std::atan2(r, z);
  const double s = DistortTheta(params, theta) / r;
  pixel[0] = params[0] * s * x + params[2];
  pixel[1] = params[1] * s * y + params[3];
  if (jacobian != nullptr) {
    const double dtheta_d = DistortThetaDerivative(params, theta);
    const double common = (dtheta_d * z / rho2 - s) / r2;  // ds/dx = common * x, ds/dy = common * y
    const double ds[3] = {common * x, common * y, -dtheta_d / rho2};
    for (int c = 0; c < 3; ++c) {
      jacobian[c] = params[0] * ((c == 0 ? s : 0.0) + x * ds[c]);
      jacobian[3 + c] = params[1] * ((c == 1 ? s : 0.0) + y * ds[c]);
    }
  }
  return true;
}

// --------------------------------------------------------------------- MEI

namespace {
// Distortion coefficients of MEI in the radtan layout {k1, k2, p1, p2, k3 = 0}.
void MeiDistortion(const double* params, double* k) {
  for (int i = 0; i < 4; ++i) k[i] = params[1 + i];
  k[4] = 0.0;
}
}  // namespace

std::string_view MeiModel::ParamsError(const double* params) {
  if (!AllFinite(params, kNumParams)) return "parameters must be finite";
  if (!(params[0] >= 0.0)) return "xi must be >= 0";
  if (!(params[5] > 0.0) || !(params[6] > 0.0)) return "gamma1 and gamma2 must be > 0";
  return "";
}

bool MeiModel::IsInDomain(const double* params, const double* point) {
  if (!AllFinite(point, 3)) return false;
  const double rho = Norm3(point);
  const double xi = params[0];
  const double w = xi > 1.0 ? 1.0 / xi : xi;
  if (!(rho > 0.0) || !(point[2] > -w * rho)) return false;
  const double denominator = point[2] + xi * rho;
  if (!(denominator > 0.0)) return false;
  const double m2 = (point[0] * point[0] + point[1] * point[1]) / (denominator * denominator);
  double k[5], c[4];
  MeiDistortion(params, k);
  camera_internal::RadTanMonotonicPoly(k, c);
  return camera_internal::PositiveOnInterval(c, 2, m2);
}

bool MeiModel::ProjectWithJacobian(const double* params, const double* point, double* pixel,
                                   double* jacobian) {
  if (!IsInDomain(params, point)) return false;
  // (x, y) = (X, Y) / D with D = Z + xi rho:
  //   dx/dP = e_x / D - X dD/dP / D^2,  dD/dP = xi P / rho + e_z.
  const double xi = params[0];
  const double rho = Norm3(point);
  const double inv_d = 1.0 / (point[2] + xi * rho);
  const double x = point[0] * inv_d;
  const double y = point[1] * inv_d;
  double k[5], xd, yd, distortion_jacobian[4];
  MeiDistortion(params, k);
  camera_internal::DistortRadTanWithJacobian(k, x, y, &xd, &yd, distortion_jacobian);
  pixel[0] = params[5] * xd + params[7];
  pixel[1] = params[6] * yd + params[8];
  if (jacobian != nullptr) {
    const double dd[3] = {xi * point[0] / rho, xi * point[1] / rho, xi * point[2] / rho + 1.0};
    double projection_jacobian[6];
    for (int c = 0; c < 3; ++c) {
      projection_jacobian[c] = ((c == 0 ? 1.0 : 0.0) - x * dd[c]) * inv_d;
      projection_jacobian[3 + c] = ((c == 1 ? 1.0 : 0.0) - y * dd[c]) * inv_d;
    }
    ScaledProduct(params[5], params[6], distortion_jacobian, projection_jacobian, jacobian);
  }
  return true;
}

bool MeiModel::Undistort(const double* params, double xd, double yd, double* x, double* y) {
  double k[5];
  MeiDistortion(params, k);
  double max_r2 = camera_internal::RadTanMaxRadiusSquared(k);
  const double xi = params[0];
  // For xi > 1 the lift to the sphere needs m^2 <= 1 / (xi^2 - 1) (the fold).
  if (xi > 1.0) max_r2 = std::min(max_r2, 1.0 / (xi * xi - 1.0));
  return camera_internal::UndistortRadTan(k, max_r2, xd, yd, x, y);
}

// ----------------------------------------------------------- double sphere

std::string_view DoubleSphereModel::ParamsError(const double* params) {
  const std::string_view focal = FocalError(params, kNumParams);
  if (!focal.empty()) return focal;
  if (!(params[4] > -1.0 && params[4] <= 1.0)) return "xi must be in (-1, 1]";
  if (!(params[5] >= 0.0 && params[5] <= 1.0)) return "alpha must be in [0, 1]";
  return "";
}

bool DoubleSphereModel::IsInDomain(const double* params, const double* point) {
  if (!AllFinite(point, 3)) return false;
  const double xi = params[4];
  const double alpha = params[5];
  const double d1 = Norm3(point);
  const double w1 = alpha <= 0.5 ? alpha / (1.0 - alpha) : (1.0 - alpha) / alpha;
  const double w2 = (w1 + xi) / std::sqrt(2.0 * w1 * xi + xi * xi + 1.0);
  if (!(d1 > 0.0) || !(point[2] > -w2 * d1)) return false;
  const double k = xi * d1 + point[2];
  const double d2 = std::sqrt(point[0] * point[0] + point[1] * point[1] + k * k);
  return alpha * d2 + (1.0 - alpha) * k > 0.0;
}

bool DoubleSphereModel::ProjectWithJacobian(const double* params, const double* point, double* pixel,
                                            double* jacobian) {
  if (!IsInDomain(params, point)) return false;
  // k = xi d1 + Z, d2 = |(X, Y, k)|, D = alpha d2 + (1 - alpha) k, u = fx X / D + cx:
  //   dk/dP = xi P / d1 + e_z,  dd2/dP = ((X, Y, 0) + k dk/dP) / d2,
  //   dD/dP = alpha dd2/dP + (1 - alpha) dk/dP,  du/dP = fx (e_x - X dD/dP / D) / D.
  const double xi = params[4];
  const double alpha = params[5];
  const double d1 = Norm3(point);
  const double k = xi * d1 + point[2];
  const double d2 = std::sqrt(point[0] * point[0] + point[1] * point[1] + k * k);
  const double inv_d = 1.0 / (alpha * d2 + (1.0 - alpha) * k);
  pixel[0] = params[0] * point[0] * inv_d + params[2];
  pixel[1] = params[1] * point[1] * inv_d + params[3];
  if (jacobian != nullptr) {
    for (int c = 0; c < 3; ++c) {
      const double dk = xi * point[c] / d1 + (c == 2 ? 1.0 : 0.0);
      const double dd2 = ((c < 2 ? point[c] : 0.0) + k * dk) / d2;
      const double dd = alpha * dd2 + (1.0 - alpha) * dk;
      jacobian[c] = params[0] * ((c == 0 ? 1.0 : 0.0) - point[0] * dd * inv_d) * inv_d;
      jacobian[3 + c] = params[1] * ((c == 1 ? 1.0 : 0.0) - point[1] * dd * inv_d) * inv_d;
    }
  }
  return true;
}

}  // namespace mcvo
