#include "mcvo/eval/rpe.h"

#include <algorithm>
#include <cmath>

#include "mcvo/geometry/so3.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

// Cumulative distance along the positions: out[0] = 0.
std::vector<double> CumulativeDistance(const std::vector<Eigen::Vector3d>& positions) {
  std::vector<double> out(positions.size(), 0.0);
  for (size_t k = 1; k < positions.size(); ++k)
    out[k] = out[k - 1] + (positions[k] - positions[k - 1]).norm();
  return out;
}

}  // namespace

std::vector<RpeSegment> ComputeRpeSegments(const std::vector<Rigid3d>& gt_poses,
                                           const std::vector<Rigid3d>& est_aligned_poses,
                                           const std::vector<Eigen::Vector3d>& est_raw_positions,
                                           double length_m, double tolerance) {
  MCVO_CHECK(gt_poses.size() == est_aligned_poses.size() && gt_poses.size() == est_raw_positions.size());
  MCVO_CHECK(length_m > 0.0);
  std::vector<Eigen::Vector3d> gt_positions;
  gt_positions.reserve(gt_poses.size());
  for (const Rigid3d& pose : gt_poses) gt_positions.push_back(pose.translation);
  const std::vector<double> gt_dist = CumulativeDistance(gt_positions);
  const std::vector<double> est_dist = CumulativeDistance(est_raw_positions);
  const size_t n = gt_poses.size();

  std::vector<RpeSegment> segments;
  for (size_t i = 0; i + 1 < n; ++i) {
    // gt_dist is non-decreasing. The closest value to target is at the first
    // index with gt_dist >= target (`above`) or the first index holding the
    // value just below it (`below`); among equal distances the first index.
    const double target = gt_dist[i] + length_m;
    const size_t above = static_cast<size_t>(
        std::lower_bound(gt_dist.begin() + static_cast<std::ptrdiff_t>(i) + 1, gt_dist.end(), target) -
        gt_dist.begin());
    size_t best = n;  // none
    if (above > i + 1) {
      const double below_value = gt_dist[above - 1];
      const size_t below = static_cast<size_t>(
          std::lower_bound(gt_dist.begin() + static_cast<std::ptrdiff_t>(i) + 1, gt_dist.end(), below_value) -
          gt_dist.begin());
      best = below;
    }
    if (above < n) {
      // Strictly closer wins; on a tie the smaller index (`below`) stays.
      if (best == n || std::abs(gt_dist[above] - target) < std::abs(gt_dist[best] - target)) best = above;
    }
    if (best == n) continue;
    const double gt_distance = gt_dist[best] - gt_dist[i];
    if (!(std::abs(gt_distance - length_m) <= tolerance * length_m)) continue;

    const size_t j = best;
    const Rigid3d gt_i_from_j = gt_poses[i].Inverse() * gt_poses[j];
    const Rigid3d est_i_from_j = est_aligned_poses[i].Inverse() * est_aligned_poses[j];
    const Rigid3d error = gt_i_from_j.Inverse() * est_i_from_j;
    RpeSegment segment;
    segment.start = i;
    segment.end = j;
    segment.gt_distance_m = gt_distance;
    segment.translation_m = error.translation.norm();
    segment.rotation_deg = RotationAngle(error.rotation) * kRadToDeg;
    segment.scale_ratio = (est_dist[j] - est_dist[i]) / gt_distance;
    segments.push_back(segment);
  }
  return segments;
}

RpeStepResult ComputeRpeStep(const std::vector<Rigid3d>& gt_poses, const std::vector<Rigid3d>& est_aligned_poses) {
  MCVO_CHECK(gt_poses.size() == est_aligned_poses.size());
  std::vector<double> translation, rotation;
  for (size_t k = 0; k + 1 < gt_poses.size(); ++k) {
    const Rigid3d error = (gt_poses[k].Inverse() * gt_poses[k + 1]).Inverse() *
                          (est_aligned_poses[k].Inverse() * est_aligned_poses[k + 1]);
    translation.push_back(error.translation.norm());
    rotation.push_back(RotationAngle(error.rotation) * kRadToDeg);
  }
  RpeStepResult step;
  step.translation_m = ComputeStats(translation);
  step.rotation_deg = ComputeStats(rotation);
  return step;
}

RpeResult ComputeRpe(const std::vector<Rigid3d>& gt_poses, const std::vector<Rigid3d>& est_aligned_poses,
                     const std::vector<Eigen::Vector3d>& est_raw_positions,
                     const std::vector<double>& lengths_m,
                     const std::vector<std::optional<double>>& length_percents, double tolerance,
                     std::optional<double> sim3_scale) {
  MCVO_CHECK(lengths_m.size() == length_percents.size());
  RpeResult result;
  result.computed = true;
  for (size_t l = 0; l < lengths_m.size(); ++l) {
    const double d = lengths_m[l];
    const std::vector<RpeSegment> segments =
        ComputeRpeSegments(gt_poses, est_aligned_poses, est_raw_positions, d, tolerance);
    std::vector<double> trans_m, trans_pct, rot_deg, rot_deg_per_m, ratio, ratio_normalized;
    for (const RpeSegment& s : segments) {
      trans_m.push_back(s.translation_m);
      trans_pct.push_back(100.0 * s.translation_m / d);
      rot_deg.push_back(s.rotation_deg);
      rot_deg_per_m.push_back(s.rotation_deg / d);
      ratio.push_back(s.scale_ratio);
      if (sim3_scale) ratio_normalized.push_back(s.scale_ratio * *sim3_scale);
    }
    RpeLengthResult length;
    length.length_m = d;
    length.length_percent = length_percents[l];
    length.translation_m = ComputeStats(trans_m);
    length.translation_percent = ComputeStats(trans_pct);
    length.rotation_deg = ComputeStats(rot_deg);
    length.rotation_deg_per_m = ComputeStats(rot_deg_per_m);
    length.scale_ratio = ComputeStats(ratio);
    length.scale_ratio_sim3_normalized = ComputeStats(ratio_normalized);
    result.lengths.push_back(length);
  }
  RpeAverage& average = result.average;
  for (const RpeLengthResult& length : result.lengths) {
    if (length.translation_m.count == 0) continue;
    ++average.num_lengths;
    average.translation_m += length.translation_m.mean;
    average.translation_percent += length.translation_percent.mean;
    average.rotation_deg += length.rotation_deg.mean;
    average.rotation_deg_per_m += length.rotation_deg_per_m.mean;
  }
  if (average.num_lengths > 0) {
    const double n = static_cast<double>(average.num_lengths);
    average.translation_m /= n;
    average.translation_percent /= n;
    average.rotation_deg /= n;
    average.rotation_deg_per_m /= n;
  }
  return result;
}

LocalScaleResult ComputeLocalScale(const std::vector<Eigen::Vector3d>& gt_positions,
                                   const std::vector<Eigen::Vector3d>& est_aligned_positions, int window,
                                   double min_distance_m) {
  MCVO_CHECK(gt_positions.size() == est_aligned_positions.size());
  MCVO_CHECK(window > 0);
  LocalScaleResult result;
  result.window_poses = window;
  const size_t step = static_cast<size_t>(window);
  std::vector<double> deviations;
  for (size_t a = 0; a + step < gt_positions.size(); a += step) {
    const size_t b = a + step;
    const double gt_distance = (gt_positions[b] - gt_positions[a]).norm();
    if (!(gt_distance >= min_distance_m)) {
      ++result.windows_skipped;
      continue;
    }
    const double ratio = (est_aligned_positions[b] - est_aligned_positions[a]).norm() / gt_distance;
    result.ratios.push_back(ratio);
    deviations.push_back(100.0 * std::abs(ratio - 1.0));
  }
  result.ratio = ComputeStats(result.ratios);
  const ErrorStats deviation = ComputeStats(deviations);
  result.worst_deviation_percent = deviation.max;
  result.median_deviation_percent = deviation.median;
  return result;
}

}  // namespace mcvo
