// Cross-camera links across time: one camera of the rig sees later (or
// earlier) what another camera saw, and the odometry never knew. The
// frontend matches cameras only within one frame; a rig whose views do not
// overlap (or barely: a corridor whose walls are 1-3 m from cameras 1-4 m
// apart) then has no landmark seen by two cameras, and driving straight its
// metric scale is not observable: only the rig's small rotations move the
// cameras' centres differently. A point seen by camera a at keyframe i and
// camera b at keyframe j ties the two cameras' tracks through the rig's
// metric baseline, so the global bundle adjustment observes the scale there
// (refine/landmark_fusion.h merges the two landmarks).
//
//   std::vector<CrossCameraLink> links = FindCrossCameraLinks(rig, keyframes, options, threads);
//
// For each keyframe j and camera b, the landmarks observed by the rig's
// other cameras in keyframes j - window .. j + window (each once: the
// observation whose ray is nearest to b's ray at j lends its descriptor)
// are looked for in b at j. The odometry's scale may be wrong there (that
// is what the links are to measure), so L's point is moved to where it
// would be if the rig's motion since j were s times as long, for s within
// 1 +- max_scale_error (the extrinsics stay metric). A landmark L and a
// landmark M of b's own observations at j are linked when
//  - L is in b's view, its ray from b within max_view_angle_deg of the ray
//    of the observation lending its descriptor (beyond, ORB does not match);
//  - M's pixel is within radius_px (at focal 460, as an angle) of the path
//    of L's projection over the scale hypotheses;
//  - the descriptors' Hamming distance is at most max_distance and below
//    ratio times that of any other M near the path;
//  - each landmark's own rays span at least min_parallax_deg;
//  - all rays of both landmarks (every keyframe observing them) meet in one
//    point within max_reprojection_px (at focal 460, as an angle) under one
//    of the scale hypotheses (steps of 0.01), with the point in front of
//    each: the scale found is reported;
//  - L is the nearest of the landmarks competing for M (mutual best; ties:
//    no link).
// b does not see L at j already. Every pair of landmarks is reported once,
// at the first keyframe (then camera) in which it was found; fusing them
// (refine/landmark_fusion.h) merges the younger id into the older, and its
// rules take it from there (no chains, no merge of two points one camera
// sees at once).
//
// Deterministic: keyframes are searched in parallel into fixed slots and
// merged in keyframe order; the result does not depend on the thread count.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"

namespace mcvo {

struct CrossCameraLinkOptions {
  // Keyframes on each side searched for other cameras' landmarks; 0: off.
  int window_keyframes = 40;
  double radius_px = 6.0;  // at focal 460
  int max_distance = 50;   // bits
  double ratio = 0.8;
  // The odometry's scale between the two observations may be off by this
  // much (relative): the links that observe it are those that disagree.
  double max_scale_error = 0.05;
  double max_reprojection_px = 2.0;  // at focal 460
  // Each landmark's own rays must span this much: a track seen from one
  // place has no depth of its own, and any point in line with it would do.
  double min_parallax_deg = 2.0;
  double max_view_angle_deg = 40.0;
  // Also link camera pairs whose views overlap (those the frontend matches
  // at every frame, given to FindCrossCameraLinks). On: the overlap is
  // computed for points 10 m away, and indoors such pairs (irregular5's)
  // see little of the same wall 1-3 m away; the links are their only tie.
  bool overlapping_pairs = true;
  // Camera pairs that look the same way: a pair each of whose cameras sees
  // more than this share of the other's view (dataset/overlap.h, points
  // 10 m away, no masks) is not linked. Such a pair observes its scale
  // through its baseline at every frame, and across time its search path
  // runs along the epipolar line, where a repeated texture gives wrong
  // links. 1: every pair may be linked.
  double max_pair_overlap = 1.0;
  // Throws InputError naming the field ("/loop/cross_camera/...").
  void Check() const;
};

// One keyframe's landmark observations, with a 32-byte ORB descriptor each.
struct LinkKeyframe {
  int frame_index = 0;
  Rigid3d world_from_rig;
  std::vector<int> camera;
  std::vector<Eigen::Vector2d> pixel;
  std::vector<int64_t> landmark_id;
  std::vector<Eigen::Vector3d> point_in_world;
  cv::Mat descriptors;  // CV_8U, one row per observation
};

// A link: landmark M observed by `camera` at `keyframe` is the landmark L
// observed by source_camera at source_keyframe (the observation that lent
// L's descriptor).
struct CrossCameraLink {
  int keyframe = 0;  // index into the keyframes given
  int frame_index = 0;
  int camera = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // M's
  int64_t landmark_id = 0;                          // M
  int source_keyframe = 0;
  int source_frame_index = 0;
  int source_camera = 0;
  Eigen::Vector2d source_pixel = Eigen::Vector2d::Zero();  // L's
  int64_t source_landmark_id = 0;                          // L
  int distance = 0;                                        // Hamming, bits
  double view_angle_deg = 0.0;                             // between the two observations' rays to L's point
  // The scale of the odometry's motion (about keyframe j's rig origin) under
  // which the two landmarks' rays meet best: a measurement of the local
  // scale error, 1 where the odometry is right.
  double scale = 1.0;
};

// overlapping: the camera pairs (a < b) whose views overlap (the frontend's
// cross-camera pairs); not linked unless options.overlapping_pairs.
std::vector<CrossCameraLink> FindCrossCameraLinks(const Rig& rig, const std::vector<LinkKeyframe>& keyframes,
                                                  const CrossCameraLinkOptions& options, int threads,
                                                  const std::vector<std::pair<int, int>>& overlapping = {});

}  // namespace mcvo
