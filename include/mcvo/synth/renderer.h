// Ray-casting renderer: every pixel is a ray through its camera's own model
// (Camera::Unproject, any model of the camera module) into the scene, shaded
// with band-limited textures and supersampled, so edges are anti-aliased and
// textures do not flicker. Photometric effects are applied afterwards.
//
// Determinism: every random draw (sample jitter, noise, exposure) comes from
// a counter-based hash of (seed, frame, camera, pixel), never from shared
// generator state, so the image is byte-identical for any number of threads
// and any order of work.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "mcvo/camera/camera.h"
#include "mcvo/geometry/rigid3d.h"
#include "mcvo/synth/scene.h"

namespace mcvo::synth {

struct RenderEffects {
  double noise_sigma = 0.0;          // additive Gaussian noise, grey levels (0..255); also adds shot noise
  bool exposure_changes = false;     // smooth per-camera gain changes over time (+-30 %)
  bool vignetting = false;           // cos^4-like radial falloff from the principal point
  int motion_blur_samples = 0;       // > 1: average over this many instants within the exposure
  double exposure_time_s = 0.01;     // shutter time used by motion blur
  // Cameras that go black: camera `blackout_camera` renders all-black images
  // for frames [blackout_first_frame, blackout_first_frame + blackout_num_frames).
  int blackout_camera = -1;
  int blackout_first_frame = 0;
  int blackout_num_frames = 0;

  // Throws UsageError naming the bad field.
  void Check() const;
};

struct RenderOptions {
  int samples_per_axis = 2;  // supersampling: n x n stratified samples per pixel
  double max_distance_m = 2000.0;
  RenderEffects effects;
  uint64_t seed = 0;
  int threads = 0;  // 0: all hardware threads

  void Check() const;
};

// Renders one 8-bit grey image (CV_8UC1, camera.height x camera.width) of
// camera `camera_index` of `rig` at time t_ns (frame number `frame` only
// seeds noise and selects the blackout). `world_from_rig_at` gives the rig
// pose at any time (for motion blur within the exposure).
template <typename PoseFn>
cv::Mat RenderImage(const Scene& scene, const Rig& rig, int camera_index, PoseFn&& world_from_rig_at,
                    int64_t t_ns, int frame, const RenderOptions& options);

// Non-template core used by RenderImage: poses at the motion-blur instants.
cv::Mat RenderImageAtPoses(const Scene& scene, const Rig& rig, int camera_index,
                           const std::vector<Rigid3d>& world_from_rig_samples,
                           const std::vector<int64_t>& t_ns_samples, int frame, const RenderOptions& options);

// Time stamps of the motion-blur instants for an exposure centred at t_ns
// (a single instant, t_ns, without motion blur).
std::vector<int64_t> ExposureInstants(int64_t t_ns, const RenderEffects& effects);

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
