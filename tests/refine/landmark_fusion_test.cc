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
  EXPECT_EQ(r.merges_rejected, 0);
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

TEST(LandmarkFusion, AmbiguousMergesAreRejected) {
  SparseMap map = LoopMap();
  map.keyframes[1].observations.push_back(Obs(1, 9, 305));  // keyframe 1 sees 3 and 9 in camera 1
  map.keyframes[2].observations.push_back(Obs(0, 11, 500));
  map.landmarks.push_back({11, Eigen::Vector3d(11, 0, 5)});
  const std::vector<LoopLandmarkMatch> matches = {
      {2, 0, Eigen::Vector2d(110, 10), 1, 7},  // 7 is 1 ...
      {2, 0, Eigen::Vector2d(110, 10), 2, 7},  // ... or 2: ambiguous
      {2, 0, Eigen::Vector2d(210, 10), 2, 8},  // 8 is 2, but 8 is a target below: a chain
      {2, 1, Eigen::Vector2d(400, 10), 8, 10}, // 10 is 8, a duplicate itself
      {2, 1, Eigen::Vector2d(310, 10), 3, 9},  // 9 is 3, but keyframe 1 sees both: two points
      {2, 0, Eigen::Vector2d(500, 10), 1, 11}, // 11 is 1: the one merge
  };
  const LandmarkFusionResult r = FuseLoopLandmarks(matches, &map);
  EXPECT_EQ(r.landmarks_merged, 1);
  EXPECT_EQ(r.merges_rejected, 4);  // 7, 8, 10, 9
  EXPECT_EQ(r.observations_added, 0);
  EXPECT_EQ(Ids(map), (std::vector<int64_t>{1, 2, 3, 7, 8, 9, 10}));
  const MapKeyframe& kf = map.keyframes[2];
  EXPECT_TRUE(Ordered(kf));
  ASSERT_EQ(kf.observations.size(), 5u);
  EXPECT_EQ(kf.observations[0].landmark_id, 1);  // 11's observation, now of 1
  EXPECT_EQ(kf.observations[0].pixel.x(), 500);
  EXPECT_EQ(map.keyframes[1].observations.size(), 4u);
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

TEST(LandmarkFusion, WithoutMatchesTheMapIsLeftExactlyAsItWas) {
  SparseMap map = LoopMap();
  std::swap(map.keyframes[0].observations[0], map.keyframes[0].observations[2]);  // out of order
  const SparseMap before = map;
  const LandmarkFusionResult r = FuseLoopLandmarks({}, &map);
  EXPECT_EQ(r.landmarks_merged + r.observations_added + r.merges_rejected + r.matches_ignored, 0);
  EXPECT_EQ(Ids(map), Ids(before));
  for (size_t k = 0; k < map.keyframes.size(); ++k) {
    ASSERT_EQ(map.keyframes[k].observations.size(), before.keyframes[k].observations.size());
    for (size_t i = 0; i < map.keyframes[k].observations.size(); ++i) {
      EXPECT_EQ(map.keyframes[k].observations[i].landmark_id, before.keyframes[k].observations[i].landmark_id);
    }
  }
}

}  // namespace
}  // namespace mcvo
