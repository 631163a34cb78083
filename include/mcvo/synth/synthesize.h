// `mcvo synth`: renders a synthetic multi-camera sequence with exact ground
// truth into the generic rig dataset format (docs/dataset-format.md):
//
//   DIR/rig.json                  the rig (as rendered, after --image-scale)
//   DIR/frames.csv                t_ns and one image path per camera
//   DIR/images/<camera>/NNNNNN.png  8-bit grey images
//   DIR/masks/<camera>.png        valid-pixel mask, for cameras whose model
//                                 does not cover the whole image (fisheyes)
//   DIR/groundtruth.tum           world_from_rig at every frame time (TUM)
//   DIR/structure/scene_quads.csv the static 3-D scene (textured rectangles)
//   DIR/meta.json                 generator settings, for reproduction
//
// Frames past the end of the route: on a closed route (urban, urban_block,
// indoor) the rig drives the loop again, lap after lap, and the pose at
// t + lap is exactly the pose at t (SmoothTrajectory::WorldFromRig); on an
// open route (urban_repeated, urban_small_repeated, open) it stands still at the end.
//
// The whole folder is written under a temporary name beside DIR and renamed
// when complete: an interrupted run leaves no DIR that looks complete.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mcvo/camera/camera.h"
#include "mcvo/synth/renderer.h"
#include "mcvo/synth/stops.h"

namespace mcvo::synth {

struct SynthPreset {
  std::string name;      // --preset NAME
  std::string rig_file;  // stem of config/rigs/<rig_file>.json (compiled in)
  std::string scene;     // default scene
  std::string description;
};

// kitti360, kitti360-3cam, stereo, multicam6, irregular5.
const std::vector<SynthPreset>& SynthPresets();
// The preset's rig; throws InputError listing the presets for an unknown name.
Rig PresetRig(const std::string& preset_name);
const SynthPreset& FindPreset(const std::string& preset_name);

struct SynthOptions {
  std::string preset;              // either a preset ...
  std::filesystem::path rig_path;  // ... or a rig.json (then scene is required)
  std::string scene;               // one of SceneNames(); default: the preset's
  int frames = 0;                  // 0: the whole route once (or `laps` of it)
  // Instead of frames: this many traversals of the route, frames =
  // floor(laps x lap duration x frame rate) (at least 1); more than 1 only on
  // closed routes. 0: not used. 1 gives the same frames as frames = 0.
  double laps = 0.0;
  uint64_t seed = 0;         // scene layout, trajectory variation, noise
  double image_scale = 1.0;  // shrinks images and intrinsics together
  double frame_rate_hz = 10.0;
  int64_t first_t_ns = 1000000000;  // time stamp of frame 0
  bool force = false;               // replace a non-empty output folder
  StopPlan stops;                   // standing at the start, stops on the way (stops.h)
  RenderOptions render;

  // Throws UsageError naming the bad field.
  void Check() const;
};

struct SynthSummary {
  int frames = 0;
  int cameras = 0;
  double route_length_m = 0.0;
  bool route_closed = false;
  double lap_seconds = 0.0;  // time to drive the route once
  double laps = 0.0;         // frames x frame period / lap_seconds
  double megapixels_per_frame = 0.0;
  double render_seconds = 0.0;  // wall time spent rendering (log only, never in outputs)
};

// Renders the sequence into out_dir. `progress(done_frames, total_frames)` is
// called after each frame (may be empty). Throws UsageError/InputError on bad
// options or input (nothing is left behind).
SynthSummary Synthesize(const SynthOptions& options, const std::filesystem::path& out_dir,
                        const std::function<void(int, int)>& progress = {});

}  // namespace mcvo::synth
