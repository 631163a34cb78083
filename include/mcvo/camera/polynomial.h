// Real-root helpers for the small polynomials that bound the valid domain of
// the distortion models (camera/models.h). A distortion r_d = r (1 + k1 r^2 +
// ...) is invertible exactly as long as its derivative, a polynomial g(s) in
// s = r^2 with g(0) = 1, stays positive; these functions find where it first
// reaches zero. Double only: the domain test of a model never needs
// derivatives, so it is evaluated on the scalar part of Jets.
#pragma once

namespace mcvo::camera_internal {

// Highest degree handled (KB: theta_d(theta) has degree 9).
inline constexpr int kMaxPolyDegree = 9;

// c[0] + c[1] s + ... + c[degree] s^degree (Horner).
double EvalPoly(const double* c, int degree, double s);

// Smallest root of the polynomial in the half-open interval (lo, hi], or
// +infinity when there is none. hi may be +infinity (then Cauchy's bound on
// the roots is used). Exact up to bisection tolerance (1e-15 relative): the
// roots of the derivative split [lo, hi] into pieces where the polynomial is
// monotonic, and each piece holds at most one root.
double FirstRootInInterval(const double* c, int degree, double lo, double hi);

// True when the polynomial, with c[0] > 0, stays positive on [0, s]. First a
// cheap sufficient bound (c[0] minus the negative terms evaluated at s), then,
// only when that fails, the exact root search.
bool PositiveOnInterval(const double* c, int degree, double s);

// Solves p(x) = target for a polynomial increasing on [lo, hi] with
// p(lo) <= target < p(hi): Newton steps, replaced by bisection whenever a step
// leaves the bracket that holds the root (so it always converges). Returns
// the root to about 1e-15 relative.
double SolveIncreasingPoly(const double* c, int degree, double target, double lo, double hi);

}  // namespace mcvo::camera_internal
