// Landmark fusion across loops (landmark_fusion.h).
#include "mcvo/refine/landmark_fusion.h"

#include <algorithm>
#include <map>
#include <set>
#include <tuple>
#include <utility>

namespace mcvo {
namespace {

bool ObservationOrder(const MapObservation& a, const MapObservation& b) {
  return std::tie(a.camera, a.landmark_id) < std::tie(b.camera, b.landmark_id);
}

}  // namespace

LandmarkFusionResult FuseLoopLandmarks(const std::vector<LoopLandmarkMatch>& matches, SparseMap* map) {
  LandmarkFusionResult result;
  const auto has_landmark = [&](int64_t id) {
    const auto it = std::lower_bound(map->landmarks.begin(), map->landmarks.end(), id,
                                     [](const MapLandmark& l, int64_t v) { return l.id < v; });
    return it != map->landmarks.end() && it->id == id;
  };
  const auto valid_keyframe = [&](int k) { return k >= 0 && static_cast<size_t>(k) < map->keyframes.size(); };

  // 1. Proposed merges: each query landmark and the earlier landmarks it matched.
  std::map<int64_t, std::set<int64_t>> matched;  // M -> {L}
  for (const LoopLandmarkMatch& m : matches) {
    if (!valid_keyframe(m.keyframe) || !has_landmark(m.landmark_id)) {
      ++result.matches_ignored;
      continue;
    }
    if (m.query_landmark_id >= 0 && m.query_landmark_id != m.landmark_id && has_landmark(m.query_landmark_id)) {
      matched[m.query_landmark_id].insert(m.landmark_id);
    }
  }
  // One target each, never a chain: M matched one L only, L is no one's
  // duplicate, M no one's target.
  std::set<int64_t> targets;
  for (const auto& [m, ls] : matched) {
    if (ls.size() == 1) targets.insert(*ls.begin());
  }
  std::map<int64_t, int64_t> into;  // M -> L
  for (const auto& [m, ls] : matched) {
    if (ls.size() != 1 || targets.count(m) != 0 || matched.count(*ls.begin()) != 0) {
      ++result.merges_rejected;
      continue;
    }
    into[m] = *ls.begin();
  }
  // Two of one group seen by one keyframe camera are two points: their merges go.
  std::set<int64_t> rejected;
  for (const MapKeyframe& kf : map->keyframes) {
    std::map<std::pair<int, int64_t>, std::vector<int64_t>> seen;  // (camera, group) -> members seen
    for (const MapObservation& o : kf.observations) {
      const auto it = into.find(o.landmark_id);
      const int64_t group = it != into.end() ? it->second : o.landmark_id;
      if (it != into.end() || targets.count(o.landmark_id) != 0) seen[{o.camera, group}].push_back(o.landmark_id);
    }
    for (const auto& [key, members] : seen) {
      if (members.size() < 2) continue;
      for (int64_t id : members) {
        if (into.count(id) != 0) rejected.insert(id);
      }
    }
  }
  for (int64_t id : rejected) into.erase(id);
  result.merges_rejected += static_cast<int>(rejected.size());
  result.landmarks_merged = static_cast<int>(into.size());
  const auto target_of = [&](int64_t id) {
    const auto it = into.find(id);
    return it != into.end() ? it->second : id;
  };

  // 2. The merged landmarks' observations become their targets'. Only the
  // keyframes that change are sorted again (camera, then landmark id).
  std::vector<bool> changed(map->keyframes.size(), false);
  for (size_t k = 0; k < map->keyframes.size(); ++k) {
    for (MapObservation& o : map->keyframes[k].observations) {
      const int64_t target = target_of(o.landmark_id);
      if (target == o.landmark_id) continue;
      o.landmark_id = target;
      changed[k] = true;
    }
  }

  // 3. ORB detections (or query landmarks the map lacks) that saw a landmark: new observations.
  for (const LoopLandmarkMatch& m : matches) {
    if (!valid_keyframe(m.keyframe) || !has_landmark(m.landmark_id)) continue;
    if (m.query_landmark_id >= 0 && has_landmark(m.query_landmark_id)) continue;  // a merge, above
    const int64_t target = target_of(m.landmark_id);
    MapKeyframe& kf = map->keyframes[static_cast<size_t>(m.keyframe)];
    const bool seen = std::any_of(kf.observations.begin(), kf.observations.end(), [&](const MapObservation& o) {
      return o.camera == m.camera && o.landmark_id == target;
    });
    if (seen) continue;
    kf.observations.push_back({m.camera, target, m.pixel});
    changed[static_cast<size_t>(m.keyframe)] = true;
    ++result.observations_added;
  }
  for (size_t k = 0; k < map->keyframes.size(); ++k) {
    if (!changed[k]) continue;
    std::vector<MapObservation>& observations = map->keyframes[k].observations;
    std::stable_sort(observations.begin(), observations.end(), ObservationOrder);
  }

  // 4. The merged landmarks go.
  map->landmarks.erase(std::remove_if(map->landmarks.begin(), map->landmarks.end(),
                                      [&](const MapLandmark& l) { return into.count(l.id) != 0; }),
                       map->landmarks.end());
  return result;
}

}  // namespace mcvo
