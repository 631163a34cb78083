// The scalar (value) part of a double or of a (nested) ceres::Jet. The camera
// models evaluate their domain tests and their Newton iterations on scalar
// parts: a domain test is a yes/no decision whose derivative is irrelevant,
// and deciding it on the value keeps Project() a smooth function of the Jet
// wherever it returns true.
#pragma once

#include <ceres/jet.h>

namespace mcvo {

inline double ScalarPart(double x) { return x; }

template <typename T, int N>
double ScalarPart(const ceres::Jet<T, N>& x) {
  return ScalarPart(x.a);
}

}  // namespace mcvo
