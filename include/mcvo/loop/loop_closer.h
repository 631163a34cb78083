// Loop closure (paper Sec. "Loop Closure"): one bag-of-words entry per
// multi-camera keyframe, verification by a generalized absolute pose over
// all cameras at once, and the loop edges for the pose graph (pose_graph.h).
//
// For each keyframe, in order (AddKeyframe):
//  1. Features: ORB (FAST + rBRIEF, `features_per_camera`, inside the
//     camera's mask) in every camera image, and ORB descriptors at the
//     pixels of the keyframe's landmark observations (the back end's tracked
//     features), which carry the landmarks' world positions. An image of
//     more than `feature_max_megapixels` is described on the first pyramid
//     level within it (dataset/image_level.h); pixels stay full-resolution.
//  2. Bag of words of the features of all cameras together (one database
//     entry per keyframe), so a place is found again whichever camera sees
//     it (a street driven the other way: the left fisheye now sees what the
//     right one saw).
//  3. Query: the keyframes older than `exclude_recent_keyframes` with a BoW
//     score of at least `min_score` and at least `min_normalized_score`
//     times the query's score with the previous keyframe (DBoW2), best
//     first; the best `max_candidates` are verified.
//  4. Verification: the query's ORB features of all cameras are matched
//     (Hamming, ratio test) to the candidate's landmarks and those of its
//     neighbours in the keyframe sequence, then the rig pose is solved from
//     all cameras at once (backend/rig_pnp.h: OpenGV GP3P in RANSAC + Ceres).
//     Verified when there are at least `min_inliers` inliers and at least
//     `min_camera_fraction` of the cameras that had features have
//     `min_camera_inliers` inliers of their own, and when the correction it
//     implies is plausible for the odometry's drift: at most
//     `max_correction_fraction` of the path between the two keyframes plus
//     `max_correction_floor_m` (repeated facades along a street match
//     geometrically too, at an implied drift of tens of percent).
//  5. Consistency against repeated facades: a verified candidate becomes a
//     loop only when the previous keyframe (or one of the last
//     `consistency_window` keyframes) verified a candidate within
//     `consistency_window` keyframes of this one: a real revisit is seen by
//     consecutive keyframes at consecutive places; a look-alike facade
//     rarely is.
// The loop edge is candidate_from_query: the query rig pose in the
// candidate's (drifted) map over the candidate's pose.
//
// Deterministic: features per camera (AddKeyframe) or per keyframe
// (AddKeyframes) are extracted in parallel into fixed slots, descriptor
// matching splits the query's rows over threads (each row is matched on its
// own); everything else is sequential in keyframe order. The results do not
// depend on the thread count.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/loop/cross_camera_links.h"
#include "mcvo/loop/pose_graph.h"
#include "mcvo/loop/vocabulary.h"

namespace mcvo {

struct LoopClosureOptions {
  int features_per_camera = 500;
  // A camera image of more megapixels than this is described (ORB detections
  // and landmark descriptors) on the first pyramid level that is not larger
  // (cv::pyrDown, halving each side); 0: always at full resolution. The
  // default leaves the images of at most 1 Mpx as they are.
  double feature_max_megapixels = 1.0;
  int exclude_recent_keyframes = 50;
  double min_score = 0.015;
  // Score over the query's score with the previous keyframe (DBoW2's
  // normalisation): candidates below it are not verified.
  double min_normalized_score = 0.0;
  int max_candidates = 3;
  double match_ratio = 0.8;       // Lowe's ratio test on Hamming distances
  int max_match_distance = 64;    // bits
  double pnp_threshold_px = 3.0;  // at focal 460
  int pnp_max_iterations = 1000;
  int min_inliers = 40;
  int min_camera_inliers = 8;        // a camera "has inliers" with at least this many
  double min_camera_fraction = 0.5;  // of the cameras that had features
  int consistency_window = 3;        // keyframes (see 5.)
  // Plausibility (see 4.): the correction a loop implies (the difference
  // between the odometry's and the loop's relative pose) must not exceed
  // this fraction of the odometry's path between the two keyframes plus the
  // floor; a look-alike place far away implies an impossible drift.
  double max_correction_fraction = 0.1;
  double max_correction_floor_m = 2.0;
  int candidate_neighbours = 2;  // landmarks of this many keyframes on each side of the candidate
  // ORB descriptors per landmark pixel, on this many pyramid levels (1.2
  // apart): more match a place seen from farther or nearer. Loop closure
  // uses its config value; relocalisation at least 3.
  int landmark_levels = 1;
  // Oriented descriptors at the landmark pixels (ORB's intensity-centroid
  // angle), like those of the detections they are matched with; false:
  // upright. Relocalisation sets it; loop closure keeps its config value
  // (false by default until measured on the suite).
  bool landmark_orientation = false;
  // Cross-camera links across time among the keyframes added
  // (CrossCameraLinks, loop/cross_camera_links.h).
  CrossCameraLinkOptions cross_camera;
  // Throws InputError naming the field ("/loop/...").
  void Check() const;
};

struct LoopKeyframe {
  int frame_index = 0;
  int64_t t_ns = 0;
  Rigid3d world_from_rig;       // the odometry's pose
  std::vector<cv::Mat> images;  // CV_8UC1 per rig camera; empty Mat: no image
  struct Point {
    int camera = 0;
    int64_t landmark_id = 0;
    Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
    Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();
  };
  std::vector<Point> points;  // the keyframe's observations of triangulated landmarks
};

// One verified (or rejected) candidate of one query keyframe: a line of loops.csv.
struct LoopAttempt {
  int query = 0;  // keyframe indices (order of AddKeyframe)
  int candidate = 0;
  int query_frame = 0;  // frame indices
  int candidate_frame = 0;
  double score = 0.0;             // BoW
  double normalized_score = 0.0;  // over the query's score with the previous keyframe
  int matches = 0;
  int inliers = 0;
  int cameras_with_inliers = 0;
  bool verified = false;         // geometric verification passed
  bool accepted = false;         // verified and consistent: a loop edge
  std::string reason;            // why not accepted
  Rigid3d candidate_from_query;  // when verified
  double correction_m = 0.0;     // |odometry relative pose - loop relative pose|, translation
  double correction_deg = 0.0;   // and rotation
  // When verified: the rig PnP's inlier matches, a query pixel seen as an
  // earlier keyframe's landmark. query_landmark_id >= 0 when the query
  // pixel is itself the query keyframe's observation of that landmark (a
  // duplicate of the same point across the loop), -1 for an ORB detection.
  struct Match {
    int camera = 0;
    Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
    int64_t landmark_id = 0;
    int64_t query_landmark_id = -1;
  };
  std::vector<Match> inlier_matches;
};

struct LoopTiming {
  double input_s = 0.0;         // AddKeyframes: in the caller's keyframe_at (reading the images)
  double features_s = 0.0;      // ORB + BoW
  double query_s = 0.0;         // database
  double verification_s = 0.0;  // matching + rig PnP
  double cross_camera_s = 0.0;  // CrossCameraLinks
};

// The part of a keyframe's loop-closure features that its images give: ORB
// detections and descriptors at its landmark pixels, per camera
// (LoopCloser::ExtractImageFeatures). Opaque.
struct LoopImageFeatures;

class LoopCloser {
 public:
  using ImageFeaturesAt = std::function<std::shared_ptr<const LoopImageFeatures>(int)>;

  // masks: per camera (CV_8UC1, 255 valid; empty: all valid). vocabulary:
  // binary, 32-byte rows (ORB). threads: feature extraction over cameras.
  LoopCloser(const Rig& rig, std::vector<cv::Mat> masks, Vocabulary vocabulary,
             const LoopClosureOptions& options, int threads);
  ~LoopCloser();
  LoopCloser(const LoopCloser&) = delete;
  LoopCloser& operator=(const LoopCloser&) = delete;

  // Adds the next keyframe (in time order); returns the candidates it
  // verified (accepted or not), best score first. Timing adds up in timing().
  std::vector<LoopAttempt> AddKeyframe(const LoopKeyframe& keyframe);
  // AddKeyframe on keyframe_at(0), ..., keyframe_at(count - 1) in that
  // order, with the same results; the attempts of all of them in order.
  // Faster on several threads: keyframe_at (which reads the images) and the
  // feature extraction run for a batch of keyframes at a time, one keyframe
  // per thread, and only the query and verification stay in keyframe order.
  // keyframe_at is called from several threads at once; an exception it
  // throws reaches the caller (ParallelFor's rule: the lowest index's).
  // image_features_at (optional): keyframe k's image features extracted
  // ahead (ExtractImageFeatures, for a keyframe with the same points'
  // cameras and pixels in the same order), which then stand for its images
  // (keyframe_at(k) may have none), or null to extract them from them.
  // The results are the same either way.
  std::vector<LoopAttempt> AddKeyframes(int count, const std::function<LoopKeyframe(int)>& keyframe_at,
                                        const ImageFeaturesAt& image_features_at = nullptr);
  // A keyframe's image features, ahead of AddKeyframes (while its images are
  // at hand: pipeline/loop_image_cache.h), on `threads` threads over the
  // cameras; they depend on its images and its points' cameras and pixels,
  // not on their ids or world positions.
  std::shared_ptr<const LoopImageFeatures> ExtractImageFeatures(const LoopKeyframe& keyframe, int threads) const;
  // True when `features` were extracted for the same points' cameras and
  // pixels, in the same order, as `keyframe` has.
  static bool ImageFeaturesFit(const LoopImageFeatures& features, const LoopKeyframe& keyframe);
  // The bytes its features hold (descriptors, pixels, indices).
  static size_t ImageFeaturesBytes(const LoopImageFeatures& features);

  // Relocalisation against a map (pipeline/relocalise_segments.h): adds a
  // keyframe to the database without querying it.
  void AddMapKeyframe(const LoopKeyframe& keyframe);
  // The query's rig pose in the map of the keyframes added so far: the best
  // `max_candidates` of them by BoW score (none excluded as recent), each
  // verified as in 4. but without the drift plausibility test (the
  // odometry between query and map is unknown: tracking was lost) and
  // without the consistency test; accepted == verified. The query is not
  // added.
  std::vector<LoopAttempt> Relocalise(const LoopKeyframe& query, int max_candidates);

  // The cross-camera links across time (loop/cross_camera_links.h) among
  // the keyframes added, with options.cross_camera, from the landmark
  // descriptors and odometry poses the database holds; keyframe: the order
  // of adding. None when its window_keyframes is 0. overlapping: the camera
  // pairs whose views overlap (FindCrossCameraLinks).
  std::vector<CrossCameraLink> CrossCameraLinks(const std::vector<std::pair<int, int>>& overlapping = {});

  int num_keyframes() const;
  const LoopTiming& timing() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mcvo
