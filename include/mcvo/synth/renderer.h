// Ray-casting renderer: every pixel is a ray through its camera's own model
// (Camera::Unproject, any model of the camera module) into the scene, shaded
// with band-limited textures and supersampled, so edges are anti-aliased and
// textures do not flicker. Photometric effects are applied afterwards.
//
// Image formation, per pixel (x, y) of camera c at frame f:
//  1. n x n samples (n = samples_per_axis) at the centres of a stratified
//     grid over the pixel square, (x - 0.5 + (i + 0.5) / n, y - 0.5 + (j + 0.5) / n).
//     The grid is fixed (not jittered), so the bearings of all samples are
//     computed once per camera (Camera::Unproject) and cached; a sample
//     outside the model's domain (outside a fisheye's image circle) has
//     radiance 0, so the circle's rim is anti-aliased as well.
// 1b. Adaptive traversal (RenderOptions::adaptive_supersampling, n > 1):
//     first one ray through each pixel centre; where it and the centre rays
//     of the 8 neighbouring pixels all hit the same static quad (or all the
//     sky), and the whole pixel is inside the domain, the pixel holds no
//     geometric edge, and its n x n samples are intersected with that quad's
//     plane directly (or shaded as sky) instead of traversing the scene:
//     the same hit points, footprints and shading as casting them. Only
//     features narrower than the gap between neighbouring centre rays (a
//     sub-pixel pole) can fall between them and be missed.
//  2. Each sample ray is cast at every motion-blur instant t_k
//     (ExposureInstants) from the camera centre of world_from_cam(t_k) =
//     world_from_rig(t_k) * cam_from_rig^-1, with moving objects at t_k.
//  3. Radiance of a surface hit: albedo * (kAmbient + kDiffuse * max(0, n . sun))
//     with a fixed sun direction (smooth, no shadows); albedo =
//     ShadeSurface(material, seed, u, v, footprint, extents) with the
//     footprint of one sample on the surface,
//        footprint_m = distance * sample_angle / sqrt(max(|cos incidence|, 0.05)),
//     sample_angle = pixel_angle / n, and pixel_angle = sqrt(|db/du x db/dv|)
//     the square root of the solid angle of the pixel (b: bearing, from
//     finite differences of Unproject between neighbouring pixel centres),
//     i.e. the local angular pitch of the model, correct for every model and
//     anywhere in a fisheye image. A surface seen at incidence i stretches the
//     sample's footprint by 1 / cos i along one axis only; the texture filter
//     is square, so it takes the geometric mean of the two axes (the sqrt),
//     capped at 1 / sqrt(0.05) ~ 4.5 at grazing incidence.
//     A ray that hits nothing sees ShadeSky(direction).
//  4. The samples of all instants are averaged (a box filter over the pixel
//     and the exposure), in double, linear radiance in [0, 1].
//  5. Optional lens blur (RenderEffects::lens_blur_sigma_px): the averaged
//     radiance image convolved with a Gaussian PSF (LensBlur), so the
//     optics blur on top of the pixel's own box filter.
//  6. value = 255 * radiance * gain(c, t) * vignetting(pixel), through the
//     optional tone curve (ToneCurve), plus noise (the constant-sigma model
//     or the signal-dependent sensor model), rounded half up and clamped to
//     [0, 255] (see RenderEffects). With every effect off, steps 5 and 6
//     are the exact arithmetic of the renderer before they existed: the
//     default output is byte-identical.
//
// Determinism: every random draw (noise, exposure phases) comes from a
// counter-based hash of (seed, frame, camera, pixel), never from shared
// generator state, and each pixel is accumulated by one thread in a fixed
// order, so the image is byte-identical for any number of threads and any
// order of work.
//
// Memory: the per-camera bearing cache holds 12 bytes per sample and 21 per
// pixel (1400 x 1400 with n = 2: 135 MB), built once per camera (a few
// Unproject calls per sample, ~1 s for 1 Mpixel of a MEI camera); it keeps
// the most recently used cameras up to kRayCacheMaxBytes (ClearRenderCache()
// frees it). Rendering adds 16 bytes per pixel while it runs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/synth/scene.h"

namespace mcvo::synth {

struct RenderEffects {
  // Additive Gaussian noise, grey levels (0..255), plus a shot-noise-like term:
  // the standard deviation at grey value v is noise_sigma * sqrt(1 + v / 255)
  // (read noise sigma, shot noise sigma * sqrt(v / 255)).
  double noise_sigma = 0.0;
  // Smooth per-camera gain changes over time, gain in [0.7, 1.3] (ExposureGain).
  bool exposure_changes = false;
  // Radial falloff with the angle of the pixel's bearing from the optical axis
  // (VignettingFalloff): cos^4, never below 0.3.
  bool vignetting = false;
  // Signal-dependent sensor noise (Poisson-Gaussian, in grey levels): the
  // variance at grey value v (after the tone curve) is
  // sensor_noise_a * v + sensor_noise_b. Off when both are 0; not together
  // with noise_sigma. Measured on KITTI odometry (tools/bench/image_stats_bench.cc,
  // results/render_realism.md): a = 0.033, b = 0.
  double sensor_noise_a = 0.0;
  double sensor_noise_b = 0.0;
  // Optical blur: a Gaussian PSF of this sigma in pixels applied to the
  // radiance image (0: off). KITTI's edges measure 0.9 px of blur beyond
  // the pixel and the renderer's own 0.48 px: 0.8 matches KITTI (0.6 with
  // motion blur of 3 instants).
  double lens_blur_sigma_px = 0.0;
  // Tone curve: value = 255 * min(1, tone_gain * v / 255)^tone_gamma of the
  // linear grey value v, which clips what tone_gain pushes past white (a
  // sky exposed for the road) and stretches the contrast (tone_gamma > 1).
  // Identity (and not applied) at 1 and 1.
  double tone_gain = 1.0;
  double tone_gamma = 1.0;
  int motion_blur_samples = 0;    // > 1: average over this many instants within the exposure
  double exposure_time_s = 0.01;  // shutter time used by motion blur
  // Cameras that go black: camera `blackout_camera` (kBlackoutAllCameras:
  // every camera) renders all-black images for frames
  // [blackout_first_frame, blackout_first_frame + blackout_num_frames).
  static constexpr int kBlackoutAllCameras = -2;
  int blackout_camera = -1;
  int blackout_first_frame = 0;
  int blackout_num_frames = 0;

  bool IsBlackout(int camera_index, int frame) const {
    return (camera_index == blackout_camera || blackout_camera == kBlackoutAllCameras) &&
           frame >= blackout_first_frame && frame - blackout_first_frame < blackout_num_frames;
  }

  bool HasSensorNoise() const { return sensor_noise_a > 0.0 || sensor_noise_b > 0.0; }
  bool HasToneCurve() const { return tone_gain != 1.0 || tone_gamma != 1.0; }

  // Throws UsageError naming the bad field ("noise_sigma: must be >= 0, got -1").
  void Check() const;
};

struct RenderOptions {
  int samples_per_axis = 2;  // supersampling: n x n stratified samples per pixel, 1..8
  // Traverse the scene once per pixel, and per sample only near geometric
  // edges (step 1b above): the same image but for sub-pixel features; on the
  // urban scene 1.4x faster (texture shading, which it does not save, then
  // dominates).
  bool adaptive_supersampling = true;
  double max_distance_m = 2000.0;
  RenderEffects effects;
  uint64_t seed = 0;
  int threads = 0;  // 0: all hardware threads

  // Throws UsageError naming the bad field (effects fields as "effects.<name>").
  void Check() const;
};

// Lighting of surfaces: radiance = albedo * (kAmbient + kDiffuse * max(0, n . kSun)).
inline constexpr double kAmbient = 0.55;
inline constexpr double kDiffuse = 0.45;
// Unit sun direction (towards the sun), world frame, z up: about 50 degrees
// high, not aligned with any axis so facades of different orientation differ.
Eigen::Vector3d SunDirection();

// Renders one 8-bit grey image (CV_8UC1, camera.height x camera.width) of
// camera `camera_index` of `rig` at time t_ns (frame number `frame` only
// seeds noise and selects the blackout). `world_from_rig_at` gives the rig
// pose at any time (for motion blur within the exposure).
template <typename PoseFn>
cv::Mat RenderImage(const Scene& scene, const Rig& rig, int camera_index, PoseFn&& world_from_rig_at,
                    int64_t t_ns, int frame, const RenderOptions& options);

// Non-template core used by RenderImage: poses at the motion-blur instants
// (same size as t_ns_samples, at least one). Throws UsageError for invalid
// options.
cv::Mat RenderImageAtPoses(const Scene& scene, const Rig& rig, int camera_index,
                           const std::vector<Rigid3d>& world_from_rig_samples,
                           const std::vector<int64_t>& t_ns_samples, int frame, const RenderOptions& options);

// Time stamps of the motion-blur instants for an exposure centred at t_ns:
// with M = motion_blur_samples > 1, t_ns + exposure * ((k + 0.5) / M - 0.5),
// k = 0..M-1 (midpoints of M equal sub-intervals); else the single instant t_ns.
std::vector<int64_t> ExposureInstants(int64_t t_ns, const RenderEffects& effects);

// Gain of camera `camera_index` at time t_ns: 1 without exposure_changes;
// else 1 + 0.3 * (0.55 sin(w1 t + p1) + 0.30 sin(w2 t + p2) + 0.15 sin(w3 t + p3))
// with periods 6.7 s, 2.3 s, 17 s and phases hashed from (seed, camera), so
// it stays in [0.7, 1.3], changes by at most 0.42 per second, and differs
// between cameras.
double ExposureGain(const RenderEffects& effects, uint64_t seed, int camera_index, int64_t t_ns);

// Vignetting factor for a bearing at `angle_rad` from the optical axis:
// cos^4 (natural vignetting of a perspective lens), clamped to >= 0.3 so
// fisheyes (whose lenses compensate much of it, and which see beyond 90
// degrees where cos^4 would vanish or come back) keep a usable signal at the rim.
double VignettingFalloff(double angle_rad);

// "A:B" of `mcvo synth --sensor-noise` into sensor_noise_a and _b, "GAIN:GAMMA"
// of --tone into tone_gain and tone_gamma; UsageError naming the flag when the
// text is not two numbers (the ranges are RenderEffects::Check's).
void ParseSensorNoise(const std::string& text, RenderEffects* effects);
void ParseTone(const std::string& text, RenderEffects* effects);

// The tone curve of RenderEffects at grey value v (linear, 0..255 and beyond).
double ToneCurve(const RenderEffects& effects, double value);

// Convolves a width x height image (row-major) with a normalised Gaussian of
// sigma_px (separable, truncated at 3 sigma, borders mirrored without
// repeating the edge pixel), rows in parallel on `threads` threads with the
// same result for any count. sigma_px <= 0 leaves the image as it is.
void LensBlur(double sigma_px, int width, int height, int threads, std::vector<double>* image);

// Frees the per-camera bearing cache.
void ClearRenderCache();
inline constexpr size_t kRayCacheMaxBytes = size_t{1} << 30;

template <typename PoseFn>
cv::Mat RenderImage(const Scene& scene, const Rig& rig, int camera_index, PoseFn&& world_from_rig_at,
                    int64_t t_ns, int frame, const RenderOptions& options) {
  const std::vector<int64_t> instants = ExposureInstants(t_ns, options.effects);
  std::vector<Rigid3d> poses;
  poses.reserve(instants.size());
  for (int64_t t : instants) poses.push_back(world_from_rig_at(t));
  return RenderImageAtPoses(scene, rig, camera_index, poses, instants, frame, options);
}

}  // namespace mcvo::synth
