// Landmark fusion across loops (issue 15, item 2): a loop's verification
// finds pixels of the query keyframe that see landmarks of the keyframes
// it returned to. The sliding window never knew: the same wall point got a
// second landmark on the way back. Fusing them makes the loop enter the
// global bundle adjustment through shared points, as every other constraint
// does, and leaves one point per place in the COLMAP model.
//
//   std::vector<LoopLandmarkMatch> matches = ...;  // loop verification's inliers
//   LandmarkFusionResult fused = FuseLoopLandmarks(matches, &map);
//
// Per match (query keyframe k, camera c, pixel u, earlier landmark L):
//  - the pixel is k's own observation of landmark M (query_landmark_id):
//    M is a duplicate of L and is merged into it (every observation of M
//    becomes one of L; L keeps its id and position), unless the evidence
//    is ambiguous: M matched more than one earlier landmark, M is itself a
//    merge target or L a duplicate (no chains: a wrong match must not join
//    two distinct points through a third), or one keyframe camera sees two
//    of the landmarks that would become one (they are two points then);
//  - an ORB detection, or a landmark of k the map no longer has: k gains
//    the observation (c, L, u) unless that camera already sees L.
// Matches naming a keyframe or landmark the map lacks are ignored. The
// result does not depend on the matches' order. A keyframe that changes has
// its observations sorted by camera, then landmark id; the others, and the
// whole map without a match, are left exactly as they were.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "mcvo/map/sparse_map.h"

namespace mcvo {

struct LoopLandmarkMatch {
  int keyframe = 0;  // index into SparseMap::keyframes (the query)
  int camera = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  int64_t landmark_id = 0;         // the earlier keyframes' landmark
  int64_t query_landmark_id = -1;  // the query's own landmark at the pixel, or -1
};

struct LandmarkFusionResult {
  int landmarks_merged = 0;     // landmarks that became another (removed from the map)
  int observations_added = 0;   // ORB detections added as observations
  int merges_rejected = 0;      // proposed merges left out as ambiguous (see above)
  int matches_ignored = 0;      // unknown keyframe or landmark
};

LandmarkFusionResult FuseLoopLandmarks(const std::vector<LoopLandmarkMatch>& matches, SparseMap* map);

}  // namespace mcvo
