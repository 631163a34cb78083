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
//   6. every scale_correction_period solves, scale correction (paper
//      Sec. "Scale Correction"): each camera's monocular SfM over the window
//      keyframes and the rig scale solve give each camera's metric
//      displacement over the window; its ratio to the current estimate's is
//      applied to that camera's landmark inverse depths (the state changes;
//      the next solve propagates it to the poses). Every attempt is logged.
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
#include "mcvo/initializer/observations.h"

namespace mcvo {

enum class EstimatorState { kInitializing, kTracking };
inline constexpr EnumName<EstimatorState> kEstimatorStateNames[] = {
    {EstimatorState::kInitializing, "initializing"}, {EstimatorState::kTracking, "tracking"}};

// One line of scale_log.csv.
struct ScaleLogEntry {
  int frame_index = 0;
  int64_t t_ns = 0;
  int segment = 0;
  std::string event;                  // "init", "correction", "reinit"
  std::vector<double> camera_scales;  // per camera: init: SfM scales; correction: applied ratios (1: unused)
  double rms_residual_m = 0.0;
  double singular_value_ratio = 0.0;
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
  // Keyframes that left the window since the last call, oldest first.
  std::vector<KeyframeEstimate> TakeFinishedKeyframes();
  // Scale log entries since the last call.
  std::vector<ScaleLogEntry> TakeScaleLog();
  // Ends the run: the keyframes still in the window, oldest first.
  std::vector<KeyframeEstimate> Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
