// LoopCloser on keyframes whose images give no ORB detection at all (a rig
// facing a blank wall): every entry point takes them without an error, and
// the database stays usable for textured keyframes after them.
#include "mcvo/loop/loop_closer.h"

#include <gtest/gtest.h>

#include <vector>

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

}  // namespace
}  // namespace mcvo
