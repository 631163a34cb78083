// Summary statistics of a list of non-negative errors, as reported for ATE
// and RPE (docs/eval.md, "Statistics").
#pragma once

#include <cstddef>
#include <vector>

namespace mcvo {

// All values are 0 when count == 0 (the JSON writes them as null).
struct ErrorStats {
  size_t count = 0;
  double rmse = 0.0;    // sqrt(sum e^2 / n)
  double mean = 0.0;    // sum e / n
  double median = 0.0;  // middle value; mean of the two middle values when n is even
  double std = 0.0;     // population standard deviation sqrt(sum (e - mean)^2 / n), as numpy/evo
  double min = 0.0;
  double max = 0.0;
};

// Sums run in the order of `values`, so the same list gives the same bits.
ErrorStats ComputeStats(const std::vector<double>& values);

}  // namespace mcvo
