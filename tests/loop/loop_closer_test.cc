// LoopCloser on keyframes whose images give no ORB detection at all (a rig
// facing a blank wall): every entry point takes them without an error, and
// the database stays usable for textured keyframes after them. And the
// batched AddKeyframes against AddKeyframe one by one.
#include "mcvo/loop/loop_closer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include <opencv2/features2d.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/loop/vocabulary.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr int kWidth = 320;
constexpr int kHeight = 240;

// upscale: images (and intrinsics) this many times larger.
Rig TwoCameraRig(int upscale = 1) {
  Rig rig;
  for (int c = 0; c < 2; ++c) {
    Camera camera;
    camera.name = "cam" + std::to_string(c);
    camera.model = CameraModelId::kPinhole;
    camera.params = {250.0 * upscale, 250.0 * upscale, kWidth * upscale / 2.0, kHeight * upscale / 2.0};
    camera.width = kWidth * upscale;
    camera.height = kHeight * upscale;
    camera.cam_from_rig = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.5 * c, 0.0, 0.0));
    rig.cameras.push_back(camera);
  }
  return rig;
}

// Random rectangles (fixed seed): plenty of ORB corners.
cv::Mat Textured(uint64_t seed) {
  cv::Mat image(kHeight, kWidth, CV_8UC1, cv::Scalar(100));
  cv::RNG rng(seed);
  for (int k = 0; k < 150; ++k) {
    const cv::Point a(rng.uniform(0, kWidth), rng.uniform(0, kHeight));
    const cv::Point b(a.x + rng.uniform(4, 30), a.y + rng.uniform(4, 30));
    cv::rectangle(image, a, b, cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
  }
  return image;
}

LoopKeyframe Keyframe(int frame_index, const cv::Mat& image) {
  LoopKeyframe keyframe;
  keyframe.frame_index = frame_index;
  keyframe.t_ns = 100000000LL * frame_index;
  keyframe.world_from_rig = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * frame_index, 0, 0));
  keyframe.images = {image.clone(), image.clone()};
  return keyframe;
}

TEST(LoopCloserTest, BlankKeyframesAreTakenWithoutAnError) {
  const Vocabulary vocabulary = Vocabulary::Load(MCVO_SOURCE_DIR "/config/vocabulary_orb.bin");
  const cv::Mat blank(kHeight, kWidth, CV_8UC1, cv::Scalar(128));
  LoopClosureOptions options;
  LoopCloser closer(TwoCameraRig(), {}, vocabulary, options, 1);
  for (int k = 0; k < 3; ++k) {
    std::vector<LoopAttempt> attempts;
    ASSERT_NO_THROW(attempts = closer.AddKeyframe(Keyframe(k, blank)));
    EXPECT_TRUE(attempts.empty());
  }
  for (int k = 3; k < 6; ++k)
    ASSERT_NO_THROW(closer.AddKeyframe(Keyframe(k, Textured(static_cast<uint64_t>(k)))));
  EXPECT_EQ(closer.num_keyframes(), 6);

  // Relocalisation: a blank map keyframe, then a blank query.
  LoopCloser map(TwoCameraRig(), {}, vocabulary, options, 1);
  ASSERT_NO_THROW(map.AddMapKeyframe(Keyframe(0, blank)));
  ASSERT_NO_THROW(map.AddMapKeyframe(Keyframe(1, Textured(1))));
  std::vector<LoopAttempt> attempts;
  ASSERT_NO_THROW(attempts = map.Relocalise(Keyframe(2, blank), 2));
  for (const LoopAttempt& a : attempts) EXPECT_FALSE(a.verified);
}

// A route that passes its places again: keyframe k shows place k % kPlaces
// (a textured image per place and camera) from that place's
// pose, with landmarks at FAST corners of the image, 10 m along their rays.
constexpr int kPlaces = 10;

// upscale: the images enlarged this many times (rig: TwoCameraRig(upscale)).
LoopKeyframe RouteKeyframe(const Rig& rig, int k, int upscale = 1) {
  const int place = k % kPlaces;
  LoopKeyframe keyframe = Keyframe(k, Textured(static_cast<uint64_t>(2 * place)));
  keyframe.images[1] = Textured(static_cast<uint64_t>(2 * place + 1));
  if (upscale > 1) {
    for (cv::Mat& image : keyframe.images) {
      cv::Mat large;
      cv::resize(image, large, cv::Size(), upscale, upscale, cv::INTER_LINEAR);
      image = large;
    }
  }
  keyframe.world_from_rig =
      Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * place, Eigen::Vector3d::UnitZ())),
              Eigen::Vector3d(2.0 * place, 0.5 * place, 0.0));
  for (int c = 0; c < 2; ++c) {
    std::vector<cv::KeyPoint> corners;
    cv::FAST(keyframe.images[static_cast<size_t>(c)], corners, 20);
    cv::KeyPointsFilter::retainBest(corners, 80);
    const Camera& camera = rig.cameras[static_cast<size_t>(c)];
    for (size_t j = 0; j < corners.size(); ++j) {
      const Eigen::Vector2d pixel(corners[j].pt.x, corners[j].pt.y);
      const std::optional<Eigen::Vector3d> ray = camera.Unproject(pixel);
      if (!ray) continue;
      const Eigen::Vector3d in_camera = ray->normalized() * 10.0;
      const Eigen::Vector3d in_world = keyframe.world_from_rig * (camera.cam_from_rig.Inverse() * in_camera);
      keyframe.points.push_back({c, 100000LL * k + 1000 * c + static_cast<int64_t>(j), pixel, in_world});
    }
  }
  return keyframe;
}

void ExpectSameAttempts(const std::vector<LoopAttempt>& a, const std::vector<LoopAttempt>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    SCOPED_TRACE("attempt " + std::to_string(i));
    EXPECT_EQ(a[i].query, b[i].query);
    EXPECT_EQ(a[i].candidate, b[i].candidate);
    EXPECT_EQ(a[i].score, b[i].score);
    EXPECT_EQ(a[i].normalized_score, b[i].normalized_score);
    EXPECT_EQ(a[i].matches, b[i].matches);
    EXPECT_EQ(a[i].inliers, b[i].inliers);
    EXPECT_EQ(a[i].verified, b[i].verified);
    EXPECT_EQ(a[i].accepted, b[i].accepted);
    EXPECT_EQ(a[i].reason, b[i].reason);
    EXPECT_EQ(a[i].inlier_matches.size(), b[i].inlier_matches.size());
    EXPECT_TRUE(a[i].candidate_from_query.translation == b[i].candidate_from_query.translation);
  }
}

// The batched entry point (images read and features extracted a batch of
// keyframes at a time, matching split over threads) gives exactly the
// attempts of AddKeyframe one by one on one thread, over more keyframes
// than one batch holds, and the route's revisits are found.
TEST(LoopCloserTest, AddKeyframesMatchesAddKeyframeOneByOne) {
  const Vocabulary vocabulary = Vocabulary::Load(MCVO_SOURCE_DIR "/config/vocabulary_orb.bin");
  const Rig rig = TwoCameraRig();
  LoopClosureOptions options;
  options.exclude_recent_keyframes = 5;
  options.min_inliers = 20;
  constexpr int kKeyframes = 3 * kPlaces + 7;  // more than one batch at 2 threads (16)

  LoopCloser one(rig, {}, vocabulary, options, 1);
  std::vector<LoopAttempt> expected;
  for (int k = 0; k < kKeyframes; ++k) {
    for (LoopAttempt& a : one.AddKeyframe(RouteKeyframe(rig, k))) expected.push_back(std::move(a));
  }
  int accepted = 0;
  for (const LoopAttempt& a : expected) {
    accepted += a.accepted ? 1 : 0;
    if (a.accepted) {
      EXPECT_EQ(a.query % kPlaces, a.candidate % kPlaces) << a.query << " " << a.candidate;
    }
  }
  EXPECT_GT(accepted, kPlaces);

  for (int threads : {1, 2}) {
    SCOPED_TRACE(std::to_string(threads) + " threads");
    LoopCloser batched(rig, {}, vocabulary, options, threads);
    const std::vector<LoopAttempt> got =
        batched.AddKeyframes(kKeyframes, [&](int k) { return RouteKeyframe(rig, k); });
    ExpectSameAttempts(expected, got);
    EXPECT_EQ(batched.num_keyframes(), kKeyframes);
  }
}

// Image features extracted ahead (ExtractImageFeatures, while the images
// are at hand; pipeline/loop_image_cache.h) stand for the images: the same
// attempts as from the images, for keyframes given without any; they fit
// only a keyframe with the same points' cameras and pixels in order, and
// ids or world points may change in between.
TEST(LoopCloserTest, ImageFeaturesExtractedAheadStandForTheImages) {
  const Vocabulary vocabulary = Vocabulary::Load(MCVO_SOURCE_DIR "/config/vocabulary_orb.bin");
  const Rig rig = TwoCameraRig();
  LoopClosureOptions options;
  options.exclude_recent_keyframes = 5;
  options.min_inliers = 20;
  options.cross_camera.window_keyframes = 4;  // the link descriptors too
  constexpr int kKeyframes = 2 * kPlaces + 5;

  LoopCloser reference(rig, {}, vocabulary, options, 2);
  const std::vector<LoopAttempt> expected =
      reference.AddKeyframes(kKeyframes, [&](int k) { return RouteKeyframe(rig, k); });
  const std::vector<CrossCameraLink> expected_links = reference.CrossCameraLinks({{0, 1}});
  int accepted = 0;
  for (const LoopAttempt& a : expected) accepted += a.accepted ? 1 : 0;
  EXPECT_GT(accepted, 0);

  LoopCloser ahead(rig, {}, vocabulary, options, 2);
  std::vector<std::shared_ptr<const LoopImageFeatures>> features;
  for (int k = 0; k < kKeyframes; ++k) features.push_back(ahead.ExtractImageFeatures(RouteKeyframe(rig, k), 2));
  // Every other keyframe from features (no images), the rest from images.
  const std::vector<LoopAttempt> got = ahead.AddKeyframes(
      kKeyframes,
      [&](int k) {
        LoopKeyframe keyframe = RouteKeyframe(rig, k);
        if (k % 2 == 0) {
          for (cv::Mat& image : keyframe.images) image.release();
        }
        return keyframe;
      },
      [&](int k) { return k % 2 == 0 ? features[static_cast<size_t>(k)] : nullptr; });
  ExpectSameAttempts(expected, got);
  const std::vector<CrossCameraLink> links = ahead.CrossCameraLinks({{0, 1}});
  ASSERT_EQ(links.size(), expected_links.size());
  for (size_t i = 0; i < links.size(); ++i) {
    EXPECT_EQ(links[i].landmark_id, expected_links[i].landmark_id);
    EXPECT_EQ(links[i].source_landmark_id, expected_links[i].source_landmark_id);
  }

  LoopKeyframe keyframe = RouteKeyframe(rig, 3);
  ASSERT_GE(keyframe.points.size(), 2u);
  EXPECT_TRUE(LoopCloser::ImageFeaturesFit(*features[3], keyframe));
  keyframe.points[1].landmark_id += 1000;  // ids and world points may change
  keyframe.points[1].point_in_world.x() += 1.0;
  EXPECT_TRUE(LoopCloser::ImageFeaturesFit(*features[3], keyframe));
  LoopKeyframe moved = keyframe;
  moved.points[1].pixel.x() += 0.5;
  EXPECT_FALSE(LoopCloser::ImageFeaturesFit(*features[3], moved));
  LoopKeyframe other_camera = keyframe;
  other_camera.points[1].camera = 1 - other_camera.points[1].camera;
  EXPECT_FALSE(LoopCloser::ImageFeaturesFit(*features[3], other_camera));
  LoopKeyframe fewer = keyframe;
  fewer.points.pop_back();
  EXPECT_FALSE(LoopCloser::ImageFeaturesFit(*features[3], fewer));
  EXPECT_FALSE(LoopCloser::ImageFeaturesFit(*features[3], RouteKeyframe(rig, 4)));
}

// loop.feature_max_megapixels: images over the bound are described on a
// coarser level, and the features keep full-resolution pixels (the
// verification's bearings and inlier pixels); images within it are
// described exactly as with no bound.
TEST(LoopCloserTest, LargeImagesAreDescribedOnACoarserLevel) {
  const Vocabulary vocabulary = Vocabulary::Load(MCVO_SOURCE_DIR "/config/vocabulary_orb.bin");
  LoopClosureOptions options;
  options.exclude_recent_keyframes = 5;
  options.min_inliers = 20;
  // Oriented landmark descriptors, like the detections': the query's ORB
  // detections then match the candidate's landmarks (upright ones match
  // mostly the query's own landmark pixels, which are full-resolution anyway).
  options.landmark_orientation = true;
  constexpr int kKeyframes = 2 * kPlaces + 5;

  // 640 x 480 (0.31 Mpx) over a bound of 0.1 Mpx: described at 320 x 240.
  const Rig large = TwoCameraRig(2);
  options.feature_max_megapixels = 0.1;
  LoopCloser coarse(large, {}, vocabulary, options, 2);
  const std::vector<LoopAttempt> attempts =
      coarse.AddKeyframes(kKeyframes, [&](int k) { return RouteKeyframe(large, k, 2); });
  int accepted = 0;
  int detection_inliers = 0;
  double largest_x = 0.0, largest_y = 0.0;
  for (const LoopAttempt& a : attempts) {
    if (!a.accepted) continue;
    ++accepted;
    EXPECT_EQ(a.query % kPlaces, a.candidate % kPlaces) << a.query << " " << a.candidate;
    // The same place from the same pose: the loop's relative pose is the identity.
    EXPECT_LT(a.candidate_from_query.translation.norm(), 0.05) << a.query << " " << a.candidate;
    for (const LoopAttempt::Match& m : a.inlier_matches) {
      if (m.query_landmark_id >= 0) continue;  // a landmark pixel: given at full resolution
      ++detection_inliers;
      largest_x = std::max(largest_x, m.pixel.x());
      largest_y = std::max(largest_y, m.pixel.y());
    }
  }
  EXPECT_GT(accepted, kPlaces / 2);
  // ORB detections are inliers at full-resolution pixels, not the coarse level's.
  EXPECT_GT(detection_inliers, 2 * accepted);
  EXPECT_GT(largest_x, 1.5 * kWidth);
  EXPECT_GT(largest_y, 1.5 * kHeight);

  // Within the bound (320 x 240 under 1 Mpx): the same attempts as with none.
  const Rig small = TwoCameraRig();
  options.feature_max_megapixels = 0.0;
  LoopCloser full(small, {}, vocabulary, options, 2);
  const std::vector<LoopAttempt> expected =
      full.AddKeyframes(kKeyframes, [&](int k) { return RouteKeyframe(small, k); });
  options.feature_max_megapixels = 1.0;
  LoopCloser bounded(small, {}, vocabulary, options, 2);
  ExpectSameAttempts(expected,
                     bounded.AddKeyframes(kKeyframes, [&](int k) { return RouteKeyframe(small, k); }));

  options.feature_max_megapixels = -1.0;
  EXPECT_THROW(LoopCloser(small, {}, vocabulary, options, 1), InputError);
}

}  // namespace
}  // namespace mcvo
