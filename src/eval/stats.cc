#include "mcvo/eval/stats.h"

#include <algorithm>
#include <cmath>

namespace mcvo {

ErrorStats ComputeStats(const std::vector<double>& values) {
  ErrorStats stats;
  stats.count = values.size();
  if (values.empty()) return stats;
  const double n = static_cast<double>(values.size());
  double sum = 0.0;
  double sum_sq = 0.0;
  stats.min = values.front();
  stats.max = values.front();
  for (double v : values) {
    sum += v;
    sum_sq += v * v;
    stats.min = std::min(stats.min, v);
    stats.max = std::max(stats.max, v);
  }
  stats.mean = sum / n;
  stats.rmse = std::sqrt(sum_sq / n);
  // Two-pass variance (no cancellation of sum_sq / n - mean^2).
  double sum_dev_sq = 0.0;
  for (double v : values) sum_dev_sq += (v - stats.mean) * (v - stats.mean);
  stats.std = std::sqrt(sum_dev_sq / n);
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  const size_t mid = sorted.size() / 2;
  stats.median = sorted.size() % 2 == 1 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return stats;
}

}  // namespace mcvo
