// Radial-tangential (Brown-Conrady) distortion on normalised coordinates, in
// OpenCV's form, shared by the radtan and MEI models (camera/models.h):
//
//   r^2 = x^2 + y^2,   R = 1 + k1 r^2 + k2 r^4 + k3 r^6
//   xd  = x R + 2 p1 x y + p2 (r^2 + 2 x^2)
//   yd  = y R + p1 (r^2 + 2 y^2) + 2 p2 x y
//
// Coefficients are passed as k[5] = {k1, k2, p1, p2, k3} (OpenCV's order; the
// MEI model passes k3 = 0).
//
// Valid domain. The radial part r_d(r) = r R(r) is invertible exactly while
// d r_d / d r = 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3 (s = r^2) stays positive;
// beyond its first positive root the image folds back and undistortion is
// ambiguous. The models restrict their domain to s below that root (the
// tangential terms, O(p r^2), are small and are covered by the round-trip
// check in Undistort).
#pragma once

#include <cmath>

#include "mcvo/camera/scalar.h"

namespace mcvo::camera_internal {

template <typename T>
void DistortRadTan(const T* k, const T& x, const T& y, T* xd, T* yd) {
  const T x2 = x * x;
  const T y2 = y * y;
  const T xy = x * y;
  const T r2 = x2 + y2;
  const T radial = T(1.0) + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
  *xd = x * radial + T(2.0) * k[2] * xy + k[3] * (r2 + T(2.0) * x2);
  *yd = y * radial + k[2] * (r2 + T(2.0) * y2) + T(2.0) * k[3] * xy;
}

// Distortion and its 2x2 Jacobian d(xd, yd)/d(x, y), row-major.
void DistortRadTanWithJacobian(const double* k, double x, double y, double* xd, double* yd, double* jacobian);

// Coefficients of g(s) = d r_d / d r (see above), degree 3.
void RadTanMonotonicPoly(const double* k, double* c);

// First positive root of g(s) (the squared radius where the radial
// distortion stops being monotonic), or +infinity.
double RadTanMaxRadiusSquared(const double* k);

// True when r^2 = s lies strictly inside the monotonic range.
bool RadTanIsMonotonicAt(const double* k, double s);

// Inverts the distortion by damped Newton iterations that stay inside the
// monotonic range (max_r2 = RadTanMaxRadiusSquared(k)). False when there is no
// preimage there, i.e. (xd, yd) is outside the image of the domain, or the
// iterations do not converge to a residual below 1e-12.
bool UndistortRadTan(const double* k, double max_r2, double xd, double yd, double* x, double* y);

// One Newton step in T from a double solution (x0, y0) of the distortion
// equation: the value is unchanged up to rounding and, when T is a Jet, the
// derivatives are those of the implicit function (x, y)(xd, yd, k).
template <typename T>
void RefineUndistortion(const T* k, const T& xd, const T& yd, double x0, double y0, T* x, T* y) {
  double k_scalar[5];
  for (int i = 0; i < 5; ++i) k_scalar[i] = ScalarPart(k[i]);
  double unused_x, unused_y, j[4];
  DistortRadTanWithJacobian(k_scalar, x0, y0, &unused_x, &unused_y, j);
  T fx, fy;
  DistortRadTan(k, T(x0), T(y0), &fx, &fy);
  fx -= xd;
  fy -= yd;
  const double det = j[0] * j[3] - j[1] * j[2];
  *x = T(x0) - (T(j[3] / det) * fx - T(j[1] / det) * fy);
  *y = T(y0) - (T(-j[2] / det) * fx + T(j[0] / det) * fy);
}

}  // namespace mcvo::camera_internal
