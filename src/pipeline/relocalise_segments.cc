#include "relocalise_segments.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <thread>
#include <utility>

#include <opencv2/video/tracking.hpp>

#include "mcvo/backend/rig_pnp.h"

#include "mcvo/util/error.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"

namespace mcvo::pipeline_internal {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
// Descriptor levels of the map's landmarks (loop/landmark_levels, at least):
// the rig moved on while tracking was lost, so the query sees the map's
// places nearer, up to 1.2^(3-1) = 1.44 times larger.
constexpr int kRelocaliseLevels = 3;

// The best verified relocalisation of one segment.
struct Located {
  bool ok = false;
  int query_frame = -1;
  int64_t query_t_ns = 0;
  int map_frame = -1;
  int inliers = 0;
  int cameras = 0;
  int verified_queries = 0;
  std::string method;        // how the verified matches were found
  std::string best_failure;  // the unverified attempt with the most matches: why
  int best_failure_matches = -1;
  Rigid3d world_prev_from_query;  // the query keyframe's rig pose in the previous segment's world
  Rigid3d world_cur_from_query;   // and in its own (linked) world
};

// Keyframe indices (into odometry.keyframes, frame order) per segment.
std::map<int, std::vector<size_t>> KeyframesBySegment(const std::vector<KeyframeEstimate>& keyframes) {
  std::vector<size_t> order(keyframes.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return keyframes[a].frame_index < keyframes[b].frame_index; });
  std::map<int, std::vector<size_t>> out;
  for (size_t k : order) out[keyframes[k].segment].push_back(k);
  return out;
}

Located Locate(const DatasetIndex& index, const Vocabulary& vocabulary, const LoopOptions& options,
               int threads, const std::vector<KeyframeEstimate>& keyframes, const std::vector<size_t>& map,
               const std::vector<size_t>& queries) {
  LoopClosureOptions closure = options.closure;
  closure.landmark_levels = std::max(closure.landmark_levels, kRelocaliseLevels);
  closure.landmark_orientation = true;
  LoopCloser closer(index.rig, index.masks, vocabulary, closure, threads);
  for (size_t k : map) closer.AddMapKeyframe(ToLoopKeyframe(index, keyframes[k], threads));
  Located best;
  for (size_t q : queries) {
    const KeyframeEstimate& query = keyframes[q];
    for (const LoopAttempt& attempt :
         closer.Relocalise(ToLoopKeyframe(index, query, threads), options.closure.max_candidates)) {
      if (!attempt.verified) {
        if (attempt.matches > best.best_failure_matches) {
          best.best_failure_matches = attempt.matches;
          best.best_failure =
              StrCat("frame ", query.frame_index, " against ", attempt.candidate_frame, ": ", attempt.matches,
                     " matches, ", attempt.inliers, " inliers, ", attempt.reason);
        }
        continue;
      }
      ++best.verified_queries;
      if (best.ok && attempt.inliers <= best.inliers) continue;
      const KeyframeEstimate& candidate = keyframes[map[static_cast<size_t>(attempt.candidate)]];
      best.ok = true;
      best.query_frame = query.frame_index;
      best.query_t_ns = query.t_ns;
      best.map_frame = candidate.frame_index;
      best.inliers = attempt.inliers;
      best.cameras = attempt.cameras_with_inliers;
      best.method = "BoW and ORB descriptors";
      best.world_prev_from_query = candidate.world_from_rig * attempt.candidate_from_query;
      best.world_cur_from_query = query.world_from_rig;
    }
  }
  return best;
}

// Re-tracking across the gap, the second look when no BoW candidate
// verifies (descriptors taken at the tracker's corners rarely match ORB's
// own corners after a loss: the tracks are new). The landmarks of the map's
// keyframes, each from the latest one that observes it in that camera
// (nearest the loss), are tracked by pyramidal LK from that
// keyframe's image into the same camera of the query, each started at its
// projection under the query's constant-velocity pose (the link the
// odometry stage made: `prior`), kept when tracking back lands within
// kRetrackBackPx of where it started; then the rig PnP of loop
// verification (seeded with the prior, which RANSAC also scores) and the
// same inlier and camera bounds. The prior only says where to look: the
// pose is the PnP's, from the map's points. (Measured on the 20 Hz street
// with every camera black for 10 frames: the map's last 3 keyframes gave
// 35 inliers, all 10 gave 44: results/relocalisation.md.)
constexpr double kRetrackBackPx = 1.0;

Located LocateByTracking(const DatasetIndex& index, const LoopClosureOptions& closure, int threads,
                         const std::vector<KeyframeEstimate>& keyframes, const std::vector<size_t>& map,
                         const std::vector<size_t>& queries) {
  const Rig& rig = index.rig;
  const int n = rig.NumCameras();
  const std::vector<Rigid3d> cam_from_rig = rig.CamFromRig();
  // Map keyframes, latest first.
  std::vector<LoopKeyframe> sources;
  for (size_t k = map.size(); k-- > 0;) sources.push_back(ToLoopKeyframe(index, keyframes[map[k]], threads));
  if (sources.empty()) return {};
  Located best;
  for (size_t q : queries) {
    const KeyframeEstimate& query = keyframes[q];
    const LoopKeyframe target = ToLoopKeyframe(index, query, threads);
    const Rigid3d& prior = query.world_from_rig;
    const Rigid3d rig_from_world = prior.Inverse();
    std::vector<RigPnpCorrespondence> correspondences;
    int cameras_tracked = 0;
    for (int c = 0; c < n; ++c) {
      const cv::Mat& to = target.images[static_cast<size_t>(c)];
      if (to.empty()) continue;
      const Camera& camera = rig.cameras[static_cast<size_t>(c)];
      std::set<int64_t> used;  // landmarks of this camera already taken from a later keyframe
      const size_t before = correspondences.size();
      for (const LoopKeyframe& source : sources) {
        const cv::Mat& from = source.images[static_cast<size_t>(c)];
        if (from.empty()) continue;
        std::vector<cv::Point2f> start, guess;
        std::vector<Eigen::Vector3d> points;
        for (const LoopKeyframe::Point& p : source.points) {
          if (p.camera != c || used.count(p.landmark_id) > 0) continue;
          const std::optional<Eigen::Vector2d> predicted =
              camera.Project(cam_from_rig[static_cast<size_t>(c)] * (rig_from_world * p.point_in_world));
          if (!predicted || !camera.IsInImage(*predicted)) continue;
          used.insert(p.landmark_id);
          start.emplace_back(static_cast<float>(p.pixel.x()), static_cast<float>(p.pixel.y()));
          guess.emplace_back(static_cast<float>(predicted->x()), static_cast<float>(predicted->y()));
          points.push_back(p.point_in_world);
        }
        if (start.empty()) continue;
        const cv::Size window(21, 21);
        const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
        std::vector<cv::Point2f> tracked = guess, back = start;
        std::vector<uint8_t> status, back_status;
        std::vector<float> error;
        cv::calcOpticalFlowPyrLK(from, to, start, tracked, status, error, window, 3, criteria,
                                 cv::OPTFLOW_USE_INITIAL_FLOW);
        cv::calcOpticalFlowPyrLK(to, from, tracked, back, back_status, error, window, 3, criteria,
                                 cv::OPTFLOW_USE_INITIAL_FLOW);
        for (size_t i = 0; i < start.size(); ++i) {
          if (!status[i] || !back_status[i] || cv::norm(back[i] - start[i]) > kRetrackBackPx) continue;
          const Eigen::Vector2d pixel(tracked[i].x, tracked[i].y);
          if (!camera.IsInImage(pixel)) continue;
          const std::optional<Eigen::Vector3d> bearing = camera.Unproject(pixel);
          if (!bearing) continue;
          correspondences.push_back({c, bearing->normalized(), points[i]});
        }
      }
      cameras_tracked += correspondences.size() > before ? 1 : 0;
    }
    const int matches = static_cast<int>(correspondences.size());
    auto fail = [&](const std::string& reason, int inliers) {
      if (matches <= best.best_failure_matches) return;
      best.best_failure_matches = matches;
      best.best_failure =
          StrCat("frame ", query.frame_index, " re-tracked from frames ", sources.back().frame_index, "-",
                 sources.front().frame_index, ": ", matches, " tracks, ", inliers, " inliers, ", reason);
    };
    if (matches < closure.min_inliers) {
      fail(StrCat(matches, " tracks < ", closure.min_inliers), 0);
      continue;
    }
    RigPnpOptions pnp_options;
    pnp_options.threshold_px = closure.pnp_threshold_px;
    pnp_options.max_iterations = closure.pnp_max_iterations;
    pnp_options.min_inliers = closure.min_inliers;
    const RigPnpResult pnp = SolveRigPnp(cam_from_rig, correspondences, pnp_options, &prior);
    if (!pnp.ok) {
      fail(StrCat("rig pose: ", pnp.reason), pnp.num_inliers);
      continue;
    }
    int cameras = 0;
    for (int inliers : pnp.inliers_per_camera) cameras += inliers >= closure.min_camera_inliers ? 1 : 0;
    const int needed =
        std::max(1, static_cast<int>(std::ceil(closure.min_camera_fraction * cameras_tracked - 1e-9)));
    if (cameras < needed) {
      fail(StrCat(cameras, " camera(s) with >= ", closure.min_camera_inliers, " inliers < ", needed),
           pnp.num_inliers);
      continue;
    }
    ++best.verified_queries;
    if (best.ok && pnp.num_inliers <= best.inliers) continue;
    best.ok = true;
    best.query_frame = query.frame_index;
    best.query_t_ns = query.t_ns;
    best.map_frame = sources.front().frame_index;
    best.inliers = pnp.num_inliers;
    best.cameras = cameras;
    best.method = StrCat("re-tracking the landmarks of frames ", sources.back().frame_index, "-",
                         sources.front().frame_index, " from the constant-velocity prediction");
    best.world_prev_from_query = pnp.world_from_rig;
    best.world_cur_from_query = query.world_from_rig;
  }
  return best;
}

}  // namespace

LoopKeyframe LoopKeyframeWithoutImages(const KeyframeEstimate& kf, int num_cameras) {
  LoopKeyframe lk;
  lk.frame_index = kf.frame_index;
  lk.t_ns = kf.t_ns;
  lk.world_from_rig = kf.world_from_rig;
  lk.images.resize(static_cast<size_t>(num_cameras));
  for (size_t k = 0; k < kf.observations.size() && k < kf.observation_points.size(); ++k) {
    const MapObservation& ob = kf.observations[k];
    lk.points.push_back({ob.camera, ob.landmark_id, ob.pixel, kf.observation_points[k]});
  }
  return lk;
}

ColmapColorSamples SampleKeyframeColors(const cv::Mat& decoded, const KeyframeEstimate& kf, int camera) {
  std::vector<Eigen::Vector2d> pixels;
  for (const MapObservation& ob : kf.observations) {
    if (ob.camera == camera) pixels.push_back(ob.pixel);
  }
  return SampleColmapColors(decoded, std::move(pixels));
}

LoopKeyframe ToLoopKeyframe(const DatasetIndex& index, const KeyframeEstimate& kf, int threads,
                            std::vector<ColmapColorSamples>* colors) {
  const Rig& rig = index.rig;
  LoopKeyframe lk = LoopKeyframeWithoutImages(kf, rig.NumCameras());
  if (colors != nullptr) colors->assign(static_cast<size_t>(rig.NumCameras()), ColmapColorSamples());
  if (kf.frame_index >= 0 && kf.frame_index < static_cast<int>(index.frames.size())) {
    const std::vector<std::filesystem::path>& paths =
        index.frames[static_cast<size_t>(kf.frame_index)].images;
    const int n = static_cast<int>(std::min(paths.size(), lk.images.size()));
    ParallelFor(n, std::max(1, threads), [&](int c) {
      if (paths[c].empty()) return;
      // One decode for the grey image (the frontend's: dataset.h
      // GreyOfDecodedImage) and the colours.
      const cv::Mat decoded = DecodeColmapColorImage(paths[c]);
      lk.images[c] = GreyOfDecodedImage(decoded);
      if (colors != nullptr) (*colors)[static_cast<size_t>(c)] = SampleKeyframeColors(decoded, kf, c);
    });
    for (int c = 0; c < n; ++c) {
      if (!paths[c].empty() && lk.images[c].empty()) {
        MCVO_THROW_INPUT(paths[c].string(), ": cannot read the image (loop closure)");
      }
    }
  }
  return lk;
}

RelocalisationSummary RelocaliseSegments(const DatasetIndex& index, const Vocabulary& vocabulary,
                                         const LoopOptions& options, int threads, OdometryOutput* odometry) {
  const ScopedStage stage("relocalising segments");
  RelocalisationSummary summary;
  if (!options.relocalise || odometry->segments < 2) return summary;
  // Segments in order, each located against the one before it as that one
  // stands now (already relocalised itself). Moving a segment changes poses
  // only, not which keyframes it has.
  const std::map<int, std::vector<size_t>> by_segment = KeyframesBySegment(odometry->keyframes);
  if (by_segment.size() < 2) return summary;
  for (auto prev = by_segment.begin(), it = std::next(prev); it != by_segment.end(); prev = it++) {
    const int prev_segment = prev->first, segment = it->first;
    const std::vector<size_t>& before = prev->second;
    const std::vector<size_t>& after = it->second;
    const size_t map_count = std::min(before.size(), static_cast<size_t>(options.relocalise_map_keyframes));
    const std::vector<size_t> map(before.end() - static_cast<std::ptrdiff_t>(map_count), before.end());
    const size_t query_count =
        std::min(after.size(), static_cast<size_t>(options.relocalise_query_keyframes));
    const std::vector<size_t> queries(after.begin(),
                                      after.begin() + static_cast<std::ptrdiff_t>(query_count));
    ++summary.attempted;
    Located located = Locate(index, vocabulary, options, threads, odometry->keyframes, map, queries);
    if (!located.ok) {
      Located tracked = LocateByTracking(index, options.closure, threads, odometry->keyframes, map, queries);
      if (tracked.ok) {
        located = std::move(tracked);
      } else {
        located.best_failure = StrCat(
            located.best_failure.empty() ? "no candidate" : located.best_failure,
            "; re-tracking: ", tracked.best_failure.empty() ? "nothing to track" : tracked.best_failure);
      }
    }

    ScaleLogEntry entry;
    entry.segment = segment;
    entry.event = "relocalise";
    const KeyframeEstimate& first_query = odometry->keyframes[queries.front()];
    entry.frame_index = located.ok ? located.query_frame : first_query.frame_index;
    entry.t_ns = located.ok ? located.query_t_ns : first_query.t_ns;
    const std::string where = StrCat("in the map of segment ", prev_segment, " (keyframes of frames ",
                                     odometry->keyframes[map.front()].frame_index, "-",
                                     odometry->keyframes[map.back()].frame_index, ")");
    if (!located.ok) {
      entry.applied = false;
      entry.note = StrCat(
          "segment ", segment, " not relocalised ", where, ": none of its first ", queries.size(),
          " keyframes verified (best: ", located.best_failure.empty() ? "no candidate" : located.best_failure,
          "); the constant-velocity link stays");
      MCVO_LOG(kWarning, "run: ", entry.note);
    } else {
      // world_prev_from_world_cur, applied to this segment and every later
      // one (they are chained to it).
      const Rigid3d correction = located.world_prev_from_query * located.world_cur_from_query.Inverse();
      std::map<int, Sim3d> move;
      for (auto later = it; later != by_segment.end(); ++later) move[later->first] = Sim3d(correction);
      MoveSegments(move, odometry);
      ++summary.applied;
      entry.applied = true;
      const double shift_m =
          (located.world_prev_from_query.translation - located.world_cur_from_query.translation).norm();
      const double shift_deg =
          located.world_prev_from_query.rotation.angularDistance(located.world_cur_from_query.rotation) *
          kRadToDeg;
      entry.note =
          StrCat("segment ", segment, " relocalised ", where, ": keyframe of frame ", located.query_frame,
                 " against frame ", located.map_frame, " (", located.method, "), ", located.inliers,
                 " inliers in ", located.cameras, " camera(s), ", located.verified_queries, " of ",
                 queries.size(), " keyframes verified; moved ", FormatFixed(shift_m, 3), " m, ",
                 FormatFixed(shift_deg, 2), " deg from the constant-velocity link");
      MCVO_LOG(kInfo, "run: ", entry.note);
    }
    odometry->scale_log.push_back(std::move(entry));
  }
  std::stable_sort(
      odometry->scale_log.begin(), odometry->scale_log.end(),
      [](const ScaleLogEntry& a, const ScaleLogEntry& b) { return a.frame_index < b.frame_index; });
  return summary;
}

}  // namespace mcvo::pipeline_internal
