#include "mcvo/backend/scale_filter.h"

#include <cmath>

namespace mcvo {

void ScaleFilter::Start(double sigma, const Eigen::Vector3d& position) {
  variance_ = sigma * sigma;
  position_ = position;
}

void ScaleFilter::Travel(const Eigen::Vector3d& position) {
  if (position_) {
    const double per_metre = options_.drift_per_100m * options_.drift_per_100m / 100.0;
    variance_ += per_metre * (position - *position_).norm();
  }
  position_ = position;
}

ScaleFilter::Update ScaleFilter::Measure(double ratio, double sigma) {
  Update update;
  const double innovation = std::log(ratio);
  const double innovation_sigma = std::sqrt(variance_ + sigma * sigma);
  update.innovation_sigmas = std::abs(innovation) / innovation_sigma;
  if (std::abs(innovation) > options_.max_innovation_sigmas * innovation_sigma) {
    update.outcome = Outcome::kOutlier;
    return update;
  }
  update.gain = variance_ / (variance_ + sigma * sigma);
  update.factor = std::exp(update.gain * innovation);
  variance_ *= 1.0 - update.gain;
  update.outcome =
      std::abs(update.factor - 1.0) <= options_.min_change ? Outcome::kBelowMinChange : Outcome::kApply;
  return update;
}

double ScaleFilter::sigma() const { return std::sqrt(variance_); }

}  // namespace mcvo
