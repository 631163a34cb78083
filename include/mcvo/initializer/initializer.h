// Metric initialisation of a rigid multi-camera rig from a window of frames
// (paper Sec. "Multi-Camera Initialization"; reference notes
// "Initialisation (as released)", with the differences listed there fixed):
//
//  1. Trigger. Frames are collected into a window of options.window_size.
//     Once full, for each candidate anchor frame l (oldest first) and each
//     camera: the features it shares with the newest frame r and their mean
//     parallax (angle between the two bearings, not derotated, in pixels at
//     options.virtual_focal_px). A camera passes with at least
//     min_correspondences and min_parallax_px (a camera without image at l
//     or r does not pass). l is the first frame where every required camera
//     passes (required_cameras; empty = all cameras of the rig) and at least
//     min_cameras_passing cameras pass. With the default (all required),
//     min_cameras_passing only matters for an explicit list.
//  2. Per passing camera, monocular SfM over the window l..r (camera_sfm.h),
//     cameras in parallel (std::thread workers writing into per-camera
//     slots), each anchored to the rig at l through its extrinsic, so only
//     one scale per camera is unknown. A required camera whose SfM fails, or
//     fewer than min_cameras_passing successful ones, make the window wait.
//  3. Principal camera: among the cameras used, the one with the most
//     features tracked through every frame l..r (the most stable tracking;
//     ties: lower index). Its SfM gives the initial rig poses.
//  4. Scale, from two sources combined in one weighted linear least squares
//     (rig_scale.h SolveRigScalesCombined):
//     - the rigid-rig constraint over frames and camera pairs, observable
//       only when the rig rotates;
//     - cross-camera observations (overlapping views, RigFrameObservations::
//       cross_camera): a feature of camera a seen by camera b in the same
//       frame is triangulated with the known metric baseline; the ratio of
//       a's SfM distance to that metric distance (near zero-mean noise: it
//       is proportional to the triangulation angle) is averaged per camera,
//       weighted by the angle the SfM point predicts, after a robust filter
//       (3.5 robust stds), into one direct measurement of 1 / s_a, also
//       under pure translation. A camera needs min_cross_camera_matches.
//     Rejected unless the combined system passes the observability test
//     (min_singular_value_ratio), the rig residual is at most
//     max_rms_residual_m and the best determined camera's scale has an
//     estimated relative std of at most 3 x max_relative_scale_sigma (a
//     screen; step 5 applies the bound itself). A camera whose scale is not
//     positive or more than 10 % uncertain is left out (camera_used false)
//     and the solve repeated.
//  5. Rig window bundle adjustment (rig_window_ba.h), unless
//     max_rig_ba_iterations = 0: all used cameras' observations and the
//     cross-camera observations, through the extrinsics, refine the metric
//     rig poses and landmarks together, and give the uncertainty of the
//     scale (marginal relative std of the distance travelled); rejected when
//     it exceeds max_relative_scale_sigma.
//  Cameras that never pass: a camera facing a blank wall, the ceiling or a
//  dark room may not pass for the whole sequence, and with every camera
//  required the rig would never initialise (two rendered indoor sequences,
//  a 5- and a 3-camera rig, posed no frame). So after
//  relax_required_after_windows full windows that only required cameras
//  held up (enough other cameras passed), the trigger takes the first
//  anchor where every required camera passes and, failing that, the first
//  where any min_cameras_passing cameras pass; a required camera whose SfM
//  fails is then left out too. The cameras left out join the odometry after
//  the initialisation, through its landmarks. The reason of a waiting window
//  counts these windows.
//  A rejected window waits: the next frame slides it by one and the reason
//  is kept (WaitingReason). So under pure translation without overlapping
//  views the initializer waits, however long, instead of returning a scale
//  the data do not hold.
//  6. Consistency (rig_consistency.h), after the rig BA: every used camera
//     must have a positive, finite scale, at least consistency.min_landmarks
//     landmarks in the BA, a scale that agrees with the one the BA implies
//     for it within its uncertainty, and its own SfM motion the shape of the
//     rig's. A window with a camera that fails waits (the reason names the
//     camera and the test), so a broken rig solution is never accepted.
//  7. Result: metric rig poses of the window frames l..r, metric landmarks.
//  8. Overlap start (overlap_start.h): when steps 1-6 fail for a full window
//     (after options.overlap_start.after_failed_windows such windows) and
//     the window has cross-camera observations, the window is initialised
//     from the overlapping views alone, without motion (source
//     kOverlapStart, l = the oldest window frame). Its failure reason is
//     appended to the motion initialisation's.
//
//  Monocular (a one-camera rig): steps 1 and 2 with that camera (it passes
//  alone), then no scale solve: the window is the camera's SfM, its unit the
//  camera's travel from l to r (source kArbitrary, relative_scale_sigma 0).
//  The scale of everything that follows is relative to that unit
//  (estimator.h "Monocular").
//
// World frame of the result: the rig frame at the anchor frame l.
// Deterministic at any thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/initializer/camera_sfm.h"
#include "mcvo/initializer/rig_consistency.h"
#include "mcvo/initializer/rig_scale.h"
#include "mcvo/map/observations.h"

namespace mcvo {

// Initialisation from overlapping views without motion (overlap_start.h).
struct OverlapStartOptions {
  bool enable = true;
  // Full windows whose motion initialisation must fail before the overlap
  // start is tried (0: at the first full window that fails). The motion
  // initialisation is preferred: its scale is better determined (0.5 % against
  // 2 %), and offline the frames before it are posed by the reverse pass. So
  // the overlap start steps in only when the rig has stood or crept for this
  // many frames; and when a whole sequence posed no frame, `mcvo run` runs it
  // again with 0 (odometry_stage.cc).
  int after_failed_windows = 100;
  int min_points = 30;         // cross-camera landmarks, inliers, seen in the newest frame
  double min_angle_deg = 0.5;  // smallest triangulation angle of a cross-camera landmark
  double max_depth_m = 200.0;  // farthest cross-camera landmark kept
  int min_frame_inliers = 20;  // observations a window frame's pose must fit
  double max_relative_scale_sigma = 0.02;
};

struct InitializerOptions {
  int window_size = 10;
  int min_correspondences = 20;   // with the newest frame, per camera
  double min_parallax_px = 30.0;  // mean, at virtual_focal_px
  double virtual_focal_px = 460.0;
  int min_cameras_passing = 2;                // with a required_cameras list: the fewest that may pass
  std::vector<std::string> required_cameras;  // empty: all cameras ("all" in JSON)
  // "Cameras that never pass" (above): after this many full windows in
  // which at least min_cameras_passing cameras passed but a required one
  // did not (trigger or SfM), any min_cameras_passing cameras initialise.
  // -1: wait for the required cameras however long.
  int relax_required_after_windows = 10;
  // Cross-camera scale: matches a camera needs in the window (after the
  // robust filter), and the smallest triangulation angle of a usable match
  // (the angle its SfM point predicts).
  int min_cross_camera_matches = 20;
  double min_cross_camera_angle_deg = 0.5;
  double min_singular_value_ratio = 1e-3;  // rig_scale.h observability threshold
  // Largest rms of the rig-constraint residual (a screen for inconsistent
  // input, e.g. a wrong extrinsic; SfM noise alone reaches 0.1-0.2 m at 2 px
  // on fisheyes with 250 px/rad).
  double max_rms_residual_m = 0.25;
  // Largest accepted estimated relative std of the metric scale: of each
  // camera's scale in the linear solve (rig_scale.h "Uncertainty") and of the
  // distance travelled after the rig window BA (rig_window_ba.h).
  double max_relative_scale_sigma = 0.005;
  // Offline fallback (mcvo run): when the whole sequence posed no frame and
  // some window failed only the bound above, with a std of at most this, the
  // sequence is run again with this as the bound (logged). 0: off.
  double max_relative_scale_sigma_fallback = 0.05;
  // Offline fallback (mcvo run): when the whole sequence posed no frame
  // because the metric scale was never observable (the rig never turned and
  // no overlapping cameras matched enough features), it is run again with
  // its best-tracked camera alone, as monocular odometry at an arbitrary
  // scale (odometry_stage.cc).
  bool monocular_fallback = true;
  // Windows passed over after a poorly observable scale: when the linear
  // scale screen (step 4) rejects a window whose best camera's scale sigma
  // is R >= 2 times the screen's bound, the next floor(log2 R) full windows,
  // at most this many, are not attempted (all of them when no camera had a
  // positive scale). The sigma falls about as fast as the rotation in the
  // window grows, so a window far from the bound has neighbours far from it
  // too; each attempt is a per-camera SfM and a scale solve, the largest
  // cost of a rig without overlap that drives straight. Offline the reverse
  // pass poses the frames before the first initialised window. 0: every
  // window is attempted.
  int max_skipped_windows = 2;
  // Rig window bundle adjustment after the scale solve (rig_window_ba.h); 0: off.
  int max_rig_ba_iterations = 50;
  CameraSfmOptions sfm;
  // Step 6: every used camera must agree with the rig solution (rig_consistency.h).
  RigConsistencyOptions consistency;
  OverlapStartOptions overlap_start;

  // Throws InputError naming the field by its config path ("/initializer/...").
  void Check() const;
};

// How the scale was determined: from the rig rotation alone (no usable
// cross-camera observations), from cross-camera observations (the rig
// rotation alone would not have passed the tests), or from both (each alone
// would have), or from overlapping views alone, without motion (the overlap
// start, overlap_start.h), or not at all: a one-camera rig, whose unit is
// arbitrary (the camera's travel over the window).
enum class ScaleSource { kRigRotation, kCrossCamera, kCombined, kOverlapStart, kArbitrary };

struct InitializationResult {
  // Window frames l..r (r = newest), metric, world = rig at l.
  std::vector<int> frame_index;  // RigFrameObservations::frame_index of each
  std::vector<int64_t> t_ns;
  std::vector<Rigid3d> world_from_rig;
  struct Landmark {
    uint64_t id = 0;
    int camera = 0;  // the camera whose feature it is
    Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();
  };
  std::vector<Landmark> landmarks;  // sorted by id
  int anchor_frame_index = 0;       // frame_index of l
  int principal_camera = 0;
  std::vector<bool> camera_used;      // per rig camera: passed and its SfM succeeded
  std::vector<double> camera_scales;  // metric scale per camera's SfM, of step 4 (0 when unused)
  ScaleSource source = ScaleSource::kRigRotation;
  RigScaleResult rig_scale;  // of the combined solve: residual, singular value ratio
  // Estimated relative std of the metric scale of the result (the rig BA's;
  // the linear solve's largest when the BA is off).
  double relative_scale_sigma = 0.0;
  int cross_camera_matches = 0;            // cross-camera observations in the scale measurements
  double cross_camera_scale_spread = 0.0;  // robust std (1.4826 MAD) of their relative scale ratios
  // Earlier windows that passed the trigger but were rejected (SfM, scale or
  // its uncertainty) since the last Reset().
  int attempts = 0;
  // Full windows not attempted since the last Reset() (max_skipped_windows).
  int skipped_windows = 0;
};

class Initializer {
 public:
  // threads: workers for the per-camera SfM (results identical at any count).
  // MCVO_CHECKs options.Check() has passed and every required camera exists.
  Initializer(const Rig& rig, const InitializerOptions& options, int threads);
  ~Initializer();
  Initializer(const Initializer&) = delete;
  Initializer& operator=(const Initializer&) = delete;

  // Adds the next frame (frame_index increasing). Returns the result when the
  // window initialises; afterwards the initializer is spent (call Reset()).
  std::optional<InitializationResult> AddFrame(const RigFrameObservations& frame);
  // Why the last AddFrame did not initialise, one line: "window 4/10",
  // "image_02: 12 correspondences < 20 (best anchor frame ...)",
  // "image_00: SfM failed: ...", "rig motion is near pure translation ...:
  // scale not observable (...)", "scale poorly observable: ...";
  // "initialised" after a result.
  const std::string& WaitingReason() const;
  // Empties the window (after tracking loss, to initialise again).
  void Reset();
  // The smallest scale std of the windows rejected only because it exceeded
  // max_relative_scale_sigma (the rig BA's; for a window the linear screen
  // of step 4 stopped, the bound that would have let it through), since
  // construction (Reset() keeps it), over the windows attempted (not those
  // max_skipped_windows passed over); infinity when none was. Decides whether the offline fallback
  // (max_relative_scale_sigma_fallback) can help.
  double SmallestRejectedScaleSigma() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
