#include "mcvo/camera/polynomial.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mcvo/util/error.h"

namespace mcvo::camera_internal {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Root of a polynomial known to be monotonic on [a, b] with a sign change
// between g(a) (nonzero) and g(b). Returns the right end of the final bracket.
double BisectMonotonic(const double* c, int degree, double a, double b) {
  const bool a_negative = EvalPoly(c, degree, a) < 0.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (a + b);
    if (mid <= a || mid >= b || b - a <= 1e-15 * std::max(1.0, std::abs(b))) break;
    const double g = EvalPoly(c, degree, mid);
    if (g == 0.0) return mid;
    if ((g < 0.0) == a_negative) {
      a = mid;
    } else {
      b = mid;
    }
  }
  return b;
}

}  // namespace

double EvalPoly(const double* c, int degree, double s) {
  double value = c[degree];
  for (int i = degree - 1; i >= 0; --i) value = value * s + c[i];
  return value;
}

double FirstRootInInterval(const double* c, int degree, double lo, double hi) {
  MCVO_CHECK(degree >= 0 && degree <= kMaxPolyDegree);
  while (degree > 0 && c[degree] == 0.0) --degree;
  if (degree == 0) return kInf;  // A constant: no isolated root.
  if (degree == 1) {
    const double root = -c[0] / c[1];
    return (root > lo && root <= hi) ? root : kInf;
  }
  if (!std::isfinite(hi)) {
    // Cauchy: every root satisfies |s| <= 1 + max_i |c_i / c_n|.
    double bound = 0.0;
    for (int i = 0; i < degree; ++i) bound = std::max(bound, std::abs(c[i] / c[degree]));
    hi = std::max(lo, 0.0) + 1.0 + bound + std::abs(lo);
  }
  if (!(hi > lo)) return kInf;

  double derivative[kMaxPolyDegree];
  for (int i = 0; i < degree; ++i) derivative[i] = (i + 1) * c[i + 1];

  // Walk the monotonic pieces [a, b] between consecutive critical points.
  double a = lo;
  while (a < hi) {
    const double critical = FirstRootInInterval(derivative, degree - 1, a, hi);
    const double b = std::min(critical, hi);
    const double ga = EvalPoly(c, degree, a);
    const double gb = EvalPoly(c, degree, b);
    if (gb == 0.0 && b > a) {
      // The root is b itself unless one lies strictly inside (impossible on a
      // monotonic piece with ga != 0).
      return ga == 0.0 ? kInf : b;
    }
    if (ga != 0.0 && (ga < 0.0) != (gb < 0.0)) return BisectMonotonic(c, degree, a, b);
    if (!(critical < hi)) break;
    a = critical;
  }
  return kInf;
}

bool PositiveOnInterval(const double* c, int degree, double s) {
  MCVO_CHECK(degree >= 0 && degree <= kMaxPolyDegree);
  if (!(s >= 0.0)) return false;
  // Lower bound: on [0, s] each negative term is >= its value at s.
  double bound = c[0];
  double power = 1.0;
  for (int i = 1; i <= degree; ++i) {
    power *= s;
    if (c[i] < 0.0) bound += c[i] * power;
  }
  if (bound > 0.0) return true;
  if (!(EvalPoly(c, degree, s) > 0.0)) return false;
  return !(FirstRootInInterval(c, degree, 0.0, s) <= s);
}

double SolveIncreasingPoly(const double* c, int degree, double target, double lo, double hi) {
  MCVO_CHECK(degree >= 1 && degree <= kMaxPolyDegree);
  double derivative[kMaxPolyDegree];
  for (int i = 0; i < degree; ++i) derivative[i] = (i + 1) * c[i + 1];
  // The target itself is a good first guess for the near-identity distortions.
  double x = (target > lo && target < hi) ? target : 0.5 * (lo + hi);
  for (int iteration = 0; iteration < 300; ++iteration) {
    const double f = EvalPoly(c, degree, x) - target;
    if (f == 0.0) break;
    (f < 0.0 ? lo : hi) = x;
    double next = x - f / EvalPoly(derivative, degree - 1, x);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const bool converged = std::abs(next - x) <= 1e-16 * std::abs(x) || !(hi > lo);
    x = next;
    if (converged) break;
  }
  return x;
}

}  // namespace mcvo::camera_internal
