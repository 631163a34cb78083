// The estimator's orchestration (estimator.h): initialisation and its
// hand-off, per-frame tracking, keyframe choice, segments. The window's
// data live in LandmarkWindow (landmark_window.h), its optimisation in
// WindowProblem (window_problem.h), the scale correction in
// WindowScaleCorrector (window_scale.h).
#include "mcvo/backend/estimator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <map>
#include <optional>
#include <utility>

#include <Eigen/Geometry>

#include "cross_camera_filter.h"
#include "landmark_window.h"
#include "mcvo/backend/rig_pnp.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"
#include "window_problem.h"
#include "window_scale.h"

namespace mcvo {
namespace {

using backend_internal::kMaxLandmarkDistanceM;
using backend_internal::kMinLandmarkDistanceM;
using backend_internal::LandmarkObservation;
using backend_internal::LandmarkWindow;
using backend_internal::WindowFrame;
using backend_internal::WindowLandmark;
using backend_internal::WindowProblem;
using backend_internal::WindowScaleCorrector;

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

std::string ScaleSourceNote(const InitializationResult& init, const Rig& rig) {
  if (init.source == ScaleSource::kArbitrary) {
    return StrCat("arbitrary scale (one camera, ", rig.cameras[init.principal_camera].name,
                  "): unit = its travel over the initialisation window, frames ", init.frame_index.front(),
                  "-", init.frame_index.back());
  }
  return StrCat("scale from ",
                init.source == ScaleSource::kRigRotation    ? "rig rotation"
                : init.source == ScaleSource::kCrossCamera  ? "cross-camera baseline"
                : init.source == ScaleSource::kOverlapStart ? "overlapping views without motion"
                                                            : "rig rotation and cross-camera baseline",
                "; principal camera ", rig.cameras[init.principal_camera].name, "; ",
                init.cross_camera_matches, " cross-camera matches");
}

}  // namespace

struct Estimator::Impl {
  Impl(const Rig& rig_in, const InitializerOptions& init_options_in, const BackendOptions& options_in,
       int threads_in)
      : rig(rig_in),
        init_options(init_options_in),
        options(options_in),
        threads(std::max(1, threads_in)),
        initializer(rig_in, init_options_in, threads),
        // window_size keyframes, the newest frame, and the frame being tracked.
        window(rig_in.CamFromRig(), options_in, options_in.window_size + 2),
        problem(rig_in, options_in),
        scale(rig_in, options_in) {}

  const Rig rig;
  const bool monocular = rig.NumCameras() == 1;  // estimator.h "Monocular"
  const InitializerOptions init_options;
  const BackendOptions options;
  const int threads;
  Initializer initializer;
  LandmarkWindow window;
  WindowProblem problem;
  WindowScaleCorrector scale;

  EstimatorState state = EstimatorState::kInitializing;
  int segment = 0;
  std::deque<RigFrameObservations> init_buffer;  // recent frames while initialising
  int solves_since_correction = 0;
  // Last two poses (constant-velocity prediction; placing a new segment).
  std::optional<Rigid3d> last_pose, previous_pose;

  std::vector<KeyframeEstimate> finished_keyframes;
  std::vector<ScaleLogEntry> scale_log;

  void Solve(FrameEstimate* estimate) {
    if (problem.Solve(&window, monocular, estimate)) ++solves_since_correction;
  }

  void MarginalizeOldest(FrameEstimate* estimate) {
    const auto start = std::chrono::steady_clock::now();
    problem.MarginalizeOldest(&window);
    const WindowFrame* oldest = window.frames().front();
    finished_keyframes.push_back(window.FinishedKeyframe(oldest));
    window.RemoveFrameObservations(oldest);
    window.PopFront();
    estimate->seconds_marginalization += Seconds(start);
  }

  // Step 5: parallax to the last keyframe after rotation compensation, or
  // too few tracked landmarks in a camera, or too few triangulated ones
  // tracked over the rig.
  bool IsKeyframe(const WindowFrame& newest) const {
    const WindowFrame* last_keyframe = nullptr;
    for (auto it = window.frames().rbegin(); it != window.frames().rend(); ++it) {
      if ((*it)->keyframe && *it != &newest) {
        last_keyframe = *it;
        break;
      }
    }
    if (last_keyframe == nullptr) return true;
    const auto& landmarks = window.landmarks();
    // Tracked landmarks per camera.
    int cameras_tracking = 0;  // cameras with at least keyframe_min_tracked features
    int usable_total = 0;
    for (int c = 0; c < static_cast<int>(newest.obs.cameras.size()); ++c) {
      const auto& features = newest.obs.cameras[c];
      const bool tracking = static_cast<int>(features.size()) >= options.keyframe_min_tracked;
      cameras_tracking += tracking ? 1 : 0;
      int tracked = 0;
      for (const FeatureObservation& f : features) {
        auto it = landmarks.find(f.id);
        if (it == landmarks.end()) continue;
        ++tracked;
        usable_total += window.UsableInBa(it->second) ? 1 : 0;
      }
      if (tracking && tracked < options.keyframe_min_tracked) return true;
    }
    // Too few triangulated landmarks tracked over the rig (per camera that
    // tracks enough features) for the PnP of the next frames. Far points
    // under slow motion stay at their initial depth for tens of frames;
    // counted above as tracked, they let a forward stereo pair in open
    // country run out of usable ones with no keyframe to make new ones from
    // its cross-camera matches, and lose track. Summed over the rig, so that
    // one camera facing far scenery does not make every frame a keyframe
    // while the others hold the pose (results/keyframe_usable_landmarks.md).
    if (usable_total < options.keyframe_min_tracked * cameras_tracking) return true;
    // Rotation-compensated parallax against the last keyframe.
    double sum = 0.0;
    int count = 0;
    for (int c = 0; c < static_cast<int>(newest.obs.cameras.size()); ++c) {
      const Eigen::Quaterniond new_from_kf = (window.WorldFromCam(newest, c).rotation.conjugate() *
                                              window.WorldFromCam(*last_keyframe, c).rotation);
      for (const FeatureObservation& f : newest.obs.cameras[c]) {
        auto it = landmarks.find(f.id);
        if (it == landmarks.end()) continue;
        for (const LandmarkObservation& ob : it->second.observations) {
          if (ob.frame != last_keyframe || ob.camera != c) continue;
          const Eigen::Vector3d rotated = new_from_kf * ob.bearing;
          sum += std::acos(std::clamp(rotated.dot(f.bearing.normalized()), -1.0, 1.0));
          ++count;
        }
      }
    }
    if (count == 0) return true;
    return sum / count * options.virtual_focal_px >= options.keyframe_parallax_px;
  }

  // ---------------------------------------------------------------- initialisation

  // The initialisation's frames enter the window as keyframes, placed in
  // the segment's world: the first segment's world is the rig at the anchor
  // frame; a later one is placed at the last good pose.
  void WindowFromInitialization(const InitializationResult& init) {
    const Rigid3d world_from_init = segment > 0 && last_pose ? *last_pose : Rigid3d();
    window.Clear();
    problem.ResetPrior();
    solves_since_correction = 0;
    for (size_t k = 0; k < init.frame_index.size(); ++k) {
      auto it = std::find_if(init_buffer.begin(), init_buffer.end(), [&](const RigFrameObservations& f) {
        return f.frame_index == init.frame_index[k];
      });
      MCVO_CHECK_MSG(it != init_buffer.end(), "initialisation frame ", init.frame_index[k], " not buffered");
      WindowFrame* frame = window.AcquireFrame();
      frame->frame_index = it->frame_index;
      frame->t_ns = it->t_ns;
      frame->segment = segment;
      frame->keyframe = true;
      frame->obs = *it;
      backend_internal::DropFarCrossCameraObservations(rig, options.cross_camera_min_angle_deg, &frame->obs);
      frame->SetWorldFromRig(world_from_init * init.world_from_rig[k]);
      window.PushBack(frame);
    }
    while (static_cast<int>(window.frames().size()) > options.window_size) {
      // No landmark exists yet: these keyframes leave without observations.
      finished_keyframes.push_back(window.FinishedKeyframe(window.frames().front()));
      window.PopFront();
    }
    // Landmarks: anchored in the first window frame that saw them; depth
    // from the initialisation where it has the point.
    std::map<uint64_t, Eigen::Vector3d> init_points;
    for (const auto& lm : init.landmarks) init_points[lm.id] = world_from_init * lm.point_in_world;
    auto& landmarks = window.landmarks();
    for (WindowFrame* frame : window.frames()) {
      window.CreateLandmarks(frame);
      for (auto& [id, ob] : window.FrameObservations(frame)) {
        auto it = landmarks.find(id);
        if (it == landmarks.end() || it->second.anchor_frame == frame) continue;
        if (LandmarkWindow::HasObservation(it->second, frame, ob.camera)) continue;
        it->second.observations.push_back(ob);
      }
    }
    for (auto& [id, lm] : landmarks) {
      auto point = init_points.find(id);
      if (point != init_points.end()) {
        const double depth =
            (window.WorldFromCam(*lm.anchor_frame, lm.anchor_camera).Inverse() * point->second)
                .dot(lm.anchor_bearing);
        if (depth > kMinLandmarkDistanceM && depth < kMaxLandmarkDistanceM) {
          lm.inverse_depth = 1.0 / depth;
          lm.triangulated = true;
          continue;
        }
      }
      window.Triangulate(&lm);
    }
  }

  void StartFromInitialization(const InitializationResult& init, FrameEstimate* estimate,
                               bool fixed_poses = false) {
    WindowFromInitialization(init);
    if (fixed_poses) {
      for (WindowFrame* frame : window.frames()) frame->pose_fixed = true;
    }
    Solve(estimate);
    window.RemoveOutliers();
    window.TriangulatePending();
    const std::deque<WindowFrame*>& frames = window.frames();
    for (const WindowFrame* frame : frames)
      estimate->poses.push_back({frame->frame_index, frame->t_ns, frame->WorldFromRig()});
    previous_pose =
        frames.size() >= 2 ? std::optional<Rigid3d>(frames[frames.size() - 2]->WorldFromRig()) : std::nullopt;
    last_pose = frames.back()->WorldFromRig();

    ScaleLogEntry entry;
    entry.frame_index = frames.back()->frame_index;
    entry.t_ns = frames.back()->t_ns;
    entry.segment = segment;
    entry.event = segment == 0 ? "init" : "reinit";
    entry.camera_scales = init.camera_scales;
    entry.rms_residual_m = init.rig_scale.rms_residual_m;
    entry.singular_value_ratio = init.rig_scale.singular_value_ratio;
    entry.applied = true;
    // The initialiser's scale std (its bound when it reported none).
    const double init_sigma =
        init.relative_scale_sigma > 0.0 ? init.relative_scale_sigma : init_options.max_relative_scale_sigma;
    scale.filter().Start(init_sigma, last_pose->translation);
    entry.scale_sigma = init.source == ScaleSource::kArbitrary ? 0.0 : init_sigma;
    entry.note = ScaleSourceNote(init, rig);
    if (init.attempts > 0 || init.skipped_windows > 0) {
      entry.note += StrCat("; after ", init.attempts, " rejected windows and ", init.skipped_windows,
                           " not attempted (initializer.max_skipped_windows)");
    }
    scale_log.push_back(std::move(entry));
    init_buffer.clear();
    state = EstimatorState::kTracking;
  }

  // The estimate of `input` before anything is done with it: its features per camera.
  FrameEstimate NewEstimate(const RigFrameObservations& input) const {
    FrameEstimate estimate;
    estimate.frame_index = input.frame_index;
    estimate.t_ns = input.t_ns;
    estimate.features_per_camera.assign(rig.NumCameras(), 0);
    estimate.landmarks_per_camera.assign(rig.NumCameras(), 0);
    for (int c = 0; c < rig.NumCameras(); ++c) {
      estimate.features_per_camera[c] = static_cast<int>(input.cameras[c].size());
    }
    return estimate;
  }

  // Estimator::StartFromPoses: the known poses enter like an initialisation
  // window (landmarks triangulated from the poses), in this world as given.
  FrameEstimate StartFromPoses(const std::vector<RigFrameObservations>& frames,
                               const std::vector<Rigid3d>& world_from_rig, double relative_scale_sigma,
                               const std::string& note) {
    MCVO_CHECK_MSG(state == EstimatorState::kInitializing && segment == 0 && init_buffer.empty() &&
                       window.frames().empty() && !last_pose,
                   "StartFromPoses: only before the first frame");
    MCVO_CHECK_MSG(frames.size() == world_from_rig.size() && frames.size() >= 2 &&
                       static_cast<int>(frames.size()) <= options.window_size,
                   "StartFromPoses: ", frames.size(), " frames, ", world_from_rig.size(), " poses (2 to ",
                   options.window_size, " needed)");
    MCVO_CHECK_MSG(relative_scale_sigma > 0.0, "StartFromPoses: scale sigma ", relative_scale_sigma);
    InitializationResult init;
    for (size_t k = 0; k < frames.size(); ++k) {
      MCVO_CHECK_MSG(static_cast<int>(frames[k].cameras.size()) == rig.NumCameras(), "frame ",
                     frames[k].frame_index, " has ", frames[k].cameras.size(), " cameras, the rig ",
                     rig.NumCameras());
      MCVO_CHECK_MSG(k == 0 || frames[k].frame_index > frames[k - 1].frame_index,
                     "StartFromPoses: frames not in increasing frame_index");
      init.frame_index.push_back(frames[k].frame_index);
      init.t_ns.push_back(frames[k].t_ns);
      init.world_from_rig.push_back(world_from_rig[k]);
      init_buffer.push_back(frames[k]);
    }
    init.anchor_frame_index = frames.front().frame_index;
    init.camera_used.assign(rig.NumCameras(), true);
    init.camera_scales.assign(rig.NumCameras(), 0.0);
    init.relative_scale_sigma = relative_scale_sigma;
    FrameEstimate estimate = NewEstimate(frames.back());
    StartFromInitialization(init, &estimate, /*fixed_poses=*/true);
    scale_log.back().event = "seeded";
    scale_log.back().note = note;
    estimate.has_pose = true;
    estimate.world_from_rig = window.frames().back()->WorldFromRig();
    estimate.keyframe = true;
    estimate.state = state;
    estimate.segment = segment;
    return estimate;
  }

  void StartNewSegment() {
    ++segment;
    state = EstimatorState::kInitializing;
    initializer.Reset();
    init_buffer.clear();
    for (const WindowFrame* frame : window.frames()) {
      if (frame->keyframe) finished_keyframes.push_back(window.FinishedKeyframe(frame));
    }
    window.FinishAllLandmarks();
    window.Clear();
    problem.ResetPrior();
  }

  // ---------------------------------------------------------------- per frame

  FrameEstimate AddFrame(const RigFrameObservations& input) {
    MCVO_CHECK_MSG(static_cast<int>(input.cameras.size()) == rig.NumCameras(), "frame ", input.frame_index,
                   " has ", input.cameras.size(), " cameras, the rig ", rig.NumCameras());
    FrameEstimate estimate = NewEstimate(input);
    if (state == EstimatorState::kTracking && !Track(input, &estimate)) {
      // Lost: a new segment starts with this frame.
      StartNewSegment();
      ScaleLogEntry entry;
      entry.frame_index = input.frame_index;
      entry.t_ns = input.t_ns;
      entry.segment = segment;
      entry.event = "lost";
      entry.note = StrCat("tracking lost: ", estimate.waiting_reason);
      scale_log.push_back(std::move(entry));
    }
    if (state == EstimatorState::kInitializing) {
      const auto start = std::chrono::steady_clock::now();
      init_buffer.push_back(input);
      while (static_cast<int>(init_buffer.size()) > init_options.window_size) init_buffer.pop_front();
      std::optional<InitializationResult> init = initializer.AddFrame(input);
      estimate.seconds_initializer = Seconds(start);
      if (init) {
        StartFromInitialization(*init, &estimate);
        estimate.has_pose = true;
        estimate.world_from_rig = window.frames().back()->WorldFromRig();
        estimate.keyframe = true;
      } else {
        estimate.waiting_reason = initializer.WaitingReason();
      }
    }
    estimate.state = state;
    estimate.segment = segment;
    return estimate;
  }

  // Step 1: the frame's pose by rig PnP against the window's landmarks,
  // from the constant-velocity prediction. Null when it fails (the frame
  // goes back to the pool).
  WindowFrame* PoseNewFrame(const RigFrameObservations& input, FrameEstimate* estimate,
                            std::vector<std::pair<uint64_t, LandmarkObservation>>* inlier_observations) {
    WindowFrame* frame = window.AcquireFrame();
    frame->frame_index = input.frame_index;
    frame->t_ns = input.t_ns;
    frame->segment = segment;
    frame->obs = input;
    backend_internal::DropFarCrossCameraObservations(rig, options.cross_camera_min_angle_deg, &frame->obs);
    for (auto& features : frame->obs.cameras) {
      for (FeatureObservation& f : features) f.bearing.normalize();
    }
    Rigid3d prediction = *last_pose;
    if (previous_pose) prediction = *last_pose * (previous_pose->Inverse() * *last_pose);

    const auto pnp_start = std::chrono::steady_clock::now();
    const auto& landmarks = window.landmarks();
    std::vector<RigPnpCorrespondence> correspondences;
    std::vector<uint64_t> correspondence_ids;
    auto observations = window.FrameObservations(frame);
    for (const auto& [id, ob] : observations) {
      auto it = landmarks.find(id);
      if (it == landmarks.end() || !window.UsableInBa(it->second)) continue;
      correspondences.push_back({ob.camera, ob.bearing, window.LandmarkInWorld(it->second)});
      correspondence_ids.push_back(id);
    }
    RigPnpOptions pnp_options;
    pnp_options.threshold_px = options.pnp_threshold_px;
    pnp_options.focal_px = options.virtual_focal_px;
    pnp_options.min_inliers = options.min_pnp_inliers;
    const RigPnpResult pnp = SolveRigPnp(window.cam_from_rig(), correspondences, pnp_options, &prediction);
    estimate->seconds_pnp = Seconds(pnp_start);
    estimate->pnp_inliers = pnp.num_inliers;
    if (!pnp.ok) {
      estimate->waiting_reason = StrCat("rig pose failed: ", pnp.reason);
      window.ReleaseFrame(frame);  // never entered the window
      return nullptr;
    }
    frame->SetWorldFromRig(pnp.world_from_rig);
    // Observations of existing landmarks; PnP outliers are left out.
    std::map<std::pair<uint64_t, int>, bool> outlier;
    for (size_t k = 0; k < correspondences.size(); ++k) {
      if (!pnp.inliers[k]) outlier[{correspondence_ids[k], correspondences[k].camera}] = true;
    }
    for (const auto& [id, ob] : observations) {
      if (landmarks.count(id) == 0 || outlier.count({id, ob.camera}) != 0) continue;
      inlier_observations->push_back({id, ob});
    }
    return frame;
  }

  // Returns false when the frame's pose cannot be found.
  bool Track(const RigFrameObservations& input, FrameEstimate* estimate) {
    // A non-keyframe newest frame is dropped now.
    if (!window.frames().empty() && !window.frames().back()->keyframe) {
      window.RemoveFrameObservations(window.frames().back());
      window.PopBack();
    }
    std::vector<std::pair<uint64_t, LandmarkObservation>> observations;
    WindowFrame* raw = PoseNewFrame(input, estimate, &observations);
    if (raw == nullptr) return false;
    window.PushBack(raw);
    auto& landmarks = window.landmarks();
    for (const auto& [id, ob] : observations) {
      WindowLandmark& lm = landmarks.at(id);
      if (LandmarkWindow::HasObservation(lm, raw, ob.camera)) continue;
      lm.observations.push_back(ob);
    }
    window.TriangulatePending();

    const auto ba_start = std::chrono::steady_clock::now();
    Solve(estimate);
    window.RemoveOutliers();
    estimate->seconds_ba = Seconds(ba_start);

    raw->keyframe = IsKeyframe(*raw);
    if (raw->keyframe) {
      window.CreateLandmarks(raw);
      if (window.NumKeyframes() > options.window_size) MarginalizeOldest(estimate);
    }
    // Scale correction once due, in the first window that turns enough for
    // the rig constraint to hold the scale (on a straight it cannot).
    // Not while poses known from elsewhere are in the window (StartFromPoses):
    // they hold the scale.
    const bool any_fixed = std::any_of(window.frames().begin(), window.frames().end(),
                                       [](const WindowFrame* f) { return f->pose_fixed; });
    if (!monocular && !any_fixed && options.scale_correction_period > 0 &&
        solves_since_correction >= options.scale_correction_period &&
        window.RotationDeg() >= options.scale_correction_min_rotation_deg) {
      const auto start = std::chrono::steady_clock::now();
      WindowScaleCorrector::Outcome correction =
          scale.Correct(*raw, segment, &window, &problem, &last_pose, &previous_pose);
      if (correction.measured) solves_since_correction = 0;
      scale_log.push_back(std::move(correction.entry));
      estimate->seconds_scale += Seconds(start);
    }

    // Report.
    for (const auto& [id, lm] : landmarks) {
      if (!window.UsableInBa(lm)) continue;
      ++estimate->num_landmarks;
      for (const LandmarkObservation& ob : lm.observations) {
        if (ob.frame == raw) ++estimate->landmarks_per_camera[ob.camera];
      }
    }
    estimate->has_pose = true;
    estimate->world_from_rig = raw->WorldFromRig();
    estimate->keyframe = raw->keyframe;
    estimate->poses.push_back({raw->frame_index, raw->t_ns, raw->WorldFromRig()});
    previous_pose = last_pose;
    last_pose = raw->WorldFromRig();
    return true;
  }

  std::vector<KeyframeEstimate> Finish() {
    std::vector<KeyframeEstimate> out = std::move(finished_keyframes);
    finished_keyframes.clear();
    for (const WindowFrame* frame : window.frames()) {
      if (frame->keyframe) out.push_back(window.FinishedKeyframe(frame));
    }
    window.FinishAllLandmarks();
    return out;
  }
};

Estimator::Estimator(const Rig& rig, const InitializerOptions& init_options, const BackendOptions& options,
                     int threads)
    : impl_(std::make_unique<Impl>(rig, init_options, options, threads)) {}
Estimator::~Estimator() = default;

FrameEstimate Estimator::AddFrame(const RigFrameObservations& frame) { return impl_->AddFrame(frame); }

FrameEstimate Estimator::StartFromPoses(const std::vector<RigFrameObservations>& frames,
                                        const std::vector<Rigid3d>& world_from_rig,
                                        double relative_scale_sigma, const std::string& note) {
  return impl_->StartFromPoses(frames, world_from_rig, relative_scale_sigma, note);
}

std::vector<KeyframeEstimate> Estimator::TakeFinishedKeyframes() {
  std::vector<KeyframeEstimate> out = std::move(impl_->finished_keyframes);
  impl_->finished_keyframes.clear();
  return out;
}

std::vector<ScaleLogEntry> Estimator::TakeScaleLog() {
  std::vector<ScaleLogEntry> out = std::move(impl_->scale_log);
  impl_->scale_log.clear();
  return out;
}

std::vector<MapLandmark> Estimator::TakeFinishedLandmarks() { return impl_->window.TakeFinishedLandmarks(); }

std::vector<KeyframeEstimate> Estimator::Finish() { return impl_->Finish(); }

double Estimator::SmallestRejectedScaleSigma() const {
  return impl_->initializer.SmallestRejectedScaleSigma();
}

std::vector<int> Estimator::PendingFrames() const {
  std::vector<int> frames;
  for (const backend_internal::WindowFrame* frame : impl_->window.frames())
    frames.push_back(frame->frame_index);
  for (const RigFrameObservations& frame : impl_->init_buffer) frames.push_back(frame.frame_index);
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  return frames;
}

}  // namespace mcvo
