// `mcvo synth`: renders a synthetic multi-camera sequence with exact ground
// truth (mcvo/synth/synthesize.h, docs/dataset-format.md).
#include <iostream>
#include <string>

#include "command.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/synth/synthesize.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/progress.h"
#include "mcvo/util/stage.h"
#include "mcvo/util/strings.h"

namespace mcvo::tools {
namespace {

int RunSynth(int argc, const char* const* argv) {
  synth::SynthOptions options;
  std::string rig_path, out_dir, blackout, sensor_noise, tone;
  std::string stops;
  int seed = 0;
  bool exposure = false, vignetting = false;
  ArgParser args(
      "mcvo synth",
      "Renders a synthetic multi-camera sequence with exact ground truth into the generic rig dataset\n"
      "format (docs/dataset-format.md): rig.json, frames.csv, PNG images, groundtruth.tum, the 3-D scene.");
  args.AddString("preset", &options.preset, "NAME",
                 "kitti360 | kitti360-3cam | stereo | mono | multicam6 | irregular5 (rig + default scene)");
  args.AddString("rig", &rig_path, "FILE", "a rig.json instead of a preset (needs --scene)");
  args.AddString(
      "scene", &options.scene, "NAME",
      "urban | urban_block | urban_small_block | urban_repeated | urban_small_repeated | indoor | open "
      "(default: the preset's)");
  args.AddString("out", &out_dir, "DIR", "output folder (must not exist or be empty, unless --force)", true);
  args.AddInt("frames", &options.frames,
              "number of frames; 0: the whole route once (a closed route repeats past its end)");
  args.AddDouble("laps", &options.laps, "instead of --frames: drive the route this many times (e.g. 1.3)");
  args.AddInt("seed", &seed, "seed of the scene layout, trajectory variation and noise");
  args.AddDouble("image-scale", &options.image_scale, "shrink (or grow) images and intrinsics together");
  args.AddDouble("rate", &options.frame_rate_hz, "frames per second");
  args.AddInt("samples", &options.render.samples_per_axis, "anti-aliasing: N x N samples per pixel");
  args.AddDouble("noise", &options.render.effects.noise_sigma, "image noise sigma in grey levels (0: off)");
  args.AddString(
      "sensor-noise", &sensor_noise, "A:B",
      "signal-dependent noise, variance A * v + B at grey value v (KITTI: 0.033:0); not with --noise");
  args.AddDouble("lens-blur", &options.render.effects.lens_blur_sigma_px,
                 "optical blur: Gaussian PSF sigma in px (0: off; KITTI: 0.8, 0.6 with --motion-blur 3)");
  args.AddString(
      "tone", &tone, "GAIN:GAMMA",
      "tone curve 255 * min(1, GAIN * v / 255)^GAMMA: clips highlights, stretches contrast (KITTI: "
      "1.5:1.5)");
  args.AddFlag("exposure-changes", &exposure, "smooth per-camera exposure changes over time");
  args.AddFlag("vignetting", &vignetting, "radial falloff towards the image border");
  args.AddInt("motion-blur", &options.render.effects.motion_blur_samples,
              "average N instants over the exposure time (0: off)");
  args.AddDouble("exposure-time", &options.render.effects.exposure_time_s,
                 "shutter time for motion blur, seconds");
  args.AddString("blackout", &blackout, "CAM:FIRST:COUNT",
                 "camera (name, index or 'all') renders black for COUNT frames from frame FIRST");
  args.AddDouble("stand", &options.stops.stand_s,
                 "seconds the rig stands still at the start before it pulls away (4 s ramp)");
  args.AddString("stop", &stops, "AT:DUR[,..]",
                 "the rig slows down at AT s, stands DUR s and pulls away (4 s ramps); comma-separated");
  args.AddInt("threads", &options.render.threads,
              "render threads (0: all cores); output is the same for any");
  args.AddFlag("force", &options.force, "replace a non-empty output folder");
  args.AddEpilog(
      "Moving objects are part of the urban scenes. urban_block is a short closed lap around one block\n"
      "(loop closure), urban_repeated an open route past look-alike facades (no true loops); their\n"
      "_small_ versions have smaller blocks (shorter sequences for quick checks). Examples:\n"
      "  mcvo synth --preset kitti360 --out seq/kitti360 --frames 200 --image-scale 0.5\n"
      "  mcvo synth --preset kitti360 --scene urban_block --laps 1.3 --image-scale 0.25 --out seq/loop\n"
      "  mcvo synth --rig my_rig.json --scene indoor --out seq/lab --noise 2 --vignetting\n"
      "Closer to a real camera (values measured on KITTI odometry, results/render_realism.md):\n"
      "  mcvo synth --preset stereo --out seq/real --sensor-noise 0.033:0 --lens-blur 0.8 --tone 1.5:1.5\n");
  if (!args.Parse(argc, argv)) return kExitOk;
  if (seed < 0) throw UsageError("--seed must be >= 0");
  options.seed = static_cast<uint64_t>(seed);
  options.rig_path = rig_path;
  options.render.seed = options.seed;
  options.render.effects.exposure_changes = exposure;
  options.render.effects.vignetting = vignetting;
  if (!sensor_noise.empty()) synth::ParseSensorNoise(sensor_noise, &options.render.effects);
  if (!tone.empty()) synth::ParseTone(tone, &options.render.effects);
  if (!stops.empty()) {
    for (std::string_view stop : SplitFields(stops, ','))
      options.stops.stops.push_back(synth::ParseStop(std::string(stop)));
  }
  if (!blackout.empty()) {
    const std::vector<std::string_view> parts = SplitFields(blackout, ':');
    const auto first = parts.size() == 3 ? ParseInt64(parts[1]) : std::nullopt;
    const auto count = parts.size() == 3 ? ParseInt64(parts[2]) : std::nullopt;
    if (!first || !count || *first < 0 || *count < 1) {
      throw UsageError("--blackout: expected CAM:FIRST:COUNT (e.g. image_02:30:10), got '" + blackout + "'");
    }
    // The camera is resolved against the rig below (name or index).
    options.render.effects.blackout_first_frame = static_cast<int>(*first);
    options.render.effects.blackout_num_frames = static_cast<int>(*count);
    const Rig rig = options.preset.empty() ? ReadRig(rig_path) : synth::PresetRig(options.preset);
    const auto index = ParseInt64(parts[0]);
    const bool all = parts[0] == "all" && rig.FindCamera(parts[0]) < 0;
    const int camera = all     ? synth::RenderEffects::kBlackoutAllCameras
                       : index ? static_cast<int>(*index)
                               : rig.FindCamera(parts[0]);
    if (!all && (camera < 0 || camera >= rig.NumCameras())) {
      throw UsageError("--blackout: no camera '" + std::string(parts[0]) + "' in the rig");
    }
    options.render.effects.blackout_camera = camera;
  }
  options.Check();

  ProgressBar bar("mcvo synth", options.frames, "frames");
  const ScopedStage stage("synth --out " + out_dir);
  const synth::SynthSummary summary = synth::Synthesize(options, out_dir, [&bar](int done, int total) {
    bar.SetTotal(total);
    bar.Update(done);
  });
  bar.Finish();
  if (!summary.route_closed && summary.laps > 1.0) {
    MCVO_LOG(kWarning, "the route is open: the rig stands still at its end for the last ",
             FormatFixed((summary.laps - 1.0) * summary.lap_seconds, 1), " s");
  }
  MCVO_LOG(kInfo, "wrote ", summary.frames, " frames x ", summary.cameras, " cameras to ", out_dir, " (",
           FormatFixed(summary.megapixels_per_frame, 2), " Mpx per frame, route ",
           FormatFixed(summary.route_length_m, 1), " m ", summary.route_closed ? "closed" : "open", ", lap ",
           FormatFixed(summary.lap_seconds, 2), " s, ", FormatFixed(summary.laps, 2), " laps) in ",
           FormatFixed(summary.render_seconds, 1),
           " s: ", FormatFixed(summary.render_seconds / summary.frames, 3), " s per frame, ",
           FormatFixed(summary.render_seconds / (summary.frames * summary.megapixels_per_frame), 3),
           " s per Mpx");
  return kExitOk;
}

const CommandRegistrar kRegistrar("synth",
                                  {"render a synthetic multi-camera sequence with ground truth", RunSynth});

}  // namespace
}  // namespace mcvo::tools
