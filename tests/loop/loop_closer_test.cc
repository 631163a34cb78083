// LoopCloser on keyframes whose images give no ORB detection at all (a rig
// facing a blank wall): every entry point takes them without an error, and
// the database stays usable for textured keyframes after them. And the
// batched AddKeyframes against AddKeyframe one by one.
#include "mcvo/loop/loop_closer.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <opencv2/features2d.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/loop/vocabulary.h"

namespace mcvo {
namespace {

constexpr int kWidth = 320;
constexpr int kHeight = 240;

Rig TwoCameraRig() {
  Rig rig;
  for (int c = 0; c < 2; ++c) {
    Camera camera;
    camera.name = "cam" + std::to_string(c);
    camera.model = CameraModelId::kPinhole;
    camera.params = {250.0, 250.0, kWidth / 2.0, kHeight / 2.0};
    camera.width = kWidth;
    camera.height = kHeight;
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
  for (int k = 3; k < 6; ++k) ASSERT_NO_THROW(closer.AddKeyframe(Keyframe(k, Textured(static_cast<uint64_t>(k)))));
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

LoopKeyframe RouteKeyframe(const Rig& rig, int k) {
  const int place = k % kPlaces;
  LoopKeyframe keyframe = Keyframe(k, Textured(static_cast<uint64_t>(2 * place)));
  keyframe.images[1] = Textured(static_cast<uint64_t>(2 * place + 1));
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

}  // namespace
}  // namespace mcvo
