#include "window_scale.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "mcvo/initializer/rig_window_ba.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::backend_internal {
namespace {

// Iterations of the rig BA; a camera's own ratio needs this many
// landmarks. (A measurement more than ScaleFilterOptions::
// max_innovation_sigmas = 4 from the current scale is an outlier.)
constexpr int kScaleCorrectionIterations = 20;
constexpr size_t kMinCameraDepthRatios = 10;

ScaleFilter MakeFilter(const BackendOptions& options) {
  ScaleFilterOptions filter_options;
  filter_options.drift_per_100m = options.scale_drift_per_100m;
  filter_options.min_change = options.scale_correction_min_change;
  return ScaleFilter(filter_options);
}

}  // namespace

WindowScaleCorrector::WindowScaleCorrector(const Rig& rig, const BackendOptions& options)
    : rig_(rig), options_(options), filter_(MakeFilter(options)) {}

WindowScaleCorrector::Outcome WindowScaleCorrector::Correct(const WindowFrame& newest, int segment,
                                                            LandmarkWindow* window, WindowProblem* problem,
                                                            std::optional<Rigid3d>* last_pose,
                                                            std::optional<Rigid3d>* previous_pose) {
  Outcome outcome;
  ScaleLogEntry& entry = outcome.entry;
  entry.frame_index = newest.frame_index;
  entry.t_ns = newest.t_ns;
  entry.segment = segment;
  entry.event = "correction";
  const int n = rig_.NumCameras();
  entry.camera_scales.assign(n, 1.0);
  if (*last_pose) filter_.Travel((*last_pose)->translation);
  auto log = [&](std::string note) {
    entry.note = std::move(note);
    entry.scale_sigma = filter_.sigma();
    return std::move(outcome);
  };

  // The window (keyframes and the newest frame), its landmarks in world
  // coordinates, and their observations.
  std::map<const WindowFrame*, int> frame_slot;
  std::vector<Rigid3d> poses;
  for (const WindowFrame* frame : window->frames()) {
    frame_slot[frame] = static_cast<int>(poses.size());
    poses.push_back(frame->WorldFromRig());
  }
  std::map<uint64_t, Eigen::Vector3d> points;
  std::vector<RigWindowObservation> observations;
  for (const auto& [id, lm] : window->landmarks()) {
    if (!window->UsableInBa(lm)) continue;
    points[id] = window->LandmarkInWorld(lm);
    for (const LandmarkObservation& ob : lm.observations) {
      observations.push_back({frame_slot.at(ob.frame), ob.camera, id, ob.bearing});
    }
  }
  RigWindowBaOptions ba_options;
  ba_options.focal_px = options_.virtual_focal_px;
  for (const Camera& camera : rig_.cameras) ba_options.camera_focal_px.push_back(camera.MeanFocalLength());
  ba_options.max_reprojection_px = options_.outlier_threshold_px;
  ba_options.max_iterations = kScaleCorrectionIterations;
  const RigWindowBaResult ba =
      AdjustRigWindow(window->cam_from_rig(), 0, poses, points, observations, ba_options);
  if (!ba.ok) return log(StrCat("not applied: rig BA failed: ", ba.reason));
  const double current_travel = (poses.back().translation - poses.front().translation).norm();
  entry.rms_reprojection_px = ba.rms_reprojection_px;
  if (!(current_travel > options_.scale_correction_min_travel_m)) {
    return log(StrCat("not applied: window travel ", FormatFixed(current_travel, 2), " m < ",
                      FormatFixed(options_.scale_correction_min_travel_m, 2),
                      " m (backend.scale_correction_min_travel_m)"));
  }
  const double ratio = ba.travel_m / current_travel;
  const double sigma = options_.scale_correction_sigma_factor * ba.travel_relative_sigma;
  entry.measured_ratio = ratio;
  entry.measured_sigma = sigma;
  if (!(std::isfinite(ratio) && ratio > 0.0 && std::isfinite(sigma))) {
    return log("not applied: non-finite rig BA travel");
  }
  if (sigma > options_.scale_correction_max_sigma) {
    return log(StrCat("not applied: measurement sigma ", FormatFixed(100.0 * sigma, 2), " % > ",
                      FormatFixed(100.0 * options_.scale_correction_max_sigma, 2), " %"));
  }
  // A measurement: this correction is done (applied or not); until then
  // the next solves try again while the window turns.
  outcome.measured = true;
  const ScaleFilter::Update update = filter_.Measure(ratio, sigma);
  if (update.outcome == ScaleFilter::Outcome::kOutlier) {
    return log(StrCat("not applied: ratio ", FormatFixed(ratio, 4), " is ",
                      FormatFixed(update.innovation_sigmas, 1), " sigma from the current scale (outlier)"));
  }
  const double gain = update.gain;
  const double k = update.factor;
  entry.gain = gain;
  if (update.outcome == ScaleFilter::Outcome::kBelowMinChange) {
    return log(StrCat("not applied: fused change ", FormatFixed(100.0 * (k - 1.0), 3),
                      " % below scale_correction_min_change"));
  }
  const std::vector<double> camera_k = CameraRatios(*window, ba.world_from_rig, ba.points, gain, k);
  // Apply: positions about the fixed keyframe, the prior's linearisation
  // positions likewise, the last poses (constant-velocity prediction), and
  // the landmark depths.
  const Eigen::Vector3d origin = poses.front().translation;
  for (WindowFrame* frame : window->frames()) {
    for (int i = 0; i < 3; ++i) frame->pose[i] = origin[i] + k * (frame->pose[i] - origin[i]);
  }
  problem->RescalePriorPositions(*window, origin, k);
  for (std::optional<Rigid3d>* pose : {last_pose, previous_pose}) {
    if (*pose) (*pose)->translation = origin + k * ((*pose)->translation - origin);
  }
  for (auto& [id, lm] : window->landmarks()) {
    if (lm.triangulated) lm.inverse_depth /= camera_k[lm.camera];
  }
  entry.applied_ratio = k;
  entry.camera_scales = camera_k;
  entry.applied = true;
  return log("applied to window positions, prior and landmark inverse depths");
}

// Per camera: the median change of its landmarks' depths from their anchor
// camera in the rig BA (the paper's per-camera adjustment), fused with the
// same gain; k for a camera with too few landmarks.
std::vector<double> WindowScaleCorrector::CameraRatios(
    const LandmarkWindow& window, const std::vector<Rigid3d>& refined_world_from_rig,
    const std::map<uint64_t, Eigen::Vector3d>& refined_points, double gain, double k) const {
  const int n = rig_.NumCameras();
  std::map<const WindowFrame*, int> frame_slot;
  int slot = 0;
  for (const WindowFrame* frame : window.frames()) frame_slot[frame] = slot++;
  std::vector<std::vector<double>> depth_ratios(n);
  for (const auto& [id, lm] : window.landmarks()) {
    auto refined = refined_points.find(id);
    if (!window.UsableInBa(lm) || refined == refined_points.end()) continue;
    const Rigid3d anchor = window.WorldFromCam(*lm.anchor_frame, lm.anchor_camera);
    // The anchor frame's refined pose: the BA moved it too.
    const Rigid3d refined_anchor = refined_world_from_rig[frame_slot.at(lm.anchor_frame)] *
                                   window.cam_from_rig()[lm.anchor_camera].Inverse();
    const double before = (anchor.Inverse() * window.LandmarkInWorld(lm)).norm();
    const double after = (refined_anchor.Inverse() * refined->second).norm();
    if (before > 0.0 && after > 0.0) depth_ratios[lm.camera].push_back(after / before);
  }
  std::vector<double> camera_k(n, k);
  for (int c = 0; c < n; ++c) {
    std::vector<double>& r = depth_ratios[c];
    if (r.size() < kMinCameraDepthRatios) continue;
    std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
    const double median = r[r.size() / 2];
    camera_k[c] = std::exp(gain * std::log(median));
  }
  return camera_k;
}

}  // namespace mcvo::backend_internal
