// Loop closure stage of `mcvo run` (private to pipeline/): the finished
// keyframes through the loop closer (loop/loop_closer.h) and, when loops
// are accepted, the pose graph (loop/pose_graph.h); then every pose,
// keyframe and landmark of the odometry moved with its keyframe's
// correction.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "mcvo/colmap/colmap_model.h"
#include "mcvo/config/pipeline_options.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/loop/loop_closer.h"
#include "mcvo/loop/pose_graph.h"
#include "mcvo/loop/vocabulary.h"
#include "odometry_stage.h"

namespace mcvo::pipeline_internal {

// Loop closure over the finished keyframes (in frame order): each keyframe
// goes into the bag-of-words database with its images and landmarks and is
// verified against earlier places; accepted loops and the odometry between
// consecutive keyframes form the pose graph.
struct LoopOutcome {
  std::vector<LoopAttempt> attempts;
  int verified = 0;
  int accepted = 0;
  bool applied = false;                 // the pose graph ran and its result is used
  std::vector<Rigid3d> keyframe_after;  // per keyframe (== before when not applied)
  PoseGraphResult graph;
  LoopTiming timing;
  double pose_graph_seconds = 0.0;
  // Landmarks of two cameras seen at different keyframes that are one
  // point (loop/cross_camera_links.h; keyframe: index into the keyframes
  // given), whether or not a loop was accepted.
  std::vector<CrossCameraLink> cross_camera_links;
  // With sample_colors: the COLMAP export's point colours at every
  // keyframe's observation pixels, sampled while its images were read for
  // the loop closer (the export then decodes none of them again).
  ColmapColorTable colors;
};

// overlapping_pairs: the camera pairs the frontend matches (their views
// overlap), for the cross-camera links (loop/cross_camera_links.h).
LoopOutcome CloseLoops(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                       const Vocabulary& vocabulary, const LoopOptions& options, int threads,
                       bool sample_colors = false, const std::vector<std::pair<int, int>>& overlapping_pairs = {});

// loops.csv: one line per verified or rejected candidate.
std::string LoopsCsv(const std::vector<LoopAttempt>& attempts);

// cross_camera_links.csv: one line per link (camera indices of the rig,
// pixels at full resolution).
std::string CrossCameraLinksCsv(const std::vector<CrossCameraLink>& links);

// The odometry as it was before loop closure (for trajectory_vo.tum,
// keyframes_vo.tum and eval_vo/).
struct OdometryBeforeLoops {
  std::map<int, StampedPose> poses;
  std::vector<KeyframeEstimate> keyframes;
};

// When loops.applied: moves every pose of `odometry` by the pose graph's
// correction of the keyframes around it (interpolated in time), every
// landmark with the last keyframe that observed it, and the keyframes to
// their corrected poses; returns the odometry from before.
OdometryBeforeLoops ApplyLoopCorrection(const LoopOutcome& loops, OdometryOutput* odometry);

}  // namespace mcvo::pipeline_internal
