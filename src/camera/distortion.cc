#include "mcvo/camera/distortion.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mcvo/camera/polynomial.h"

namespace mcvo::camera_internal {

void DistortRadTanWithJacobian(const double* k, double x, double y, double* xd, double* yd,
                               double* jacobian) {
  const double x2 = x * x;
  const double y2 = y * y;
  const double xy = x * y;
  const double r2 = x2 + y2;
  const double radial = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
  // dR / d(r^2).
  const double radial_d = k[0] + r2 * (2.0 * k[1] + 3.0 * r2 * k[4]);
  *xd = x * radial + 2.0 * k[2] * xy + k[3] * (r2 + 2.0 * x2);
  *yd = y * radial + k[2] * (r2 + 2.0 * y2) + 2.0 * k[3] * xy;
  jacobian[0] = radial + 2.0 * x2 * radial_d + 2.0 * k[2] * y + 6.0 * k[3] * x;
  jacobian[1] = 2.0 * xy * radial_d + 2.0 * k[2] * x + 2.0 * k[3] * y;
  jacobian[2] = 2.0 * xy * radial_d + 2.0 * k[2] * x + 2.0 * k[3] * y;
  jacobian[3] = radial + 2.0 * y2 * radial_d + 6.0 * k[2] * y + 2.0 * k[3] * x;
}

void RadTanMonotonicPoly(const double* k, double* c) {
  c[0] = 1.0;
  c[1] = 3.0 * k[0];
  c[2] = 5.0 * k[1];
  c[3] = 7.0 * k[4];
}

double RadTanMaxRadiusSquared(const double* k) {
  double c[4];
  RadTanMonotonicPoly(k, c);
  return FirstRootInInterval(c, 3, 0.0, std::numeric_limits<double>::infinity());
}

bool RadTanIsMonotonicAt(const double* k, double s) {
  double c[4];
  RadTanMonotonicPoly(k, c);
  return PositiveOnInterval(c, 3, s);
}

bool UndistortRadTan(const double* k, double max_r2, double xd, double yd, double* x, double* y) {
  if (!std::isfinite(xd) || !std::isfinite(yd)) return false;
  // Start from the radial-only solution r_d(r) = |(xd, yd)| (r_d increases on
  // [0, sqrt(max_r2))), then let 2-D Newton add the tangential terms.
  double cx = xd;
  double cy = yd;
  const double rd = std::hypot(xd, yd);
  if (rd > 0.0) {
    const double poly[8] = {0.0, 1.0, 0.0, k[0], 0.0, k[1], 0.0, k[4]};
    double hi = std::sqrt(max_r2);
    if (!std::isfinite(hi)) {
      hi = std::max(1.0, rd);
      for (int i = 0; i < 2000 && EvalPoly(poly, 7, hi) <= rd; ++i) hi *= 2.0;
    }
    const double r = EvalPoly(poly, 7, hi) > rd ? SolveIncreasingPoly(poly, 7, rd, 0.0, hi) : 0.5 * hi;
    cx *= r / rd;
    cy *= r / rd;
  }
  double px, py, j[4];
  DistortRadTanWithJacobian(k, cx, cy, &px, &py, j);
  double fx = px - xd;
  double fy = py - yd;
  double residual2 = fx * fx + fy * fy;
  const double tolerance2 = 1e-30 * (1.0 + xd * xd + yd * yd);
  for (int iteration = 0; iteration < 100 && residual2 > tolerance2; ++iteration) {
    const double det = j[0] * j[3] - j[1] * j[2];
    if (!(std::abs(det) > 1e-300)) return false;
    double step_x = (j[3] * fx - j[1] * fy) / det;
    double step_y = (-j[2] * fx + j[0] * fy) / det;
    // Backtrack until the step stays in the domain and lowers the residual.
    bool accepted = false;
    for (int halving = 0; halving < 40 && !accepted; ++halving) {
      const double nx = cx - step_x;
      const double ny = cy - step_y;
      if (nx * nx + ny * ny < max_r2) {
        double nj[4];
        DistortRadTanWithJacobian(k, nx, ny, &px, &py, nj);
        const double nfx = px - xd;
        const double nfy = py - yd;
        const double new_residual2 = nfx * nfx + nfy * nfy;
        if (new_residual2 < residual2) {
          cx = nx;
          cy = ny;
          fx = nfx;
          fy = nfy;
          residual2 = new_residual2;
          for (int i = 0; i < 4; ++i) j[i] = nj[i];
          accepted = true;
        }
      }
      step_x *= 0.5;
      step_y *= 0.5;
    }
    if (!accepted) break;  // Stalled: at the precision limit, or no preimage.
  }
  if (!(residual2 <= 1e-24 * (1.0 + xd * xd + yd * yd))) return false;
  *x = cx;
  *y = cy;
  return true;
}

}  // namespace mcvo::camera_internal
