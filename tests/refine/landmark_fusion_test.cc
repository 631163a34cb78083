// Landmark fusion across loops on small hand-built maps: what is merged,
// added, dropped and ignored, and the map's order invariants after it.
#include <gtest/gtest.h>

#include <algorithm>
#include <tuple>
#include <vector>

#include "mcvo/refine/landmark_fusion.h"

namespace mcvo {
namespace {

MapObservation Obs(int camera, int64_t id, double u) { return {camera, id, Eigen::Vector2d(u, 10.0)}; }

// Keyframes 0 and 1 (the old visit) see landmarks 1, 2, 3; keyframe 2 (the
// return) sees 7, 8, 9 again, and 10, which nothing matches.
SparseMap LoopMap() {
  SparseMap map;
  for (int k = 0; k < 3; ++k) {
    MapKeyframe kf;
    kf.frame_index = 10 * k;
    map.keyframes.push_back(kf);
  }
  map.keyframes[0].observations = {Obs(0, 1, 100), Obs(0, 2, 200), Obs(1, 3, 300)};
  map.keyframes[1].observations = {Obs(0, 1, 101), Obs(0, 2, 201), Obs(1, 3, 301)};
  map.keyframes[2].observations = {Obs(0, 7, 110), Obs(0, 8, 210), Obs(1, 9, 310), Obs(1, 10, 400)};
  for (int64_t id : {1, 2, 3, 7, 8, 9, 10}) map.landmarks.push_back({id, Eigen::Vector3d(id, 0, 5)});
  return map;
}

std::vector<int64_t> Ids(const SparseMap& map) {
  std::vector<int64_t> ids;
  for (const MapLandmark& l : map.landmarks) ids.push_back(l.id);
  return ids;
}

bool Ordered(const MapKeyframe& kf) {
  return std::is_sorted(kf.observations.begin(), kf.observations.end(),
                        [](const MapObservation& a, const MapObservation& b) {
                          return std::tie(a.camera, a.landmark_id) < std::tie(b.camera, b.landmark_id);
                        });
}

TEST(LandmarkFusion, DuplicatesMergeIntoTheOlderLandmark) {
  SparseMap map = LoopMap();
  // Keyframe 2's own pixels of 7 and 9 matched 1 and 3; an ORB detection
  // in camera 1 matched 2 (keyframe 2 sees 2 nowhere yet).
  const std::vector<LoopLandmarkMatch> matches = {
      {2, 0, Eigen::Vector2d(110, 10), 1, 7},
      {2, 1, Eigen::Vector2d(310, 10), 3, 9},
      {2, 1, Eigen::Vector2d(250, 12), 2, -1},
  };
  const LandmarkFusionResult r = FuseLoopLandmarks(matches, &map);
  EXPECT_EQ(r.landmarks_merged, 2);
  EXPECT_EQ(r.observations_added, 1);
  EXPECT_EQ(r.observations_dropped, 0);
  EXPECT_EQ(r.matches_ignored, 0);
  EXPECT_EQ(Ids(map), (std::vector<int64_t>{1, 2, 3, 8, 10}));
  // The old landmarks keep their positions.
  EXPECT_EQ(map.landmarks[0].position_world, Eigen::Vector3d(1, 0, 5));
  const MapKeyframe& kf = map.keyframes[2];
  ASSERT_EQ(kf.observations.size(), 5u);
  EXPECT_TRUE(Ordered(kf));
  // (camera, id, u): 7 -> 1 and 9 -> 3 at their own pixels, the detection of 2 added.
  EXPECT_EQ(kf.observations[0].landmark_id, 1);
  EXPECT_EQ(kf.observations[0].pixel.x(), 110);
  EXPECT_EQ(kf.observations[1].landmark_id, 8);
  EXPECT_EQ(kf.observations[2].camera, 1);
  EXPECT_EQ(kf.observations[2].landmark_id, 2);
  EXPECT_EQ(kf.observations[2].pixel, Eigen::Vector2d(250, 12));
  EXPECT_EQ(kf.observations[3].landmark_id, 3);
  EXPECT_EQ(kf.observations[4].landmark_id, 10);
  // The old keyframes are unchanged.
  EXPECT_EQ(map.keyframes[0].observations.size(), 3u);
}

TEST(LandmarkFusion, ChainsUniteAndConflictsKeepOneObservation) {
  SparseMap map = LoopMap();
  // 8 matched 2, a second loop says 10 is 8 (so 10 is 2), and a third that
  // 1 is 2: all four are landmark 1. Keyframes 0 and 1 saw 1 and 2 in
  // camera 0 at different pixels: one of each pair is dropped, 1's own kept.
  // Keyframe 2 saw 8 in camera 0 and 10 in camera 1: both stay (one
  // landmark seen by two cameras).
  const std::vector<LoopLandmarkMatch> matches = {
      {2, 0, Eigen::Vector2d(210, 10), 2, 8},
      {2, 1, Eigen::Vector2d(400, 10), 8, 10},
      {1, 0, Eigen::Vector2d(101, 10), 2, 1},
  };
  const LandmarkFusionResult r = FuseLoopLandmarks(matches, &map);
  EXPECT_EQ(r.landmarks_merged, 3);  // 8 -> 2, 10 -> 2, 2 -> 1
  EXPECT_EQ(Ids(map), (std::vector<int64_t>{1, 3, 7, 9}));
  // Keyframes 0 and 1 each saw 1 and 2 in camera 0: one observation kept, 1's own.
  EXPECT_EQ(r.observations_dropped, 2);
  for (int k : {0, 1}) {
    const MapKeyframe& kf = map.keyframes[static_cast<size_t>(k)];
    ASSERT_EQ(kf.observations.size(), 2u);
    EXPECT_EQ(kf.observations[0].landmark_id, 1);
    EXPECT_EQ(kf.observations[0].pixel.x(), 100 + k);
    EXPECT_TRUE(Ordered(kf));
  }
  // Keyframe 2: 8 (camera 0) and 10 (camera 1) are both 1 now, one per camera.
  const MapKeyframe& kf = map.keyframes[2];
  EXPECT_TRUE(Ordered(kf));
  int ones = 0;
  for (const MapObservation& o : kf.observations) ones += o.landmark_id == 1 ? 1 : 0;
  EXPECT_EQ(ones, 2);
}

TEST(LandmarkFusion, UnknownKeyframesAndLandmarksAreIgnoredAndSeenOnesNotAdded) {
  SparseMap map = LoopMap();
  const SparseMap before = map;
  const std::vector<LoopLandmarkMatch> matches = {
      {5, 0, Eigen::Vector2d(1, 1), 1, -1},    // no keyframe 5
      {2, 0, Eigen::Vector2d(1, 1), 42, -1},   // no landmark 42
      {2, 0, Eigen::Vector2d(1, 1), 1, 42},    // the query's landmark not in the map: an observation of 1
      {2, 0, Eigen::Vector2d(2, 1), 1, -1},    // and again: keyframe 2 sees 1 in camera 0 now
      {0, 0, Eigen::Vector2d(1, 1), 2, -1},    // keyframe 0 sees 2 in camera 0 already
  };
  const LandmarkFusionResult r = FuseLoopLandmarks(matches, &map);
  EXPECT_EQ(r.matches_ignored, 2);
  EXPECT_EQ(r.landmarks_merged, 0);
  EXPECT_EQ(r.observations_added, 1);
  EXPECT_EQ(Ids(map), Ids(before));
  for (size_t k = 0; k < map.keyframes.size(); ++k) {
    EXPECT_EQ(map.keyframes[k].observations.size(), before.keyframes[k].observations.size() + (k == 2 ? 1 : 0));
    EXPECT_TRUE(Ordered(map.keyframes[k]));
  }
  EXPECT_EQ(map.keyframes[2].observations[0].landmark_id, 1);
  EXPECT_EQ(map.keyframes[2].observations[0].pixel, Eigen::Vector2d(1, 1));
}

}  // namespace
}  // namespace mcvo
