// Texture gate of new features (the reasons and the measure: texture_gate.h).
#include "texture_gate.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "mcvo/util/error.h"

namespace mcvo::internal {

double EstimateNoiseSigma(const cv::Mat& image) {
  MCVO_CHECK(image.type() == CV_8UC1);
  if (image.rows < 3 || image.cols < 3) return 0.0;
  std::vector<int> samples;
  samples.reserve(static_cast<size_t>((image.rows / 2) * (image.cols / 2)));
  for (int y = 1; y + 1 < image.rows; y += 2) {
    const uint8_t* a = image.ptr<uint8_t>(y - 1);
    const uint8_t* b = image.ptr<uint8_t>(y);
    const uint8_t* c = image.ptr<uint8_t>(y + 1);
    for (int x = 1; x + 1 < image.cols; x += 2) {
      const int v = (a[x - 1] - 2 * a[x] + a[x + 1]) - 2 * (b[x - 1] - 2 * b[x] + b[x + 1]) +
                    (c[x - 1] - 2 * c[x] + c[x + 1]);
      if (v != 0) samples.push_back(std::abs(v));
    }
  }
  if (samples.empty()) return 0.0;
  const auto mid = samples.begin() + static_cast<std::ptrdiff_t>(samples.size() / 2);
  std::nth_element(samples.begin(), mid, samples.end());
  return static_cast<double>(*mid) / (0.6745 * 6.0);
}

TextureGate::TextureGate(const cv::Mat& image, int half_window) : half_window_(std::max(1, half_window)) {
  MCVO_CHECK(image.type() == CV_8UC1);
  cv::Sobel(image, gx_, CV_16S, 1, 0, 3, 1.0, 0.0, cv::BORDER_REFLECT_101);
  cv::Sobel(image, gy_, CV_16S, 0, 1, 3, 1.0, 0.0, cv::BORDER_REFLECT_101);
  noise_sigma_ = EstimateNoiseSigma(image);
}

double TextureGate::Strength(const Eigen::Vector2f& pixel) const {
  const int cx = std::clamp(static_cast<int>(std::lround(pixel.x())), 0, gx_.cols - 1);
  const int cy = std::clamp(static_cast<int>(std::lround(pixel.y())), 0, gx_.rows - 1);
  const int x0 = std::max(0, cx - half_window_), x1 = std::min(gx_.cols - 1, cx + half_window_);
  const int y0 = std::max(0, cy - half_window_), y1 = std::min(gx_.rows - 1, cy + half_window_);
  int64_t sxx = 0, sxy = 0, syy = 0;
  for (int y = y0; y <= y1; ++y) {
    const int16_t* px = gx_.ptr<int16_t>(y);
    const int16_t* py = gy_.ptr<int16_t>(y);
    for (int x = x0; x <= x1; ++x) {
      const int64_t gx = px[x], gy = py[x];
      sxx += gx * gx;
      sxy += gx * gy;
      syy += gy * gy;
    }
  }
  // Mean over the window, Sobel / 8 (grey levels per pixel): / (64 n).
  const double n = 64.0 * static_cast<double>((x1 - x0 + 1) * (y1 - y0 + 1));
  const double a = static_cast<double>(sxx) / n, b = static_cast<double>(sxy) / n,
               d = static_cast<double>(syy) / n;
  const double smaller = 0.5 * (a + d) - std::sqrt(0.25 * (a - d) * (a - d) + b * b);
  return std::sqrt(std::max(0.0, smaller));
}

double TextureGate::Threshold(double min_gradient, double noise_factor) const {
  constexpr double kNoiseStrengthPerSigma = 0.433;  // sqrt(12) / 8
  return std::max(min_gradient, noise_factor * kNoiseStrengthPerSigma * noise_sigma_);
}

}  // namespace mcvo::internal
