// Photometric effects and option checks of the renderer (renderer.h):
// exposure instants for motion blur, per-camera gain, vignetting, and the
// counter-based hash that seeds every random draw of the renderer.
#include <algorithm>
#include <cmath>
#include <string>

#include "mcvo/synth/renderer.h"

#include "mcvo/util/error.h"
#include "mcvo/util/hash.h"

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

double VignettingFalloff(double angle_rad) {
  const double c = std::cos(std::min(std::abs(angle_rad), 0.5 * M_PI));
  return std::max(0.3, c * c * c * c);
}

}  // namespace mcvo::synth
