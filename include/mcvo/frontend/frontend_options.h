// Options of the frontend (detection, LK tracking, outlier rejection,
// selection). Defaults follow the published implementation
// (../shared/reference/mcvo-reference-notes.md). Every key: docs/config.md.
#pragma once

#include <string>

#include "mcvo/util/enum_names.h"

namespace mcvo {

enum class DetectorType { kShiTomasi, kOrb, kXFeat, kSuperPoint };
inline constexpr EnumName<DetectorType> kDetectorTypeNames[] = {{DetectorType::kShiTomasi, "shi_tomasi"},
                                                                {DetectorType::kOrb, "orb"},
                                                                {DetectorType::kXFeat, "xfeat"},
                                                                {DetectorType::kSuperPoint, "superpoint"}};
// A network detector (an ONNX model, frontend.model_path): XFeat or the
// SuperPoint layout.
inline bool IsLearnedDetector(DetectorType type) {
  return type == DetectorType::kXFeat || type == DetectorType::kSuperPoint;
}

// How new features are chosen among the detections (reference notes,
// "3-priority quad-tree selection").
enum class FeatureSelection { kThreePriority, kQuadtree, kScore };
inline constexpr EnumName<FeatureSelection> kFeatureSelectionNames[] = {
    {FeatureSelection::kThreePriority, "three_priority"},
    {FeatureSelection::kQuadtree, "quadtree"},
    {FeatureSelection::kScore, "score"}};

struct ClaheOptions {
  bool enabled = true;
  double clip_limit = 3.0;
  int tile_grid = 8;  // tiles per image side
};

// Texture gate of new detections (src/frontend/texture_gate.h): kept only
// where the decoded image's structure tensor over the LK window has a
// smaller eigenvalue of at least max(min_gradient, noise_factor x the
// noise's own) (sqrt, grey levels per pixel). CLAHE stretches blank walls
// into corners that are not there; without the gate they take the budget
// and die in a frame. Both 0: off.
struct TextureOptions {
  double min_gradient = 0.0;
  double noise_factor = 0.0;
};

struct LkOptions {
  // Square window side. The published implementation uses 21; on the
  // synthetic urban scene (full-resolution KITTI-360 pinhole, forward
  // motion) frame-to-frame LK drifts as patches zoom, and a 15 px window
  // halves that drift: median error against ground truth 0.27 px vs 0.33 px
  // over 10-frame tracks, for 5 % shorter mean track length (12.6 vs 13.3
  // frames on 30 frames of the kitti360 preset).
  int window_px = 15;
  int pyramid_levels = 3;              // levels above the full image (OpenCV maxLevel)
  int max_iterations = 30;             // per level
  bool forward_backward_check = true;  // track back and reject points that do not return
  double forward_backward_threshold_px = 0.5;
  // Start LK at each feature's bearing rotated by the camera's rotation of
  // the previous frame (constant angular velocity; camera_tracker.h), and
  // the backward LK at the inverse rotation of the forward result, instead
  // of at the previous position: a turn of 7 deg per frame moves a 460 px
  // focal image by 56 px, beyond LK's reach from the previous position.
  // Only when that rotation moves the image by at least
  // predict_rotation_min_px (angle x the camera's mean focal length):
  // slower turns, which LK follows from the previous position, are tracked
  // as without the prediction.
  bool predict_rotation = true;
  double predict_rotation_min_px = 16.0;
  // Start LK at the pixel where the rig's own motion moves a feature that
  // has a metric depth from a cross-camera match (src/frontend/
  // motion_predictor.h): the rig motion of the previous frame pair is fitted
  // to those features (constant velocity), so a near point under fast
  // forward motion, which moves beyond LK's reach from its previous
  // position, is found. Features without a depth start as above, and so
  // does a feature whose predicted pixel is less than predict_motion_min_px
  // from that start (LK reaches it from there). Rigs without overlapping
  // cameras are unaffected.
  bool predict_motion = false;  // off until the renders say yes (results/motion_prediction.md)
  double predict_motion_min_px = 16.0;
  int predict_motion_min_points = 12;  // fewest inliers of the fitted motion; fewer: no prediction
};

// Anchor check of LK tracks (include/mcvo/frontend/patch_aligner.h): every
// tracked position is refined by aligning the feature's patch from the
// frame it was detected in (affine warp, gain and offset), so that LK's
// frame-to-frame errors do not add up along the track; a feature whose
// patch no longer matches is dropped (CameraFrameStats::lost_anchor).
struct AnchorOptions {
  bool enabled = true;
  int half_size_px = 10;         // template of (2 h + 1)^2 pixels
  double weight_sigma_px = 3.0;  // Gaussian weight of the template around the feature; 0: uniform
  int max_iterations = 30;
  double min_zncc = 0.8;         // smallest normalised cross-correlation after alignment
  double max_shift_px = 3.0;     // largest move from the LK position
  double max_warp_change = 1.6;  // largest change of the affine warp in one frame (singular values)
  // A feature whose patch no longer matches: dropped (true), or kept on its
  // LK position with a new template taken there (false).
  bool drop_mismatch = true;
  // A new template is taken at the aligned position when the warp since the
  // last one has a singular value outside [1 / s, s].
  double reanchor_scale = 1.5;
};

struct SuperPointOptions {
  int downscale = 2;  // image downscaled by this factor before inference
  double confidence_threshold = 0.015;
  int nms_radius_px = 2;
  int border_px = 4;
  // The network runs on a camera's image only when at least this fraction
  // of the camera's feature budget is free (the budget minus the features
  // it tracks), or when the camera tracks nothing; 0: on every frame. One forward
  // pass costs the same whatever it is asked for, so topping up a few lost
  // features every frame is most of a learned frontend's time. XFeat on 14
  // held-out sequences, 0.5 against 0: results/learned_detect_skip.md (the
  // same rule broke a tri_rear run with Shi-Tomasi). Not used by shi_tomasi
  // and orb, which read FrontendOptions::detect_missing_fraction.
  double detect_missing_fraction = 0.5;
};

// Cross-camera matches: camera a's features of a frame found again in camera
// b's image of the same frame, for every camera pair a < b whose views
// overlap (src/frontend/cross_camera.cc). They give the estimator metric
// scale from the known baseline and landmarks shared between cameras.
struct CrossCameraOptions {
  bool enabled = true;
  // Pairs whose ViewOverlap(a, b) at kViewOverlapDepthM (10 m, masks
  // included) is at least this are matched; computed once at start-up.
  double min_view_overlap = 0.1;
  // Distance along camera a's ray of the point that seeds LK in b (b's image
  // is warped into a's grid through it, cross_camera.h). Matches found over
  // 4 frames of the synthetic KITTI-360 rig at half resolution, all 6 pairs:
  // 5 m: 319, 10 m: 564, 20 m: 606, 30 m: 605, 100 m: 598 (same accuracy);
  // near points land farther from the seed than far ones.
  double init_distance_m = 20.0;
  // A second warp through the point this far along a's ray (0: none), for
  // near points (cross_camera.h, step 6).
  double near_distance_m = 4.0;
  // Match on the tracker's CLAHE'd images (true) or on the images as
  // decoded (false). CLAHE maps each camera's intensities by its own tiles,
  // so the same patch differs between two cameras by a tone curve that
  // varies across it, and LK's match moves (cross_camera.h, step 2).
  bool equalised = true;
  // Both images LK compares, a's and b's warped into a's grid, are
  // normalised to zero mean and unit variance over a box window with the
  // variance of a Gaussian of this standard deviation (side 2 round(sqrt(3)
  // sigma) + 1 pixels; 0: off): exposure, vignetting and the cameras'
  // different responses cancel the same way in both.
  double normalise_sigma_px = 0.0;
  // Largest angle between b's bearing and the epipolar plane of a's bearing,
  // in pixels at focal ransac_focal_px (1 px at 460).
  double epipolar_threshold_px = 1.0;
  // Smallest angle between the two rays at the triangulated point (degrees);
  // below it the point is indistinguishable from one at infinity (0.25 deg
  // is 2 px at focal 460) and its distance, even its sign, is not observed.
  double min_angle_deg = 0.25;
  // At most this many matches per pair, longest tracks first; 0: no limit.
  int max_matches_per_pair = 0;
  // Match through the warps (steps 1-6 of cross_camera.h: a remap and a
  // pyramid of b's whole image per warp, the frontend's largest cost) on
  // every rematch_every-th frame of a pair; on the frames between, the
  // previous frame's matches are followed in b's own images (LK, forward-
  // backward, then steps 4-5 against a's feature), and a's features matched
  // for the first time wait for the next full frame. 1: every frame. 2:
  // about a fifth less frontend CPU time at full resolution, ATE neutral
  // over 21 suite runs (results/cross_camera_follow.md).
  int rematch_every = 2;
  // A frame between is matched in full all the same when fewer matches than
  // this fraction of the last full frame's survive being followed (fast
  // turns, occlusions).
  double rematch_below_fraction = 0.5;
};

struct FrontendOptions {
  DetectorType detector = DetectorType::kShiTomasi;
  std::string model_path;  // ONNX model of xfeat / superpoint; required for those
  int max_features_pinhole = 100;
  int max_features_fisheye = 150;
  // Large pinhole cameras: max_features_pinhole is the budget of a pinhole
  // or radtan camera of up to this many megapixels (the renders it was set
  // and checked on: 0.05-0.23 Mpx); a larger one keeps that density, budget
  // x its megapixels / this (PinholeFeatureBudget below; MultiCameraTracker
  // applies it per camera). On real KITTI stereo (0.45-0.47 Mpx: 181-187 features)
  // the scale was 0.64 % (kitti06) and 6.1 % (kitti01) too long with 100,
  // 0.38 % and 5.4 % with 181-187. A reference of 0.15 gave KITTI more (302-311
  // features: 0.33 %, 3.9 %) but moved the 0.23 Mpx roof-pair renders both
  // ways (monocular median ATE 0.060 -> 0.100 %); results/feature_budget.md.
  // Fisheye budgets are kept as given (no real fisheye recording to measure
  // them on; the KITTI-360 fisheyes at full resolution would get 8 x).
  // 0: never.
  double max_features_pinhole_megapixels = 0.25;
  int min_distance_px = 20;
  // Small cameras: the frontend's pixel-sized parameters (min_distance_px,
  // lk.window_px, anchor.half_size_px, clahe.tile_grid) were chosen on
  // cameras of 265 to 1400 px (sqrt(width x height)). On a camera under
  // this, they are scaled by sqrt(width x height) / this
  // (PixelScaleForCamera below; MultiCameraTracker applies it per camera,
  // a CameraTracker built alone takes its options as given); larger cameras
  // keep them. In the benchmark suite only irregular5's 246 x 184 camera is
  // scaled (0.85). 0: never. Measured in results/small_cameras.md (200 and
  // 250 compared).
  double pixel_scale_reference_px = 250.0;
  FeatureSelection selection = FeatureSelection::kThreePriority;
  int candidate_factor = 4;  // keep the best factor x (max - tracked) new detections before selection
  // Shi-Tomasi on a camera image of more megapixels than this runs on the
  // LK pyramid's first level that is not (each level halves both sides);
  // the detections are scaled to full resolution. 0: always full resolution.
  double detection_max_megapixels = 1.0;
  // Shi-Tomasi and ORB search a camera's image for new features only when at
  // least this fraction of the camera's feature budget (max_features_*) is
  // free, or the camera tracks nothing; on the frames between, the camera
  // keeps what LK tracks. 0: every frame that lacks any feature. The learned
  // detectors have their own rule (superpoint.detect_missing_fraction).
  // 0 by default: at 0.5 one tri_rear run lost its scale (0.11 -> 3.6 %,
  // results/learned_detect_skip.md), and the 1.18 km route with the
  // 4-camera KITTI-360 rig ended 1.25 x worse; at full resolution that rig
  // ran 0.8 x the time and more accurately (results/classic_detect_skip.md).
  double detect_missing_fraction = 0.0;
  double ransac_threshold_px = 1.0;
  double ransac_focal_px = 460.0;  // virtual pinhole focal the threshold is expressed at
  ClaheOptions clahe;
  TextureOptions texture;
  LkOptions lk;
  AnchorOptions anchor;
  SuperPointOptions superpoint;
  CrossCameraOptions cross_camera;

  // Throws InputError naming the bad field by its config path.
  void Check() const;
};

// The factor a camera of width x height scales the pixel-sized parameters
// by: min(1, sqrt(width x height) / pixel_scale_reference_px); 1 when the
// reference is 0 or the size is not positive.
double PixelScaleForCamera(const FrontendOptions& options, int width, int height);

// The budget of a pinhole camera of width x height: max_features_pinhole,
// times width x height / (max_features_pinhole_megapixels x 10^6) when that
// is over 1 (rounded, at most 20000, never below max_features_pinhole);
// max_features_pinhole when the reference is 0 or the size not positive.
int PinholeFeatureBudget(const FrontendOptions& options, int width, int height);

// `options` with its pixel-sized parameters scaled by `scale` (in (0, 1];
// 1 returns them unchanged): min_distance_px and anchor.half_size_px
// rounded (at least 1 and 3), lk.window_px to the nearest odd size (at
// least 5), clahe.tile_grid rounded (at least 2). A camera pair's matcher
// gets the smaller of its two cameras' scales, so that its LK window fits
// both trackers' pyramids.
FrontendOptions ScalePixelParameters(const FrontendOptions& options, double scale);

}  // namespace mcvo
