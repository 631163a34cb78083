// Landmark fusion across loops (landmark_fusion.h).
#include "mcvo/refine/landmark_fusion.h"

#include <algorithm>
#include <map>
#include <tuple>
#include <utility>

namespace mcvo {
namespace {

// Union-find over landmark ids; the smallest id of a set is its root.
class IdUnion {
 public:
  int64_t Find(int64_t id) {
    auto it = parent_.find(id);
    if (it == parent_.end()) return id;
    const int64_t root = Find(it->second);
    it->second = root;
    return root;
  }
  // True when a and b were in different sets.
  bool Join(int64_t a, int64_t b) {
    a = Find(a);
    b = Find(b);
    if (a == b) return false;
    if (b < a) std::swap(a, b);
    parent_[b] = a;
    return true;
  }

 private:
  std::map<int64_t, int64_t> parent_;
};

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

  // 1. Which landmarks are one.
  IdUnion same;
  for (const LoopLandmarkMatch& m : matches) {
    if (!valid_keyframe(m.keyframe) || !has_landmark(m.landmark_id)) {
      ++result.matches_ignored;
      continue;
    }
    if (m.query_landmark_id >= 0 && has_landmark(m.query_landmark_id)) {
      if (same.Join(m.landmark_id, m.query_landmark_id)) ++result.landmarks_merged;
    }
  }

  // 2. Every observation under its set's id; one per keyframe camera and id.
  for (MapKeyframe& kf : map->keyframes) {
    std::map<std::pair<int, int64_t>, size_t> kept;  // (camera, root) -> index in `out`
    std::vector<MapObservation> out;
    out.reserve(kf.observations.size());
    for (const MapObservation& o : kf.observations) {
      MapObservation renamed = o;
      renamed.landmark_id = same.Find(o.landmark_id);
      const auto [it, inserted] = kept.emplace(std::make_pair(o.camera, renamed.landmark_id), out.size());
      if (inserted) {
        out.push_back(renamed);
        continue;
      }
      ++result.observations_dropped;
      if (o.landmark_id == renamed.landmark_id) out[it->second] = renamed;  // the surviving id's own pixel
    }
    kf.observations = std::move(out);
  }

  // 3. ORB detections that saw a landmark: new observations.
  for (const LoopLandmarkMatch& m : matches) {
    if (!valid_keyframe(m.keyframe) || !has_landmark(m.landmark_id)) continue;
    if (m.query_landmark_id >= 0 && has_landmark(m.query_landmark_id)) continue;  // merged above
    const int64_t root = same.Find(m.landmark_id);
    MapKeyframe& kf = map->keyframes[static_cast<size_t>(m.keyframe)];
    const bool seen = std::any_of(kf.observations.begin(), kf.observations.end(), [&](const MapObservation& o) {
      return o.camera == m.camera && o.landmark_id == root;
    });
    if (seen) continue;
    kf.observations.push_back({m.camera, root, m.pixel});
    ++result.observations_added;
  }
  for (MapKeyframe& kf : map->keyframes) {
    std::sort(kf.observations.begin(), kf.observations.end(), ObservationOrder);
  }

  // 4. The merged landmarks go.
  map->landmarks.erase(std::remove_if(map->landmarks.begin(), map->landmarks.end(),
                                      [&](const MapLandmark& l) { return same.Find(l.id) != l.id; }),
                       map->landmarks.end());
  return result;
}

}  // namespace mcvo
