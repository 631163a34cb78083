// Global refinement stage of `mcvo run` (private to pipeline/): after loop
// closure, one rig bundle adjustment over the run's sparse map
// (refine/global_ba.h); then every pose of the odometry follows its
// keyframe's correction.
#pragma once

#include "loop_stage.h"
#include "mcvo/camera/camera.h"
#include "mcvo/map/sparse_map.h"
#include "mcvo/refine/global_ba.h"
#include "mcvo/refine/landmark_fusion.h"
#include "odometry_stage.h"

namespace mcvo::pipeline_internal {

struct RefineOutcome {
  bool applied = false;  // the bundle adjustment ran and its result is used
  bool extrinsics_refined = false;  // applied with options.refine_extrinsics: ba.cam_from_rig is the new rig
  GlobalBaResult ba;     // ba.map: the refined map (when applied)
  LandmarkFusionResult fusion;  // the loops' landmarks fused before it (options.fuse_loop_landmarks)
  // Then the cross-camera links across time (LoopOutcome::cross_camera_links).
  LandmarkFusionResult cross_camera_fusion;
  OdometryBeforeLoops before;  // poses and keyframes as they were before it
};

// Whether RefineGlobally fuses landmarks (loops' matches and cross-camera
// links): the refinement runs (options.enabled, and on a scale-free run
// options.monocular) with options.fuse_loop_landmarks. The loop stage looks
// for cross-camera links only then.
inline bool RefineFusesLandmarks(const GlobalBaOptions& options, bool scale_free) {
  return options.enabled && options.fuse_loop_landmarks && !(scale_free && !options.monocular);
}


// Runs the global bundle adjustment on `map` (BuildSparseMap of `odometry`;
// scale_free: the run's scale is arbitrary). When it ran, `map` becomes the
// refined map and `odometry` follows it: refined keyframes take their new
// poses; every other pose (non-keyframes, keyframes the bundle adjustment
// did not hold) follows the corrections of the refined keyframes before and
// after it in its segment, blended by time, each relative to the keyframe's
// pose when its frame was the newest (the reference the non-keyframe poses
// share), its offset scaled by how much the refined keyframe interval
// around it stretched (the refined scale applies between keyframes too;
// pose_graph.h InterpolateCorrections); refined landmarks take their new
// positions.
// Loops the pose graph accepted (loops: may be null) enter as relative pose
// constraints with the pose graph's loop sigmas and, with
// options.fuse_loop_landmarks, through their inlier matches: the landmarks
// seen again are fused first (refine/landmark_fusion.h), so the map that
// replaces `map` has one landmark per place.
RefineOutcome RefineGlobally(const Rig& rig, const GlobalBaOptions& options, const LoopOutcome* loops,
                             const PoseGraphOptions& pose_graph, bool scale_free, SparseMap* map,
                             OdometryOutput* odometry);

}  // namespace mcvo::pipeline_internal
