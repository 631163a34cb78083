// Loop-closure input from the frontend's decode (private to pipeline/;
// issue 17). The loop closer (loop_stage.h) needs each keyframe's images
// for its ORB features and the COLMAP colours at its observations; it runs
// after the odometry, when the frontend's images are long gone, so it used
// to decode every keyframe's images a second time (a tenth of a
// full-resolution run; more for colour files). `mcvo run` tracking images
// keeps the decodes of the frames the estimator may still make finished
// keyframes (Estimator::PendingFrames, about a window's worth) and, as each
// keyframe of the forward pass finishes, extracts its image features
// (LoopCloser::ExtractImageFeatures) and samples its colours from them;
// then drops them. What the cache holds depends on the keyframe's images
// and its observations' cameras and pixels only, and it is used only for a
// keyframe whose final observations have the same cameras and pixels in
// the same order (LoopCloser::ImageFeaturesFit): every other keyframe (of
// the reverse pass, of a fallback pass, one whose observations changed
// since) is read from its files as before. The results are therefore the
// same with and without the cache, and a replay of a track file (no
// images) gives the same outputs as the run that tracked them.
#pragma once

#include <map>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "mcvo/colmap/colmap_model.h"
#include "mcvo/loop/loop_closer.h"
#include "odometry_stage.h"

namespace mcvo::pipeline_internal {

class LoopImageCache {
 public:
  struct Entry {
    std::shared_ptr<const LoopImageFeatures> features;
    std::vector<ColmapColorSamples> colors;  // per camera; empty without sample_colors
  };

  // closer: the loop closer that will add the keyframes (its rig, masks and
  // options define the features); it must outlive the cache. max_bytes: of
  // the entries (features and colours); a keyframe whose entry would pass
  // it gets none (which keyframes do depends on the data only). threads:
  // over the cameras of one keyframe.
  LoopImageCache(const LoopCloser& closer, int num_cameras, bool sample_colors, size_t max_bytes,
                 int threads);

  // After OdometryStage::Add of frame `frame_index` (FrontendItem::images
  // and decoded): keeps its images, extracts the keyframes the stage
  // finished since the last call whose images are kept, and drops the
  // images of frames no longer pending.
  void Add(int frame_index, std::vector<cv::Mat> images, std::vector<cv::Mat> decoded,
           const OdometryStage& stage);
  // After OdometryStage::Finish: the keyframes among `keyframes` whose
  // images are still kept (the last window's) are extracted; every image is
  // dropped.
  void Finish(const std::vector<KeyframeEstimate>& keyframes);

  // The entry for `keyframe` when it was extracted for the same
  // observations' cameras and pixels (in order); null otherwise.
  const Entry* Find(const KeyframeEstimate& keyframe) const;

  int extracted() const { return static_cast<int>(entries_.size()); }
  int over_budget() const { return over_budget_; }  // keyframes left to the loop stage by max_bytes
  size_t bytes() const { return bytes_; }           // of the entries
  double seconds() const { return seconds_; }       // extracting and sampling (wall)

 private:
  struct Images {
    std::vector<cv::Mat> grey, decoded;
  };
  void Extract(const KeyframeEstimate& keyframe);

  const LoopCloser& closer_;
  const int num_cameras_;
  const bool sample_colors_;
  const size_t max_bytes_;
  const int threads_;
  std::map<int, Images> images_;  // by frame index
  size_t keyframes_seen_ = 0;
  std::map<int, Entry> entries_;  // by frame index
  size_t bytes_ = 0;
  bool full_ = false;
  int over_budget_ = 0;
  double seconds_ = 0.0;
};

}  // namespace mcvo::pipeline_internal
