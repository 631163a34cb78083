#include "loop_stage.h"

#include <chrono>
#include <utility>

#include "mcvo/frontend/cross_camera.h"
#include "mcvo/util/error.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"
#include "refine_stage.h"
#include "relocalise_segments.h"

namespace mcvo::pipeline_internal {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

std::unique_ptr<LoopCloser> MakeLoopCloser(const DatasetIndex& index, const Vocabulary& vocabulary,
                                           const LoopOptions& options, int threads) {
  return std::make_unique<LoopCloser>(index.rig, index.masks, vocabulary, options.closure, threads);
}

LoopOutcome CloseLoops(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                       const Vocabulary& vocabulary, const LoopOptions& options, int threads,
                       bool sample_colors, const std::vector<std::pair<int, int>>& overlapping_pairs) {
  const std::unique_ptr<LoopCloser> closer = MakeLoopCloser(index, vocabulary, options, threads);
  return CloseLoops(index, keyframes, closer.get(), nullptr, options, sample_colors, overlapping_pairs);
}

LoopOutcome CloseLoops(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                       LoopCloser* closer_ptr, const LoopImageCache* cache, const LoopOptions& options,
                       bool sample_colors, const std::vector<std::pair<int, int>>& overlapping_pairs) {
  const ScopedStage stage("loop closure");
  MCVO_CHECK(closer_ptr != nullptr && closer_ptr->num_keyframes() == 0);
  LoopCloser& closer = *closer_ptr;
  LoopOutcome out;
  const int num_cameras = index.rig.NumCameras();
  // Each keyframe's images are read on the thread that extracts its
  // features, its colours sampled into its own slot; or both come from the
  // cache, extracted while the frontend's decode was at hand.
  std::vector<const LoopImageCache::Entry*> cached(keyframes.size(), nullptr);
  if (cache != nullptr) {
    for (size_t k = 0; k < keyframes.size(); ++k) cached[k] = cache->Find(keyframes[k]);
  }
  std::vector<std::vector<ColmapColorSamples>> colors(sample_colors ? keyframes.size() : 0);
  out.attempts = closer.AddKeyframes(
      static_cast<int>(keyframes.size()),
      [&](int k) {
        const size_t at = static_cast<size_t>(k);
        if (cached[at] == nullptr) {
          return ToLoopKeyframe(index, keyframes[at], 1, sample_colors ? &colors[at] : nullptr);
        }
        if (sample_colors) colors[at] = cached[at]->colors;
        return LoopKeyframeWithoutImages(keyframes[at], num_cameras);
      },
      [&](int k) {
        const LoopImageCache::Entry* entry = cached[static_cast<size_t>(k)];
        return entry != nullptr ? entry->features : nullptr;
      });
  for (const LoopImageCache::Entry* entry : cached) out.keyframes_from_cache += entry != nullptr ? 1 : 0;
  for (size_t k = 0; k < colors.size(); ++k) {
    for (size_t c = 0; c < colors[k].size(); ++c) {
      out.colors[{keyframes[k].frame_index, static_cast<int>(c)}] = std::move(colors[k][c]);
    }
  }
  for (const LoopAttempt& attempt : out.attempts) {
    out.verified += attempt.verified ? 1 : 0;
    out.accepted += attempt.accepted ? 1 : 0;
  }
  out.cross_camera_links = closer.CrossCameraLinks(overlapping_pairs);
  if (!out.cross_camera_links.empty()) {
    MCVO_LOG(kInfo, "run: cross-camera links across time: ", out.cross_camera_links.size(),
             " landmark pairs");
  }
  out.timing = closer.timing();
  for (const KeyframeEstimate& kf : keyframes) out.keyframe_after.push_back(kf.world_from_rig);
  if (out.accepted == 0) return out;

  std::vector<PoseGraphEdge> edges;
  for (size_t k = 1; k < keyframes.size(); ++k) {
    PoseGraphEdge edge;
    edge.from = static_cast<int>(k - 1);
    edge.to = static_cast<int>(k);
    edge.from_T_to = keyframes[k - 1].world_from_rig.Inverse() * keyframes[k].world_from_rig;
    edges.push_back(edge);
  }
  for (const LoopAttempt& attempt : out.attempts) {
    if (!attempt.accepted) continue;
    PoseGraphEdge edge;
    edge.from = attempt.candidate;
    edge.to = attempt.query;
    edge.from_T_to = attempt.candidate_from_query;
    edge.loop = true;
    edges.push_back(edge);
  }
  const Clock::time_point start = Clock::now();
  out.graph = OptimizePoseGraph(out.keyframe_after, edges, options.pose_graph);
  out.pose_graph_seconds = SecondsSince(start);
  if (out.graph.ok) {
    out.keyframe_after = out.graph.world_from_node;
    out.applied = true;
  } else {
    MCVO_LOG(kWarning, "run: loop closure: pose graph failed (", out.graph.reason,
             "); trajectory left as is");
  }
  return out;
}

RunLoopStage::RunLoopStage(const DatasetIndex& index, const Vocabulary& vocabulary,
                           const PipelineOptions& options, bool track_images, int threads)
    : vocabulary_(vocabulary),
      options_(options),
      threads_(threads),
      sample_colors_(options.colmap.enabled && options.colmap.export_options.sample_colors) {
  if (!track_images) return;
  // The options of a run at the rig's own scale; Close makes another closer
  // after the monocular fallback.
  closer_ = MakeLoopCloser(index, vocabulary_, OptionsFor(index.rig.NumCameras() == 1), threads_);
  cache_ = std::make_unique<LoopImageCache>(*closer_, index.rig.NumCameras(), sample_colors_,
                                            static_cast<size_t>(options.loop.frontend_cache_mb) << 20, threads_);
}

LoopOptions RunLoopStage::OptionsFor(bool scale_arbitrary) const {
  LoopOptions loop_options = options_.loop;
  if (!RefineFusesLandmarks(options_.refine, scale_arbitrary))
    loop_options.closure.cross_camera.window_keyframes = 0;
  return loop_options;
}

void RunLoopStage::AddFrame(int frame_index, std::vector<cv::Mat> images, std::vector<cv::Mat> decoded,
                            const OdometryStage& stage) {
  if (cache_) cache_->Add(frame_index, std::move(images), std::move(decoded), stage);
}

LoopOutcome RunLoopStage::Close(const DatasetIndex& posed, const OdometryOutput& odometry,
                                bool scale_arbitrary) {
  const auto matched_pairs = SelectCrossCameraPairs(posed.rig, posed.masks, options_.frontend.cross_camera);
  const LoopOptions loop_options = OptionsFor(scale_arbitrary);
  LoopOutcome out;
  if (!cache_ || odometry.monocular_camera >= 0) {
    out = CloseLoops(posed, odometry.keyframes, vocabulary_, loop_options, threads_, sample_colors_, matched_pairs);
  } else {
    // No fallback to one camera: the rig and options the closer was made with.
    cache_->Finish(odometry.keyframes);
    out = CloseLoops(posed, odometry.keyframes, closer_.get(), cache_.get(), loop_options, sample_colors_,
                     matched_pairs);
    out.cache_seconds = cache_->seconds();
    out.cache_bytes = cache_->bytes();
    out.cache_over_budget = cache_->over_budget();
  }
  cache_.reset();
  closer_.reset();
  MCVO_LOG(kInfo, "run: loop closure: ", odometry.keyframes.size(), " keyframes (", out.keyframes_from_cache,
           " described from the frontend's decode, ", FormatFixed(out.cache_bytes / 1048576.0, 1), " MB",
           out.cache_over_budget > 0 ? StrCat("; ", out.cache_over_budget, " over loop.frontend_cache_mb") : "",
           "), ", out.verified, " candidates verified, ", out.accepted, " loop(s) accepted",
           out.applied ? ", pose graph applied" : "");
  return out;
}

std::string LoopsCsv(const std::vector<LoopAttempt>& attempts) {
  std::string csv =
      "query_keyframe,query_frame,candidate_keyframe,candidate_frame,score,normalized_score,matches,inliers,"
      "cameras_with_inliers,verified,accepted,correction_m,correction_deg,reason\n";
  for (const LoopAttempt& a : attempts) {
    csv += StrCat(a.query, ",", a.query_frame, ",", a.candidate, ",", a.candidate_frame, ",",
                  FormatDouble(a.score), ",", FormatDouble(a.normalized_score), ",", a.matches, ",",
                  a.inliers, ",", a.cameras_with_inliers, ",", a.verified ? 1 : 0, ",", a.accepted ? 1 : 0,
                  ",", FormatDouble(a.correction_m), ",", FormatDouble(a.correction_deg), ",",
                  CsvQuote(a.reason), "\n");
  }
  return csv;
}

std::string CrossCameraLinksCsv(const std::vector<CrossCameraLink>& links) {
  std::string csv =
      "keyframe,frame,camera,u,v,landmark_id,source_keyframe,source_frame,source_camera,source_u,source_v,"
      "source_landmark_id,distance_bits,view_angle_deg,scale\n";
  for (const CrossCameraLink& l : links) {
    csv += StrCat(l.keyframe, ",", l.frame_index, ",", l.camera, ",", FormatFixed(l.pixel.x(), 3), ",",
                  FormatFixed(l.pixel.y(), 3), ",", l.landmark_id, ",", l.source_keyframe, ",",
                  l.source_frame_index, ",", l.source_camera, ",", FormatFixed(l.source_pixel.x(), 3), ",",
                  FormatFixed(l.source_pixel.y(), 3), ",", l.source_landmark_id, ",", l.distance, ",",
                  FormatFixed(l.view_angle_deg, 2), ",", FormatFixed(l.scale, 2), "\n");
  }
  return csv;
}

OdometryBeforeLoops ApplyLoopCorrection(const LoopOutcome& loops, OdometryOutput* odometry) {
  OdometryBeforeLoops before;
  if (!loops.applied) return before;
  std::map<int, StampedPose>& poses = odometry->poses;
  std::vector<KeyframeEstimate>& keyframes = odometry->keyframes;
  std::map<int64_t, Eigen::Vector3d>& landmarks = odometry->landmarks;
  before.poses = poses;
  before.keyframes = keyframes;
  std::vector<int64_t> node_t_ns;
  std::vector<Rigid3d> node_before;
  for (const KeyframeEstimate& kf : keyframes) {
    node_t_ns.push_back(kf.t_ns);
    node_before.push_back(kf.world_from_rig);
  }
  std::vector<int64_t> pose_t_ns;
  std::vector<Rigid3d> pose_before;
  for (const auto& [frame_index, pose] : poses) {
    pose_t_ns.push_back(pose.t_ns);
    pose_before.push_back(pose.world_from_body);
  }
  const std::vector<Rigid3d> pose_after =
      CorrectPoses(node_t_ns, node_before, loops.keyframe_after, pose_t_ns, pose_before);
  size_t k = 0;
  for (auto& [frame_index, pose] : poses) pose.world_from_body = pose_after[k++];
  // A landmark moves with the last keyframe that observed it (its final
  // position was estimated while that keyframe was in the window).
  std::map<int64_t, size_t> last_observer;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    for (const MapObservation& ob : keyframes[i].observations) last_observer[ob.landmark_id] = i;
  }
  for (auto& [id, position] : landmarks) {
    auto it = last_observer.find(id);
    if (it == last_observer.end()) continue;
    position = loops.keyframe_after[it->second] * (node_before[it->second].Inverse() * position);
  }
  for (size_t i = 0; i < keyframes.size(); ++i) keyframes[i].world_from_rig = loops.keyframe_after[i];
  return before;
}

}  // namespace mcvo::pipeline_internal
