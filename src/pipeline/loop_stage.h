// Loop closure stage of `mcvo run` (private to pipeline/): the finished
// keyframes through the loop closer (loop/loop_closer.h) and, when loops
// are accepted, the pose graph (loop/pose_graph.h); then every pose,
// keyframe and landmark of the odometry moved with its keyframe's
// correction.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mcvo/colmap/colmap_model.h"
#include "mcvo/config/pipeline_options.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/loop/loop_closer.h"
#include "mcvo/loop/pose_graph.h"
#include "mcvo/loop/vocabulary.h"
#include "loop_image_cache.h"
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
  // Keyframes whose image features and colours came from the loop image
  // cache (not read from their files again).
  int keyframes_from_cache = 0;
  double cache_seconds = 0.0;  // extracting them during the odometry (wall)
  size_t cache_bytes = 0;      // what they held
  int cache_over_budget = 0;   // keyframes left to be read again by loop.frontend_cache_mb
};

// overlapping_pairs: the camera pairs the frontend matches (their views
// overlap), for the cross-camera links (loop/cross_camera_links.h).
LoopOutcome CloseLoops(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                       const Vocabulary& vocabulary, const LoopOptions& options, int threads,
                       bool sample_colors = false, const std::vector<std::pair<int, int>>& overlapping_pairs = {});

// The loop closer CloseLoops makes of these (to extract keyframes' image
// features ahead with, loop_image_cache.h).
std::unique_ptr<LoopCloser> MakeLoopCloser(const DatasetIndex& index, const Vocabulary& vocabulary,
                                           const LoopOptions& options, int threads);
// CloseLoops with that closer (no keyframe added yet) and the keyframes'
// image features and colours extracted ahead where `cache` has them (it
// must have been filled with `closer`); the same outcome.
LoopOutcome CloseLoops(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                       LoopCloser* closer, const LoopImageCache* cache, const LoopOptions& options,
                       bool sample_colors, const std::vector<std::pair<int, int>>& overlapping_pairs);

// The loop stage of `mcvo run`, from before the odometry to its end: the
// loop options (cross-camera links are looked for only where the
// refinement fuses landmarks, refine_stage.h), the loop closer and, when
// the odometry tracks images, the image cache it fills from the frontend's
// decode (loop_image_cache.h).
class RunLoopStage {
 public:
  // track_images: the frames come with their images (FrontendItem::images,
  // decoded), not from a track file.
  RunLoopStage(const DatasetIndex& index, const Vocabulary& vocabulary, const PipelineOptions& options,
               bool track_images, int threads);
  // After OdometryStage::Add of each frame (LoopImageCache::Add).
  void AddFrame(int frame_index, std::vector<cv::Mat> images, std::vector<cv::Mat> decoded,
                const OdometryStage& stage);
  // CloseLoops over the odometry's keyframes. posed: the dataset they are of
  // (one camera's after the monocular fallback, whose keyframes the cache,
  // of the whole rig, does not serve).
  LoopOutcome Close(const DatasetIndex& posed, const OdometryOutput& odometry, bool scale_arbitrary);

 private:
  LoopOptions OptionsFor(bool scale_arbitrary) const;

  const Vocabulary& vocabulary_;
  const PipelineOptions& options_;
  const int threads_;
  const bool sample_colors_;  // the COLMAP export's colours, sampled as the keyframes are read
  std::unique_ptr<LoopCloser> closer_;
  std::unique_ptr<LoopImageCache> cache_;
};

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
