#include "loop_stage.h"

#include <chrono>
#include <utility>

#include "mcvo/util/logging.h"
#include "mcvo/util/strings.h"
#include "relocalise_segments.h"

namespace mcvo::pipeline_internal {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

LoopOutcome CloseLoops(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                       const Vocabulary& vocabulary, const LoopOptions& options, int threads,
                       bool sample_colors, const std::vector<std::pair<int, int>>& overlapping_pairs) {
  LoopOutcome out;
  const Rig& rig = index.rig;
  LoopCloser closer(rig, index.masks, vocabulary, options.closure, threads);
  // Each keyframe's images are read on the thread that extracts its
  // features, its colours sampled into its own slot.
  std::vector<std::vector<ColmapColorSamples>> colors(sample_colors ? keyframes.size() : 0);
  out.attempts = closer.AddKeyframes(static_cast<int>(keyframes.size()), [&](int k) {
    const size_t at = static_cast<size_t>(k);
    return ToLoopKeyframe(index, keyframes[at], 1, sample_colors ? &colors[at] : nullptr);
  });
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
    MCVO_LOG(kInfo, "run: cross-camera links across time: ", out.cross_camera_links.size(), " landmark pairs");
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
