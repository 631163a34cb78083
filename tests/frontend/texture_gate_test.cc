// The texture gate of new features (src/frontend/texture_gate.h): the noise
// estimate, the patch strength, and the tracker keeping its new features off
// a blank, vignetted wall that CLAHE stretches into false corners.
#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "../../src/frontend/texture_gate.h"
#include "mcvo/frontend/camera_tracker.h"
#include "mcvo/frontend/detector.h"
#include "mcvo/util/error.h"

namespace mcvo {
namespace {

constexpr int kWidth = 320;
constexpr int kHeight = 160;

// A wall lit unevenly: a smooth falloff from the centre (vignetting), in
// 8 bits (its quantisation steps are the only "texture"), plus Gaussian
// noise of std `noise` (fixed seed); with `board`, a checkerboard (squares
// of 12 px, 60 and 190) over x < kWidth / 3, under the same noise.
cv::Mat Wall(double noise, uint64_t seed, bool board) {
  cv::Mat wall(kHeight, kWidth, CV_32F);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const double r2 = (std::pow(x - 0.5 * kWidth, 2) + std::pow(y - 0.5 * kHeight, 2)) /
                        (0.25 * kWidth * kWidth);
      wall.at<float>(y, x) = static_cast<float>(90.0 + 40.0 * std::exp(-r2));
      if (board && x < kWidth / 3) wall.at<float>(y, x) = ((x / 12 + y / 12) % 2) ? 190.0f : 60.0f;
    }
  }
  if (noise > 0.0) {
    cv::Mat n(kHeight, kWidth, CV_32F);
    cv::RNG rng(seed);
    rng.fill(n, cv::RNG::NORMAL, 0.0, noise);
    wall += n;
  }
  cv::Mat out;
  wall.convertTo(out, CV_8U);  // rounds and saturates
  return out;
}

cv::Mat BlankWall(double noise, uint64_t seed) { return Wall(noise, seed, false); }
cv::Mat WallWithBoard(double noise, uint64_t seed) { return Wall(noise, seed, true); }

TEST(TextureGateTest, NoiseEstimateFollowsTheNoiseNotTheWall) {
  EXPECT_LT(internal::EstimateNoiseSigma(BlankWall(0.0, 1)), 0.3);
  for (const double sigma : {1.0, 2.0, 4.0}) {
    const double estimate = internal::EstimateNoiseSigma(BlankWall(sigma, 7));
    EXPECT_GT(estimate, 0.8 * sigma) << sigma;
    EXPECT_LT(estimate, 1.2 * sigma) << sigma;
    // A third of the image textured: the median still sees the noise.
    const double with_board = internal::EstimateNoiseSigma(WallWithBoard(sigma, 7));
    EXPECT_GT(with_board, 0.8 * sigma) << sigma;
    EXPECT_LT(with_board, 1.3 * sigma) << sigma;
  }
}

TEST(TextureGateTest, StrengthSeparatesCornersFromEdgesRampsAndNoise) {
  // Noise alone: ~0.43 sigma (the smaller eigenvalue of a noise tensor is a
  // little below the mean).
  const internal::TextureGate noise(BlankWall(2.0, 3), 7);
  double sum = 0.0;
  int n = 0;
  for (int y = 20; y < kHeight - 20; y += 10) {
    for (int x = 150; x < kWidth - 20; x += 10) {
      sum += noise.Strength(Eigen::Vector2f(static_cast<float>(x), static_cast<float>(y)));
      ++n;
    }
  }
  EXPECT_GT(sum / n, 0.5);
  EXPECT_LT(sum / n, 0.9);
  // A vertical step edge and a ramp: gradients in one direction only.
  cv::Mat edge(kHeight, kWidth, CV_8UC1, cv::Scalar(60));
  edge(cv::Rect(kWidth / 2, 0, kWidth / 2, kHeight)).setTo(190);
  cv::Mat ramp(kHeight, kWidth, CV_8UC1);
  for (int x = 0; x < kWidth; ++x) ramp.col(x).setTo(x / 2);
  const Eigen::Vector2f centre(kWidth / 2.0f, kHeight / 2.0f);
  EXPECT_LT(internal::TextureGate(edge, 7).Strength(centre), 1e-9);
  EXPECT_LT(internal::TextureGate(ramp, 7).Strength(centre), 1e-9);
  // A checkerboard corner (contrast 130): tens of grey levels per pixel.
  const internal::TextureGate board(WallWithBoard(0.0, 1), 7);
  EXPECT_GT(board.Strength(Eigen::Vector2f(48.0f, 48.0f)), 10.0);
  // Windows clipped at the border and pixels outside the image are handled.
  EXPECT_GT(board.Strength(Eigen::Vector2f(6.0f, 12.0f)), 1.0);  // window x from -1: corner (12, 12)
  EXPECT_GE(board.Strength(Eigen::Vector2f(-50.0f, 1e6f)), 0.0);
  // The threshold: the floor, or the noise's strength times the factor.
  EXPECT_DOUBLE_EQ(board.Threshold(0.3, 0.0), 0.3);
  EXPECT_NEAR(noise.Threshold(0.0, 1.5), 1.5 * 0.433 * internal::EstimateNoiseSigma(BlankWall(2.0, 3)), 1e-12);
}

// With CLAHE, a blank wall gets corners; the gate keeps every new feature
// on the board, and turns the wall's away.
TEST(TextureGateTest, TrackerPutsNoNewFeatureOnABlankWall) {
  Camera camera;
  camera.name = "cam";
  camera.model = CameraModelId::kPinhole;
  camera.params = {200.0, 200.0, kWidth / 2.0, kHeight / 2.0};
  camera.width = kWidth;
  camera.height = kHeight;
  for (const double noise : {0.0, 2.0}) {
    const cv::Mat image = WallWithBoard(noise, 11);
    int on_wall[2] = {0, 0};
    int untextured[2] = {0, 0};
    for (const bool gate : {false, true}) {
      FrontendOptions options;
      options.detector = DetectorType::kShiTomasi;
      options.clahe.enabled = true;
      options.min_distance_px = 10;
      options.max_features_pinhole = 200;
      options.texture.min_gradient = gate ? 0.3 : 0.0;
      options.texture.noise_factor = gate ? 1.5 : 0.0;
      CameraTracker tracker(camera, cv::Mat(), options, CreateDetector(options));
      const CameraFrameResult result = tracker.Track(image);
      ASSERT_GT(result.features.size(), 20u) << "noise " << noise << " gate " << gate;
      for (const TrackedFeature& f : result.features) {
        if (f.pixel.x() > kWidth / 3.0f + 8.0f) ++on_wall[gate];
      }
      untextured[gate] = result.stats.untextured;
    }
    EXPECT_GT(on_wall[0], 10) << "noise " << noise << ": CLAHE made no corners on the wall (test premise)";
    EXPECT_EQ(on_wall[1], 0) << "noise " << noise;
    EXPECT_EQ(untextured[0], 0);
    EXPECT_GE(untextured[1], on_wall[0]) << "noise " << noise;
  }
}

TEST(TextureGateTest, OptionsAreChecked) {
  const auto error = [](double min_gradient, double noise_factor) -> std::string {
    FrontendOptions options;
    options.texture.min_gradient = min_gradient;
    options.texture.noise_factor = noise_factor;
    try {
      options.Check();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error(0.0, 0.0), "");
  EXPECT_EQ(error(0.3, 1.5), "");
  EXPECT_EQ(error(-0.1, 0.0), "/frontend/texture/min_gradient: must be >= 0, got -0.1");
  EXPECT_EQ(error(0.0, -1.0), "/frontend/texture/noise_factor: must be >= 0, got -1");
}

}  // namespace
}  // namespace mcvo
