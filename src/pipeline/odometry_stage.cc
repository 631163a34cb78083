#include "odometry_stage.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "mcvo/pipeline/run.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"

namespace mcvo::pipeline_internal {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::unique_ptr<ReversePass> MakeReversePass(const Rig& rig, const PipelineOptions& options,
                                             const InitializerOptions& init_options, int threads) {
  if (!options.backend.reverse_pass) return nullptr;
  ReversePassOptions reverse_options;
  reverse_options.overlap_frames = options.backend.reverse_pass_overlap_frames;
  reverse_options.seed_from_forward = options.backend.reverse_pass_seeded;
  // The reverse run's own scale is replaced by the forward one when it is
  // aligned (a similarity), so its initializer needs the scale only well
  // enough to track: it may use the fallback bound, and the overlap start at
  // the first failed window (the frames before a forward overlap start are
  // those the rig stood or crept through).
  InitializerOptions reverse_init = init_options;
  reverse_init.max_relative_scale_sigma =
      std::max(init_options.max_relative_scale_sigma, options.initializer.max_relative_scale_sigma_fallback);
  reverse_init.overlap_start.after_failed_windows = 0;
  return std::make_unique<ReversePass>(rig, reverse_init, options.backend, reverse_options, threads);
}

// Merges the reverse passes' poses, keyframes and landmarks (a landmark the
// forward pass has keeps the forward position) and their log lines.
void ApplyReversePass(ReversePassResult result, OdometryOutput* out) {
  for (const BackfilledFrame& frame : result.frames) {
    out->poses[frame.frame_index] = StampedPose{frame.t_ns, frame.frame_index, frame.world_from_rig};
    out->reverse_posed[frame.frame_index] = frame.segment;
  }
  for (KeyframeEstimate& kf : result.keyframes) out->keyframes.push_back(std::move(kf));
  for (const MapLandmark& lm : result.landmarks) out->landmarks.emplace(lm.id, lm.position_world);
  for (const ReversePassReport& report : result.reports) {
    if (report.applied) {
      MCVO_LOG(kInfo, "run: reverse pass before segment ", report.segment, ": ", report.note);
    } else {
      MCVO_LOG(kWarning, "run: reverse pass before segment ", report.segment, ": ", report.note);
    }
  }
  for (ScaleLogEntry& entry : result.scale_log) out->scale_log.push_back(std::move(entry));
}

// Mean speed (distance per frame) over up to kSpeedFrames consecutive posed
// frames of `frames` (frame indices, increasing) from its start or its end,
// in the frame `move` maps the poses to; 0 when it cannot be measured.
constexpr size_t kSpeedFrames = 10;
double MeanSpeed(const OdometryOutput& out, const std::vector<int>& frames, bool from_end, const Sim3d& move) {
  if (frames.size() < 2) return 0.0;
  const size_t n = std::min(frames.size(), kSpeedFrames);
  const size_t first = from_end ? frames.size() - n : 0;
  double path = 0.0;
  for (size_t k = first + 1; k < first + n; ++k) {
    path += (move * out.poses.at(frames[k]).world_from_body.translation -
             move * out.poses.at(frames[k - 1]).world_from_body.translation)
                .norm();
  }
  const int span = frames[first + n - 1] - frames[first];
  return span > 0 ? path / span : 0.0;
}

// Places each later segment where the one before it was heading: a segment
// starts after a tracking loss, at the last good pose (estimator.h); once
// the reverse pass has posed it back towards the loss, its first posed
// frame a is moved to the constant-velocity prediction from the previous
// segment's last two poses (b-1, b) over the a - b frames between, and
// everything of the segment (poses, keyframes, landmarks) moves with it.
// Monocular (each segment initialises in its own arbitrary unit): the
// segment is also scaled about frame a so that its mean speed over its first
// 10 posed frames is the previous segment's over its last 10 (the same
// constant-velocity assumption, applied to the unit). Logged as one "link"
// line per segment.
void LinkSegments(bool monocular, OdometryOutput* out) {
  const std::map<int, int> segment_of = SegmentOfPosedFrames(*out);
  std::map<int, Sim3d> correction;  // segment -> world_new_from_world_old
  std::map<int, std::vector<int>> frames_of;
  for (const auto& [index, segment] : segment_of) frames_of[segment].push_back(index);
  int previous = -1;
  for (const auto& [segment, frames] : frames_of) {
    correction[segment] = previous >= 0 ? correction[previous] : Sim3d();
    const std::vector<int>& before = previous >= 0 ? frames_of[previous] : std::vector<int>();
    if (before.size() >= 2 && frames.front() > before.back()) {
      const Sim3d& moved = correction[previous];
      const Rigid3d last = moved.TransformPose(out->poses.at(before.back()).world_from_body);
      const Rigid3d second = moved.TransformPose(out->poses.at(before[before.size() - 2]).world_from_body);
      const Rigid3d step = second.Inverse() * last;
      const int gap = frames.front() - before.back();
      Rigid3d predicted = last;
      for (int k = 0; k < gap; ++k) predicted = predicted * step;
      double scale = 1.0;
      std::string scaled;
      if (monocular) {
        const double before_speed = MeanSpeed(*out, before, /*from_end=*/true, moved);
        const double own_speed = MeanSpeed(*out, frames, /*from_end=*/false, Sim3d());
        if (before_speed > 0.0 && own_speed > 0.0 && std::isfinite(before_speed / own_speed)) {
          scale = before_speed / own_speed;
          scaled = StrCat(", scaled by ", FormatFixed(scale, 4),
                          " to continue its speed (monocular: each segment has its own unit)");
        } else {
          scaled = ", not scaled (no speed to match: monocular segments keep their own units)";
        }
      }
      const Rigid3d& first = out->poses.at(frames.front()).world_from_body;
      correction[segment] =
          Sim3d(predicted) * Sim3d(scale, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) *
          Sim3d(first.Inverse());
      ScaleLogEntry entry;
      entry.frame_index = frames.front();
      entry.t_ns = out->poses.at(frames.front()).t_ns;
      entry.segment = segment;
      entry.event = "link";
      entry.applied = true;
      entry.applied_ratio = scale;
      entry.note = StrCat("segment ", segment, " placed by constant velocity from frame ", before.back(),
                          " of segment ", previous, " over ", gap, " frame(s)", scaled, " (no relocalisation)");
      out->scale_log.push_back(std::move(entry));
    }
    previous = segment;
  }
  MoveSegments(correction, out);
}

}  // namespace

std::map<int, int> SegmentOfPosedFrames(const OdometryOutput& out) {
  std::map<int, int> segment_of;
  for (const FrameRecord& record : out.records) {
    const int index = record.estimate.frame_index;
    if (out.poses.count(index) == 0) continue;
    auto reverse = out.reverse_posed.find(index);
    segment_of[index] = reverse != out.reverse_posed.end() ? reverse->second : record.estimate.segment;
  }
  return segment_of;
}

void MoveSegments(const std::map<int, Sim3d>& correction, OdometryOutput* out) {
  const std::map<int, int> segment_of = SegmentOfPosedFrames(*out);
  auto find = [&](int segment) -> const Sim3d* {
    auto it = correction.find(segment);
    return it == correction.end() ? nullptr : &it->second;
  };
  for (auto& [index, pose] : out->poses) {
    auto segment = segment_of.find(index);
    const Sim3d* c = segment == segment_of.end() ? nullptr : find(segment->second);
    if (c != nullptr) pose.world_from_body = c->TransformPose(pose.world_from_body);
  }
  std::map<int64_t, int> landmark_segment;
  for (KeyframeEstimate& kf : out->keyframes) {
    for (const MapObservation& ob : kf.observations) landmark_segment[ob.landmark_id] = kf.segment;
    const Sim3d* c = find(kf.segment);
    if (c == nullptr) continue;
    kf.world_from_rig = c->TransformPose(kf.world_from_rig);
    for (Eigen::Vector3d& p : kf.observation_points) p = *c * p;
  }
  for (auto& [id, position] : out->landmarks) {
    auto it = landmark_segment.find(id);
    const Sim3d* c = it == landmark_segment.end() ? nullptr : find(it->second);
    if (c != nullptr) position = *c * position;
  }
}

OdometryStage::OdometryStage(const Rig& rig, const PipelineOptions& options, int threads)
    : rig_(rig),
      options_(options),
      threads_(threads),
      estimator_(std::make_unique<Estimator>(rig, options.initializer, options.backend, threads)),
      reverse_(MakeReversePass(rig, options, options.initializer, threads)) {}

void OdometryStage::Consume(Estimator* estimator, ReversePass* reverse, const RigFrameObservations& frame,
                            double frontend_seconds, OdometryOutput* out) {
  const ScopedStage stage(StrCat("odometry: frame ", frame.frame_index));
  const Clock::time_point start = Clock::now();
  FrameEstimate est = estimator->AddFrame(frame);
  const double backend_seconds = SecondsSince(start);
  for (const PoseUpdate& update : est.poses) {
    out->poses[update.frame_index] = StampedPose{update.t_ns, update.frame_index, update.world_from_rig};
  }
  if (reverse != nullptr) reverse->Add(frame, est);
  std::vector<KeyframeEstimate> finished = estimator->TakeFinishedKeyframes();
  if (reverse != nullptr) reverse->AddKeyframes(finished);
  for (KeyframeEstimate& kf : finished) out->keyframes.push_back(std::move(kf));
  for (const MapLandmark& lm : estimator->TakeFinishedLandmarks()) out->landmarks[lm.id] = lm.position_world;
  for (ScaleLogEntry& entry : estimator->TakeScaleLog()) out->scale_log.push_back(std::move(entry));
  out->segments = std::max(out->segments, est.segment + 1);
  StageSeconds& t = out->totals;
  t.frontend += frontend_seconds;
  t.initializer += est.seconds_initializer;
  t.pnp += est.seconds_pnp;
  t.ba += est.seconds_ba;
  t.marginalization += est.seconds_marginalization;
  t.scale += est.seconds_scale;
  t.backend += backend_seconds;
  est.poses.clear();
  out->records.push_back({std::move(est), frame.cross_camera.size(), frontend_seconds, backend_seconds});
}

void OdometryStage::FinishEstimator(Estimator* estimator, ReversePass* reverse, OdometryOutput* out) {
  const ScopedStage stage("odometry: finishing the window");
  std::vector<KeyframeEstimate> finished = estimator->Finish();
  if (reverse != nullptr) reverse->AddKeyframes(finished);
  for (KeyframeEstimate& kf : finished) out->keyframes.push_back(std::move(kf));
  for (const MapLandmark& lm : estimator->TakeFinishedLandmarks()) out->landmarks[lm.id] = lm.position_world;
  for (ScaleLogEntry& entry : estimator->TakeScaleLog()) out->scale_log.push_back(std::move(entry));
}

void OdometryStage::Add(const RigFrameObservations& frame, double frontend_seconds) {
  Consume(estimator_.get(), reverse_.get(), frame, frontend_seconds, &out_);
  if (out_.poses.empty()) {
    unposed_.push_back(frame);
    unposed_frontend_seconds_.push_back(frontend_seconds);
  } else if (!unposed_.empty()) {
    unposed_.clear();
    unposed_.shrink_to_fit();
    unposed_frontend_seconds_.clear();
  }
}

OdometryOutput OdometryStage::Finish() {
  FinishEstimator(estimator_.get(), reverse_.get(), &out_);
  const double sigma = estimator_->SmallestRejectedScaleSigma();
  const double fallback = options_.initializer.max_relative_scale_sigma_fallback;
  const bool relax_sigma =
      std::isfinite(sigma) && sigma <= fallback && sigma > options_.initializer.max_relative_scale_sigma;
  const OverlapStartOptions& overlap = options_.initializer.overlap_start;
  // The overlap start reads cross-camera matches only (initializer.cc
  // TryOverlapStart): without any in the unposed frames, starting it
  // earlier changes nothing, and the pass again would repeat the first one
  // (a rig without overlapping views that never turned: every frame's
  // initialiser attempt, twice).
  bool any_cross = false;
  for (const RigFrameObservations& frame : unposed_) any_cross = any_cross || !frame.cross_camera.empty();
  const bool overlap_at_once =
      overlap.enable && overlap.after_failed_windows > 0 && rig_.NumCameras() >= 2 && any_cross;
  if (out_.poses.empty() && !unposed_.empty() && (relax_sigma || overlap_at_once)) {
    // Fallback: the same frames again with the relaxed bound, and the
    // overlap start at the first failed window; the first window that meets
    // them (and every other gate) initialises, so the forward segment is as
    // long as it can be and the back end's scale corrections, fused by their
    // uncertainty, get every later turn.
    InitializerOptions relaxed = options_.initializer;
    if (relax_sigma) {
      MCVO_LOG(kWarning, "run: no frame posed with the initializer's scale bound of ",
               FormatFixed(100.0 * options_.initializer.max_relative_scale_sigma, 2), " % (best window ",
               FormatFixed(100.0 * sigma, 2), " %); running again with the fallback bound of ",
               FormatFixed(100.0 * fallback, 2), " % (initializer.max_relative_scale_sigma_fallback)");
      relaxed.max_relative_scale_sigma = fallback;
    }
    if (overlap_at_once) {
      MCVO_LOG(kInfo, "run: no frame posed; running again with the overlap start at the first failed window ",
               "(initializer.overlap_start.after_failed_windows ", overlap.after_failed_windows, " -> 0)");
      relaxed.overlap_start.after_failed_windows = 0;
    }
    Estimator estimator(rig_, relaxed, options_.backend, threads_);
    reverse_ = MakeReversePass(rig_, options_, relaxed, threads_);
    OdometryOutput rerun;
    for (size_t k = 0; k < unposed_.size(); ++k) {
      Consume(&estimator, reverse_.get(), unposed_[k], unposed_frontend_seconds_[k], &rerun);
    }
    FinishEstimator(&estimator, reverse_.get(), &rerun);
    // Both passes' back-end time counts; the frontend ran once.
    rerun.totals.initializer += out_.totals.initializer;
    rerun.totals.backend += out_.totals.backend;
    for (ScaleLogEntry& entry : rerun.scale_log) {
      if (entry.event != "init") continue;
      if (relax_sigma) {
        entry.note += StrCat("; offline fallback: no window of the sequence met the scale bound of ",
                             FormatFixed(100.0 * options_.initializer.max_relative_scale_sigma, 2),
                             " %, this one met ", FormatFixed(100.0 * fallback, 2), " %");
      }
      if (overlap_at_once) entry.note += "; offline fallback: overlap start at the first failed window";
    }
    rerun.passes = out_.passes + 1;
    out_ = std::move(rerun);
    if (relax_sigma) out_.fallback_sigma = fallback;
  }
  MonocularFallback();
  unposed_.clear();
  if (reverse_) {
    const Clock::time_point start = Clock::now();
    ApplyReversePass(reverse_->Run(), &out_);
    out_.reverse_seconds = SecondsSince(start);
    reverse_.reset();
  }
  if (out_.segments > 1) LinkSegments(rig_.NumCameras() == 1 || out_.monocular_camera >= 0, &out_);
  std::stable_sort(
      out_.keyframes.begin(), out_.keyframes.end(),
      [](const KeyframeEstimate& a, const KeyframeEstimate& b) { return a.frame_index < b.frame_index; });
  std::stable_sort(out_.scale_log.begin(), out_.scale_log.end(),
                   [](const ScaleLogEntry& a, const ScaleLogEntry& b) { return a.frame_index < b.frame_index; });
  return std::move(out_);
}

// When nothing was posed because the rig's metric scale was never
// observable (the most frequent waiting reason): the frames again with the
// camera that tracked the most features alone, as monocular odometry at an
// arbitrary scale (estimator.h "Monocular"); kept when it poses anything.
void OdometryStage::MonocularFallback() {
  const ScopedStage stage("odometry: monocular fallback");
  if (!out_.poses.empty() || unposed_.empty() || rig_.NumCameras() < 2 ||
      !options_.initializer.monocular_fallback) {
    return;
  }
  std::vector<std::string> reasons;
  std::vector<int64_t> features(static_cast<size_t>(rig_.NumCameras()), 0);
  for (const FrameRecord& record : out_.records) {
    reasons.push_back(record.estimate.waiting_reason);
    for (size_t c = 0; c < features.size() && c < record.estimate.features_per_camera.size(); ++c) {
      features[c] += record.estimate.features_per_camera[c];
    }
  }
  const std::string why = MostFrequentPosingFailure(reasons);
  if (why != kScaleNeverObservable) return;
  const int camera = static_cast<int>(std::max_element(features.begin(), features.end()) - features.begin());
  Rig mono = rig_;
  mono.cameras = {rig_.cameras[static_cast<size_t>(camera)]};
  mono.cameras.front().cam_from_rig.translation.setZero();  // its centre: run.cc MonocularIndex
  const std::string& name = mono.cameras.front().name;
  MCVO_LOG(kWarning, "run: no frame posed: ", why, "; running again with ", name,
           " alone (the camera with the most tracked features), as monocular odometry at an arbitrary scale "
           "(initializer.monocular_fallback)");
  Estimator estimator(mono, options_.initializer, options_.backend, threads_);
  std::unique_ptr<ReversePass> reverse = MakeReversePass(mono, options_, options_.initializer, threads_);
  OdometryOutput rerun;
  for (size_t k = 0; k < unposed_.size(); ++k) {
    const RigFrameObservations& frame = unposed_[k];
    RigFrameObservations one;
    one.frame_index = frame.frame_index;
    one.t_ns = frame.t_ns;
    one.cameras = {frame.cameras[static_cast<size_t>(camera)]};
    if (!frame.camera_missing.empty()) one.camera_missing = {frame.camera_missing[static_cast<size_t>(camera)]};
    Consume(&estimator, reverse.get(), one, unposed_frontend_seconds_[k], &rerun);
  }
  FinishEstimator(&estimator, reverse.get(), &rerun);
  ++out_.passes;
  if (rerun.poses.empty()) {
    MCVO_LOG(kWarning, "run: ", name, " alone posed no frame either");
    return;
  }
  rerun.totals.initializer += out_.totals.initializer;
  rerun.totals.backend += out_.totals.backend;
  rerun.passes = out_.passes;
  rerun.monocular_camera = camera;
  rerun.monocular_reason = why;
  for (ScaleLogEntry& entry : rerun.scale_log) {
    if (entry.event == "init") {
      entry.note += StrCat("; offline fallback: ", why, ", so ", name, " alone at an arbitrary scale");
    }
  }
  out_ = std::move(rerun);
  reverse_ = std::move(reverse);
}

std::string FrameStatsCsv(const Rig& rig, const OdometryOutput& odometry) {
  std::string csv =
      "frame,t_ns,state,segment,keyframe,has_pose,pose_source,pnp_inliers,landmarks,ba_iterations,"
      "ba_initial_cost,ba_final_cost";
  for (const Camera& camera : rig.cameras) csv += ",features_" + camera.name;
  for (const Camera& camera : rig.cameras) csv += ",landmarks_" + camera.name;
  csv += ",cross_camera,note\n";
  for (const FrameRecord& record : odometry.records) {
    const FrameEstimate& est = record.estimate;
    auto reverse = odometry.reverse_posed.find(est.frame_index);
    const bool has_pose = odometry.poses.count(est.frame_index) != 0;
    const char* source = reverse != odometry.reverse_posed.end() ? "reverse" : has_pose ? "forward" : "none";
    const int segment = reverse != odometry.reverse_posed.end() ? reverse->second : est.segment;
    csv += StrCat(est.frame_index, ",", est.t_ns, ",", EnumToName(kEstimatorStateNames, est.state), ",", segment,
                  ",", est.keyframe ? 1 : 0, ",", has_pose ? 1 : 0, ",", source, ",", est.pnp_inliers, ",",
                  est.num_landmarks, ",", est.ba_iterations, ",", FormatDouble(est.ba_initial_cost), ",",
                  FormatDouble(est.ba_final_cost));
    for (int n : est.features_per_camera) csv += StrCat(",", n);
    for (int n : est.landmarks_per_camera) csv += StrCat(",", n);
    csv += StrCat(",", record.cross_camera, ",", CsvQuote(est.waiting_reason), "\n");
  }
  return csv;
}

std::string TimingCsv(const OdometryOutput& odometry) {
  std::string csv =
      "frame,t_ns,frontend_s,initializer_s,pnp_s,ba_s,marginalization_s,scale_correction_s,backend_s\n";
  for (const FrameRecord& record : odometry.records) {
    const FrameEstimate& est = record.estimate;
    csv += StrCat(est.frame_index, ",", est.t_ns, ",", FormatFixed(record.frontend_seconds, 6), ",",
                  FormatFixed(est.seconds_initializer, 6), ",", FormatFixed(est.seconds_pnp, 6), ",",
                  FormatFixed(est.seconds_ba, 6), ",", FormatFixed(est.seconds_marginalization, 6), ",",
                  FormatFixed(est.seconds_scale, 6), ",", FormatFixed(record.backend_seconds, 6), "\n");
  }
  return csv;
}

}  // namespace mcvo::pipeline_internal
