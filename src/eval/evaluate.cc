#include "mcvo/eval/evaluate.h"

#include <algorithm>
#include <cmath>

#include "mcvo/eval/rpe.h"
#include "mcvo/geometry/so3.h"
#include "mcvo/geometry/umeyama.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

void CheckFinite(const Trajectory& trajectory, const std::string& name) {
  if (trajectory.poses.empty()) MCVO_THROW_INPUT(name, ": has no poses");
  for (size_t i = 0; i < trajectory.poses.size(); ++i) {
    const Rigid3d& pose = trajectory.poses[i].world_from_body;
    if (!pose.translation.allFinite() || !pose.rotation.coeffs().allFinite()) {
      MCVO_THROW_INPUT(name, ": pose ", i, " (0-based) has a non-finite value (NaN or inf)");
    }
  }
}

std::string TimeRange(const Trajectory& trajectory) {
  if (!trajectory.has_time || trajectory.poses.empty()) return "no time stamps";
  int64_t lo = trajectory.poses.front().t_ns;
  int64_t hi = lo;
  for (const StampedPose& pose : trajectory.poses) {
    lo = std::min(lo, pose.t_ns);
    hi = std::max(hi, pose.t_ns);
  }
  return StrCat("times ", FormatNsAsSeconds(lo), " .. ", FormatNsAsSeconds(hi), " s");
}

std::vector<Eigen::Vector3d> Positions(const Trajectory& trajectory) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(trajectory.poses.size());
  for (const StampedPose& pose : trajectory.poses) out.push_back(pose.world_from_body.translation);
  return out;
}

StartEndResult ComputeStartEnd(const Trajectory& gt, const Trajectory& est) {
  StartEndResult result;
  const std::vector<Eigen::Vector3d> est_positions = Positions(est);
  const std::vector<Eigen::Vector3d> gt_positions = Positions(gt);
  result.est_distance_m = (est_positions.back() - est_positions.front()).norm();
  result.est_path_length_m = PathLength(est_positions);
  if (result.est_path_length_m > 0.0)
    result.est_percent = 100.0 * result.est_distance_m / result.est_path_length_m;
  result.gt_distance_m = (gt_positions.back() - gt_positions.front()).norm();
  result.gt_path_length_m = PathLength(gt_positions);
  if (result.gt_path_length_m > 0.0)
    result.gt_percent = 100.0 * result.gt_distance_m / result.gt_path_length_m;
  return result;
}

}  // namespace

std::optional<AlignmentMode> AlignmentModeFromName(std::string_view name) {
  if (name == "none") return AlignmentMode::kNone;
  if (name == "se3") return AlignmentMode::kSe3;
  if (name == "sim3") return AlignmentMode::kSim3;
  if (name == "posyaw") return AlignmentMode::kPosYaw;
  return std::nullopt;
}

std::string_view AlignmentModeName(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kNone:
      return "none";
    case AlignmentMode::kSe3:
      return "se3";
    case AlignmentMode::kSim3:
      return "sim3";
    case AlignmentMode::kPosYaw:
      return "posyaw";
  }
  return "none";
}

size_t MinPosesForAlignment(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kNone:
      return 0;
    case AlignmentMode::kPosYaw:
      return 2;
    case AlignmentMode::kSe3:
    case AlignmentMode::kSim3:
      return 3;
  }
  return 0;
}

void EvalOptions::Check() const {
  association.Check();
  const size_t min_poses = MinPosesForAlignment(align);
  if (align_num_poses < 0 || (align_num_poses > 0 && static_cast<size_t>(align_num_poses) < min_poses)) {
    throw UsageError(StrCat("align_num_poses: expected 0 (all) or at least ", std::max<size_t>(min_poses, 1),
                            " for ", AlignmentModeName(align), " alignment, got ", align_num_poses));
  }
  for (double length : rpe_lengths_m) {
    if (!std::isfinite(length) || !(length > 0.0)) {
      throw UsageError(StrCat("rpe_lengths_m: expected lengths > 0, got ", FormatDouble(length)));
    }
  }
  for (double percent : rpe_length_percents) {
    if (!std::isfinite(percent) || !(percent > 0.0) || percent > 100.0) {
      throw UsageError(
          StrCat("rpe_length_percents: expected values in (0, 100], got ", FormatDouble(percent)));
    }
  }
  if (!std::isfinite(rpe_length_tolerance) || !(rpe_length_tolerance > 0.0) ||
      !(rpe_length_tolerance < 1.0)) {
    throw UsageError(StrCat("rpe_length_tolerance: expected a fraction in (0, 1), got ",
                            FormatDouble(rpe_length_tolerance)));
  }
  if (local_scale_window < 1) {
    throw UsageError(StrCat("local_scale_window: expected at least 1 pose, got ", local_scale_window));
  }
  if (!std::isfinite(local_scale_min_distance_m) || local_scale_min_distance_m < 0.0) {
    throw UsageError(StrCat("local_scale_min_distance_m: expected a distance >= 0, got ",
                            FormatDouble(local_scale_min_distance_m)));
  }
}

double PathLength(const std::vector<Eigen::Vector3d>& positions) {
  double length = 0.0;
  for (size_t k = 1; k < positions.size(); ++k) length += (positions[k] - positions[k - 1]).norm();
  return length;
}

EvalResult EvaluateTrajectory(const Trajectory& gt, const Trajectory& est, const EvalOptions& options,
                              const std::string& gt_name, const std::string& est_name) {
  options.Check();
  CheckFinite(gt, gt_name);
  CheckFinite(est, est_name);

  EvalResult result;
  result.gt_name = gt_name;
  result.est_name = est_name;
  result.options = options;
  result.num_gt_poses = gt.poses.size();
  result.num_est_poses = est.poses.size();
  result.association = AssociatePoses(gt, est, options.association, gt_name, est_name);
  const std::vector<PosePair>& pairs = result.association.pairs;
  if (pairs.empty()) {
    if (options.association.mode == AssociationMode::kTime) {
      MCVO_THROW_INPUT(est_name, ": no pose matches a pose of ", gt_name, " within ",
                       FormatDouble(options.association.max_dt_s), " s (estimate ", TimeRange(est),
                       "; ground truth ", TimeRange(gt), ")");
    }
    MCVO_THROW_INPUT(est_name, ": no pose has a frame index present in ", gt_name);
  }
  const size_t min_poses = MinPosesForAlignment(options.align);
  if (pairs.size() < min_poses) {
    MCVO_THROW_INPUT(est_name, ": only ", pairs.size(), " pose(s) matched ", gt_name, "; ",
                     AlignmentModeName(options.align), " alignment needs at least ", min_poses);
  }

  // Matched positions, and the prefix used for the alignment.
  const size_t m = pairs.size();
  std::vector<Eigen::Vector3d> gt_matched(m);
  std::vector<Eigen::Vector3d> est_matched(m);
  for (size_t k = 0; k < m; ++k) {
    gt_matched[k] = gt.poses[pairs[k].gt_index].world_from_body.translation;
    est_matched[k] = est.poses[pairs[k].est_index].world_from_body.translation;
  }
  const size_t num_align =
      options.align_num_poses > 0 ? std::min(m, static_cast<size_t>(options.align_num_poses)) : m;
  const std::vector<Eigen::Vector3d> gt_align(gt_matched.begin(), gt_matched.begin() + num_align);
  const std::vector<Eigen::Vector3d> est_align(est_matched.begin(), est_matched.begin() + num_align);

  // The alignment.
  if (options.align != AlignmentMode::kNone) {
    std::optional<Sim3d> alignment;
    UmeyamaInfo info;
    if (options.align == AlignmentMode::kPosYaw) {
      alignment = AlignPosYaw(est_align, gt_align);
    } else {
      alignment = AlignUmeyama(est_align, gt_align, options.align == AlignmentMode::kSim3, &info);
    }
    if (!alignment) {
      MCVO_THROW_INPUT(
          est_name, ": ", AlignmentModeName(options.align), " alignment to ", gt_name,
          " is undetermined on the ", num_align, " matched poses used: ",
          options.align == AlignmentMode::kPosYaw ? "no horizontal (x, y) extent" : "all positions coincide");
    }
    result.gt_world_from_est_world = *alignment;
    result.num_alignment_poses = num_align;
    result.alignment_collinear = info.collinear;
    if (info.collinear) {
      result.notes.push_back(
          "matched positions are collinear: rotation about the line is unobservable; the alignment uses the "
          "smallest rotation onto the line, so ATE rotation depends on that choice");
    }
  }
  const Sim3d& alignment = result.gt_world_from_est_world;

  // The scale report: always a Sim3 on the same poses.
  ScaleResult& scale = result.scale;
  scale.num_poses = num_align;
  if (num_align < 3) {
    scale.unavailable_reason = StrCat("only ", num_align, " matched poses (Sim3 needs 3)");
  } else if (const std::optional<Sim3d> sim3 = AlignUmeyama(est_align, gt_align, /*estimate_scale=*/true)) {
    scale.available = true;
    scale.sim3_scale = sim3->scale;
    scale.est_scale_factor = 1.0 / sim3->scale;
    scale.scale_error_signed_percent = 100.0 * (scale.est_scale_factor - 1.0);
    scale.scale_error_percent = std::abs(scale.scale_error_signed_percent);
  } else {
    scale.unavailable_reason = "the matched positions coincide";
  }
  if (!scale.available) result.notes.push_back("scale not available: " + scale.unavailable_reason);

  // The aligned estimate (all poses).
  result.est_aligned = est;
  for (StampedPose& pose : result.est_aligned.poses) {
    pose.world_from_body = alignment.TransformPose(pose.world_from_body);
  }

  // ATE.
  std::vector<Rigid3d> gt_poses(m);
  std::vector<Rigid3d> est_aligned_poses(m);
  std::vector<double> trans_errors(m);
  std::vector<double> rot_errors(m);
  result.pose_errors.resize(m);
  for (size_t k = 0; k < m; ++k) {
    gt_poses[k] = gt.poses[pairs[k].gt_index].world_from_body;
    est_aligned_poses[k] = result.est_aligned.poses[pairs[k].est_index].world_from_body;
    PoseError& error = result.pose_errors[k];
    error.gt_index = pairs[k].gt_index;
    error.est_index = pairs[k].est_index;
    error.translation_m = (gt_poses[k].translation - est_aligned_poses[k].translation).norm();
    error.rotation_deg =
        RotationAngle(est_aligned_poses[k].rotation.conjugate() * gt_poses[k].rotation) * kRadToDeg;
    trans_errors[k] = error.translation_m;
    rot_errors[k] = error.rotation_deg;
  }
  result.ate_translation_m = ComputeStats(trans_errors);
  result.ate_rotation_deg = ComputeStats(rot_errors);

  // RPE and scale drift.
  result.gt_matched_path_length_m = PathLength(gt_matched);
  if (m < 2) {
    result.rpe.skipped_reason = "fewer than 2 matched poses";
  } else if (!(result.gt_matched_path_length_m > 0.0)) {
    result.rpe.skipped_reason = "the matched ground-truth path has zero length";
  } else {
    std::vector<double> lengths_m;
    std::vector<std::optional<double>> length_percents;
    if (!options.rpe_lengths_m.empty()) {
      lengths_m = options.rpe_lengths_m;
      length_percents.assign(lengths_m.size(), std::nullopt);
    } else {
      for (double percent : options.rpe_length_percents) {
        lengths_m.push_back(percent / 100.0 * result.gt_matched_path_length_m);
        length_percents.push_back(percent);
      }
    }
    std::optional<double> sim3_scale;
    if (scale.available) sim3_scale = scale.sim3_scale;
    result.rpe = ComputeRpe(gt_poses, est_aligned_poses, est_matched, lengths_m, length_percents,
                            options.rpe_length_tolerance, sim3_scale);
    for (const RpeLengthResult& length : result.rpe.lengths) {
      if (length.translation_m.count == 0) {
        result.notes.push_back(StrCat("RPE length ", FormatFixed(length.length_m, 3),
                                      " m has no segment within tolerance (ground-truth path ",
                                      FormatFixed(result.gt_matched_path_length_m, 3), " m)"));
      }
    }
  }
  if (!result.rpe.computed) result.notes.push_back("RPE skipped: " + result.rpe.skipped_reason);
  result.rpe.step = ComputeRpeStep(gt_poses, est_aligned_poses);

  std::vector<Eigen::Vector3d> est_aligned_matched(m);
  for (size_t k = 0; k < m; ++k) est_aligned_matched[k] = est_aligned_poses[k].translation;
  result.local_scale = ComputeLocalScale(gt_matched, est_aligned_matched, options.local_scale_window,
                                         options.local_scale_min_distance_m);

  result.start_end = ComputeStartEnd(gt, est);
  return result;
}

}  // namespace mcvo
