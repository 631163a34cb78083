// The sliding-window multi-camera estimator: metric initialisation
// (initializer/initializer.h), then per frame:
//   1. pose of the new frame by a generalized absolute pose over all cameras
//      (rig_pnp.h) against the window's landmarks, from a constant-velocity
//      prediction;
//   2. new landmarks (anchored in the keyframe and camera that first saw
//      them, inverse distance along the anchor bearing) and triangulation of
//      the landmarks seen from enough baseline (other frames or, for
//      overlapping views, other cameras of the same frame);
//   3. bundle adjustment of the window (factors.h: tangent-plane bearing
//      residuals, Huber or Cauchy, Dogleg, dense Schur, iteration limit only,
//      single-threaded so the result never depends on thread scheduling),
//      with the marginalisation prior of the keyframes dropped before;
//   4. outlier observations removed;
//   5. keyframe decision (parallax to the last keyframe after rotation
//      compensation, or too few tracked landmarks in a camera): a keyframe
//      stays in the window, and when the window holds more than window_size
//      keyframes the oldest is marginalised into the prior (marginalization.h)
//      with the landmarks anchored in it, which are re-anchored in the next
//      frame that saw them; a non-keyframe is dropped when the next frame
//      arrives;
//   6. every scale_correction_period solves, in a window that turns at
//      least scale_correction_min_rotation_deg, scale correction (paper Sec.
//      "Scale Correction"): the initialiser's metric rig window BA
//      (initializer/rig_window_ba.h) re-estimates the window from its own
//      observations only, without the marginalisation prior (which holds
//      the scale the window had when it was marginalised), with the oldest
//      keyframe fixed. Its travel over the current estimate's travel is a
//      measurement of the scale error with a relative std from the BA's
//      covariance. It is fused with the current scale (whose relative std
//      starts at the initialiser's and grows by scale_drift_per_100m as a
//      random walk over the distance travelled) by a scalar Kalman update in
//      log scale, and the fused ratio k is applied to the state: window
//      positions about the fixed keyframe, the prior's linearisation
//      positions, and each camera's landmark inverse depths (divided by that
//      camera's fused ratio, from the median change of its landmarks'
//      depths in the rig BA: the paper's per-camera adjustment). The state
//      changes; every attempt is logged with the measurement, its std, the
//      gain and what was applied.
// Monocular (a one-camera rig): the initialiser's unit is arbitrary
// (initializer.h), and the window BA has a seventh gauge freedom, the scale,
// that the marginalisation prior does not hold (it constrains only the
// window's shape). Each solve therefore keeps the distance from the oldest
// keyframe to the farthest other keyframe of the window at its value before
// the solve (one residual, std 0.1 % of that distance): it removes only the
// scale gauge, as holding the oldest keyframe removes the other six. No
// scale correction (step 6): there is no metric information to correct with;
// the scale drifts as monocular odometry does, and the outputs say so.
// Tracking loss: a camera without image or features simply contributes
// nothing. When the pose of a frame cannot be found (too few inliers over all
// cameras), the estimator starts a new segment: it initialises again, and
// the new segment's world frame is placed at the constant-velocity prediction
// from the last good pose, so the trajectory stays usable; the break is
// recorded (FrameEstimate::segment, the scale log).
// Deterministic: same frames and options, same results, at any thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mcvo/backend/backend_options.h"
#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/initializer/initializer.h"
#include "mcvo/map/observations.h"
#include "mcvo/map/sparse_map.h"

namespace mcvo {

enum class EstimatorState { kInitializing, kTracking };
inline constexpr EnumName<EstimatorState> kEstimatorStateNames[] = {
    {EstimatorState::kInitializing, "initializing"}, {EstimatorState::kTracking, "tracking"}};

// One line of scale_log.csv.
struct ScaleLogEntry {
  int frame_index = 0;
  int64_t t_ns = 0;
  int segment = 0;
  std::string event;  // "init", "reinit", "seeded", "lost", "correction"; "backfill" (reverse_pass.h)
  // init / reinit: each camera's SfM scale (0: camera unused). correction:
  // the ratio applied to each camera's landmark depths (1: none applied).
  std::vector<double> camera_scales;
  double rms_residual_m = 0.0;        // init: of the rig scale solve
  double singular_value_ratio = 0.0;  // init: of the rig scale solve
  // correction: the window's metric travel from the rig BA without the prior
  // over the current estimate's (measured_ratio), its relative std, the gain
  // it was fused with, and the ratio applied to the window (1: none).
  double measured_ratio = 0.0;
  double measured_sigma = 0.0;
  double gain = 0.0;
  double applied_ratio = 1.0;
  double rms_reprojection_px = 0.0;  // correction: of the rig BA
  // Relative std of the current scale after this event (init: the
  // initialiser's; then grown by travel and shrunk by corrections).
  double scale_sigma = 0.0;
  bool applied = false;
  std::string note;  // source of the scale, or why nothing was applied
};

struct PoseUpdate {
  int frame_index = 0;
  int64_t t_ns = 0;
  Rigid3d world_from_rig;
};

struct FrameEstimate {
  int frame_index = 0;
  int64_t t_ns = 0;
  EstimatorState state = EstimatorState::kInitializing;
  int segment = 0;             // number of (re-)initialisations before this frame's segment
  std::string waiting_reason;  // while initialising
  bool has_pose = false;
  Rigid3d world_from_rig;  // valid when has_pose
  bool keyframe = false;
  // Poses found by this call: the frame itself, or after an initialisation
  // every frame of the initialisation window.
  std::vector<PoseUpdate> poses;
  std::vector<int> features_per_camera;   // observations in the input
  std::vector<int> landmarks_per_camera;  // of them, used in the BA
  int pnp_inliers = 0;
  int num_landmarks = 0;  // in the window's BA
  int ba_iterations = 0;
  double ba_initial_cost = 0.0;
  double ba_final_cost = 0.0;
  // Wall time of the stages (seconds): for timing outputs only, never for
  // deterministic outputs.
  double seconds_initializer = 0.0, seconds_pnp = 0.0, seconds_ba = 0.0, seconds_marginalization = 0.0,
         seconds_scale = 0.0;
};

struct KeyframeEstimate {
  int frame_index = 0;
  int64_t t_ns = 0;
  int segment = 0;
  Rigid3d world_from_rig;  // final: when it left the window (or at Finish)
  // Its observations of landmarks the bundle adjustment used when it left
  // the window (camera then feature order); the landmarks come from
  // TakeFinishedLandmarks. For the sparse map (colmap/sparse_map.h).
  std::vector<MapObservation> observations;
  // The observed landmarks' positions when the keyframe left (parallel to
  // observations): what loop closure matches against.
  std::vector<Eigen::Vector3d> observation_points;
};

class Estimator {
 public:
  // threads: for the initializer's per-camera SfM; results do not depend on it.
  Estimator(const Rig& rig, const InitializerOptions& init_options, const BackendOptions& options,
            int threads);
  ~Estimator();
  Estimator(const Estimator&) = delete;
  Estimator& operator=(const Estimator&) = delete;

  // Frames in increasing frame_index, one entry per rig camera.
  FrameEstimate AddFrame(const RigFrameObservations& frame);
  // Starts tracking from frames whose poses are already known, instead of
  // the initializer: an offline pass that continues a world whose metric
  // scale another pass determined (reverse_pass.h). The frames (2 to
  // window_size, increasing frame_index) enter the window as keyframes at
  // the given poses in this estimator's world, their landmarks are
  // triangulated from those poses, and the window is solved once, as after
  // an initialisation. relative_scale_sigma starts the scale filter; the
  // scale log gets a "seeded" entry with `note`. Only before the first
  // AddFrame. Returns the estimate of the last frame, every frame's pose in
  // its poses.
  FrameEstimate StartFromPoses(const std::vector<RigFrameObservations>& frames,
                               const std::vector<Rigid3d>& world_from_rig, double relative_scale_sigma,
                               const std::string& note);
  // Keyframes that left the window since the last call, oldest first.
  std::vector<KeyframeEstimate> TakeFinishedKeyframes();
  // Scale log entries since the last call.
  std::vector<ScaleLogEntry> TakeScaleLog();
  // Triangulated landmarks that left the estimator since the last call
  // (their last observing frame left the window, a new segment started, or
  // Finish), with their final positions, in the order they left. A feature
  // track whose landmark left and was created again appears again: the
  // later entry is the newer estimate.
  std::vector<MapLandmark> TakeFinishedLandmarks();
  // Ends the run: the keyframes still in the window, oldest first; every
  // remaining landmark goes to TakeFinishedLandmarks.
  std::vector<KeyframeEstimate> Finish();
  // Initializer::SmallestRejectedScaleSigma of its initializer.
  double SmallestRejectedScaleSigma() const;
  // The frames that may still become (or are) keyframes not yet finished:
  // those in the window and, while initialising, in the initializer's
  // window; increasing frame_index. A frame not among them never leaves
  // through TakeFinishedKeyframes or Finish.
  std::vector<int> PendingFrames() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
