// Global refinement stage of `mcvo run` (refine_stage.h).
#include "refine_stage.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <vector>

#include "mcvo/loop/pose_graph.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"

namespace mcvo::pipeline_internal {
namespace {

// A keyframe interval shorter than this (metres, or units of an arbitrary
// scale) is standing still: its stretch is not measured.
constexpr double kMinIntervalForStretch = 0.05;
// The stretch of one interval is kept within these bounds (a refined scale
// change of a few percent is expected; more is a sign of a bad interval).
constexpr double kMinStretch = 0.8, kMaxStretch = 1.25;

// Per refined keyframe: the length ratio after / before of the interval to
// the next refined keyframe of the same segment (the previous interval's for
// the last one; 1 where it cannot be measured).
std::vector<double> IntervalStretch(const std::vector<int>& segment, const std::vector<Rigid3d>& before,
                                    const std::vector<Rigid3d>& after) {
  const size_t n = before.size();
  std::vector<double> stretch(n, 1.0);
  for (size_t i = 0; i + 1 < n; ++i) {
    if (segment[i] != segment[i + 1]) {
      if (i > 0 && segment[i - 1] == segment[i]) stretch[i] = stretch[i - 1];
      continue;
    }
    const double length_before = (before[i + 1].translation - before[i].translation).norm();
    const double length_after = (after[i + 1].translation - after[i].translation).norm();
    if (length_before >= kMinIntervalForStretch && length_after >= kMinIntervalForStretch) {
      stretch[i] = std::clamp(length_after / length_before, kMinStretch, kMaxStretch);
    }
  }
  if (n >= 2 && segment[n - 1] == segment[n - 2]) stretch[n - 1] = stretch[n - 2];
  return stretch;
}

// Frame index -> index into map.keyframes.
std::map<int, int> KeyframeOfFrame(const SparseMap& map) {
  std::map<int, int> keyframe_of_frame;
  for (size_t k = 0; k < map.keyframes.size(); ++k) {
    keyframe_of_frame[map.keyframes[k].frame_index] = static_cast<int>(k);
  }
  return keyframe_of_frame;
}

// The accepted loops of `loops` between keyframes of `map`.
std::vector<GlobalBaPoseConstraint> LoopConstraints(const LoopOutcome* loops, const PoseGraphOptions& pose_graph,
                                                    const SparseMap& map) {
  std::vector<GlobalBaPoseConstraint> constraints;
  if (loops == nullptr || !loops->applied) return constraints;
  const std::map<int, int> keyframe_of_frame = KeyframeOfFrame(map);
  for (const LoopAttempt& attempt : loops->attempts) {
    if (!attempt.accepted) continue;
    const auto from = keyframe_of_frame.find(attempt.candidate_frame);
    const auto to = keyframe_of_frame.find(attempt.query_frame);
    if (from == keyframe_of_frame.end() || to == keyframe_of_frame.end()) continue;
    GlobalBaPoseConstraint c;
    c.from = from->second;
    c.to = to->second;
    c.from_T_to = attempt.candidate_from_query;
    c.rotation_sigma_rad = pose_graph.loop_rotation_sigma_deg * M_PI / 180.0;
    c.translation_sigma_m = pose_graph.loop_translation_sigma_m;
    c.loss_scale = pose_graph.loop_loss_scale;
    constraints.push_back(c);
  }
  return constraints;
}

// The inlier matches of the accepted loops whose query is a keyframe of `map`.
std::vector<LoopLandmarkMatch> LoopMatches(const LoopOutcome* loops, const SparseMap& map) {
  std::vector<LoopLandmarkMatch> matches;
  if (loops == nullptr || !loops->applied) return matches;
  const std::map<int, int> keyframe_of_frame = KeyframeOfFrame(map);
  for (const LoopAttempt& attempt : loops->attempts) {
    if (!attempt.accepted) continue;
    const auto query = keyframe_of_frame.find(attempt.query_frame);
    if (query == keyframe_of_frame.end()) continue;
    for (const LoopAttempt::Match& m : attempt.inlier_matches) {
      matches.push_back({query->second, m.camera, m.pixel, m.landmark_id, m.query_landmark_id});
    }
  }
  return matches;
}

// The cross-camera links across time at keyframes of `map` (merges),
// whether or not a loop was accepted.
std::vector<LoopLandmarkMatch> CrossCameraMatches(const LoopOutcome* loops, const SparseMap& map) {
  std::vector<LoopLandmarkMatch> matches;
  if (loops == nullptr) return matches;
  const std::map<int, int> keyframe_of_frame = KeyframeOfFrame(map);
  for (const CrossCameraLink& link : loops->cross_camera_links) {
    const auto at = keyframe_of_frame.find(link.frame_index);
    if (at == keyframe_of_frame.end()) continue;
    // The younger landmark merges into the older.
    const auto [older, younger] = std::minmax(link.landmark_id, link.source_landmark_id);
    matches.push_back({at->second, link.camera, link.pixel, older, younger});
  }
  return matches;
}

// The cross-camera links across time as ties (refine.cross_camera_link_sigma_px
// > 0): both landmarks kept, the sigma at the linked camera's distance to
// the linked landmark. Links naming a landmark the map lacks (merged by a
// loop) are left out; a pair is tied once.
std::vector<GlobalBaLandmarkTie> CrossCameraTies(const Rig& rig, const LoopOutcome* loops, const SparseMap& map,
                                                 const GlobalBaOptions& options) {
  std::vector<GlobalBaLandmarkTie> ties;
  if (loops == nullptr) return ties;
  const std::map<int, int> keyframe_of_frame = KeyframeOfFrame(map);
  std::map<int64_t, const MapLandmark*> landmark_of_id;
  for (const MapLandmark& l : map.landmarks) landmark_of_id.emplace(l.id, &l);
  std::set<std::pair<int64_t, int64_t>> tied;
  for (const CrossCameraLink& link : loops->cross_camera_links) {
    const auto at = keyframe_of_frame.find(link.frame_index);
    const auto a = landmark_of_id.find(link.source_landmark_id), b = landmark_of_id.find(link.landmark_id);
    if (at == keyframe_of_frame.end() || a == landmark_of_id.end() || b == landmark_of_id.end()) continue;
    if (link.camera < 0 || link.camera >= rig.NumCameras()) continue;
    if (!tied.insert(std::minmax(link.landmark_id, link.source_landmark_id)).second) continue;
    const Rigid3d world_from_cam = map.keyframes[static_cast<size_t>(at->second)].world_from_rig *
                                   rig.cameras[static_cast<size_t>(link.camera)].cam_from_rig.Inverse();
    const double distance = (b->second->position_world - world_from_cam.translation).norm();
    if (!(distance > 0.0) || !std::isfinite(distance)) continue;
    GlobalBaLandmarkTie tie;
    tie.landmark_a = link.source_landmark_id;
    tie.landmark_b = link.landmark_id;
    tie.sigma_m = distance * options.cross_camera_link_sigma_px / options.virtual_focal_px;
    ties.push_back(tie);
  }
  return ties;
}

}  // namespace

RefineOutcome RefineGlobally(const Rig& rig, const GlobalBaOptions& options, const LoopOutcome* loops,
                             const PoseGraphOptions& pose_graph, bool scale_free, SparseMap* map,
                             OdometryOutput* odometry) {
  const ScopedStage stage("global bundle adjustment");
  RefineOutcome outcome;
  if (!options.enabled || map->keyframes.empty()) return outcome;
  if (scale_free && !options.monocular) {
    outcome.ba.message = "the scale is arbitrary (one camera) and refine.monocular is off";
    MCVO_LOG(kInfo, "run: global bundle adjustment not run: ", outcome.ba.message);
    return outcome;
  }
  SparseMap fused = *map;
  std::vector<GlobalBaLandmarkTie> ties;
  if (RefineFusesLandmarks(options, scale_free)) {
    outcome.fusion = FuseLoopLandmarks(LoopMatches(loops, *map), &fused);
    const LandmarkFusionResult& f = outcome.fusion;
    if (f.landmarks_merged + f.observations_added > 0) {
      MCVO_LOG(kInfo, "run: loop landmarks fused: ", f.landmarks_merged, " merged, ", f.observations_added,
               " observations added, ", f.merges_rejected, " merges rejected as ambiguous");
    }
    // After the loops' merges: a link naming a landmark merged there is ignored.
    if (options.cross_camera_link_sigma_px > 0.0) {
      ties = CrossCameraTies(rig, loops, fused, options);
    } else {
      outcome.cross_camera_fusion = FuseLoopLandmarks(CrossCameraMatches(loops, fused), &fused);
    }
    const LandmarkFusionResult& x = outcome.cross_camera_fusion;
    if (x.landmarks_merged + x.merges_rejected > 0) {
      MCVO_LOG(kInfo, "run: cross-camera landmarks fused: ", x.landmarks_merged, " merged, ", x.merges_rejected,
               " merges rejected as ambiguous, ", x.matches_ignored, " links ignored");
    }
  }
  outcome.ba =
      RunGlobalBundleAdjustment(rig, fused, scale_free, options, LoopConstraints(loops, pose_graph, fused), ties);
  if (!ties.empty()) {
    MCVO_LOG(kInfo, "run: cross-camera links tied: ", outcome.ba.ties_used, " of ", ties.size(), " in the last solve");
  }
  const GlobalBaResult& ba = outcome.ba;
  if (!ba.ran) {
    MCVO_LOG(kInfo, "run: global bundle adjustment not run: ", ba.message);
    return outcome;
  }
  outcome.applied = true;
  outcome.extrinsics_refined = options.refine_extrinsics;
  outcome.before.poses = odometry->poses;
  outcome.before.keyframes = odometry->keyframes;

  // The refined keyframes are the nodes that carry the correction. Its
  // "before" is the keyframe's pose in odometry->poses, estimated when the
  // frame was the newest, as every non-keyframe's pose there was, not its
  // final window pose: the window moves a keyframe after its frame's pose
  // was taken (on kitti01_stereo by up to 0.45 m), and a non-keyframe
  // carried relative to the moved keyframe jumps by that much at the next
  // keyframe. Between two refined keyframes of a segment the two
  // corrections are blended by time (InterpolateCorrections).
  std::vector<int64_t> node_t_ns;
  std::vector<int> node_segment;
  std::vector<Rigid3d> node_before, node_after;
  std::map<int, Rigid3d> refined_pose;  // frame index -> refined world_from_rig
  for (size_t k = 0; k < map->keyframes.size(); ++k) {
    if (!ba.refined[k]) continue;
    const MapKeyframe& kf = map->keyframes[k];
    if (!node_t_ns.empty() && kf.t_ns <= node_t_ns.back()) continue;  // strictly increasing times
    const auto at_frame = odometry->poses.find(kf.frame_index);
    node_t_ns.push_back(kf.t_ns);
    node_segment.push_back(kf.segment);
    node_before.push_back(at_frame != odometry->poses.end() ? at_frame->second.world_from_body : kf.world_from_rig);
    node_after.push_back(ba.map.keyframes[k].world_from_rig);
    refined_pose[kf.frame_index] = ba.map.keyframes[k].world_from_rig;
  }
  const std::vector<double> stretch = IntervalStretch(node_segment, node_before, node_after);

  const std::map<int, int> segment_of = SegmentOfPosedFrames(*odometry);
  std::vector<int64_t> pose_t_ns;
  std::vector<int> pose_segment;
  std::vector<Rigid3d> pose_before;
  for (const auto& [frame_index, pose] : odometry->poses) {
    pose_t_ns.push_back(pose.t_ns);
    const auto segment = segment_of.find(frame_index);
    pose_segment.push_back(segment != segment_of.end() ? segment->second : -1);
    pose_before.push_back(pose.world_from_body);
  }
  const std::vector<Rigid3d> pose_after = InterpolateCorrections(node_t_ns, node_segment, node_before, node_after,
                                                                 stretch, pose_t_ns, pose_segment, pose_before);
  size_t i = 0;
  for (auto& [frame_index, pose] : odometry->poses) {
    const auto refined = refined_pose.find(frame_index);
    pose.world_from_body = refined != refined_pose.end() ? refined->second : pose_after[i];
    ++i;
  }
  for (KeyframeEstimate& kf : odometry->keyframes) {
    const auto refined = refined_pose.find(kf.frame_index);
    if (refined != refined_pose.end()) {
      kf.world_from_rig = refined->second;
    } else if (const auto pose = odometry->poses.find(kf.frame_index); pose != odometry->poses.end()) {
      kf.world_from_rig = pose->second.world_from_body;
    }
  }
  for (const MapLandmark& landmark : ba.map.landmarks) {
    const auto it = odometry->landmarks.find(landmark.id);
    if (it != odometry->landmarks.end()) it->second = landmark.position_world;
  }
  *map = ba.map;
  MCVO_LOG(kInfo, "run: global bundle adjustment: ", ba.keyframes_refined, " keyframes, ", ba.landmarks_refined,
           " landmarks, ", ba.observations_used, " observations (", ba.observations_removed, " removed), ",
           ba.constraints_used, " loop constraint(s), ",
           ba.solves, " solve(s), ", ba.iterations, " iterations, rms error ", FormatFixed(ba.rms_error_px_before, 3),
           " -> ", FormatFixed(ba.rms_error_px_after, 3), " px, ", FormatFixed(ba.seconds, 2), " s");
  if (outcome.extrinsics_refined) {
    for (size_t c = 0; c < rig.cameras.size() && c < ba.cam_from_rig.size(); ++c) {
      MCVO_LOG(kInfo, "run: extrinsics of ", rig.cameras[c].name, c == 0 ? " (reference, fixed)" : "", ": moved ",
               FormatFixed(ba.extrinsic_rotation_change_deg[c], 4), " deg, ",
               FormatFixed(1000.0 * ba.extrinsic_translation_change_m[c], 2), " mm");
    }
  }
  return outcome;
}

}  // namespace mcvo::pipeline_internal
