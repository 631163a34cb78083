// The estimator's belief about its scale error (estimator.h, step 6), as a
// scalar Kalman filter in log scale: pure, no state of the window.
//
// State: the variance v of log(s), s the factor by which the current
// estimate's lengths are off. It starts at the initialiser's relative std
// squared (Start) and grows as a random walk over the distance travelled,
// v += (drift_per_100m^2 / 100 m) * distance (Travel). A scale correction
// measures a ratio r (the rig BA's travel over the estimate's) with a
// relative std sigma; Measure fuses y = log r:
//   innovation std  S = sqrt(v + sigma^2);
//   |y| > max_innovation_sigmas * S: an outlier, nothing changes;
//   gain g = v / (v + sigma^2), factor k = exp(g y), v <- (1 - g) v;
//   |k - 1| <= min_change: below the smallest change worth applying (the
//   variance still shrinks: the measurement was informative).
// The caller applies k to the state when Measure says kApply.
#pragma once

#include <optional>

#include <Eigen/Core>

namespace mcvo {

struct ScaleFilterOptions {
  double drift_per_100m = 0.01;        // BackendOptions::scale_drift_per_100m
  double max_innovation_sigmas = 4.0;  // measurements beyond: outliers
  double min_change = 0.002;           // BackendOptions::scale_correction_min_change
};

class ScaleFilter {
 public:
  explicit ScaleFilter(const ScaleFilterOptions& options = ScaleFilterOptions()) : options_(options) {}

  // A new scale from an initialisation with relative std `sigma`, at rig
  // position `position`.
  void Start(double sigma, const Eigen::Vector3d& position);
  // The rig is now at `position`: the variance grows by the distance from
  // the previous call's (or Start's) position; the first call after
  // construction only records the position.
  void Travel(const Eigen::Vector3d& position);

  enum class Outcome { kApply, kOutlier, kBelowMinChange };
  struct Update {
    Outcome outcome = Outcome::kOutlier;
    double innovation_sigmas = 0.0;  // |log r| / S
    double gain = 0.0;               // 0 for an outlier
    double factor = 1.0;             // k (1 for an outlier)
  };
  // Fuses a measured ratio r > 0 with relative std sigma (finite).
  Update Measure(double ratio, double sigma);

  double variance() const { return variance_; }
  double sigma() const;

 private:
  ScaleFilterOptions options_;
  double variance_ = 0.0;
  std::optional<Eigen::Vector3d> position_;
};

}  // namespace mcvo
