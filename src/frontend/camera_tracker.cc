// Per-camera tracking (see camera_tracker.h). One frame:
//  1. optional CLAHE, then the LK pyramid of the image, built once and kept
//     for the next frame (the previous pyramid serves forward and backward);
//  2. pyramidal LK previous -> current, then current -> previous (forward-
//     backward check); points that fail, leave the image border or land on a
//     mask zero are dropped. With lk.predict_rotation, when the rotation
//     fitted to the previous frame pair's RANSAC inliers moves the image by
//     lk.predict_rotation_min_px or more, LK starts at each point's bearing
//     rotated by it (constant angular velocity), and the backward LK at the
//     forward result rotated back; a fast turn otherwise moves the image
//     beyond LK's reach (10 deg per frame at half resolution: 246 of 305
//     features kept against 33, camera_tracker_test);
//  3. RANSAC on the bearings of the survivors (bearing_ransac.h);
//  3b. with frontend.anchor.enabled, each survivor's position refined by
//     aligning the patch of the frame it was detected in (patch_aligner.h);
//     a feature whose patch no longer matches is dropped (lost_anchor);
//  4. detection where new features are wanted and selection (selection.h);
//     Shi-Tomasi on an image over frontend.detection_max_megapixels runs on
//     the pyramid's first level that is not (the level-l pixel x maps to
//     2^l x + (2^l - 1) / 2 at full resolution, pixel centres at integers)
//     with the mask reduced to it; LK tracks at full resolution.
//
// Decisions:
//  * The feature budget comes from the camera model: max_features_fisheye for
//    kannala_brandt, mei, double_sphere, else max_features_pinhole (the rule
//    of multi_camera_tracker.h, applied here so every user of CameraTracker
//    gets it).
//  * Border: a tracked point must lie at least BorderPx() from the image
//    border, the same border detection uses (SuperPoint: its own border).
//  * The backward LK starts from the forward result (without the rotation
//    prediction) or from its rotation back, never from the previous
//    position itself, so the check stays independent of where LK started.
#include "mcvo/frontend/camera_tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>
#include <utility>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "classic_detectors.h"
#include "mcvo/dataset/image_level.h"
#include "mcvo/frontend/bearing_ransac.h"
#include "mcvo/frontend/patch_aligner.h"
#include "mcvo/frontend/selection.h"
#include "mcvo/util/error.h"
#include "texture_gate.h"

namespace mcvo {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Copies the rows `keep` of `rows` (empty stays empty).
cv::Mat SelectRows(const cv::Mat& rows, const std::vector<int>& keep) {
  if (rows.empty()) return cv::Mat();
  cv::Mat out(static_cast<int>(keep.size()), rows.cols, rows.type());
  for (size_t i = 0; i < keep.size(); ++i) rows.row(keep[i]).copyTo(out.row(static_cast<int>(i)));
  return out;
}

}  // namespace

struct CameraTracker::Impl {
  Camera camera;
  cv::Mat mask;
  FrontendOptions options;
  std::unique_ptr<Detector> detector;
  cv::Ptr<cv::CLAHE> clahe;
  int max_features = 0;
  int border_px = 1;
  // Detection on pyramid level detection_level (FrontendOptions::
  // detection_max_megapixels), with the mask at that level.
  int detection_level = 0;
  cv::Mat detection_mask;

  // State after the last Track() (+ AssignNewIds): what the next frame tracks.
  std::vector<cv::Mat> prev_pyramid;
  // With CLAHE on and cross_camera.equalised off: the pyramid of the
  // unequalised image, for cross-camera matching (CrossCameraPyramid()).
  std::vector<cv::Mat> prev_raw_pyramid;
  // With cross_camera.rematch_every > 1: the cross-camera pyramid of the
  // frame before (PreviousCrossCameraPyramid()).
  std::vector<cv::Mat> older_cross_pyramid;
  std::vector<TrackedFeature> prev_features;
  cv::Mat prev_descriptors;
  // With options.anchor.enabled: one per prev_features entry (the patch of
  // the frame the feature was detected in, on the unequalised image).
  std::vector<PatchAnchor> prev_anchors;
  PatchAlignOptions align;
  // With options.lk.predict_rotation: the rotation of the last frame pair
  // (bearing_cur = rotation * bearing_prev, fitted to its RANSAC inliers),
  // or none (too few inliers, a missing image, the first frames).
  std::optional<Eigen::Matrix3d> rotation;

  bool Usable(const cv::Point2f& p) const {
    const float b = static_cast<float>(border_px);
    if (!(p.x >= b && p.y >= b && p.x <= camera.width - 1 - b && p.y <= camera.height - 1 - b)) return false;
    if (mask.empty()) return true;
    const int x = static_cast<int>(std::lround(p.x));
    const int y = static_cast<int>(std::lround(p.y));
    return mask.at<uint8_t>(y, x) != 0;
  }

  CameraFrameResult Track(const cv::Mat& input, const FeaturePredictions* predictions);
  // The steps of Track: LK forward (and backward) from the previous frame;
  // `kept`: indices into prev_features, `kept_pixels` their new pixels.
  void TrackLk(const std::vector<cv::Mat>& pyramid, const FeaturePredictions* predictions,
               std::vector<int>* kept, std::vector<cv::Point2f>* kept_pixels, CameraFrameStats* stats) const;
  // RANSAC on bearings removes the tracks inconsistent with one relative
  // pose; a pixel the model cannot unproject counts as lost by LK. Returns
  // the rotation fitted to the inliers (FitBearingRotation) when
  // options.lk.predict_rotation is on and there are enough of them.
  std::optional<Eigen::Matrix3d> RejectByRansac(std::vector<int>* kept, std::vector<cv::Point2f>* kept_pixels,
                                                CameraFrameStats* stats) const;
  // Where `pixel` moves under `r` (bearing r * Unproject(pixel)), or
  // `pixel` itself when that is not defined or not Usable.
  cv::Point2f Rotated(const cv::Point2f& pixel, const Eigen::Matrix3d& r) const;
  // Anchor check (options.anchor): refines kept_pixels against each
  // feature's anchor patch in `image`, drops the features whose patch no
  // longer matches; `anchors` receives the kept features' anchors.
  // The kept features' anchors are moved out of prev_anchors.
  void RefineByAnchor(const cv::Mat& image, std::vector<int>* kept, std::vector<cv::Point2f>* kept_pixels,
                      std::vector<PatchAnchor>* anchors, CameraFrameStats* stats);
  // Detection and selection of new features up to max_features.
  void AddNewFeatures(const cv::Mat& input, const cv::Mat& image, const std::vector<cv::Mat>& pyramid,
                      CameraFrameResult* result) const;
  // Detections on detection_level, in full-resolution pixels.
  Detections Detect(const cv::Mat& image, const std::vector<cv::Mat>& pyramid, int cap) const;
};

CameraTracker::CameraTracker(const Camera& camera, const cv::Mat& mask, const FrontendOptions& options,
                             std::unique_ptr<Detector> detector)
    : impl_(std::make_unique<Impl>()) {
  MCVO_CHECK(detector != nullptr);
  impl_->camera = camera;
  impl_->options = options;
  impl_->detector = std::move(detector);
  if (!mask.empty()) {
    if (mask.type() != CV_8UC1 || mask.cols != camera.width || mask.rows != camera.height) {
      MCVO_THROW_INPUT("mask of camera ", camera.name, ": expected CV_8UC1 ", camera.width, "x",
                       camera.height, ", got type ", mask.type(), " ", mask.cols, "x", mask.rows);
    }
    impl_->mask = mask.clone();
  }
  if (options.clahe.enabled) {
    impl_->clahe =
        cv::createCLAHE(options.clahe.clip_limit, cv::Size(options.clahe.tile_grid, options.clahe.tile_grid));
  }
  impl_->align.half_size_px = options.anchor.half_size_px;
  impl_->align.weight_sigma_px = options.anchor.weight_sigma_px;
  impl_->align.max_iterations = options.anchor.max_iterations;
  impl_->align.min_zncc = options.anchor.min_zncc;
  impl_->align.max_shift_px = options.anchor.max_shift_px;
  impl_->align.max_warp_change = options.anchor.max_warp_change;
  impl_->max_features = IsFisheyeModel(camera.model) ? options.max_features_fisheye : options.max_features_pinhole;
  impl_->border_px =
      options.detector == DetectorType::kSuperPoint ? std::max(1, options.superpoint.border_px) : 1;
  if (options.detector == DetectorType::kShiTomasi) {
    impl_->detection_level = LevelForMegapixels(camera.width, camera.height, options.detection_max_megapixels,
                                                options.lk.pyramid_levels);
  }
  if (impl_->detection_level > 0 && !impl_->mask.empty()) {
    impl_->detection_mask = CoarseMask(impl_->mask, impl_->detection_level);
  }
}

CameraTracker::~CameraTracker() = default;

CameraFrameResult CameraTracker::Track(const cv::Mat& image, const FeaturePredictions* predictions) {
  return impl_->Track(image, predictions);
}

CameraFrameResult CameraTracker::Impl::Track(const cv::Mat& input, const FeaturePredictions* predictions) {
  CameraFrameResult result;
  CameraFrameStats& stats = result.stats;
  if (input.empty()) {
    // No image: every track ends; the next image starts afresh.
    stats.image_missing = true;
    prev_pyramid.clear();
    prev_raw_pyramid.clear();
    older_cross_pyramid.clear();
    prev_features.clear();
    prev_descriptors = cv::Mat();
    prev_anchors.clear();
    rotation.reset();
    return result;
  }
  if (input.type() != CV_8UC1 || input.cols != camera.width || input.rows != camera.height) {
    MCVO_THROW_INPUT("image of camera ", camera.name, ": expected CV_8UC1 ", camera.width, "x", camera.height,
                     ", got type ", input.type(), " ", input.cols, "x", input.rows);
  }

  // 1. Preprocessing and pyramid.
  auto start = Clock::now();
  cv::Mat image;
  if (clahe) {
    clahe->apply(input, image);
    stats.seconds_clahe = SecondsSince(start);
    start = Clock::now();
  } else {
    image = input;
  }
  const cv::Size window(options.lk.window_px, options.lk.window_px);
  std::vector<cv::Mat> pyramid;
  cv::buildOpticalFlowPyramid(image, pyramid, window, options.lk.pyramid_levels);
  std::vector<cv::Mat> raw_pyramid;
  if (clahe && options.cross_camera.enabled && !options.cross_camera.equalised) {
    cv::buildOpticalFlowPyramid(input, raw_pyramid, window, options.lk.pyramid_levels);
  }
  stats.seconds_pyramid = SecondsSince(start);

  // 2. LK forward, backward; 3. RANSAC on bearings.
  start = Clock::now();
  std::vector<int> kept;  // indices into prev_features
  std::vector<cv::Point2f> kept_pixels;
  TrackLk(pyramid, predictions, &kept, &kept_pixels, &stats);
  stats.seconds_lk = SecondsSince(start);
  start = Clock::now();
  rotation = RejectByRansac(&kept, &kept_pixels, &stats);
  stats.seconds_ransac = SecondsSince(start);
  std::vector<PatchAnchor> anchors;
  if (options.anchor.enabled) {
    start = Clock::now();
    RefineByAnchor(input, &kept, &kept_pixels, &anchors, &stats);
    stats.seconds_anchor = SecondsSince(start);
  }

  for (size_t k = 0; k < kept.size(); ++k) {
    TrackedFeature f = prev_features[static_cast<size_t>(kept[k])];
    f.pixel = Eigen::Vector2f(kept_pixels[k].x, kept_pixels[k].y);
    ++f.track_length;
    result.features.push_back(f);
  }
  result.descriptors = SelectRows(prev_descriptors, kept);
  stats.tracked = static_cast<int>(kept.size());

  // 4. Detection and selection of new features.
  AddNewFeatures(input, image, pyramid, &result);
  if (options.anchor.enabled) {
    start = Clock::now();
    for (size_t i = anchors.size(); i < result.features.size(); ++i) {
      anchors.push_back(MakePatchAnchor(input, result.features[i].pixel, align));
    }
    stats.seconds_anchor += SecondsSince(start);
  }

  double length_sum = 0.0;
  std::vector<Eigen::Vector2f> pixels;
  for (const TrackedFeature& f : result.features) {
    length_sum += f.track_length;
    pixels.push_back(f.pixel);
  }
  if (!result.features.empty())
    stats.mean_track_length = length_sum / static_cast<double>(result.features.size());
  stats.sfd = ComputeSfd(pixels, camera.width, camera.height);

  if (options.cross_camera.enabled && options.cross_camera.rematch_every > 1) {
    older_cross_pyramid = prev_raw_pyramid.empty() ? std::move(prev_pyramid) : std::move(prev_raw_pyramid);
  }
  prev_pyramid = std::move(pyramid);
  prev_raw_pyramid = std::move(raw_pyramid);
  prev_features = result.features;
  prev_descriptors = result.descriptors;
  prev_anchors = std::move(anchors);
  return result;
}

void CameraTracker::Impl::TrackLk(const std::vector<cv::Mat>& pyramid, const FeaturePredictions* predictions,
                                  std::vector<int>* kept, std::vector<cv::Point2f>* kept_pixels,
                                  CameraFrameStats* stats) const {
  const cv::Size window(options.lk.window_px, options.lk.window_px);
  if (!prev_features.empty() && !prev_pyramid.empty()) {
    std::vector<cv::Point2f> prev_pts, cur_pts;
    for (const TrackedFeature& f : prev_features) prev_pts.emplace_back(f.pixel.x(), f.pixel.y());
    const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                    options.lk.max_iterations, 0.001);
    std::vector<uint8_t> status;
    std::vector<float> error;
    // Per feature, the predicted move (motion prediction), if any: both
    // directions start from it. Otherwise, with a rotation, both start at
    // the rotated positions; else at the previous position and the forward
    // result. OpenCV's LK started at the previous position with
    // OPTFLOW_USE_INITIAL_FLOW is LK without it, so mixing starts changes
    // nothing for the others. own_pts: LK's own start (the previous
    // position, or its rotation).
    const bool predict_rotation = rotation.has_value();
    std::vector<cv::Point2f> own_pts = prev_pts;
    if (predict_rotation) {
      for (cv::Point2f& p : own_pts) p = Rotated(p, *rotation);
    }
    std::vector<std::optional<cv::Point2f>> moved(prev_pts.size());
    bool any_moved = false;
    if (predictions != nullptr && !predictions->empty()) {
      const double min_move2 = options.lk.predict_motion_min_px * options.lk.predict_motion_min_px;
      for (size_t i = 0; i < prev_pts.size(); ++i) {
        const auto it = predictions->find(prev_features[i].id);
        if (it == predictions->end()) continue;
        const cv::Point2f p(it->second.x(), it->second.y());
        if (!Usable(p)) continue;
        // Only a start LK would not reach from its own one.
        const cv::Point2f d = p - own_pts[i];
        if (static_cast<double>(d.dot(d)) < min_move2) continue;
        moved[i] = p - prev_pts[i];
        any_moved = true;
      }
    }
    const bool predict = predict_rotation || any_moved;
    int flags = 0;
    if (predict) {
      flags = cv::OPTFLOW_USE_INITIAL_FLOW;
      cur_pts = own_pts;
      for (size_t i = 0; i < prev_pts.size(); ++i) {
        if (moved[i]) cur_pts[i] = prev_pts[i] + *moved[i];
      }
    }
    cv::calcOpticalFlowPyrLK(prev_pyramid, pyramid, prev_pts, cur_pts, status, error, window,
                             options.lk.pyramid_levels, criteria, flags);
    std::vector<uint8_t> back_status(prev_pts.size(), 1);
    std::vector<cv::Point2f> back_pts;
    if (options.lk.forward_backward_check) {
      if (predict) {
        const Eigen::Matrix3d inverse = predict_rotation ? Eigen::Matrix3d(rotation->transpose()) : Eigen::Matrix3d();
        for (size_t i = 0; i < cur_pts.size(); ++i) {
          if (moved[i]) {
            back_pts.push_back(cur_pts[i] - *moved[i]);
          } else {
            back_pts.push_back(predict_rotation ? Rotated(cur_pts[i], inverse) : cur_pts[i]);
          }
        }
      }
      cv::calcOpticalFlowPyrLK(pyramid, prev_pyramid, cur_pts, back_pts, back_status, error, window,
                               options.lk.pyramid_levels, criteria, flags);
    }
    const double fb2 = options.lk.forward_backward_threshold_px * options.lk.forward_backward_threshold_px;
    for (size_t i = 0; i < prev_pts.size(); ++i) {
      if (!status[i] || !Usable(cur_pts[i])) {
        ++stats->lost_lk;
        continue;
      }
      if (options.lk.forward_backward_check) {
        const cv::Point2f d = back_pts[i] - prev_pts[i];
        if (!back_status[i] || static_cast<double>(d.dot(d)) > fb2) {
          ++stats->lost_forward_backward;
          continue;
        }
      }
      kept->push_back(static_cast<int>(i));
      kept_pixels->push_back(cur_pts[i]);
    }
  }
}

cv::Point2f CameraTracker::Impl::Rotated(const cv::Point2f& pixel, const Eigen::Matrix3d& r) const {
  const auto bearing = camera.Unproject(Eigen::Vector2d(pixel.x, pixel.y));
  if (!bearing) return pixel;
  const auto moved = camera.Project(r * *bearing);
  if (!moved || !moved->allFinite()) return pixel;
  const cv::Point2f out(static_cast<float>(moved->x()), static_cast<float>(moved->y()));
  return Usable(out) ? out : pixel;
}

std::optional<Eigen::Matrix3d> CameraTracker::Impl::RejectByRansac(std::vector<int>* kept,
                                                                   std::vector<cv::Point2f>* kept_pixels,
                                                                   CameraFrameStats* stats) const {
  std::optional<Eigen::Matrix3d> fitted;
  {
    std::vector<Eigen::Vector3d> bearings_prev, bearings_cur;
    std::vector<int> with_bearing;  // positions in kept
    for (size_t k = 0; k < kept->size(); ++k) {
      const Eigen::Vector2f& p = prev_features[static_cast<size_t>((*kept)[k])].pixel;
      const auto b_prev = camera.Unproject(p.cast<double>());
      const auto b_cur = camera.Unproject(Eigen::Vector2d((*kept_pixels)[k].x, (*kept_pixels)[k].y));
      if (!b_prev || !b_cur) {
        ++stats->lost_lk;
        continue;
      }
      bearings_prev.push_back(*b_prev);
      bearings_cur.push_back(*b_cur);
      with_bearing.push_back(static_cast<int>(k));
    }
    BearingRansacOptions ransac;
    ransac.threshold = BearingThresholdFromPixels(options.ransac_threshold_px, options.ransac_focal_px);
    const std::vector<bool> inliers = RansacRelativePoseInliers(bearings_prev, bearings_cur, ransac);
    std::vector<int> survivors;
    std::vector<cv::Point2f> survivor_pixels;
    std::vector<Eigen::Vector3d> inlier_prev, inlier_cur;
    for (size_t j = 0; j < with_bearing.size(); ++j) {
      if (!inliers[j]) {
        ++stats->ransac_outliers;
        continue;
      }
      ++stats->ransac_inliers;
      survivors.push_back((*kept)[static_cast<size_t>(with_bearing[j])]);
      survivor_pixels.push_back((*kept_pixels)[static_cast<size_t>(with_bearing[j])]);
      inlier_prev.push_back(bearings_prev[j]);
      inlier_cur.push_back(bearings_cur[j]);
    }
    kept->swap(survivors);
    kept_pixels->swap(survivor_pixels);
    if (options.lk.predict_rotation && static_cast<int>(inlier_prev.size()) >= ransac.min_correspondences) {
      fitted = FitBearingRotation(inlier_prev, inlier_cur);
      // Too slow a turn to need it: LK starts at the previous position.
      const double min_angle = options.lk.predict_rotation_min_px / camera.MeanFocalLength();
      if (fitted && Eigen::AngleAxisd(*fitted).angle() < min_angle) fitted.reset();
    }
  }
  return fitted;
}

void CameraTracker::Impl::RefineByAnchor(const cv::Mat& image, std::vector<int>* kept,
                                         std::vector<cv::Point2f>* kept_pixels,
                                         std::vector<PatchAnchor>* anchors, CameraFrameStats* stats) {
  MCVO_CHECK(prev_anchors.size() == prev_features.size());
  std::vector<int> survivors;
  std::vector<cv::Point2f> survivor_pixels;
  for (size_t k = 0; k < kept->size(); ++k) {
    const int index = (*kept)[k];
    // Each previous feature is kept at most once (kept holds distinct indices).
    PatchAnchor anchor = std::move(prev_anchors[static_cast<size_t>(index)]);
    cv::Point2f pixel = (*kept_pixels)[k];
    // A patch without the texture to align (or cut by the border when the
    // feature was found) keeps its LK track unchecked, as does one whose
    // warped patch now leaves the image.
    if (anchor.valid) {
      const PatchAlignResult aligned = AlignPatch(anchor, image, Eigen::Vector2f(pixel.x, pixel.y), align);
      if (aligned.status == PatchAlignStatus::kNoMatch) {
        if (options.anchor.drop_mismatch) {
          ++stats->lost_anchor;
          continue;
        }
        // Kept on its LK position with a new template there.
        anchor = MakePatchAnchor(image, Eigen::Vector2f(pixel.x, pixel.y), align);
      }
      if (aligned.status == PatchAlignStatus::kAligned) {
        const cv::Point2f refined(aligned.pixel.x(), aligned.pixel.y());
        if (!Usable(refined)) {
          ++stats->lost_lk;
          continue;
        }
        pixel = refined;
        anchor.warp = aligned.warp;
        if (WarpBeyond(aligned.warp, options.anchor.reanchor_scale)) {
          PatchAnchor fresh = MakePatchAnchor(image, aligned.pixel, align);
          if (fresh.valid) anchor = std::move(fresh);
        }
      }
    }
    survivors.push_back(index);
    survivor_pixels.push_back(pixel);
    anchors->push_back(std::move(anchor));
  }
  kept->swap(survivors);
  kept_pixels->swap(survivor_pixels);
}

namespace {

// The detections of `all` at `rows`, pixels and scores only (what the
// selection reads).
Detections DetectionRows(const Detections& all, const std::vector<size_t>& rows) {
  Detections out;
  for (size_t k : rows) {
    out.pixels.push_back(all.pixels[k]);
    out.scores.push_back(all.scores[k]);
  }
  return out;
}

}  // namespace

Detections CameraTracker::Impl::Detect(const cv::Mat& image, const std::vector<cv::Mat>& pyramid,
                                       int cap) const {
  // buildOpticalFlowPyramid with derivatives: level l's image at 2 l.
  const size_t index = static_cast<size_t>(2 * detection_level);
  if (detection_level == 0 || index >= pyramid.size()) return detector->Detect(image, mask, cap, border_px);
  Detections detections = detector->Detect(pyramid[index], detection_mask, cap, 1);
  MCVO_CHECK(detections.descriptors.empty());  // Shi-Tomasi only: pixels and scores
  // Pixel centres: coarse x covers fine 2x - 0.5 .. 2x + 1.5, centre 2x + 0.5.
  const float factor = static_cast<float>(1 << detection_level);
  const float offset = 0.5f * (factor - 1.0f);
  Detections out;
  for (size_t k = 0; k < detections.pixels.size(); ++k) {
    const Eigen::Vector2f p = detections.pixels[k] * factor + Eigen::Vector2f(offset, offset);
    if (!Usable(cv::Point2f(p.x(), p.y()))) continue;
    out.pixels.push_back(p);
    out.scores.push_back(detections.scores[k]);
  }
  return out;
}

void CameraTracker::Impl::AddNewFeatures(const cv::Mat& input, const cv::Mat& image,
                                         const std::vector<cv::Mat>& pyramid,
                                         CameraFrameResult* result) const {
  const int wanted = max_features - result->stats.tracked;
  if (wanted <= 0) return;
  // FrontendOptions::detect_missing_fraction, superpoint.detect_missing_fraction
  const double missing_fraction = IsLearnedDetector(options.detector) ? options.superpoint.detect_missing_fraction
                                                                      : options.detect_missing_fraction;
  if (result->stats.tracked > 0 && wanted < missing_fraction * static_cast<double>(max_features)) return;
  auto start = Clock::now();
  const int cap = std::max(1, options.candidate_factor) * wanted;
  Detections detections = Detect(image, pyramid, cap);
  const TextureOptions& texture = options.texture;
  if (texture.min_gradient > 0.0 || texture.noise_factor > 0.0) {
    // Texture gate (texture_gate.h): on the decoded image, before the
    // selection, so the budget goes to patches LK can follow.
    const internal::TextureGate gate(input, options.lk.window_px / 2);
    const double threshold = gate.Threshold(texture.min_gradient, texture.noise_factor);
    std::vector<size_t> rows;
    for (size_t k = 0; k < detections.size(); ++k) {
      if (gate.Strength(detections.pixels[k]) >= threshold) rows.push_back(k);
    }
    result->stats.untextured = static_cast<int>(detections.size() - rows.size());
    if (rows.size() < detections.size()) {
      Detections kept = DetectionRows(detections, rows);
      if (!detections.descriptors.empty()) {
        kept.descriptors = SelectRows(detections.descriptors, std::vector<int>(rows.begin(), rows.end()));
      }
      detections = std::move(kept);
    }
  }
  result->stats.seconds_detect = SecondsSince(start);
  start = Clock::now();
  // Two passes: the best `cap` candidates by score first (the first `cap`
  // detections); only when they cannot place every wanted feature (strong
  // corners bunched on a few edges) the spread extras after them fill the
  // rest, kept away from everything chosen so far.
  const size_t top = std::min(detections.size(), static_cast<size_t>(cap));
  SelectionInput selection;
  for (const TrackedFeature& f : result->features) selection.tracked.push_back(f.pixel);
  selection.image_width = camera.width;
  selection.image_height = camera.height;
  selection.mask = mask;
  selection.max_features = max_features;
  selection.min_distance_px = options.min_distance_px;
  std::vector<size_t> top_rows(top);
  std::iota(top_rows.begin(), top_rows.end(), size_t{0});
  const Detections first = DetectionRows(detections, top_rows);
  selection.candidates = &first;
  std::vector<int> chosen = SelectFeatures(selection, options.selection);
  if (static_cast<int>(chosen.size()) < wanted && top < detections.size()) {
    for (int index : chosen) selection.tracked.push_back(detections.pixels[static_cast<size_t>(index)]);
    // Only extras in grid cells that hold no feature yet (coverage holes).
    const internal::CandidateGrid grid(camera.width, camera.height);
    const auto cell_of = [&grid](const Eigen::Vector2f& p) {
      return static_cast<size_t>(grid.Cell(grid.Col(p.x()), grid.Row(p.y())));
    };
    std::vector<bool> occupied(static_cast<size_t>(grid.NumCells()), false);
    for (const Eigen::Vector2f& p : selection.tracked) occupied[cell_of(p)] = true;
    std::vector<size_t> hole_rows;
    for (size_t k = top; k < detections.size(); ++k) {
      if (!occupied[cell_of(detections.pixels[k])]) hole_rows.push_back(k);
    }
    const Detections extras = DetectionRows(detections, hole_rows);
    selection.candidates = &extras;
    for (int index : SelectFeatures(selection, options.selection)) {
      chosen.push_back(static_cast<int>(hole_rows[static_cast<size_t>(index)]));
    }
  }
  for (int index : chosen) {
    TrackedFeature f;
    f.pixel = detections.pixels[static_cast<size_t>(index)];
    f.score = detections.scores[static_cast<size_t>(index)];
    result->features.push_back(f);
  }
  if (!detections.descriptors.empty() && !chosen.empty()) {
    const cv::Mat new_rows = SelectRows(detections.descriptors, chosen);
    if (result->descriptors.empty()) {
      result->descriptors = new_rows;
    } else {
      cv::vconcat(result->descriptors, new_rows, result->descriptors);
    }
  }
  result->stats.new_features = static_cast<int>(chosen.size());
  result->stats.seconds_select = SecondsSince(start);
}

void CameraTracker::AssignNewIds(uint64_t* next_id, CameraFrameResult* result) {
  MCVO_CHECK(next_id != nullptr && result != nullptr);
  MCVO_CHECK(result->features.size() == impl_->prev_features.size());
  for (size_t i = 0; i < result->features.size(); ++i) {
    if (result->features[i].id != 0) continue;
    result->features[i].id = (*next_id)++;
    impl_->prev_features[i].id = result->features[i].id;
  }
}

const std::vector<cv::Mat>& CameraTracker::Pyramid() const { return impl_->prev_pyramid; }

const std::vector<cv::Mat>& CameraTracker::CrossCameraPyramid() const {
  return impl_->prev_raw_pyramid.empty() ? impl_->prev_pyramid : impl_->prev_raw_pyramid;
}

const std::vector<cv::Mat>& CameraTracker::PreviousCrossCameraPyramid() const {
  return impl_->older_cross_pyramid;
}

int CameraTracker::DescriptorSize() const { return impl_->detector->DescriptorSize(); }
int CameraTracker::DescriptorType() const { return impl_->detector->DescriptorType(); }

}  // namespace mcvo
