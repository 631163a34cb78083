// Photometric effects and option checks of the renderer (renderer.h):
// exposure instants for motion blur, per-camera gain, vignetting, the tone
// curve and the lens blur.
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include "mcvo/synth/renderer.h"

#include "mcvo/util/error.h"
#include "mcvo/util/hash.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/strings.h"

namespace mcvo::synth {
namespace {

[[noreturn]] void Bad(const std::string& field, const std::string& what) {
  throw UsageError(StrCat(field, ": ", what));
}

}  // namespace

void RenderEffects::Check() const {
  if (!std::isfinite(noise_sigma) || noise_sigma < 0.0)
    Bad("noise_sigma", StrCat("must be >= 0, got ", noise_sigma));
  if (noise_sigma > 255.0) Bad("noise_sigma", StrCat("must be <= 255 grey levels, got ", noise_sigma));
  if (!std::isfinite(sensor_noise_a) || sensor_noise_a < 0.0 || sensor_noise_a > 64.0)
    Bad("sensor_noise_a", StrCat("must be in [0, 64] grey levels, got ", sensor_noise_a));
  if (!std::isfinite(sensor_noise_b) || sensor_noise_b < 0.0 || sensor_noise_b > 4096.0)
    Bad("sensor_noise_b", StrCat("must be in [0, 4096] grey levels^2, got ", sensor_noise_b));
  if (HasSensorNoise() && noise_sigma > 0.0)
    Bad("sensor_noise_a", "the sensor noise model and noise_sigma exclude each other; give one");
  if (!std::isfinite(lens_blur_sigma_px) || lens_blur_sigma_px < 0.0 || lens_blur_sigma_px > 20.0)
    Bad("lens_blur_sigma_px", StrCat("must be in [0, 20] px, got ", lens_blur_sigma_px));
  if (!std::isfinite(tone_gain) || tone_gain <= 0.0 || tone_gain > 16.0)
    Bad("tone_gain", StrCat("must be in (0, 16], got ", tone_gain));
  if (!std::isfinite(tone_gamma) || tone_gamma < 0.1 || tone_gamma > 10.0)
    Bad("tone_gamma", StrCat("must be in [0.1, 10], got ", tone_gamma));
  if (motion_blur_samples < 0 || motion_blur_samples > 64) {
    Bad("motion_blur_samples", StrCat("must be in [0, 64], got ", motion_blur_samples));
  }
  if (!std::isfinite(exposure_time_s) || exposure_time_s <= 0.0 || exposure_time_s > 1.0) {
    Bad("exposure_time_s", StrCat("must be in (0, 1] seconds, got ", exposure_time_s));
  }
  if (blackout_camera < kBlackoutAllCameras)
    Bad("blackout_camera", StrCat("must be -1 (none), -2 (all) or a camera index, got ", blackout_camera));
  if (blackout_first_frame < 0)
    Bad("blackout_first_frame", StrCat("must be >= 0, got ", blackout_first_frame));
  if (blackout_num_frames < 0) Bad("blackout_num_frames", StrCat("must be >= 0, got ", blackout_num_frames));
}

void RenderOptions::Check() const {
  if (samples_per_axis < 1 || samples_per_axis > 8) {
    Bad("samples_per_axis", StrCat("must be in [1, 8], got ", samples_per_axis));
  }
  if (!std::isfinite(max_distance_m) || max_distance_m <= 0.0) {
    Bad("max_distance_m", StrCat("must be > 0, got ", max_distance_m));
  }
  if (threads < 0) Bad("threads", StrCat("must be >= 0 (0: all hardware threads), got ", threads));
  try {
    effects.Check();
  } catch (const UsageError& error) {
    throw UsageError(StrCat("effects.", error.what()));
  }
}

Eigen::Vector3d SunDirection() { return Eigen::Vector3d(-0.40, 0.52, 0.75).normalized(); }

std::vector<int64_t> ExposureInstants(int64_t t_ns, const RenderEffects& effects) {
  const int count = effects.motion_blur_samples;
  if (count <= 1) return {t_ns};
  const double exposure_ns = effects.exposure_time_s * 1e9;
  std::vector<int64_t> instants(count);
  for (int k = 0; k < count; ++k) {
    instants[k] = t_ns + std::llround(exposure_ns * ((k + 0.5) / count - 0.5));
  }
  return instants;
}

double ExposureGain(const RenderEffects& effects, uint64_t seed, int camera_index, int64_t t_ns) {
  if (!effects.exposure_changes) return 1.0;
  constexpr double kAmplitudes[3] = {0.55, 0.30, 0.15};  // sum 1: gain in [0.7, 1.3]
  constexpr double kPeriodsS[3] = {6.7, 2.3, 17.0};
  const double t_s = static_cast<double>(t_ns) * 1e-9;
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    const uint64_t key = HashWords(
        {seed, 0x65787030ULL /*"exp0"*/, static_cast<uint64_t>(camera_index), static_cast<uint64_t>(k)});
    const double phase = 2.0 * M_PI * OpenUnitFromHash(key);
    sum += kAmplitudes[k] * std::sin(2.0 * M_PI * t_s / kPeriodsS[k] + phase);
  }
  return 1.0 + 0.3 * sum;
}

namespace {

// "X:Y" as two numbers; UsageError naming the flag otherwise.
std::pair<double, double> ParsePair(const std::string& text, const std::string& flag,
                                    const std::string& form) {
  const std::vector<std::string_view> parts = SplitFields(text, ':');
  const auto x = parts.size() == 2 ? ParseDouble(parts[0]) : std::nullopt;
  const auto y = parts.size() == 2 ? ParseDouble(parts[1]) : std::nullopt;
  if (!x || !y) throw UsageError(flag + ": expected " + form + ", got '" + text + "'");
  return {*x, *y};
}

}  // namespace

void ParseSensorNoise(const std::string& text, RenderEffects* effects) {
  std::tie(effects->sensor_noise_a, effects->sensor_noise_b) =
      ParsePair(text, "--sensor-noise", "A:B (e.g. 0.033:0)");
}

void ParseTone(const std::string& text, RenderEffects* effects) {
  std::tie(effects->tone_gain, effects->tone_gamma) = ParsePair(text, "--tone", "GAIN:GAMMA (e.g. 1.5:1.5)");
}

double ToneCurve(const RenderEffects& effects, double value) {
  const double x = std::clamp(effects.tone_gain * value / 255.0, 0.0, 1.0);
  return 255.0 * std::pow(x, effects.tone_gamma);
}

void LensBlur(double sigma_px, int width, int height, int threads, std::vector<double>* image) {
  if (!(sigma_px > 0.0) || width <= 0 || height <= 0) return;
  MCVO_CHECK(image->size() == static_cast<size_t>(width) * height);
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma_px)));
  std::vector<double> kernel(2 * radius + 1);
  double total = 0.0;
  for (int k = -radius; k <= radius; ++k)
    total += kernel[k + radius] = std::exp(-0.5 * k * k / (sigma_px * sigma_px));
  for (double& w : kernel) w /= total;
  // Mirror index (..., 2, 1, 0, 1, 2, ...) into [0, n); a kernel wider than
  // the image folds back and forth.
  auto mirror = [](int i, int n) {
    if (n == 1) return 0;
    const int period = 2 * (n - 1);
    i %= period;
    if (i < 0) i += period;
    return i < n ? i : period - i;
  };
  std::vector<double> rows(image->size());
  ParallelFor(height, threads, [&](int y) {
    const double* in = image->data() + static_cast<size_t>(y) * width;
    double* out = rows.data() + static_cast<size_t>(y) * width;
    for (int x = 0; x < width; ++x) {
      double sum = 0.0;
      for (int k = -radius; k <= radius; ++k) sum += kernel[k + radius] * in[mirror(x + k, width)];
      out[x] = sum;
    }
  });
  ParallelFor(height, threads, [&](int y) {
    double* out = image->data() + static_cast<size_t>(y) * width;
    for (int x = 0; x < width; ++x) {
      double sum = 0.0;
      for (int k = -radius; k <= radius; ++k) {
        sum += kernel[k + radius] * rows[static_cast<size_t>(mirror(y + k, height)) * width + x];
      }
      out[x] = sum;
    }
  });
}

double VignettingFalloff(double angle_rad) {
  const double c = std::cos(std::min(std::abs(angle_rad), 0.5 * M_PI));
  return std::max(0.3, c * c * c * c);
}

}  // namespace mcvo::synth
