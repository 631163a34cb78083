// The renderer's camera-realism effects (renderer.h: sensor noise, lens
// blur, tone curve): today's default output is unchanged, the noise model's
// variance is a * v + b, the blur widens edges as its sigma grows, all of
// it deterministic at any thread count.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "camera/test_cameras.h"
#include "mcvo/synth/renderer.h"
#include "mcvo/util/error.h"
#include "synth/street_scene.h"

namespace mcvo::synth {
namespace {

// Camera looking along world +x (rig = world axes): x_cam = -y, y_cam = -z, z_cam = x.
Rig ForwardRig(int width = 320, int height = 240, double f = 250.0) {
  Camera camera = test::MakeCamera("front", CameraModelId::kPinhole,
                                   {f, f, 0.5 * width - 0.5, 0.5 * height - 0.5}, width, height);
  Eigen::Matrix3d cam_from_rig;
  cam_from_rig << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  camera.cam_from_rig = Rigid3d(cam_from_rig, Eigen::Vector3d::Zero());
  Rig rig;
  rig.cameras = {camera};
  return rig;
}

using test::MakeQuad;

// A street along +x (asphalt, two facades, a poster), the sky above: grey
// values from dark to bright.
Scene StreetScene() {
  Scene scene;
  test::AddStreetQuads(&scene);
  scene.Build();
  return scene;
}

// A white disc of radius 350 m on black (kMarker, a 1000 m quad) 10 m
// ahead, its right rim on the optical axis (x = 159.5 px): within the middle
// rows a straight vertical step edge, white on the left, black on the right
// (the rim bends by 0.02 px over +-20 rows).
Scene EdgeScene() {
  Scene scene;
  scene.AddQuad(MakeQuad({10, -150, -498.5}, {0, 1000, 0}, {0, 0, 1000}, Material::kMarker, 7));
  scene.Build();
  return scene;
}

cv::Mat Render(const Scene& scene, const Rig& rig, const RenderOptions& options, int frame = 0) {
  // Driving along +x at 10 m/s (motion blur sees it), at x = 0 at t = 0.
  auto pose = [](int64_t t_ns) {
    return Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(10.0 * t_ns * 1e-9, 0, 1.5));
  };
  return RenderImage(scene, rig, 0, pose, 0, frame, options);
}

uint64_t Fnv1a(const cv::Mat& image) {
  uint64_t h = 1469598103934665603ULL;
  for (int y = 0; y < image.rows; ++y) {
    const uint8_t* row = image.ptr<uint8_t>(y);
    for (int x = 0; x < image.cols; ++x) h = (h ^ row[x]) * 1099511628211ULL;
  }
  return h;
}

bool Identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && a.isContinuous() && b.isContinuous() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

// The hashes of these renders by the renderer before the realism effects
// existed (commit 0013d44), recorded from it: the default output, and the
// older effects, must stay byte-identical (tests and regression baselines
// depend on them).
TEST(SensorEffects, DefaultOutputIsTodays) {
  const Scene scene = StreetScene();
  const Rig rig = ForwardRig(96, 64, 80.0);
  RenderOptions options;
  options.threads = 2;
  const uint64_t plain = Fnv1a(Render(scene, rig, options, 3));
  options.effects.noise_sigma = 2.0;
  options.effects.vignetting = true;
  options.effects.exposure_changes = true;
  options.effects.motion_blur_samples = 3;
  options.seed = 5;
  const uint64_t effects = Fnv1a(Render(scene, rig, options, 3));
  std::printf("hashes: plain %016llx, old effects %016llx\n", static_cast<unsigned long long>(plain),
              static_cast<unsigned long long>(effects));
  EXPECT_EQ(plain, 0xcc8deb0d0f3a21b3ULL);
  EXPECT_EQ(effects, 0x15d9a1e1813bb618ULL);
  // The new effects at their neutral values are not applied at all.
  RenderOptions neutral = options;
  neutral.effects.tone_gain = 1.0;
  neutral.effects.tone_gamma = 1.0;
  neutral.effects.lens_blur_sigma_px = 0.0;
  neutral.effects.sensor_noise_a = neutral.effects.sensor_noise_b = 0.0;
  EXPECT_EQ(Fnv1a(Render(scene, rig, neutral, 3)), effects);
}

// Mean squared difference between noisy and clean renders, over the pixels
// whose clean value lies in [lo, hi], and the mean model variance there.
struct Level {
  double measured = 0.0, model = 0.0, pixels = 0.0;
};
Level NoiseAt(const std::vector<cv::Mat>& noisy, const cv::Mat& clean, int lo, int hi, double a, double b) {
  Level level;
  double sum_sq = 0.0;
  for (const cv::Mat& image : noisy) {
    for (int y = 0; y < clean.rows; ++y) {
      for (int x = 0; x < clean.cols; ++x) {
        const int v = clean.at<uint8_t>(y, x);
        if (v < lo || v > hi) continue;
        const double d = static_cast<double>(image.at<uint8_t>(y, x)) - v;
        sum_sq += d * d;
        level.model += a * v + b;
        level.pixels += 1.0;
      }
    }
  }
  level.measured = sum_sq / level.pixels;
  level.model /= level.pixels;
  return level;
}

TEST(SensorEffects, SensorNoiseVarianceIsAffineInTheSignal) {
  const Scene scene = StreetScene();
  const Rig rig = ForwardRig();
  RenderOptions options;
  const cv::Mat clean = Render(scene, rig, options);
  constexpr double kA = 0.5, kB = 9.0;  // sigma 5.8 at grey 50, 10.4 at grey 200
  options.effects.sensor_noise_a = kA;
  options.effects.sensor_noise_b = kB;
  std::vector<cv::Mat> noisy;
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    options.seed = seed;
    noisy.push_back(Render(scene, rig, options));
  }
  const Level dark = NoiseAt(noisy, clean, 40, 60, kA, kB);
  const Level bright = NoiseAt(noisy, clean, 180, 220, kA, kB);
  std::printf("variance: dark %.2f (model %.2f, %.0f px), bright %.2f (model %.2f, %.0f px)\n", dark.measured,
              dark.model, dark.pixels, bright.measured, bright.model, bright.pixels);
  ASSERT_GT(dark.pixels, 4000.0);
  ASSERT_GT(bright.pixels, 4000.0);
  // Sampling error of a variance from n >= 4000 draws: sqrt(2 / n) <= 2.3 %;
  // rounding to integers adds about 1/12 on average.
  EXPECT_NEAR(dark.measured / dark.model, 1.0, 0.08);
  EXPECT_NEAR(bright.measured / bright.model, 1.0, 0.08);
  const double a = (bright.measured - dark.measured) / (bright.model - dark.model) * kA;
  const double b = dark.measured - a * (dark.model - kB) / kA;
  std::printf("fit through the two levels: a %.3f (%.3f), b %.2f (%.2f)\n", a, kA, b, kB);
  EXPECT_NEAR(a, kA, 0.15 * kA);
  EXPECT_NEAR(b, kB, 4.0);
  // The noise differs between seeds and frames but not between runs.
  options.seed = 1;
  EXPECT_TRUE(Identical(Render(scene, rig, options), noisy[0]));
  EXPECT_FALSE(Identical(Render(scene, rig, options, 1), noisy[0]));
}

// 10-90 % rise of the mean profile of the middle 40 rows across the edge
// of EdgeScene, in px (crossings linearly interpolated between pixels).
double EdgeWidth(const cv::Mat& image) {
  std::vector<double> profile(image.cols, 0.0);
  for (int y = image.rows / 2 - 20; y < image.rows / 2 + 20; ++y) {
    for (int x = 0; x < image.cols; ++x) profile[x] += image.at<uint8_t>(y, x) / 40.0;
  }
  const int c = image.cols / 2;
  double left = 0.0, right = 0.0;
  for (int k = 16; k < 24; ++k) left += profile[c - k] / 8.0, right += profile[c + k] / 8.0;
  auto crossing = [&](double share) {  // where the profile passes left + share (right - left)
    const double level = left + share * (right - left);
    for (int x = c - 16; x < c + 16; ++x) {
      const double p0 = profile[x] - level, p1 = profile[x + 1] - level;
      if ((p0 <= 0.0) != (p1 <= 0.0)) return x + p0 / (p0 - p1);
    }
    return static_cast<double>(c + 16);
  };
  EXPECT_GT(left - right, 100.0);  // the edge is there
  return std::abs(crossing(0.9) - crossing(0.1));
}

TEST(SensorEffects, LensBlurWidensEdgesWithItsSigma) {
  const Scene scene = EdgeScene();
  const Rig rig = ForwardRig();
  RenderOptions options;
  std::vector<double> widths;
  for (double sigma : {0.0, 1.0, 2.0, 3.0}) {
    options.effects.lens_blur_sigma_px = sigma;
    widths.push_back(EdgeWidth(Render(scene, rig, options)));
    // The rise of a 1-px box blurred by a Gaussian of sigma: about 2.56 sqrt(sigma^2 + 1/12) (0.8 px at 0).
    const double model = sigma == 0.0 ? 0.8 : 2.563 * std::sqrt(sigma * sigma + 1.0 / 12.0);
    std::printf("lens blur %.1f px: edge width %.2f px (model %.2f)\n", sigma, widths.back(), model);
    EXPECT_NEAR(widths.back(), model, 0.08 * model + 0.1);
  }
  for (size_t i = 1; i < widths.size(); ++i) EXPECT_GT(widths[i], widths[i - 1] + 1.0);
}

TEST(SensorEffects, LensBlurIsANormalisedGaussian) {
  const int w = 41, h = 31;
  std::vector<double> image(static_cast<size_t>(w) * h, 0.0);
  image[15 * w + 20] = 1.0;
  LensBlur(2.0, w, h, 1, &image);
  double sum = 0.0, second_moment = 0.0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      sum += image[y * w + x];
      second_moment += image[y * w + x] * (x - 20) * (x - 20);
    }
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
  EXPECT_NEAR(second_moment, 4.0, 0.04 * 4.0);  // truncated at 3 sigma: 2.7 % less
  // Mirrored borders keep a constant image constant.
  std::vector<double> flat(static_cast<size_t>(w) * h, 7.0);
  LensBlur(5.0, w, h, 1, &flat);
  for (double v : flat) EXPECT_NEAR(v, 7.0, 1e-12);
  const std::vector<double> before = image;
  LensBlur(0.0, w, h, 1, &image);  // off: unchanged
  EXPECT_EQ(image, before);
}

TEST(SensorEffects, ToneCurveClipsAndStretches) {
  RenderEffects effects;
  effects.tone_gain = 1.5;
  effects.tone_gamma = 1.5;
  EXPECT_DOUBLE_EQ(ToneCurve(effects, 170.0), 255.0);
  EXPECT_DOUBLE_EQ(ToneCurve(effects, 250.0), 255.0);
  EXPECT_NEAR(ToneCurve(effects, 85.0), 255.0 * std::pow(0.5, 1.5), 1e-9);
  EXPECT_DOUBLE_EQ(ToneCurve(effects, 0.0), 0.0);
  EXPECT_FALSE(RenderEffects().HasToneCurve());
  EXPECT_TRUE(effects.HasToneCurve());
}

TEST(SensorEffects, ByteIdenticalForAnyThreadCount) {
  const Scene scene = StreetScene();
  const Rig rig = ForwardRig(160, 120, 125.0);
  RenderOptions options;
  options.effects.sensor_noise_a = 0.033;
  options.effects.lens_blur_sigma_px = 0.9;
  options.effects.tone_gain = 1.5;
  options.effects.tone_gamma = 1.5;
  options.seed = 3;
  options.threads = 1;
  const cv::Mat one = Render(scene, rig, options, 2);
  for (int threads : {2, 3, 7}) {
    options.threads = threads;
    EXPECT_TRUE(Identical(Render(scene, rig, options, 2), one)) << threads;
  }
}

TEST(SensorEffects, OptionsCheckNamesTheBadField) {
  auto message = [](RenderEffects effects) {
    try {
      effects.Check();
    } catch (const UsageError& error) {
      return std::string(error.what());
    }
    return std::string();
  };
  RenderEffects e;
  e.sensor_noise_a = -1.0;
  EXPECT_NE(message(e).find("sensor_noise_a"), std::string::npos);
  e = RenderEffects();
  e.sensor_noise_b = 0.5;
  e.noise_sigma = 1.0;
  EXPECT_NE(message(e).find("exclude"), std::string::npos);
  e = RenderEffects();
  e.lens_blur_sigma_px = -0.1;
  EXPECT_NE(message(e).find("lens_blur_sigma_px"), std::string::npos);
  e = RenderEffects();
  e.tone_gain = 0.0;
  EXPECT_NE(message(e).find("tone_gain"), std::string::npos);
  e = RenderEffects();
  e.tone_gamma = 20.0;
  EXPECT_NE(message(e).find("tone_gamma"), std::string::npos);
  EXPECT_EQ(message(RenderEffects()), "");
}

}  // namespace
}  // namespace mcvo::synth
