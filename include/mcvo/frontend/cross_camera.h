// Cross-camera matching: camera a's features of a rig frame found again in
// camera b's image of the same frame, for camera pairs whose views overlap.
// The known extrinsics give the initial guess and the geometric check, so a
// match is a point seen by two cameras with a metric baseline between them:
// the estimator's source of metric scale and of landmarks tying cameras
// together (map/observations.h, CrossCameraObservation).
//
// The warp W: a's pixel u -> b's pixel Project_b(b_from_a * (d0 f_a(u))),
// f_a = Unproject_a (unit), d0 = init_distance_m (a distance along the ray,
// so fisheyes beyond 90 deg work). It maps the point at d0 on u's ray to
// where b sees it; a point at another distance lands elsewhere on u's
// epipolar curve.
//  1. b's image (the tracker's CLAHE'd one; as decoded with
//     cross_camera.equalised false) is resampled into a's pixel grid
//     through W (a map computed once per pair and warp distance; cv::remap,
//     bilinear, only inside the box b sees), so the patch around a
//     feature looks in the warped image as in a's: the same scale,
//     orientation and distortion, whatever the two camera models (a pinhole
//     against a fisheye's rim differs by 2x in scale and by a rotation, which
//     plain translational LK cannot follow). Features whose W(u) is outside
//     b's image or mask are not candidates.
//  2. Pyramidal LK from a's image to the warped one, starting at u itself
//     (the point at d0), ends at p; b's pixel is W(p), computed exactly (not
//     interpolated from the map). With normalise_sigma_px > 0 both images
//     are first normalised to zero mean and unit variance over a local
//     window, the warped one over the pixels b sees: the cameras' exposures,
//     vignetting and responses differ, and LK has no gain term. CLAHE (the
//     default, equalised true) instead maps each camera by its own tone
//     curves, which vary across a patch and move the match: on kitti360
//     4-camera urban (k360_urban_s1) the pinhole-fisheye pairs triangulate
//     points 10-20 m away 0.1-0.2 % too far, and the vignetted multicam6
//     run's pairs 0.6-1.5 % too near (median; results/anchor_tracking.md).
//     Off by default until its cost and its losses on two indoor runs are
//     settled (docs/config.md).
//  3. Forward-backward: LK back from p to a's image, starting at p (the same
//     hypothesis seen from the other side), must return within
//     lk.forward_backward_threshold_px of u.
//  4. Epipolar check: with b_from_a = (R, t), a's centre is t in b and a's
//     ray direction r = R f_a; the epipolar plane holds both centres and the
//     ray, normal n = t x r / |t x r|. b's bearing f_b must satisfy
//     |n . f_b| <= sin(atan(epipolar_threshold_px / ransac_focal_px)) (the
//     sine of its angle to the plane).
//  5. Triangulation (midpoint): depths (d_a, d_b) minimise
//     |t + d_a r - d_b f_b|^2, i.e. solve
//        [ 1        -r.f_b ] [d_a]   [ -r.t  ]
//        [ -r.f_b    1     ] [d_b] = [ f_b.t ];
//     both must be > 0 (in front of both cameras), and the angle between the
//     rays, acos(r . f_b), at least min_angle_deg (else the point is
//     indistinguishable from one at infinity).
//  6. Steps 2-5 run through a second warp, d1 = near_distance_m (4 m), as
//     well. The warped patch matches a's only for points near the warp's
//     distance: indoors, points 1-5 m away seen through the 20 m warp are
//     scaled and sheared against a's at the fisheye rims, and LK lands off
//     the point or fails. Where both warps match, the match whose warp
//     distance is nearest (|log(depth / d)|) to the depth it triangulates
//     is kept; where only the near warp matches, its match is kept if it
//     triangulates nearer than sqrt(d0 d1) (8.9 m): a "near" match farther
//     away is one the far warp should have found (without this gate
//     multicam6 urban lost 7 % of its ATE). Failures are counted under the
//     first warp's reason. (Measured and not adopted: a second LK start on
//     the first warp, rejecting features where the two starts end apart: on
//     the KITTI-360 indoor sequence both ended at the same point every
//     time; and, of two matches, keeping the far warp's or none where they
//     differ: multicam6 indoor 0.069 -> 0.079 % ATE and a tracking loss in a
//     7 deg/frame turn of irregular5 indoor.)
//  7. With rematch_every = K > 1, steps 1-6 (two remaps and pyramids of
//     b's whole image per pair: the frontend's largest cost at full
//     resolution) run on every K-th frame of a pair; on the frames between,
//     Follow() carries the frame before's matches: b's pixel is tracked in
//     b's own images by LK (forward-backward checked) and must pass steps 4
//     and 5 against a's current pixel. A feature of a new since the last
//     full frame waits for the next one. When fewer than
//     rematch_below_fraction of the last full frame's matches survive (a
//     fast turn, an occlusion), the frame is matched in full instead.
// Steps 4-5 cannot see an error along the epipolar curve: a feature on a
// depth edge (its window mixes a foreground and a background disparity) or
// on texture repeated along the curve can pass them. Against the ray-cast
// ground truth on the synthetic KITTI-360 rig at half resolution (12 frames
// from 3 places on the route; features with a visible ground truth):
//   pinhole stereo pair   84 % of features matched, median 0.17-0.20 px,
//                         0.9 % beyond 2 px (depth edges, ~3 px);
//   pinhole - fisheye     1129 matches, median 0.19-0.33 px, 0.2 % beyond 2 px;
//   fisheye rims (2-3)    138 matches, median 0.21-0.44 px, 2.6 % beyond 2 px
//                         (up to 26 px, at the extreme rims).
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/frontend/frontend_options.h"
#include "mcvo/frontend/multi_camera_tracker.h"

namespace mcvo {

// The pairs (a, b), a < b, in increasing order, with ViewOverlap(a, b,
// kViewOverlapDepthM, mask_a, mask_b) >= options.min_view_overlap; none when
// !options.enabled. masks: one per camera or empty (no masks).
std::vector<std::pair<int, int>> SelectCrossCameraPairs(const Rig& rig, const std::vector<cv::Mat>& masks,
                                                        const CrossCameraOptions& options);

enum class CrossCameraCheck { kOk, kEpipolar, kTriangulation };

// Steps 4 and 5 above for unit bearings f_a (camera a) and f_b (camera b).
// max_epipolar_sine: sine of the largest angle of f_b to the epipolar plane;
// min_angle_rad: smallest angle between the rays. A ray along the baseline
// (no epipolar plane) fails the triangulation.
// depth_a_out (if given) gets the point's distance from a's centre when kOk.
CrossCameraCheck CheckCrossCameraBearings(const Eigen::Vector3d& bearing_a, const Eigen::Vector3d& bearing_b,
                                          const Rigid3d& b_from_a, double max_epipolar_sine,
                                          double min_angle_rad, double* depth_a_out = nullptr);

// Camera a's unit bearing Unproject(u).normalized() at every pixel u = (x,
// y), row-major (index y * width + x); NaN where Unproject fails. The
// costly part of a warp map (an iterative undistortion per pixel), shared
// by every pair and warp of the same camera a. Row blocks on `threads`
// threads; the grid does not depend on their number.
std::vector<Eigen::Vector3d> UnitBearingGrid(const Camera& a, int threads = 1);

// Matches one camera pair. Thread-safe (const); one per pair.
class CrossCameraMatcher {
 public:
  // mask_b: CV_8UC1 of b's size or empty. The warp maps (one Project per
  // pixel of a and warp distance, from a's UnitBearingGrid) are computed in
  // row blocks on `threads` threads; they do not depend on their number.
  // bearings_a: UnitBearingGrid(a) when the caller shares it between pairs
  // (it must be a's); null: computed here.
  CrossCameraMatcher(int camera_a, int camera_b, const Camera& a, const Camera& b, const cv::Mat& mask_b,
                     const FrontendOptions& options, int threads = 1,
                     const std::vector<Eigen::Vector3d>* bearings_a = nullptr);

  // features_a: camera a's features of the frame (ids assigned); pyramid_a,
  // pyramid_b: CameraTracker::Pyramid() of both (empty when that image is
  // missing: no matches). Returns the matches sorted by id_a and fills
  // *stats (never null). Deterministic.
  std::vector<CrossCameraMatch> Match(const std::vector<TrackedFeature>& features_a,
                                      const std::vector<cv::Mat>& pyramid_a,
                                      const std::vector<cv::Mat>& pyramid_b,
                                      CrossCameraPairStats* stats) const;

  // The frames between full matches (cross_camera.rematch_every > 1):
  // `previous` (this pair's matches of the frame before, sorted by id_a)
  // followed into the current frame. A match is kept when a's feature is
  // still tracked and its b pixel, LK from previous_pyramid_b to pyramid_b
  // (b's CrossCameraPyramid() of both frames) with the forward-backward
  // check, is inside b's image and mask and passes steps 4 and 5 against
  // a's current pixel. *stats counts over the followed matches (`features`:
  // those whose a feature is still tracked; failures under lost_lk,
  // lost_forward_backward, lost_epipolar, lost_triangulation). Returns the
  // matches sorted by id_a. Deterministic.
  std::vector<CrossCameraMatch> Follow(const std::vector<TrackedFeature>& features_a,
                                       const std::vector<CrossCameraMatch>& previous,
                                       const std::vector<cv::Mat>& previous_pyramid_b,
                                       const std::vector<cv::Mat>& pyramid_b,
                                       CrossCameraPairStats* stats) const;

  int camera_a() const { return camera_a_; }
  int camera_b() const { return camera_b_; }

 private:
  enum class Outcome { kOk, kLostLk, kForwardBackward, kEpipolar, kTriangulation };
  // W_d over a's pixel grid, fixed-point (cv::convertMaps), and where b does
  // not see (255).
  struct WarpMap {
    double distance_m = 0.0;
    cv::Mat map_xy, map_fraction, unseen;
    cv::Mat seen;  // 255 - unseen: where step 2 normalises the warped image
    // Bounding box of the pixels b sees (unseen == 0); the warped image is 0
    // outside it, so only this part is resampled.
    cv::Rect seen_box;
  };

  // Statistics of this pair for a frame, zeroed, with the pair's cameras.
  CrossCameraPairStats EmptyStats() const;

  // A match that passed the checks: a's feature and its pixel in b.
  using Accepted = std::pair<const TrackedFeature*, Eigen::Vector2f>;
  // max_matches_per_pair (longest tracks first, ties in the given order;
  // stats->over_limit), then the matches sorted by id_a.
  std::vector<CrossCameraMatch> ToMatches(std::vector<Accepted> accepted, CrossCameraPairStats* stats) const;

  // b's pixel is inside b's image (1 px border) and mask.
  bool UsableInB(const cv::Point2f& p) const;
  // W_d(u) = Project_b(b_from_a * (d Unproject_a(u))); nullopt outside b's image.
  std::optional<Eigen::Vector2d> Warp(const Eigen::Vector2d& pixel_a, double distance_m) const;
  // The same from a's unit bearing.
  std::optional<Eigen::Vector2d> WarpBearing(const Eigen::Vector3d& unit_bearing_a, double distance_m) const;
  // Steps 2-5 through one warp for a's pixels: per pixel the outcome, and
  // when kOk b's pixel and the depth along a's ray.
  void MatchThroughWarp(const WarpMap& warp, const std::vector<cv::Mat>& pyramid_a,
                        const std::vector<cv::Mat>& pyramid_b, const std::vector<cv::Point2f>& pts_a,
                        std::vector<Outcome>* outcome, std::vector<Eigen::Vector2f>* pixel_b,
                        std::vector<double>* depth_a) const;

  int camera_a_ = 0;
  int camera_b_ = 0;
  Camera a_, b_;
  cv::Mat mask_b_;
  FrontendOptions options_;
  Rigid3d b_from_a_;
  double max_epipolar_sine_ = 0.0;
  double min_angle_rad_ = 0.0;
  std::vector<WarpMap> warps_;  // init_distance_m, then near_distance_m (if on and different)
  cv::Rect normalise_roi_a_;    // where a's image is normalised (step 2)
};

}  // namespace mcvo
