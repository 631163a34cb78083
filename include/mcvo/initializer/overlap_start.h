// Initialisation from overlapping views alone, without motion ("overlap
// start"): the metric scale of a rig whose cameras share part of their view
// is the known baseline between them, so it needs no parallax from motion.
// Used by the initializer (initializer.h) when the motion initialisation of a
// full window does not succeed (typically: too little parallax, the rig
// standing still or moving slowly past distant scenery).
//
//  1. Frame 0 of the window is the world (rig at rest). Every cross-camera
//     observation (feature `id` of camera a found again by camera b in the
//     same frame) is triangulated through the two cameras' extrinsics
//     (midpoint of the two rays); kept when its triangulation angle is at
//     least min_angle_deg, it lies in front of both cameras and within
//     max_depth_m. A landmark keeps its first such triangulation.
//  2. Each later frame is posed against the landmarks seen so far (all
//     cameras' features and the cross-camera bearings), started at the
//     constant-velocity prediction, by a Huber-robust pose-only adjustment
//     (Ceres; observations beyond 3x, then 1x max_reprojection_px dropped);
//     it needs min_frame_inliers. Then its own cross-camera observations add
//     landmarks.
//  3. The rig window bundle adjustment (rig_window_ba.h) refines all poses
//     and landmarks with every observation, frame 0 held.
//  4. Accepted when at least min_points landmarks triangulated across cameras
//     are inliers seen in the newest frame, and the scale's relative std is at
//     most max_relative_scale_sigma. That std: each cross-camera landmark
//     measures the scale through its depth along the baseline, with relative
//     std rms_px / (focal * angle) (rms_px: the BA's inlier rms, at least
//     0.5 px); they are combined as independent measurements, but at most
//     kMaxIndependentPoints (in overlap_start.cc) count as independent (they
//     share the calibration and the frame poses), so the std is not
//     over-optimistic for thousands of points.
//
// Deterministic (no randomness, single-threaded Ceres, iteration limits).
#pragma once

#include <deque>
#include <optional>
#include <string>

#include "mcvo/camera/camera.h"
#include "mcvo/initializer/initializer.h"
#include "mcvo/map/observations.h"

namespace mcvo {

// Fills a result whose world is the rig at window.front(). `options` gives
// the overlap_start section and the reprojection thresholds (sfm). On
// failure std::nullopt and *reason says why, one line.
std::optional<InitializationResult> InitialiseFromOverlap(const Rig& rig,
                                                          const std::deque<RigFrameObservations>& window,
                                                          const InitializerOptions& options,
                                                          std::string* reason);

}  // namespace mcvo
