// The cross-camera part of the initializer's scale solve (initializer.h,
// step 4) and small helpers shared by the initializer's files. Internal to
// the module.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "mcvo/camera/camera.h"
#include "mcvo/initializer/camera_sfm.h"
#include "mcvo/initializer/initializer.h"
#include "mcvo/initializer/rig_scale.h"
#include "mcvo/map/observations.h"

namespace mcvo::initializer_internal {

inline std::map<uint64_t, Eigen::Vector3d> BearingsById(const std::vector<FeatureObservation>& features) {
  std::map<uint64_t, Eigen::Vector3d> out;
  for (const FeatureObservation& f : features) out.emplace(f.id, f.bearing);
  return out;
}

// Robust std of values centred on zero: 1.4826 x the median of their absolute values.
inline double RobustSpread(std::vector<double> values) {
  if (values.empty()) return 0.0;
  for (double& v : values) v = std::abs(v);
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return 1.4826 * *mid;
}

inline double Median(std::vector<double> values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// Window positions anchor..newest of `window`; `used`: the rig cameras of the
// solve, sfm_of_used their SfM (same order). Measurements index `used`.
std::vector<ScaleMeasurement> CrossCameraMeasurements(const Rig& rig,
                                                      const std::deque<RigFrameObservations>& window,
                                                      const InitializerOptions& options, int anchor,
                                                      const std::vector<int>& used,
                                                      const std::vector<CameraSfmResult>& sfm_of_used,
                                                      int* num_matches, double* spread);

}  // namespace mcvo::initializer_internal
