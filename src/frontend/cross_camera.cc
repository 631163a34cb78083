// Cross-camera matching (the steps and the geometry: cross_camera.h).
//
// Decisions:
//  * Only camera a's side is a feature: b's pixel is where a's feature lies
//    in b, not one of b's own features (those are tracked in b's own track
//    and may be the same point under another id; the estimator merges them
//    through the match).
//  * b's image is warped into a's grid for every pair, rectified stereo
//    pairs included (one code path). Plain translational LK from a's image
//    to b's, seeded at W(u), found 2 matches in 2 frames of the three
//    kitti360-3cam pairs (quarter resolution) where the warp finds 33, and
//    5 % more on a rectified stereo pair (232 vs 220 in 4 frames, same
//    accuracy); the warp costs ~0.4 ms per frame for a 704 x 188 camera a.
//  * The LK settings (window, levels, iterations) are the tracker's, since
//    a's pyramid is the tracker's; the forward-backward check is always on
//    for cross-camera matches (lk.forward_backward_threshold_px).
//  * max_matches_per_pair keeps the longest tracks (ties: a's feature
//    order): a long track ties the two cameras over more frames.
#include "mcvo/frontend/cross_camera.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "mcvo/dataset/overlap.h"
#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"

namespace mcvo {
namespace {

using Clock = std::chrono::steady_clock;

constexpr double kPi = 3.14159265358979323846;

// (I - mean) / max(std, floor) with mean and std over a box window of
// (2 r + 1)^2 pixels, r = round(sqrt(3) sigma_px) (a box of the Gaussian's
// variance; running sums, O(1) per pixel), mapped to 8 bits around 128 (LK
// reads 8-bit images), inside `roi` only; 128 elsewhere. Pixels where
// `valid` is 0 (b does not see them) stay out of the statistics and come
// out 128. A linear map per pixel, the same for a's image and b's warped
// into a's grid: a gain, an offset or a smooth falloff (vignetting) between
// the cameras cancels; a histogram equalisation per camera (CLAHE) would
// not.
cv::Mat LocalNormalise(const cv::Mat& image, const cv::Mat& valid, const cv::Rect& roi, double sigma_px) {
  cv::Mat out(image.size(), CV_8UC1, cv::Scalar(128));
  if (roi.empty()) return out;
  const int r = std::max(1, static_cast<int>(std::lround(std::sqrt(3.0) * sigma_px)));
  const cv::Size box(2 * r + 1, 2 * r + 1);
  cv::Mat i, m;
  image(roi).convertTo(i, CV_32F);
  if (valid.empty()) {
    m = cv::Mat(roi.size(), CV_32F, cv::Scalar(1.0f));
  } else {
    valid(roi).convertTo(m, CV_32F, 1.0 / 255.0);
  }
  const cv::Mat im = i.mul(m), i2m = im.mul(i);
  cv::Mat bm, bim, bi2m;
  cv::boxFilter(m, bm, CV_32F, box, cv::Point(-1, -1), true, cv::BORDER_CONSTANT);
  cv::boxFilter(im, bim, CV_32F, box, cv::Point(-1, -1), true, cv::BORDER_CONSTANT);
  cv::boxFilter(i2m, bi2m, CV_32F, box, cv::Point(-1, -1), true, cv::BORDER_CONSTANT);
  constexpr float kFloorStd = 4.0f;  // grey levels: flat regions are not amplified into noise
  constexpr float kOutputStd = 32.0f;
  for (int y = 0; y < roi.height; ++y) {
    const float* pi = i.ptr<float>(y);
    const float* pm = m.ptr<float>(y);
    const float* pbm = bm.ptr<float>(y);
    const float* pbim = bim.ptr<float>(y);
    const float* pbi2m = bi2m.ptr<float>(y);
    uint8_t* po = out.ptr<uint8_t>(roi.y + y) + roi.x;
    for (int x = 0; x < roi.width; ++x) {
      if (pm[x] < 0.5f || pbm[x] < 1e-3f) continue;
      const float mean = pbim[x] / pbm[x];
      const float var = std::max(0.0f, pbi2m[x] / pbm[x] - mean * mean);
      const float v = 128.0f + kOutputStd * (pi[x] - mean) / std::max(std::sqrt(var), kFloorStd);
      po[x] = static_cast<uint8_t>(std::clamp(v, 0.0f, 255.0f) + 0.5f);
    }
  }
  return out;
}

}  // namespace

std::vector<std::pair<int, int>> SelectCrossCameraPairs(const Rig& rig, const std::vector<cv::Mat>& masks,
                                                        const CrossCameraOptions& options) {
  std::vector<std::pair<int, int>> pairs;
  if (!options.enabled) return pairs;
  MCVO_CHECK(masks.empty() || static_cast<int>(masks.size()) == rig.NumCameras());
  const auto mask = [&](int c) { return masks.empty() ? cv::Mat() : masks[static_cast<size_t>(c)]; };
  for (int a = 0; a < rig.NumCameras(); ++a) {
    for (int b = a + 1; b < rig.NumCameras(); ++b) {
      const double overlap =
          ViewOverlap(rig.cameras[static_cast<size_t>(a)], rig.cameras[static_cast<size_t>(b)],
                      kViewOverlapDepthM, mask(a), mask(b));
      if (overlap > 0.0 && overlap >= options.min_view_overlap) pairs.emplace_back(a, b);
    }
  }
  return pairs;
}

CrossCameraCheck CheckCrossCameraBearings(const Eigen::Vector3d& bearing_a, const Eigen::Vector3d& bearing_b,
                                          const Rigid3d& b_from_a, double max_epipolar_sine,
                                          double min_angle_rad, double* depth_a_out) {
  const Eigen::Vector3d r = b_from_a.rotation * bearing_a.normalized();  // a's ray direction in b
  const Eigen::Vector3d f = bearing_b.normalized();
  const Eigen::Vector3d& t = b_from_a.translation;  // a's centre in b
  const Eigen::Vector3d normal = t.cross(r);
  const double normal_norm = normal.norm();
  // A ray along the baseline (or no baseline): no epipolar plane, no depth.
  if (!(normal_norm > 1e-12 * std::max(1.0, t.norm()))) return CrossCameraCheck::kTriangulation;
  if (std::abs(normal.dot(f)) / normal_norm > max_epipolar_sine) return CrossCameraCheck::kEpipolar;
  const double c = r.dot(f);
  const double det = 1.0 - c * c;
  if (!(det > 1e-15) || c > std::cos(min_angle_rad)) return CrossCameraCheck::kTriangulation;
  const double rt = r.dot(t);
  const double ft = f.dot(t);
  const double depth_a = (-rt + c * ft) / det;
  const double depth_b = (ft - c * rt) / det;
  if (!(depth_a > 0.0 && depth_b > 0.0)) return CrossCameraCheck::kTriangulation;
  if (depth_a_out != nullptr) *depth_a_out = depth_a;
  return CrossCameraCheck::kOk;
}

std::vector<Eigen::Vector3d> UnitBearingGrid(const Camera& a, int threads) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Eigen::Vector3d> grid(static_cast<size_t>(a.width) * static_cast<size_t>(a.height));
  constexpr int kRowsPerBlock = 16;  // each pixel's value is its own: any split gives the same grid
  const int blocks = (a.height + kRowsPerBlock - 1) / kRowsPerBlock;
  ParallelFor(blocks, threads, [&](int block) {
    const int end = std::min(a.height, (block + 1) * kRowsPerBlock);
    for (int y = block * kRowsPerBlock; y < end; ++y) {
      Eigen::Vector3d* row = &grid[static_cast<size_t>(y) * static_cast<size_t>(a.width)];
      for (int x = 0; x < a.width; ++x) {
        const std::optional<Eigen::Vector3d> bearing = a.Unproject(Eigen::Vector2d(x, y));
        row[x] = bearing ? bearing->normalized() : Eigen::Vector3d(nan, nan, nan);
      }
    }
  });
  return grid;
}

CrossCameraMatcher::CrossCameraMatcher(int camera_a, int camera_b, const Camera& a, const Camera& b,
                                       const cv::Mat& mask_b, const FrontendOptions& options, int threads,
                                       const std::vector<Eigen::Vector3d>* bearings_a)
    : camera_a_(camera_a), camera_b_(camera_b), a_(a), b_(b), mask_b_(mask_b.clone()), options_(options) {
  MCVO_CHECK(mask_b.empty() ||
             (mask_b.type() == CV_8UC1 && mask_b.cols == b.width && mask_b.rows == b.height));
  MCVO_CHECK(bearings_a == nullptr ||
             bearings_a->size() == static_cast<size_t>(a.width) * static_cast<size_t>(a.height));
  b_from_a_ = b.cam_from_rig * a.cam_from_rig.Inverse();
  const double px = options.cross_camera.epipolar_threshold_px;
  max_epipolar_sine_ = px / std::hypot(px, options.ransac_focal_px);
  min_angle_rad_ = options.cross_camera.min_angle_deg * kPi / 180.0;
  // The warps W_d: a's pixel grid -> b's pixels, through the point at d on
  // each pixel's ray, one per distance (init_distance_m, near_distance_m).
  // Where b does not see that point (outside b's image, domain or mask) the
  // map points at b's pixel (0, 0) (out-of-image coordinates send cv::remap
  // to a slow per-pixel path) and the warped image is set to 0 afterwards.
  // Fixed-point maps (1/32 px) remap 2-5x faster; the matched pixel itself
  // is computed exactly, W_d(p). Each pixel's value is Warp()'s: the same
  // bearing, the same arithmetic.
  std::vector<double> distances = {options.cross_camera.init_distance_m};
  if (options.cross_camera.near_distance_m > 0.0 &&
      options.cross_camera.near_distance_m != options.cross_camera.init_distance_m) {
    distances.push_back(options.cross_camera.near_distance_m);
  }
  std::vector<Eigen::Vector3d> own_bearings;
  if (bearings_a == nullptr) {
    own_bearings = UnitBearingGrid(a, threads);
    bearings_a = &own_bearings;
  }
  const size_t n = distances.size();
  std::vector<cv::Mat> map_x(n), map_y(n);
  warps_.resize(n);
  for (size_t w = 0; w < n; ++w) {
    warps_[w].distance_m = distances[w];
    map_x[w].create(a.height, a.width, CV_32FC1);
    map_y[w].create(a.height, a.width, CV_32FC1);
    warps_[w].unseen = cv::Mat::zeros(a.height, a.width, CV_8UC1);
  }
  constexpr int kRowsPerBlock = 16;  // each pixel's value is its own: any split gives the same maps
  const int blocks = (a.height + kRowsPerBlock - 1) / kRowsPerBlock;
  ParallelFor(blocks, threads, [&](int block) {
    const int end = std::min(a.height, (block + 1) * kRowsPerBlock);
    for (int y = block * kRowsPerBlock; y < end; ++y) {
      const Eigen::Vector3d* bearing = &(*bearings_a)[static_cast<size_t>(y) * static_cast<size_t>(a.width)];
      for (size_t w = 0; w < n; ++w) {
        float* mx = map_x[w].ptr<float>(y);
        float* my = map_y[w].ptr<float>(y);
        uint8_t* unseen = warps_[w].unseen.ptr<uint8_t>(y);
        for (int x = 0; x < a.width; ++x) {
          const std::optional<Eigen::Vector2d> q =
              std::isnan(bearing[x].x()) ? std::nullopt : WarpBearing(bearing[x], distances[w]);
          const cv::Point2f p =
              q ? cv::Point2f(static_cast<float>(q->x()), static_cast<float>(q->y())) : cv::Point2f();
          if (q && UsableInB(p)) {
            mx[x] = p.x;
            my[x] = p.y;
          } else {
            mx[x] = my[x] = 0.0f;
            unseen[x] = 255;
          }
        }
      }
    }
  });
  for (size_t w = 0; w < n; ++w) {
    WarpMap& warp = warps_[w];
    cv::convertMaps(map_x[w], map_y[w], warp.map_xy, warp.map_fraction, CV_16SC2);
    cv::bitwise_not(warp.unseen, warp.seen);
    warp.seen_box = cv::boundingRect(warp.seen);
    normalise_roi_a_ |= warp.seen_box;
  }
  // a's image is normalised (step 2) where LK can read it: around the
  // pixels b sees, by LK's window at the coarsest pyramid level.
  const int margin = (options.lk.window_px / 2 + 2) << options.lk.pyramid_levels;
  if (!normalise_roi_a_.empty()) {
    normalise_roi_a_ = cv::Rect(normalise_roi_a_.x - margin, normalise_roi_a_.y - margin,
                                normalise_roi_a_.width + 2 * margin, normalise_roi_a_.height + 2 * margin) &
                       cv::Rect(0, 0, a.width, a.height);
  }
}

bool CrossCameraMatcher::UsableInB(const cv::Point2f& p) const {
  if (!(p.x >= 1.0f && p.y >= 1.0f && p.x <= static_cast<float>(b_.width - 2) &&
        p.y <= static_cast<float>(b_.height - 2)))
    return false;
  if (mask_b_.empty()) return true;
  return mask_b_.at<uint8_t>(static_cast<int>(std::lround(p.y)), static_cast<int>(std::lround(p.x))) != 0;
}

std::optional<Eigen::Vector2d> CrossCameraMatcher::Warp(const Eigen::Vector2d& pixel_a,
                                                        double distance_m) const {
  const std::optional<Eigen::Vector3d> bearing = a_.Unproject(pixel_a);
  if (!bearing) return std::nullopt;
  return WarpBearing(bearing->normalized(), distance_m);
}

std::optional<Eigen::Vector2d> CrossCameraMatcher::WarpBearing(const Eigen::Vector3d& unit_bearing_a,
                                                               double distance_m) const {
  std::optional<Eigen::Vector2d> q = b_.Project(b_from_a_ * (distance_m * unit_bearing_a));
  if (!q || !b_.IsInImage(*q)) return std::nullopt;
  return q;
}

void CrossCameraMatcher::MatchThroughWarp(const WarpMap& warp, const std::vector<cv::Mat>& pyramid_a,
                                          const std::vector<cv::Mat>& pyramid_b,
                                          const std::vector<cv::Point2f>& pts_a,
                                          std::vector<Outcome>* outcome,
                                          std::vector<Eigen::Vector2f>* pixel_b,
                                          std::vector<double>* depth_a) const {
  outcome->assign(pts_a.size(), Outcome::kLostLk);
  pixel_b->assign(pts_a.size(), Eigen::Vector2f::Zero());
  depth_a->assign(pts_a.size(), 0.0);
  // 2. b's image warped into a's grid, and LK a -> warped b from the feature
  // itself (its point at d), 3. back from where it landed (the same
  // hypothesis seen from the other side).
  cv::Mat warped = cv::Mat::zeros(a_.height, a_.width, CV_8UC1);
  if (!warp.seen_box.empty()) {
    const cv::Rect& box = warp.seen_box;
    cv::Mat warped_box = warped(box);  // a view: remap writes into warped
    cv::remap(pyramid_b.front(), warped_box, warp.map_xy(box), warp.map_fraction(box), cv::INTER_LINEAR,
              cv::BORDER_CONSTANT, cv::Scalar(0));
    warped_box.setTo(0, warp.unseen(box));
  }

  const cv::Size window(options_.lk.window_px, options_.lk.window_px);
  std::vector<cv::Mat> pyramid_w;
  const double sigma = options_.cross_camera.normalise_sigma_px;
  if (sigma > 0.0) warped = LocalNormalise(warped, warp.seen, warp.seen_box, sigma);
  cv::buildOpticalFlowPyramid(warped, pyramid_w, window, options_.lk.pyramid_levels);

  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, options_.lk.max_iterations,
                                  0.001);
  std::vector<cv::Point2f> pts_w = pts_a;
  std::vector<uint8_t> status, back_status;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(pyramid_a, pyramid_w, pts_a, pts_w, status, error, window,
                           options_.lk.pyramid_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
  std::vector<cv::Point2f> back = pts_w;
  cv::calcOpticalFlowPyrLK(pyramid_w, pyramid_a, pts_w, back, back_status, error, window,
                           options_.lk.pyramid_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);

  // 4, 5. b's pixel W(p_w), forward-backward distance, epipolar plane, triangulation.
  const double fb2 = options_.lk.forward_backward_threshold_px * options_.lk.forward_backward_threshold_px;
  for (size_t k = 0; k < pts_a.size(); ++k) {
    const std::optional<Eigen::Vector2d> q =
        status[k] ? Warp(Eigen::Vector2d(static_cast<double>(pts_w[k].x), static_cast<double>(pts_w[k].y)),
                         warp.distance_m)
                  : std::nullopt;
    const cv::Point2f pixel =
        q ? cv::Point2f(static_cast<float>(q->x()), static_cast<float>(q->y())) : cv::Point2f();
    const std::optional<Eigen::Vector3d> bearing_b =
        q && UsableInB(pixel)
            ? b_.Unproject(Eigen::Vector2d(static_cast<double>(pixel.x), static_cast<double>(pixel.y)))
            : std::nullopt;
    if (!bearing_b) continue;  // kLostLk
    const cv::Point2f d = back[k] - pts_a[k];
    if (!back_status[k] || static_cast<double>(d.dot(d)) > fb2) {
      (*outcome)[k] = Outcome::kForwardBackward;
      continue;
    }
    const Eigen::Vector3d bearing_a = *a_.Unproject(Eigen::Vector2d(pts_a[k].x, pts_a[k].y));  // step 1
    double depth = 0.0;
    switch (CheckCrossCameraBearings(bearing_a, *bearing_b, b_from_a_, max_epipolar_sine_, min_angle_rad_,
                                     &depth)) {
      case CrossCameraCheck::kEpipolar:
        (*outcome)[k] = Outcome::kEpipolar;
        continue;
      case CrossCameraCheck::kTriangulation:
        (*outcome)[k] = Outcome::kTriangulation;
        continue;
      case CrossCameraCheck::kOk:
        break;
    }
    (*outcome)[k] = Outcome::kOk;
    (*pixel_b)[k] = Eigen::Vector2f(pixel.x, pixel.y);
    (*depth_a)[k] = depth;
  }
}

std::vector<CrossCameraMatch> CrossCameraMatcher::Match(const std::vector<TrackedFeature>& features_a,
                                                        const std::vector<cv::Mat>& pyramid_a,
                                                        const std::vector<cv::Mat>& pyramid_b,
                                                        CrossCameraPairStats* stats) const {
  MCVO_CHECK(stats != nullptr);
  const Clock::time_point start = Clock::now();
  *stats = EmptyStats();
  std::vector<CrossCameraMatch> matches;
  if (pyramid_a.empty() || pyramid_b.empty()) return matches;
  MCVO_CHECK(pyramid_a.front().cols == a_.width && pyramid_a.front().rows == a_.height);
  MCVO_CHECK(pyramid_b.front().cols == b_.width && pyramid_b.front().rows == b_.height);
  stats->features = static_cast<int>(features_a.size());

  // 1. Candidates: features whose point at d0 b sees.
  std::vector<int> index;  // into features_a
  std::vector<cv::Point2f> pts_a;
  for (size_t i = 0; i < features_a.size(); ++i) {
    const Eigen::Vector2f& u = features_a[i].pixel;
    const std::optional<Eigen::Vector2d> q = Warp(u.cast<double>(), warps_.front().distance_m);
    if (!q || !UsableInB(cv::Point2f(static_cast<float>(q->x()), static_cast<float>(q->y())))) {
      ++stats->outside_view;
      continue;
    }
    index.push_back(static_cast<int>(i));
    pts_a.emplace_back(u.x(), u.y());
  }
  auto finish = [&]() {
    stats->matches = static_cast<int>(matches.size());
    stats->seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return matches;
  };
  if (index.empty()) return finish();

  // 2-5 through the first warp: the matches.
  std::vector<Outcome> outcome;
  std::vector<Eigen::Vector2f> pixel_b;
  std::vector<double> depth;
  // a's image normalised once for both warps (step 2).
  std::vector<cv::Mat> normalised_a;
  const double sigma = options_.cross_camera.normalise_sigma_px;
  if (sigma > 0.0) {
    cv::buildOpticalFlowPyramid(LocalNormalise(pyramid_a.front(), cv::Mat(), normalise_roi_a_, sigma),
                                normalised_a, cv::Size(options_.lk.window_px, options_.lk.window_px),
                                options_.lk.pyramid_levels);
  }
  const std::vector<cv::Mat>& pa = sigma > 0.0 ? normalised_a : pyramid_a;
  MatchThroughWarp(warps_.front(), pa, pyramid_b, pts_a, &outcome, &pixel_b, &depth);
  // 6. Through the near warp: where both warps match, the match whose warp
  // distance is nearest (log ratio) to the depth it triangulates; where only
  // the near warp does, its match if it triangulates nearer than the
  // distances' geometric mean.
  if (warps_.size() > 1) {
    std::vector<Outcome> near_outcome;
    std::vector<Eigen::Vector2f> near_pixel_b;
    std::vector<double> near_depth;
    MatchThroughWarp(warps_[1], pa, pyramid_b, pts_a, &near_outcome, &near_pixel_b, &near_depth);
    const double far_m = warps_[0].distance_m, near_m = warps_[1].distance_m;
    const double near_limit_m = std::sqrt(far_m * near_m);
    for (size_t k = 0; k < index.size(); ++k) {
      if (near_outcome[k] != Outcome::kOk) continue;
      const bool take = outcome[k] == Outcome::kOk ? std::abs(std::log(near_depth[k] / near_m)) <
                                                         std::abs(std::log(depth[k] / far_m))
                                                   : near_depth[k] < near_limit_m;
      if (!take) continue;
      outcome[k] = Outcome::kOk;
      pixel_b[k] = near_pixel_b[k];
    }
  }
  std::vector<Accepted> accepted;
  for (size_t k = 0; k < index.size(); ++k) {
    switch (outcome[k]) {
      case Outcome::kLostLk:
        ++stats->lost_lk;
        continue;
      case Outcome::kForwardBackward:
        ++stats->lost_forward_backward;
        continue;
      case Outcome::kEpipolar:
        ++stats->lost_epipolar;
        continue;
      case Outcome::kTriangulation:
        ++stats->lost_triangulation;
        continue;
      case Outcome::kOk:
        break;
    }
    accepted.emplace_back(&features_a[static_cast<size_t>(index[k])], pixel_b[k]);
  }
  matches = ToMatches(std::move(accepted), stats);
  return finish();
}

CrossCameraPairStats CrossCameraMatcher::EmptyStats() const {
  CrossCameraPairStats stats;
  stats.camera_a = camera_a_;
  stats.camera_b = camera_b_;
  return stats;
}

std::vector<CrossCameraMatch> CrossCameraMatcher::ToMatches(std::vector<Accepted> accepted,
                                                            CrossCameraPairStats* stats) const {
  // Limit: longest tracks first (ties: a's feature order), then by id.
  const int limit = options_.cross_camera.max_matches_per_pair;
  if (limit > 0 && static_cast<int>(accepted.size()) > limit) {
    std::stable_sort(accepted.begin(), accepted.end(), [](const Accepted& x, const Accepted& y) {
      return x.first->track_length > y.first->track_length;
    });
    stats->over_limit = static_cast<int>(accepted.size()) - limit;
    accepted.resize(static_cast<size_t>(limit));
  }
  std::vector<CrossCameraMatch> matches;
  for (const auto& [feature, pixel] : accepted) {
    CrossCameraMatch match;
    match.camera_a = camera_a_;
    match.id_a = feature->id;
    match.camera_b = camera_b_;
    match.pixel_b = pixel;
    matches.push_back(match);
  }
  std::sort(matches.begin(), matches.end(),
            [](const CrossCameraMatch& x, const CrossCameraMatch& y) { return x.id_a < y.id_a; });
  return matches;
}

std::vector<CrossCameraMatch> CrossCameraMatcher::Follow(const std::vector<TrackedFeature>& features_a,
                                                         const std::vector<CrossCameraMatch>& previous,
                                                         const std::vector<cv::Mat>& previous_pyramid_b,
                                                         const std::vector<cv::Mat>& pyramid_b,
                                                         CrossCameraPairStats* stats) const {
  MCVO_CHECK(stats != nullptr);
  const Clock::time_point start = Clock::now();
  *stats = EmptyStats();
  std::vector<CrossCameraMatch> matches;
  auto finish = [&]() {
    stats->matches = static_cast<int>(matches.size());
    stats->seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return matches;
  };
  if (previous_pyramid_b.empty() || pyramid_b.empty() || previous.empty()) return finish();
  // a's features still tracked whose id was matched in the frame before
  // (previous is sorted by id_a; features_a is in the tracker's order).
  std::vector<const TrackedFeature*> feature;
  std::vector<cv::Point2f> pts_prev;
  for (const TrackedFeature& f : features_a) {
    const auto it = std::lower_bound(previous.begin(), previous.end(), f.id,
                                     [](const CrossCameraMatch& m, uint64_t id) { return m.id_a < id; });
    if (it == previous.end() || it->id_a != f.id) continue;
    MCVO_CHECK(it->camera_a == camera_a_ && it->camera_b == camera_b_);
    feature.push_back(&f);
    pts_prev.emplace_back(it->pixel_b.x(), it->pixel_b.y());
  }
  stats->features = static_cast<int>(feature.size());
  if (feature.empty()) return finish();

  const cv::Size window(options_.lk.window_px, options_.lk.window_px);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, options_.lk.max_iterations,
                                  0.001);
  std::vector<cv::Point2f> pts = pts_prev, back;
  std::vector<uint8_t> status, back_status;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(previous_pyramid_b, pyramid_b, pts_prev, pts, status, error, window,
                           options_.lk.pyramid_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
  back = pts;
  cv::calcOpticalFlowPyrLK(pyramid_b, previous_pyramid_b, pts, back, back_status, error, window,
                           options_.lk.pyramid_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
  const double fb2 = options_.lk.forward_backward_threshold_px * options_.lk.forward_backward_threshold_px;
  std::vector<Accepted> accepted;
  for (size_t k = 0; k < feature.size(); ++k) {
    const std::optional<Eigen::Vector3d> bearing_b =
        status[k] && UsableInB(pts[k])
            ? b_.Unproject(Eigen::Vector2d(static_cast<double>(pts[k].x), static_cast<double>(pts[k].y)))
            : std::nullopt;
    if (!bearing_b) {
      ++stats->lost_lk;
      continue;
    }
    const cv::Point2f d = back[k] - pts_prev[k];
    if (!back_status[k] || static_cast<double>(d.dot(d)) > fb2) {
      ++stats->lost_forward_backward;
      continue;
    }
    const std::optional<Eigen::Vector3d> bearing_a = a_.Unproject(feature[k]->pixel.cast<double>());
    if (!bearing_a) {
      ++stats->lost_lk;
      continue;
    }
    switch (CheckCrossCameraBearings(*bearing_a, *bearing_b, b_from_a_, max_epipolar_sine_, min_angle_rad_)) {
      case CrossCameraCheck::kEpipolar:
        ++stats->lost_epipolar;
        continue;
      case CrossCameraCheck::kTriangulation:
        ++stats->lost_triangulation;
        continue;
      case CrossCameraCheck::kOk:
        break;
    }
    accepted.emplace_back(feature[k], Eigen::Vector2f(pts[k].x, pts[k].y));
  }
  matches = ToMatches(std::move(accepted), stats);
  return finish();
}

}  // namespace mcvo
