// Metric initialisation of the rig (see initializer.h for the steps).
#include "mcvo/initializer/initializer.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "bearing_residual.h"
#include "cross_camera_scale.h"
#include "scale_screen.h"
#include "mcvo/initializer/overlap_start.h"
#include "mcvo/initializer/rig_window_ba.h"
#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

using initializer_internal::AngleBetween;
using initializer_internal::BearingsById;
using initializer_internal::CrossCameraMeasurements;
using initializer_internal::DropCamera;
using initializer_internal::RelativeSigmas;
using initializer_internal::ScaleScreen;
using initializer_internal::ScreenScale;
using initializer_internal::RobustSpread;

bool Missing(const RigFrameObservations& frame, int camera) {
  return static_cast<size_t>(camera) < frame.camera_missing.size() &&
         frame.camera_missing[static_cast<size_t>(camera)];
}

// Trigger statistics of one camera between an anchor candidate and the newest frame.
struct CameraParallax {
  int correspondences = 0;
  double parallax_px = 0.0;  // mean angle between the two bearings, pixels at the virtual focal
  bool missing = false;
  bool passes = false;
};

}  // namespace

struct Initializer::Impl {
  Impl(const Rig& rig_in, const InitializerOptions& options_in, int threads_in)
      : rig(rig_in), options(options_in), threads(threads_in), required(rig_in.cameras.size(), false) {
    try {
      options.Check();
    } catch (const InputError& e) {
      MCVO_CHECK_MSG(false, "initializer options were not checked: ", e.what());
    }
    MCVO_CHECK_MSG(threads >= 1, "threads must be >= 1, got ", threads);
    MCVO_CHECK_MSG(rig.NumCameras() >= 1, "rig has no camera");
    if (options.required_cameras.empty()) {
      required.assign(required.size(), true);
    } else {
      for (const std::string& name : options.required_cameras) {
        const int c = rig.FindCamera(name);
        MCVO_CHECK_MSG(c >= 0, "required camera \"", name, "\" is not in the rig");
        required[static_cast<size_t>(c)] = true;
      }
    }
    Reset();
  }

  void Reset() {
    window.clear();
    reason = StrCat("window 0/", options.window_size);
    spent = false;
    attempts = 0;
    failed_windows = 0;
    blocked_windows = 0;
    windows_to_skip = 0;
    skipped_windows = 0;
  }

  // initializer.h max_skipped_windows: after the linear screen rejected a
  // window with a best scale sigma `ratio` times its bound, floor(log2 ratio)
  // windows, at most max_skipped_windows (all for infinity: no camera had a
  // positive scale); 0 for a rejection of another kind (ratio 0).
  int WindowsToSkip(double ratio) const {
    if (!(ratio >= 2.0)) return 0;
    if (!std::isfinite(ratio)) return options.max_skipped_windows;
    return std::min(options.max_skipped_windows, static_cast<int>(std::floor(std::log2(ratio))));
  }

  int NumCameras() const { return rig.NumCameras(); }
  // A one-camera rig: monocular, its scale arbitrary (initializer.h "Monocular").
  bool Monocular() const { return rig.NumCameras() == 1; }
  // The fewest cameras that must pass (a one-camera rig has one).
  int MinCamerasPassing() const { return std::min(options.min_cameras_passing, NumCameras()); }
  // initializer.h "Cameras that never pass": after relax_required_after_windows
  // windows held up only by required cameras, any MinCamerasPassing() do.
  bool Relaxed() const {
    return options.relax_required_after_windows >= 0 && blocked_windows >= options.relax_required_after_windows;
  }
  std::string BlockedNote() const {
    if (options.relax_required_after_windows < 0) return "";
    return StrCat("; held up by required cameras ", blocked_windows, "/", options.relax_required_after_windows,
                  " windows");
  }

  std::optional<InitializationResult> AddFrame(const RigFrameObservations& frame) {
    MCVO_CHECK_MSG(static_cast<int>(frame.cameras.size()) == NumCameras(), "frame ", frame.frame_index,
                   " has ", frame.cameras.size(), " camera lists, the rig has ", NumCameras(), " cameras");
    MCVO_CHECK_MSG(
        frame.camera_missing.empty() || static_cast<int>(frame.camera_missing.size()) == NumCameras(),
        "frame ", frame.frame_index, ": camera_missing has ", frame.camera_missing.size(), " entries");
    if (spent) {
      reason = "already initialised (call Reset() to initialise again)";
      return std::nullopt;
    }
    MCVO_CHECK_MSG(window.empty() || frame.frame_index > window.back().frame_index, "frame index ",
                   frame.frame_index, " does not increase (previous ", window.back().frame_index, ")");
    window.push_back(frame);
    while (static_cast<int>(window.size()) > options.window_size) window.pop_front();
    if (static_cast<int>(window.size()) < options.window_size) {
      reason = StrCat("window ", window.size(), "/", options.window_size);
      return std::nullopt;
    }
    int anchor = -1;
    std::vector<bool> passing;
    std::optional<InitializationResult> result;
    if (Trigger(&anchor, &passing)) {
      if (windows_to_skip > 0) {
        --windows_to_skip;
        ++skipped_windows;
        reason = StrCat(skip_reason, "; window not attempted",
                        windows_to_skip > 0 ? StrCat(", ", windows_to_skip, " more") : std::string(),
                        " (initializer.max_skipped_windows)");
      } else {
        result = Initialise(anchor, passing);  // a poor scale sets windows_to_skip
        if (!result) {
          ++attempts;
          skip_reason = reason;
        }
      }
    }
    if (!result) result = TryOverlapStart();
    if (!result) return std::nullopt;
    spent = true;
    reason = "initialised";
    return result;
  }

  // After the motion initialisation of a full window failed (reason set):
  // the overlap start, once enabled and after_failed_windows have failed.
  // On failure its reason follows the motion initialisation's.
  std::optional<InitializationResult> TryOverlapStart() {
    ++failed_windows;
    const OverlapStartOptions& o = options.overlap_start;
    if (!o.enable || NumCameras() < 2 || failed_windows <= o.after_failed_windows) return std::nullopt;
    bool any_cross = false;
    for (const RigFrameObservations& frame : window) any_cross = any_cross || !frame.cross_camera.empty();
    if (!any_cross) return std::nullopt;  // no overlapping views: nothing to say
    std::string why;
    std::optional<InitializationResult> result = InitialiseFromOverlap(rig, window, options, &why);
    if (!result) {
      reason = StrCat(reason, "; ", why);
      return std::nullopt;
    }
    result->attempts = attempts;
    result->skipped_windows = skipped_windows;
    return result;
  }

  // Step 1: the anchor frame l (window position) and the cameras that pass there.
  bool Trigger(int* anchor, std::vector<bool>* passing) {
    const int newest = static_cast<int>(window.size()) - 1;
    std::vector<std::map<uint64_t, Eigen::Vector3d>> newest_bearings(static_cast<size_t>(NumCameras()));
    for (int c = 0; c < NumCameras(); ++c) {
      newest_bearings[static_cast<size_t>(c)] =
          BearingsById(window[static_cast<size_t>(newest)].cameras[static_cast<size_t>(c)]);
    }
    int best_l = -1, best_count = -1;
    std::vector<CameraParallax> best_stats;
    int relaxed_l = -1;  // the first l where enough cameras pass, required or not
    std::vector<bool> relaxed_passing;
    for (int l = 0; l < newest; ++l) {
      std::vector<CameraParallax> stats(static_cast<size_t>(NumCameras()));
      int count = 0;
      bool required_pass = true;
      for (int c = 0; c < NumCameras(); ++c) {
        CameraParallax& s = stats[static_cast<size_t>(c)];
        s.missing =
            Missing(window[static_cast<size_t>(l)], c) || Missing(window[static_cast<size_t>(newest)], c);
        if (!s.missing) {
          const auto& newest_c = newest_bearings[static_cast<size_t>(c)];
          double sum = 0.0;
          for (const FeatureObservation& f : window[static_cast<size_t>(l)].cameras[static_cast<size_t>(c)]) {
            const auto it = newest_c.find(f.id);
            if (it == newest_c.end()) continue;
            ++s.correspondences;
            sum += AngleBetween(f.bearing, it->second);
          }
          s.parallax_px = s.correspondences > 0 ? options.virtual_focal_px * sum / s.correspondences : 0.0;
          s.passes =
              s.correspondences >= options.min_correspondences && s.parallax_px >= options.min_parallax_px;
        }
        count += s.passes ? 1 : 0;
        if (required[static_cast<size_t>(c)] && !s.passes) required_pass = false;
      }
      if (count >= MinCamerasPassing() && (required_pass || relaxed_l < 0)) {
        std::vector<bool> passes(stats.size());
        for (size_t c = 0; c < stats.size(); ++c) passes[c] = stats[c].passes;
        if (required_pass) {
          *anchor = l;
          *passing = std::move(passes);
          return true;
        }
        if (relaxed_l < 0) {
          relaxed_l = l;
          relaxed_passing = std::move(passes);
        }
      }
      if (count > best_count) {
        best_count = count;
        best_l = l;
        best_stats = stats;
      }
    }
    if (relaxed_l >= 0) {  // only required cameras hold it up
      if (Relaxed()) {
        *anchor = relaxed_l;
        *passing = std::move(relaxed_passing);
        return true;
      }
      ++blocked_windows;
    }
    // Why not: the first failing (required, then any) camera of the best candidate.
    int failing = -1;
    for (int pass = 0; pass < 2 && failing < 0; ++pass) {
      for (int c = 0; c < NumCameras(); ++c) {
        if (!best_stats[static_cast<size_t>(c)].passes && (pass == 1 || required[static_cast<size_t>(c)])) {
          failing = c;
          break;
        }
      }
    }
    const std::string where =
        StrCat(" (best anchor frame ", window[static_cast<size_t>(best_l)].frame_index, ": ", best_count, "/",
               NumCameras(), " cameras pass, ", MinCamerasPassing(), " needed", relaxed_l >= 0 ? BlockedNote() : "",
               ")");
    if (failing < 0) {
      reason = StrCat("too few cameras pass", where);
      return false;
    }
    const CameraParallax& s = best_stats[static_cast<size_t>(failing)];
    const std::string& name = rig.cameras[static_cast<size_t>(failing)].name;
    if (s.missing) {
      reason = StrCat(name, ": no image", where);
    } else if (s.correspondences < options.min_correspondences) {
      reason =
          StrCat(name, ": ", s.correspondences, " correspondences < ", options.min_correspondences, where);
    } else {
      reason = StrCat(name, ": parallax ", FormatFixed(s.parallax_px, 1), " px < ",
                      FormatDouble(options.min_parallax_px), " px", where);
    }
    return false;
  }

  // Step 2: per-camera SfM over window positions l..newest, cameras in
  // parallel; slot k belongs to cameras[k], so the results do not depend on
  // the number of workers.
  std::vector<CameraSfmResult> RunSfm(int anchor, const std::vector<int>& cameras) const {
    const int newest = static_cast<int>(window.size()) - 1;
    const int num_frames = newest - anchor + 1;
    std::vector<CameraSfmResult> results(cameras.size());
    auto solve = [&](size_t k) {
      std::vector<WindowObservation> observations;
      for (int t = anchor; t <= newest; ++t) {
        for (const FeatureObservation& f :
             window[static_cast<size_t>(t)].cameras[static_cast<size_t>(cameras[k])]) {
          WindowObservation o;
          o.frame = t - anchor;
          o.id = f.id;
          o.bearing = f.bearing;
          observations.push_back(o);
        }
      }
      results[k] = SolveCameraWindowSfm(num_frames, 0, num_frames - 1, observations, options.sfm);
    };
    ParallelFor(static_cast<int>(cameras.size()), std::max(1, threads),
                [&](int k) { solve(static_cast<size_t>(k)); });
    return results;
  }

  // Step 4 (scale_screen.h), recording a rejection for the offline fallback
  // and setting the windows that max_skipped_windows passes over after it
  // (a rejection here always ends the attempt).
  bool SolveScale(std::vector<int>* used, std::vector<CameraSfmResult>* sfm_of_used,
                  std::vector<CameraWindowTrack>* tracks, std::vector<ScaleMeasurement>* measurements,
                  InitializationResult* result) {
    const ScaleScreen screen = ScreenScale(rig, options, used, sfm_of_used, tracks, measurements, result);
    if (screen.ok) return true;
    reason = screen.reason;
    windows_to_skip = WindowsToSkip(screen.poor_ratio);
    smallest_rejected_sigma = std::min(smallest_rejected_sigma, screen.passing_bound);
    return false;
  }

  // Step 6: the used camera that disagrees most with the rig solution
  // (its index into used, with `reason` naming it and the test), or
  // used.size() when all agree.
  size_t InconsistentCamera(const std::vector<int>& used, const std::vector<CameraSfmResult>& sfm_of_used,
                            const std::vector<double>& scales, const RigScaleResult& solve,
                            const std::vector<Rigid3d>& world_from_rig,
                            const std::map<uint64_t, Eigen::Vector3d>& points,
                            const std::map<uint64_t, int>& point_camera) {
    const std::vector<double> relative = RelativeSigmas(solve);
    std::map<int, int> landmarks;  // per rig camera
    for (const auto& [id, point] : points) {
      auto it = point_camera.find(id);
      if (it != point_camera.end()) ++landmarks[it->second];
    }
    size_t worst = used.size();
    double worst_badness = 0.0;
    for (size_t k = 0; k < used.size(); ++k) {
      const Camera& camera = rig.cameras[static_cast<size_t>(used[k])];
      const CameraConsistency consistency = MeasureCameraConsistency(
          world_from_rig, camera.cam_from_rig, sfm_of_used[k].anchor_from_cam, scales[k],
          k < relative.size() ? relative[k] : std::numeric_limits<double>::infinity(), landmarks[used[k]]);
      const std::optional<std::string> failure = CameraConsistencyFailure(consistency, options.consistency);
      if (!failure) continue;
      const double badness = CameraConsistencyBadness(consistency, options.consistency);
      if (worst == used.size() || badness > worst_badness) {
        worst = k;
        worst_badness = badness;
        reason = StrCat("rig solution rejected: ", camera.name, ": ", *failure);
      }
    }
    return worst;
  }

  std::optional<InitializationResult> Initialise(int anchor, const std::vector<bool>& passing) {
    std::vector<int> candidates;
    for (int c = 0; c < NumCameras(); ++c) {
      if (passing[static_cast<size_t>(c)]) candidates.push_back(c);
    }
    const std::vector<CameraSfmResult> sfm = RunSfm(anchor, candidates);
    std::vector<int> used;
    std::vector<CameraSfmResult> sfm_of_used;
    std::string failure;  // the first required camera's SfM failure, else the first one
    bool required_failed = false;
    for (size_t k = 0; k < candidates.size(); ++k) {
      const int c = candidates[k];
      if (sfm[k].ok) {
        used.push_back(c);
        sfm_of_used.push_back(sfm[k]);
        continue;
      }
      const bool is_required = required[static_cast<size_t>(c)];
      if (failure.empty() || (is_required && !required_failed)) {
        failure = StrCat(rig.cameras[static_cast<size_t>(c)].name, ": SfM failed: ", sfm[k].reason);
      }
      required_failed = required_failed || is_required;
    }
    const bool enough = static_cast<int>(used.size()) >= MinCamerasPassing();
    if (required_failed && enough && !Relaxed()) {
      ++blocked_windows;
      reason = StrCat(failure, " (", used.size(), " cameras would do", BlockedNote(), ")");
      return std::nullopt;
    }
    if (!enough) {
      reason = failure;
      return std::nullopt;
    }
    if (Monocular()) return InitialiseMonocular(anchor, used, sfm_of_used);

    // Each camera's SfM in the rig frame at l (A): q = r_c t_c(t), R = r_c R_c(t).
    std::vector<CameraWindowTrack> tracks(used.size());
    for (size_t k = 0; k < used.size(); ++k) {
      const Camera& camera = rig.cameras[static_cast<size_t>(used[k])];
      const Eigen::Quaterniond rig_from_cam = camera.cam_from_rig.rotation.conjugate();
      CameraWindowTrack& track = tracks[k];
      track.cam_from_rig = camera.cam_from_rig;
      for (const Rigid3d& pose : sfm_of_used[k].anchor_from_cam) {
        track.position_up_to_scale.push_back(rig_from_cam * pose.translation);
        track.rotation.push_back((rig_from_cam * pose.rotation).toRotationMatrix());
      }
    }
    InitializationResult result;
    std::vector<ScaleMeasurement> measurements =
        CrossCameraMeasurements(rig, window, options, anchor, used, sfm_of_used, &result.cross_camera_matches,
                                &result.cross_camera_scale_spread);

    // Scale, then the metric window; a camera that disagrees with the rig
    // solution (step 6) is left out and both are solved again without it.
    std::string left_out;
    for (;;) {
      if (!SolveScale(&used, &sfm_of_used, &tracks, &measurements, &result)) {
        if (!left_out.empty()) reason = StrCat(reason, " (after leaving out ", left_out, ")");
        return std::nullopt;
      }
      size_t inconsistent = used.size();
      if (SolveMetricWindow(anchor, used, sfm_of_used, &result, &inconsistent)) {
        result.attempts = attempts;
        result.skipped_windows = skipped_windows;
        return result;
      }
      if (inconsistent >= used.size()) return std::nullopt;  // reason set
      left_out += StrCat(left_out.empty() ? "" : "; ", reason);
      DropCamera(inconsistent, &used, &sfm_of_used, &tracks, &measurements);
    }
  }

  // A one-camera rig: the camera's SfM is the window, its unit the camera's
  // travel from l to r (camera_sfm.h); no scale solve, no rig BA (with one
  // camera it would refine the same observations again).
  std::optional<InitializationResult> InitialiseMonocular(int anchor, const std::vector<int>& used,
                                                          const std::vector<CameraSfmResult>& sfm_of_used) {
    InitializationResult result;
    result.source = ScaleSource::kArbitrary;
    result.rig_scale.scales = {1.0};
    result.rig_scale.solution = {1.0};
    result.rig_scale.reason = "one camera: the scale is arbitrary";
    size_t inconsistent = used.size();
    if (!SolveMetricWindow(anchor, used, sfm_of_used, &result, &inconsistent)) return std::nullopt;
    result.attempts = attempts;
    result.skipped_windows = skipped_windows;
    return result;
  }

  // Steps 5 to 7 for the cameras `used` and the scale solve in *result:
  // principal camera, metric poses and landmarks, rig window BA, the
  // consistency of every camera. false with `reason` set when the window
  // waits; *inconsistent is then the index (into used) of the camera that
  // disagrees most with the solution, or used.size() when the failure is
  // not a camera's.
  bool SolveMetricWindow(int anchor, const std::vector<int>& used,
                         const std::vector<CameraSfmResult>& sfm_of_used, InitializationResult* out,
                         size_t* inconsistent) {
    const int newest = static_cast<int>(window.size()) - 1;
    InitializationResult& result = *out;
    *inconsistent = used.size();
    result.frame_index.clear();
    result.t_ns.clear();
    result.landmarks.clear();

    // Principal camera: the most features tracked through every frame l..r.
    int principal_k = 0;
    int best_stable = -1;
    for (size_t k = 0; k < used.size(); ++k) {
      std::map<uint64_t, int> seen;
      for (int t = anchor; t <= newest; ++t) {
        for (const FeatureObservation& f :
             window[static_cast<size_t>(t)].cameras[static_cast<size_t>(used[k])]) {
          ++seen[f.id];
        }
      }
      int stable = 0;
      for (const auto& [id, n] : seen) stable += n == newest - anchor + 1 ? 1 : 0;
      if (stable > best_stable) {
        best_stable = stable;
        principal_k = static_cast<int>(k);
      }
    }

    // Step 5: metric rig poses from the principal camera, landmarks from
    // every camera, then refined together by the rig window BA.
    const std::vector<double>& scales = result.rig_scale.scales;
    const Camera& principal = rig.cameras[static_cast<size_t>(used[static_cast<size_t>(principal_k)])];
    const Rigid3d rig_from_principal = principal.cam_from_rig.Inverse();
    std::vector<Rigid3d> world_from_rig;
    for (int t = anchor; t <= newest; ++t) {
      const Rigid3d& pose =
          sfm_of_used[static_cast<size_t>(principal_k)].anchor_from_cam[static_cast<size_t>(t - anchor)];
      const Rigid3d metric(pose.rotation, scales[static_cast<size_t>(principal_k)] * pose.translation);
      world_from_rig.push_back(rig_from_principal * metric * principal.cam_from_rig);
      result.frame_index.push_back(window[static_cast<size_t>(t)].frame_index);
      result.t_ns.push_back(window[static_cast<size_t>(t)].t_ns);
    }
    std::map<uint64_t, Eigen::Vector3d> points;
    std::map<uint64_t, int> point_camera;
    for (size_t k = 0; k < used.size(); ++k) {
      const Rigid3d rig_from_cam = rig.cameras[static_cast<size_t>(used[k])].cam_from_rig.Inverse();
      for (const auto& [id, point] : sfm_of_used[k].points) {
        // Ids are unique over cameras; a repeated one keeps the first camera's.
        if (points.emplace(id, rig_from_cam * (scales[k] * point)).second) point_camera.emplace(id, used[k]);
      }
    }
    if (Monocular()) {
      result.relative_scale_sigma = 0.0;  // nothing to measure: the unit is chosen
    } else if (options.max_rig_ba_iterations > 0) {
      const std::vector<Rigid3d> cam_from_rig = rig.CamFromRig();
      std::vector<RigWindowObservation> observations;
      for (int t = anchor; t <= newest; ++t) {
        const RigFrameObservations& frame = window[static_cast<size_t>(t)];
        for (int c : used) {
          for (const FeatureObservation& f : frame.cameras[static_cast<size_t>(c)]) {
            if (points.count(f.id) != 0) observations.push_back({t - anchor, c, f.id, f.bearing});
          }
        }
        for (const CrossCameraObservation& x : frame.cross_camera) {
          if (x.camera_b >= 0 && x.camera_b < NumCameras() && x.camera_b != x.camera_a &&
              points.count(x.id) != 0) {
            observations.push_back({t - anchor, x.camera_b, x.id, x.bearing_b});
          }
        }
      }
      RigWindowBaOptions ba_options;
      ba_options.focal_px = options.sfm.focal_px;
      // Residuals, the Huber loss and the outlier threshold in each camera's own pixels.
      for (const Camera& camera : rig.cameras) ba_options.camera_focal_px.push_back(camera.MeanFocalLength());
      ba_options.huber_px = options.sfm.ba_huber_px;
      ba_options.max_reprojection_px = options.sfm.max_reprojection_px;
      ba_options.max_iterations = options.max_rig_ba_iterations;
      const RigWindowBaResult ba =
          AdjustRigWindow(cam_from_rig, 0, world_from_rig, points, observations, ba_options);
      if (!ba.ok) {
        reason = ba.reason;
        return false;
      }
      result.relative_scale_sigma = ba.travel_relative_sigma;
      *inconsistent = InconsistentCamera(used, sfm_of_used, scales, result.rig_scale, ba.world_from_rig,
                                         ba.points, point_camera);
      if (*inconsistent < used.size()) return false;
      if (!(ba.travel_relative_sigma <= options.max_relative_scale_sigma)) {
        reason = StrCat("scale poorly observable: rig bundle adjustment gives a scale sigma of ",
                        FormatFixed(100.0 * ba.travel_relative_sigma, 2), " % > ",
                        FormatFixed(100.0 * options.max_relative_scale_sigma, 2), " %");
        // Rejected for this alone: the best such window is the offline fallback's.
        smallest_rejected_sigma = std::min(smallest_rejected_sigma, ba.travel_relative_sigma);
        return false;
      }
      world_from_rig = ba.world_from_rig;
      points = ba.points;
    } else {
      result.relative_scale_sigma = RelativeSigmas(result.rig_scale)[static_cast<size_t>(principal_k)];
      if (!(result.relative_scale_sigma <= options.max_relative_scale_sigma)) {
        reason = StrCat("scale poorly observable: principal camera ", principal.name,
                        " has a scale sigma of ", FormatFixed(100.0 * result.relative_scale_sigma, 2),
                        " % > ", FormatFixed(100.0 * options.max_relative_scale_sigma, 2), " %");
        return false;
      }
    }
    result.world_from_rig = world_from_rig;
    for (const auto& [id, point] : points) {
      InitializationResult::Landmark lm;
      lm.id = id;
      lm.camera = point_camera.at(id);
      lm.point_in_world = point;
      result.landmarks.push_back(lm);
    }
    result.anchor_frame_index = window[static_cast<size_t>(anchor)].frame_index;
    result.principal_camera = used[static_cast<size_t>(principal_k)];
    result.camera_used.assign(static_cast<size_t>(NumCameras()), false);
    result.camera_scales.assign(static_cast<size_t>(NumCameras()), 0.0);
    for (size_t k = 0; k < used.size(); ++k) {
      result.camera_used[static_cast<size_t>(used[k])] = true;
      result.camera_scales[static_cast<size_t>(used[k])] = scales[k];
    }
    return true;
  }

  const Rig rig;
  const InitializerOptions options;
  const int threads;
  std::vector<bool> required;  // per rig camera
  std::deque<RigFrameObservations> window;
  std::string reason;
  bool spent = false;
  int attempts = 0;
  int failed_windows = 0;  // full windows whose motion initialisation failed, since Reset()
  // Full windows where enough cameras passed but a required one did not (in
  // the trigger or its SfM), since Reset(): Relaxed().
  int blocked_windows = 0;
  double smallest_rejected_sigma = std::numeric_limits<double>::infinity();
  // max_skipped_windows: the full windows still to pass over (set by
  // SolveScale), those passed over since Reset(), and the reason of the
  // attempt that set them.
  int windows_to_skip = 0;
  int skipped_windows = 0;
  std::string skip_reason;
};

Initializer::Initializer(const Rig& rig, const InitializerOptions& options, int threads)
    : impl_(std::make_unique<Impl>(rig, options, threads)) {}

Initializer::~Initializer() = default;

std::optional<InitializationResult> Initializer::AddFrame(const RigFrameObservations& frame) {
  return impl_->AddFrame(frame);
}

const std::string& Initializer::WaitingReason() const { return impl_->reason; }

void Initializer::Reset() { impl_->Reset(); }

double Initializer::SmallestRejectedScaleSigma() const { return impl_->smallest_rejected_sigma; }

}  // namespace mcvo
