#include "mcvo/loop/loop_closer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <thread>
#include <utility>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/backend/rig_pnp.h"
#include "mcvo/dataset/image_level.h"
#include "mcvo/loop/descriptor_match.h"
#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/strings.h"
#include "loop_image_features.h"
#include "orb_describe.h"

namespace mcvo {
namespace {

constexpr double kFocalPx = 460.0;  // thresholds "at focal 460", as the back end's
constexpr double kRadToDeg = 180.0 / M_PI;

// Coarsest level feature_max_megapixels may pick (1/16 of each side).
constexpr int kMaxFeatureLevel = 4;

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

struct LoopCloser::Impl {
  // A keyframe's features, once extracted.
  struct Features {
    // 2-D features of all cameras: ORB detections and the landmark pixels.
    std::vector<int> camera;
    std::vector<Eigen::Vector2d> pixel;
    std::vector<Eigen::Vector3d> bearing;
    cv::Mat descriptors;     // CV_8U, 32 bytes per row, one per feature
    int num_detections = 0;  // the first rows are ORB detections (the BoW's words)
    // Landmarks (rows of the landmark-pixel features): world point, id.
    std::vector<int64_t> landmark_id;
    std::vector<Eigen::Vector3d> landmark_point;
    cv::Mat landmark_descriptors;
    std::vector<bool> camera_has_features;
    // With cross-camera links: the landmark pixels as
    // loop/cross_camera_links.h takes them.
    LinkKeyframe link;
  };

  struct Entry {
    int frame_index = 0;
    Rigid3d world_from_rig;
    double path_m = 0.0;  // odometry path length from the first keyframe
    std::vector<int64_t> landmark_id;
    std::vector<Eigen::Vector3d> landmark_point;
    cv::Mat landmark_descriptors;
    LinkKeyframe link;  // with cross-camera links (options.cross_camera)
  };

  Impl(const Rig& rig_in, std::vector<cv::Mat> masks_in, Vocabulary vocabulary_in,
       const LoopClosureOptions& o, int threads_in)
      : rig(rig_in), vocabulary(std::move(vocabulary_in)), options(o), threads(std::max(1, threads_in)) {
    options.Check();
    if (vocabulary.kind() != DescriptorKind::kBinary || vocabulary.descriptor_size() != 32) {
      MCVO_THROW_INPUT("loop closure needs a vocabulary of 32-byte binary (ORB) descriptors, got ",
                       vocabulary.kind() == DescriptorKind::kBinary ? "binary" : "float", " of size ",
                       vocabulary.descriptor_size());
    }
    // The masks on the level each camera's features are extracted on.
    masks_in.resize(static_cast<size_t>(rig.NumCameras()));
    for (size_t c = 0; c < masks_in.size(); ++c) {
      const Camera& camera = rig.cameras[c];
      const int level =
          LevelForMegapixels(camera.width, camera.height, options.feature_max_megapixels, kMaxFeatureLevel);
      feature_masks.push_back(level > 0 && !masks_in[c].empty() ? CoarseMask(masks_in[c], level)
                                                                : masks_in[c]);
    }
    cam_from_rig = rig.CamFromRig();
  }

  const Rig rig;
  std::vector<cv::Mat> feature_masks;  // per camera, on the level its features are extracted on
  const Vocabulary vocabulary;
  const LoopClosureOptions options;
  const int threads;
  std::vector<Rigid3d> cam_from_rig;
  std::vector<Entry> entries;
  // Inverted file: word -> (keyframe, weight), keyframes ascending.
  std::map<uint32_t, std::vector<std::pair<int, double>>> inverted;
  // Verified (query, candidate) pairs, for the consistency test.
  std::vector<std::pair<int, int>> verified;
  LoopTiming timing;
  BowVector previous_bow;

  using CameraFeatures = LoopImageFeatures::CameraFeatures;

  CameraFeatures ExtractCamera(int camera, const LoopKeyframe& keyframe) const {
    CameraFeatures out;
    const cv::Mat& full = keyframe.images[static_cast<size_t>(camera)];
    if (full.empty()) return out;
    // A large image is described on a coarser level (feature_max_megapixels);
    // pyrDown's coarse pixel x is the fine pixel 2x (its Gaussian is centred
    // there), so full-resolution pixels are 2^level times the coarse ones.
    const int image_level =
        LevelForMegapixels(full.cols, full.rows, options.feature_max_megapixels, kMaxFeatureLevel);
    cv::Mat image = full;
    for (int l = 0; l < image_level; ++l) {
      cv::Mat coarser;
      cv::pyrDown(image, coarser);
      image = coarser;
    }
    const float factor = static_cast<float>(1 << image_level);
    cv::Ptr<cv::ORB> orb = cv::ORB::create(options.features_per_camera);
    const cv::Mat& mask = feature_masks[static_cast<size_t>(camera)];
    std::vector<cv::KeyPoint> detections;
    orb->detectAndCompute(image, mask.empty() || mask.size() != image.size() ? cv::noArray() : mask, detections,
                          out.detection_descriptors);
    if (options.cross_camera.window_keyframes > 0) {
      std::vector<cv::Point2f> points;
      std::vector<int> point_of;
      for (size_t k = 0; k < keyframe.points.size(); ++k) {
        const LoopKeyframe::Point& p = keyframe.points[k];
        if (p.camera != camera) continue;
        points.emplace_back(static_cast<float>(p.pixel.x()) / factor, static_cast<float>(p.pixel.y()) / factor);
        point_of.push_back(static_cast<int>(k));
      }
      loop_internal::DescribeOriented(orb, image, points, &out.link_point_index, &out.link_point_descriptors);
      for (int& k : out.link_point_index) k = point_of[static_cast<size_t>(k)];
    }
    out.detections.reserve(detections.size());
    for (const cv::KeyPoint& kp : detections) out.detections.push_back(kp.pt * factor);
    std::vector<cv::KeyPoint> points;
    for (size_t k = 0; k < keyframe.points.size(); ++k) {
      const LoopKeyframe::Point& p = keyframe.points[k];
      if (p.camera != camera) continue;
      // One descriptor per pyramid level asked for (ORB's levels, 1.2 apart):
      // a place seen again from farther or nearer matches at another level.
      for (int level = 0; level < options.landmark_levels; ++level) {
        cv::KeyPoint kp(static_cast<float>(p.pixel.x()) / factor, static_cast<float>(p.pixel.y()) / factor,
                        static_cast<float>(31.0 * std::pow(1.2, level)));
        kp.octave = level;
        kp.class_id = static_cast<int>(k);
        if (options.landmark_orientation) {
          kp.angle = loop_internal::IntensityCentroidAngle(image, kp.pt.x, kp.pt.y,
                                            static_cast<int>(std::lround(15.0 * std::pow(1.2, level))));
        }
        points.push_back(kp);
      }
    }
    if (!points.empty()) {
      // Descriptors at the given pixels on their levels; ORB drops keypoints
      // too close to the border and groups them by level: class_id says
      // which remain, in its order.
      orb->compute(image, points, out.point_descriptors);
      for (const cv::KeyPoint& kp : points) out.point_index.push_back(kp.class_id);
    }
    return out;
  }

  std::shared_ptr<const LoopImageFeatures> ExtractImageFeatures(const LoopKeyframe& keyframe,
                                                               int camera_threads) const {
    CheckImages(keyframe);
    const int n = rig.NumCameras();
    auto out = std::make_shared<LoopImageFeatures>();
    out->cameras.resize(static_cast<size_t>(n));
    ParallelFor(n, camera_threads,
                [&](int c) { out->cameras[static_cast<size_t>(c)] = ExtractCamera(c, keyframe); });
    for (const LoopKeyframe::Point& p : keyframe.points) {
      out->point_camera.push_back(p.camera);
      out->point_pixel.push_back(p.pixel);
    }
    return out;
  }

  Features Extract(const LoopKeyframe& keyframe, int camera_threads) const {
    return Assemble(keyframe, *ExtractImageFeatures(keyframe, camera_threads));
  }

  // The keyframe's features from its image features (extracted for the same
  // points' cameras and pixels) and its points' ids and world positions.
  Features Assemble(const LoopKeyframe& keyframe, const LoopImageFeatures& image_features) const {
    MCVO_CHECK_MSG(image_features.Fits(keyframe), "keyframe ", keyframe.frame_index,
                   ": image features extracted for other points");
    const int n = rig.NumCameras();
    const std::vector<CameraFeatures>& per_camera = image_features.cameras;
    MCVO_CHECK(static_cast<int>(per_camera.size()) == n);
    Features f;
    f.camera_has_features.assign(static_cast<size_t>(n), false);
    std::vector<cv::Mat> detection_rows, point_rows;
    auto add_2d = [&](int c, const cv::Point2f& pt) {
      const std::optional<Eigen::Vector3d> bearing =
          rig.cameras[static_cast<size_t>(c)].Unproject({pt.x, pt.y});
      f.camera.push_back(c);
      f.pixel.emplace_back(pt.x, pt.y);
      f.bearing.push_back(bearing ? bearing->normalized() : Eigen::Vector3d::Zero());
    };
    for (int c = 0; c < n; ++c) {
      const CameraFeatures& cf = per_camera[static_cast<size_t>(c)];
      for (const cv::Point2f& pt : cf.detections) add_2d(c, pt);
      if (!cf.detection_descriptors.empty()) detection_rows.push_back(cf.detection_descriptors);
      f.camera_has_features[static_cast<size_t>(c)] = !cf.detections.empty();
    }
    f.num_detections = static_cast<int>(f.camera.size());
    for (int c = 0; c < n; ++c) {
      const CameraFeatures& cf = per_camera[static_cast<size_t>(c)];
      for (size_t r = 0; r < cf.point_index.size(); ++r) {
        const LoopKeyframe::Point& p = keyframe.points[static_cast<size_t>(cf.point_index[r])];
        add_2d(c, cv::Point2f(static_cast<float>(p.pixel.x()), static_cast<float>(p.pixel.y())));
        f.landmark_id.push_back(p.landmark_id);
        f.landmark_point.push_back(p.point_in_world);
      }
      if (!cf.point_descriptors.empty()) point_rows.push_back(cf.point_descriptors);
    }
    std::vector<cv::Mat> link_point_rows;
    for (int c = 0; c < n; ++c) {
      const CameraFeatures& cf = per_camera[static_cast<size_t>(c)];
      for (int k : cf.link_point_index) {
        const LoopKeyframe::Point& p = keyframe.points[static_cast<size_t>(k)];
        f.link.camera.push_back(c);
        f.link.pixel.push_back(p.pixel);
        f.link.landmark_id.push_back(p.landmark_id);
        f.link.point_in_world.push_back(p.point_in_world);
      }
      if (!cf.link_point_descriptors.empty()) link_point_rows.push_back(cf.link_point_descriptors);
    }
    if (!link_point_rows.empty()) cv::vconcat(link_point_rows, f.link.descriptors);
    cv::Mat detections, points;
    if (!detection_rows.empty()) cv::vconcat(detection_rows, detections);
    if (!point_rows.empty()) cv::vconcat(point_rows, points);
    f.landmark_descriptors = points;
    if (detections.empty()) {
      f.descriptors = points;
    } else if (points.empty()) {
      f.descriptors = detections;
    } else {
      cv::vconcat(detections, points, f.descriptors);
    }
    return f;
  }

  // Keyframes (older than the exclusion) by BoW score, best first, at least min_score.
  std::vector<std::pair<int, double>> Query(const BowVector& bow, int query) const {
    const int last = query - options.exclude_recent_keyframes - 1;
    std::vector<std::pair<int, double>> out;
    if (last < 0) return out;
    std::vector<double> sums(static_cast<size_t>(last) + 1, 0.0);
    for (const auto& [word, q] : bow) {
      auto it = inverted.find(word);
      if (it == inverted.end()) continue;
      for (const auto& [kf, b] : it->second) {
        if (kf > last) break;
        sums[static_cast<size_t>(kf)] += q + b - std::abs(q - b);
      }
    }
    for (int kf = 0; kf <= last; ++kf) {
      const double score = 0.5 * sums[static_cast<size_t>(kf)];
      if (score >= options.min_score) out.emplace_back(kf, score);
    }
    std::stable_sort(out.begin(), out.end(),
                     [](const auto& a, const auto& b) { return a.second > b.second; });
    return out;
  }

  // Geometric verification of one candidate.
  // relocalise: the query is not part of the sequence of the keyframes
  // (Relocalise): every neighbour of the candidate may lend its landmarks
  // and the drift plausibility test does not apply (the odometry between
  // the two is unknown).
  LoopAttempt Verify(const Features& query, int query_index, const LoopKeyframe& keyframe, int candidate,
                     double score, bool relocalise = false) const {
    LoopAttempt attempt;
    attempt.query = query_index;
    attempt.candidate = candidate;
    attempt.query_frame = keyframe.frame_index;
    attempt.candidate_frame = entries[static_cast<size_t>(candidate)].frame_index;
    attempt.score = score;
    // The candidate's landmarks and its neighbours', one per landmark id
    // (the candidate's own first).
    std::vector<int> keyframes{candidate};
    for (int d = 1; d <= options.candidate_neighbours; ++d) {
      if (candidate - d >= 0) keyframes.push_back(candidate - d);
      if (candidate + d < static_cast<int>(entries.size()) &&
          (relocalise || candidate + d < query_index - options.exclude_recent_keyframes)) {
        keyframes.push_back(candidate + d);
      }
    }
    // A landmark's rows (one per descriptor level) come from the first of
    // these keyframes that has it.
    std::map<int64_t, int> first_keyframe;
    std::vector<Eigen::Vector3d> points;
    std::vector<int64_t> row_landmark;
    std::vector<size_t> landmark_row;  // per row: the landmark's first row (its key below)
    std::map<int64_t, size_t> first_row;
    std::vector<cv::Mat> rows;
    for (int kf : keyframes) {
      const Entry& e = entries[static_cast<size_t>(kf)];
      for (size_t k = 0; k < e.landmark_id.size(); ++k) {
        if (first_keyframe.emplace(e.landmark_id[k], kf).first->second != kf) continue;
        points.push_back(e.landmark_point[k]);
        row_landmark.push_back(e.landmark_id[k]);
        landmark_row.push_back(first_row.emplace(e.landmark_id[k], rows.size()).first->second);
        rows.push_back(e.landmark_descriptors.row(static_cast<int>(k)));
      }
    }
    // Query features -> best landmark by Hamming distance with the ratio
    // test (OpenCV's brute-force matcher: each query row independently, so
    // the result does not depend on its threads); a landmark keeps its best
    // query feature.
    std::map<size_t, std::pair<int, int>> best_for_landmark;  // landmark -> (distance, query feature)
    if (rows.size() >= 2 && query.descriptors.rows > 0) {
      cv::Mat train;
      cv::vconcat(rows, train);
      // The ratio test compares with the nearest row of another landmark
      // (a landmark has landmark_levels rows).
      const std::vector<std::vector<cv::DMatch>> knn =
          HammingKnnMatch(query.descriptors, train, options.landmark_levels + 1, threads);
      for (const std::vector<cv::DMatch>& m : knn) {
        if (m.size() < 2) continue;
        const int q = m[0].queryIdx;
        if (query.bearing[static_cast<size_t>(q)].squaredNorm() == 0.0) continue;
        size_t other = 1;
        while (other < m.size() && row_landmark[static_cast<size_t>(m[other].trainIdx)] ==
                                       row_landmark[static_cast<size_t>(m[0].trainIdx)]) {
          ++other;
        }
        if (other == m.size()) continue;
        const int best = static_cast<int>(m[0].distance), second = static_cast<int>(m[other].distance);
        if (best > options.max_match_distance || best >= options.match_ratio * second) continue;
        const size_t landmark = landmark_row[static_cast<size_t>(m[0].trainIdx)];
        auto it = best_for_landmark.find(landmark);
        if (it == best_for_landmark.end() || best < it->second.first) best_for_landmark[landmark] = {best, q};
      }
    }
    std::vector<RigPnpCorrespondence> correspondences;
    std::vector<LoopAttempt::Match> matches;  // per correspondence
    correspondences.reserve(best_for_landmark.size());
    for (const auto& [landmark, match] : best_for_landmark) {
      const size_t q = static_cast<size_t>(match.second);
      correspondences.push_back({query.camera[q], query.bearing[q], points[landmark]});
      LoopAttempt::Match m;
      m.camera = query.camera[q];
      m.pixel = query.pixel[q];
      m.landmark_id = row_landmark[landmark];
      if (q >= static_cast<size_t>(query.num_detections)) {
        m.query_landmark_id = query.landmark_id[q - static_cast<size_t>(query.num_detections)];
      }
      matches.push_back(m);
    }
    attempt.matches = static_cast<int>(correspondences.size());
    if (attempt.matches < options.min_inliers) {
      attempt.reason = StrCat(attempt.matches, " matches < ", options.min_inliers);
      return attempt;
    }
    RigPnpOptions pnp_options;
    pnp_options.threshold_px = options.pnp_threshold_px;
    pnp_options.focal_px = kFocalPx;
    pnp_options.max_iterations = options.pnp_max_iterations;
    pnp_options.min_inliers = options.min_inliers;
    const RigPnpResult pnp = SolveRigPnp(cam_from_rig, correspondences, pnp_options);
    attempt.inliers = pnp.num_inliers;
    int cameras_with_features = 0;
    for (size_t c = 0; c < query.camera_has_features.size(); ++c) {
      cameras_with_features += query.camera_has_features[c] ? 1 : 0;
      if (c < pnp.inliers_per_camera.size() && pnp.inliers_per_camera[c] >= options.min_camera_inliers) {
        ++attempt.cameras_with_inliers;
      }
    }
    if (!pnp.ok) {
      attempt.reason = StrCat("rig pose: ", pnp.reason);
      return attempt;
    }
    const int needed =
        std::max(1, static_cast<int>(std::ceil(options.min_camera_fraction * cameras_with_features - 1e-9)));
    if (attempt.cameras_with_inliers < needed) {
      attempt.reason = StrCat(attempt.cameras_with_inliers, " camera(s) with >= ", options.min_camera_inliers,
                              " inliers < ", needed);
      return attempt;
    }
    const Rigid3d& world_from_candidate = entries[static_cast<size_t>(candidate)].world_from_rig;
    attempt.candidate_from_query = world_from_candidate.Inverse() * pnp.world_from_rig;
    for (size_t k = 0; k < matches.size(); ++k) {
      if (pnp.inliers[k]) attempt.inlier_matches.push_back(matches[k]);
    }
    if (relocalise) {
      attempt.verified = true;
      return attempt;
    }
    const Rigid3d odometry = world_from_candidate.Inverse() * keyframe.world_from_rig;
    const Rigid3d delta = odometry.Inverse() * attempt.candidate_from_query;
    attempt.correction_m = delta.translation.norm();
    attempt.correction_deg = delta.rotation.angularDistance(Eigen::Quaterniond::Identity()) * kRadToDeg;
    const double path_m =
        (entries.empty() ? 0.0 : entries.back().path_m) +
        (entries.empty()
             ? 0.0
             : (keyframe.world_from_rig.translation - entries.back().world_from_rig.translation).norm()) -
        entries[static_cast<size_t>(candidate)].path_m;
    const double max_correction = options.max_correction_fraction * path_m + options.max_correction_floor_m;
    if (!(attempt.correction_m <= max_correction)) {
      attempt.reason = StrCat("implausible: the loop implies a correction of ",
                              FormatFixed(attempt.correction_m, 2), " m after ", FormatFixed(path_m, 1),
                              " m of odometry (at most ", FormatFixed(max_correction, 2), " m)");
      return attempt;
    }
    attempt.verified = true;
    return attempt;
  }

  bool Consistent(int query, int candidate) const {
    for (auto it = verified.rbegin(); it != verified.rend(); ++it) {
      const int dq = query - it->first;
      if (dq <= 0) continue;
      if (dq > options.consistency_window) break;
      if (std::abs((candidate - it->second) - dq) <= options.consistency_window) return true;
    }
    return false;
  }

  // A keyframe's features and its bag of words (pure: any thread).
  struct Prepared {
    Features features;
    BowVector bow;
  };

  // image_features: extracted ahead (ExtractImageFeatures) for this
  // keyframe's points, or null to extract them from its images.
  Prepared Prepare(const LoopKeyframe& keyframe, int camera_threads,
                   const LoopImageFeatures* image_features = nullptr) const {
    Prepared p;
    p.features = image_features != nullptr ? Assemble(keyframe, *image_features) : Extract(keyframe, camera_threads);
    p.bow = vocabulary.Transform(DetectionDescriptors(p.features));
    return p;
  }

  std::vector<LoopAttempt> AddKeyframe(const LoopKeyframe& keyframe) {
    const auto start = std::chrono::steady_clock::now();
    const Prepared prepared = Prepare(keyframe, threads);
    timing.features_s += Seconds(start);
    return AddPrepared(keyframe, prepared.features, prepared.bow);
  }

  // Batches of keyframes: their inputs and features in parallel (one
  // keyframe per thread), then each added in order. A batch holds its
  // keyframes' images only until their features are extracted.
  std::vector<LoopAttempt> AddKeyframes(int count, const std::function<LoopKeyframe(int)>& keyframe_at,
                                        const LoopCloser::ImageFeaturesAt& image_features_at) {
    std::vector<LoopAttempt> all;
    const int batch = 8 * threads;
    for (int begin = 0; begin < count; begin += batch) {
      const int n = std::min(batch, count - begin);
      std::vector<LoopKeyframe> keyframes(static_cast<size_t>(n));
      std::vector<Prepared> prepared(static_cast<size_t>(n));
      std::vector<double> input_s(static_cast<size_t>(n), 0.0), prepare_s(static_cast<size_t>(n), 0.0);
      const auto start = std::chrono::steady_clock::now();
      ParallelFor(n, threads, [&](int i) {
        auto step = std::chrono::steady_clock::now();
        LoopKeyframe& keyframe = keyframes[static_cast<size_t>(i)];
        keyframe = keyframe_at(begin + i);
        const std::shared_ptr<const LoopImageFeatures> ahead =
            image_features_at ? image_features_at(begin + i) : nullptr;
        input_s[static_cast<size_t>(i)] = Seconds(step);
        step = std::chrono::steady_clock::now();
        prepared[static_cast<size_t>(i)] = Prepare(keyframe, 1, ahead.get());
        prepare_s[static_cast<size_t>(i)] = Seconds(step);
        keyframe.images.clear();
      });
      // The batch's wall time, split between input and features in the
      // proportion of their thread time.
      const double wall = Seconds(start);
      double input_sum = 0.0, prepare_sum = 0.0;
      for (int i = 0; i < n; ++i) {
        input_sum += input_s[static_cast<size_t>(i)];
        prepare_sum += prepare_s[static_cast<size_t>(i)];
      }
      const double input_share = input_sum + prepare_sum > 0.0 ? input_sum / (input_sum + prepare_sum) : 0.0;
      timing.input_s += wall * input_share;
      timing.features_s += wall * (1.0 - input_share);
      for (int i = 0; i < n; ++i) {
        const Prepared& p = prepared[static_cast<size_t>(i)];
        std::vector<LoopAttempt> attempts = AddPrepared(keyframes[static_cast<size_t>(i)], p.features, p.bow);
        for (LoopAttempt& a : attempts) all.push_back(std::move(a));
      }
    }
    return all;
  }

  std::vector<LoopAttempt> AddPrepared(const LoopKeyframe& keyframe, const Features& features,
                                       const BowVector& bow) {
    const int index = static_cast<int>(entries.size());
    auto start = std::chrono::steady_clock::now();
    std::vector<std::pair<int, double>> candidates = Query(bow, index);
    // DBoW2's normalisation: the score over the query's score with the
    // previous keyframe (a place seen again should look about as similar as
    // the view a moment ago); places that merely share generic words do not.
    const double previous_score = previous_bow.empty() ? 0.0 : BowScore(bow, previous_bow);
    std::vector<double> normalized;
    for (auto it = candidates.begin(); it != candidates.end();) {
      const double n = previous_score > 0.0 ? it->second / previous_score : 0.0;
      if (n < options.min_normalized_score) {
        it = candidates.erase(it);
      } else {
        normalized.push_back(n);
        ++it;
      }
    }
    previous_bow = bow;
    timing.query_s += Seconds(start);

    start = std::chrono::steady_clock::now();
    std::vector<LoopAttempt> attempts;
    bool accepted = false;
    for (size_t k = 0; k < candidates.size() && static_cast<int>(k) < options.max_candidates; ++k) {
      LoopAttempt attempt = Verify(features, index, keyframe, candidates[k].first, candidates[k].second);
      attempt.normalized_score = normalized[k];
      if (attempt.verified) {
        if (accepted) {
          attempt.reason = "another candidate of this keyframe was accepted";
        } else if (Consistent(index, attempt.candidate)) {
          attempt.accepted = true;
          accepted = true;
        } else {
          attempt.reason = StrCat("not yet consistent: no verified loop to nearby keyframes in the last ",
                                  options.consistency_window, " keyframes");
        }
      }
      attempts.push_back(std::move(attempt));
    }
    for (const LoopAttempt& a : attempts) {
      if (a.verified) verified.emplace_back(a.query, a.candidate);
    }
    timing.verification_s += Seconds(start);
    Insert(keyframe, features, bow);
    return attempts;
  }

  void Insert(const LoopKeyframe& keyframe, const Features& features, const BowVector& bow) {
    const int index = static_cast<int>(entries.size());
    Entry entry;
    entry.frame_index = keyframe.frame_index;
    entry.world_from_rig = keyframe.world_from_rig;
    if (!entries.empty()) {
      entry.path_m = entries.back().path_m +
                     (keyframe.world_from_rig.translation - entries.back().world_from_rig.translation).norm();
    }
    entry.landmark_id = features.landmark_id;
    entry.landmark_point = features.landmark_point;
    entry.landmark_descriptors = features.landmark_descriptors;
    entry.link = features.link;
    entry.link.frame_index = keyframe.frame_index;
    entry.link.world_from_rig = keyframe.world_from_rig;
    entries.push_back(std::move(entry));
    for (const auto& [word, weight] : bow) inverted[word].emplace_back(index, weight);
  }

  // The ORB detections' descriptors (the BoW's words): none when the images
  // gave no detection (a blank view; rowRange of an empty matrix throws).
  static cv::Mat DetectionDescriptors(const Features& features) {
    if (features.num_detections <= 0 || features.descriptors.empty()) return cv::Mat();
    return features.descriptors.rowRange(0, features.num_detections);
  }

  void CheckImages(const LoopKeyframe& keyframe) const {
    MCVO_CHECK_MSG(static_cast<int>(keyframe.images.size()) == rig.NumCameras(), "keyframe ",
                   keyframe.frame_index, " has ", keyframe.images.size(), " images, the rig ",
                   rig.NumCameras());
  }

  void AddMapKeyframe(const LoopKeyframe& keyframe) {
    CheckImages(keyframe);
    const auto start = std::chrono::steady_clock::now();
    const Features features = Extract(keyframe, threads);
    const BowVector bow = vocabulary.Transform(DetectionDescriptors(features));
    timing.features_s += Seconds(start);
    Insert(keyframe, features, bow);
    previous_bow = bow;
  }

  std::vector<LoopAttempt> Relocalise(const LoopKeyframe& keyframe, int max_candidates) {
    CheckImages(keyframe);
    auto start = std::chrono::steady_clock::now();
    const Features features = Extract(keyframe, threads);
    const BowVector bow = vocabulary.Transform(DetectionDescriptors(features));
    timing.features_s += Seconds(start);
    start = std::chrono::steady_clock::now();
    // Every keyframe of the map by BoW score (no recency exclusion, no
    // score floor: the map is the place the rig just was), best first.
    std::vector<double> sums(entries.size(), 0.0);
    for (const auto& [word, q] : bow) {
      auto it = inverted.find(word);
      if (it == inverted.end()) continue;
      for (const auto& [kf, b] : it->second) sums[static_cast<size_t>(kf)] += q + b - std::abs(q - b);
    }
    std::vector<std::pair<int, double>> candidates;
    for (size_t kf = 0; kf < sums.size(); ++kf) {
      if (sums[kf] > 0.0) candidates.emplace_back(static_cast<int>(kf), 0.5 * sums[kf]);
    }
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const auto& a, const auto& b) { return a.second > b.second; });
    timing.query_s += Seconds(start);
    start = std::chrono::steady_clock::now();
    std::vector<LoopAttempt> attempts;
    const int query_index = static_cast<int>(entries.size());
    for (size_t k = 0; k < candidates.size() && static_cast<int>(k) < max_candidates; ++k) {
      LoopAttempt attempt =
          Verify(features, query_index, keyframe, candidates[k].first, candidates[k].second, true);
      attempt.accepted = attempt.verified;
      attempts.push_back(std::move(attempt));
    }
    timing.verification_s += Seconds(start);
    return attempts;
  }
};

LoopCloser::LoopCloser(const Rig& rig, std::vector<cv::Mat> masks, Vocabulary vocabulary,
                       const LoopClosureOptions& options, int threads)
    : impl_(std::make_unique<Impl>(rig, std::move(masks), std::move(vocabulary), options, threads)) {}
LoopCloser::~LoopCloser() = default;

std::vector<LoopAttempt> LoopCloser::AddKeyframe(const LoopKeyframe& keyframe) {
  return impl_->AddKeyframe(keyframe);
}

std::vector<LoopAttempt> LoopCloser::AddKeyframes(int count,
                                                  const std::function<LoopKeyframe(int)>& keyframe_at,
                                                  const ImageFeaturesAt& image_features_at) {
  return impl_->AddKeyframes(count, keyframe_at, image_features_at);
}

std::shared_ptr<const LoopImageFeatures> LoopCloser::ExtractImageFeatures(const LoopKeyframe& keyframe,
                                                                          int threads) const {
  return impl_->ExtractImageFeatures(keyframe, std::max(1, threads));
}

bool LoopCloser::ImageFeaturesFit(const LoopImageFeatures& features, const LoopKeyframe& keyframe) {
  return features.Fits(keyframe);
}

size_t LoopCloser::ImageFeaturesBytes(const LoopImageFeatures& features) { return features.Bytes(); }

void LoopCloser::AddMapKeyframe(const LoopKeyframe& keyframe) { impl_->AddMapKeyframe(keyframe); }

std::vector<LoopAttempt> LoopCloser::Relocalise(const LoopKeyframe& query, int max_candidates) {
  return impl_->Relocalise(query, max_candidates);
}

std::vector<CrossCameraLink> LoopCloser::CrossCameraLinks(const std::vector<std::pair<int, int>>& overlapping) {
  const Impl& impl = *impl_;
  if (impl.options.cross_camera.window_keyframes <= 0) return {};
  const auto start = std::chrono::steady_clock::now();
  std::vector<LinkKeyframe> keyframes;
  keyframes.reserve(impl.entries.size());
  for (const Impl::Entry& e : impl.entries) keyframes.push_back(e.link);
  std::vector<CrossCameraLink> links =
      FindCrossCameraLinks(impl.rig, keyframes, impl.options.cross_camera, impl.threads, overlapping);
  impl_->timing.cross_camera_s += Seconds(start);
  return links;
}

int LoopCloser::num_keyframes() const { return static_cast<int>(impl_->entries.size()); }

const LoopTiming& LoopCloser::timing() const { return impl_->timing; }

}  // namespace mcvo
