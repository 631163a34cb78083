// mcvo._run_pipeline and mcvo.synth: the pipeline of `mcvo run` and the
// renderer of `mcvo synth`, built from their arguments exactly as
// tools/run_command.cc and tools/synth_command.cc build them from flags, so
// the outputs are the same files. Both run on a worker thread without the
// GIL; Ctrl-C cancels them (RunInterruptible).
#include <atomic>
#include <chrono>
#include <filesystem>
#include <optional>
#include <string>

#include <pybind11/stl.h>

#include "bindings.h"
#include "dataset.h"
#include "mcvo/config/config.h"
#include "mcvo/pipeline/run.h"
#include "mcvo/synth/synthesize.h"
#include "mcvo/util/enum_names.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::python {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string PyRepr(const py::handle& value) { return py::repr(value).cast<std::string>(); }

// The config as `mcvo run --config` reads it: a file path, a dict (its JSON
// text through the same parser, named "<dict>" in errors) or None.
void ReadConfig(const py::object& config, RunRequest* request) {
  if (config.is_none()) {
    request->options = PipelineOptions();
    request->config_source = "built-in defaults";
  } else if (py::isinstance<py::dict>(config)) {
    const std::string text = py::module_::import("json").attr("dumps")(config).cast<std::string>();
    request->config_source = "<dict>";
    request->options = ParsePipelineOptions(text, request->config_source);
  } else {
    const std::string path = PathString(config);
    request->options = ReadPipelineOptions(path);
    request->config_source = path;
    request->config_path = path;
  }
}

struct RunArgs {
  py::object dataset;
  py::object config;
  py::object out;
  py::object threads;
  int frames = 0;
  bool force = false;
  py::object progress;
  py::object tracks;
  py::object detector;
  py::object model;
};

// run_command.cc's request, from the Python arguments.
RunRequest MakeRunRequest(const RunArgs& args, const PyDataset& dataset) {
  if (!args.threads.is_none() && args.threads.cast<int>() < 0) throw UsageError("threads: must be >= 0");
  if (args.frames < 0) throw UsageError("frames: must be >= 0");
  RunRequest request;
  ReadConfig(args.config, &request);
  if (!args.detector.is_none()) {
    const std::string name = args.detector.cast<std::string>();
    const std::optional<DetectorType> detector = EnumFromName(kDetectorTypeNames, name);
    if (!detector) {
      throw UsageError(StrCat("detector: unknown value '", name, "' (known: ", EnumNameList(kDetectorTypeNames), ")"));
    }
    request.options.frontend.detector = *detector;
  }
  if (!args.model.is_none()) request.options.frontend.model_path = PathString(args.model);
  if (!args.threads.is_none()) request.options.runtime.threads = args.threads.cast<int>();
  request.options.Check();
  request.dataset = dataset.options;
  if (!args.tracks.is_none()) request.tracks = PathString(args.tracks);
  request.out_dir = PathString(args.out);
  request.force = args.force;
  request.max_frames = args.frames;
  request.version = MCVO_VERSION;
  // run.json's command_line: the call, as Python would write it.
  std::string call = StrCat("mcvo.run(", PyRepr(py::str(dataset.options.root.string())));
  if (!args.config.is_none()) {
    call += ", config=" + (py::isinstance<py::dict>(args.config) ? std::string("<dict>")
                                                                  : PyRepr(py::str(request.config_source)));
  }
  call += ", out=" + PyRepr(py::str(request.out_dir.string()));
  if (!args.threads.is_none()) call += StrCat(", threads=", args.threads.cast<int>());
  if (args.frames > 0) call += StrCat(", frames=", args.frames);
  if (args.force) call += ", force=True";
  request.command_line = call + ")";
  return request;
}

py::dict SummaryDict(const RunSummary& s) {
  py::dict d;
  d["frames"] = s.frames;
  d["posed_frames"] = s.posed_frames;
  d["keyframes"] = s.keyframes;
  d["segments"] = s.segments;
  d["segments_relocalised"] = s.segments_relocalised;
  d["seconds"] = s.seconds;
  d["frames_per_second"] = s.frames_per_second;
  d["evaluated"] = s.evaluated;
  d["ate_rmse_m"] = s.evaluated ? py::cast(s.ate_rmse_m) : py::none();
  d["ate_percent_of_path"] = s.evaluated ? py::cast(s.ate_percent_of_path) : py::none();
  d["scale_error_percent"] = s.evaluated ? py::cast(s.scale_error_percent) : py::none();
  d["gt_path_length_m"] = s.evaluated ? py::cast(s.gt_path_length_m) : py::none();
  d["scale_arbitrary"] = s.scale_arbitrary;
  d["alignment"] = std::string(AlignmentModeName(s.alignment));
  d["unit_m"] = s.scale_arbitrary ? py::cast(s.unit_m) : py::none();
  d["loops_accepted"] = s.loops_accepted;
  d["warning"] = s.warning.empty() ? py::none() : py::cast(s.warning);
  return d;
}

// progress({"stage": "running", "elapsed_s": ..., "frames": N}) about twice a
// second while the pipeline runs (RunPipeline reports no per-frame count).
py::dict RunPipelinePy(const RunArgs& args, const PyDataset& dataset) {
  const RunRequest request = MakeRunRequest(args, dataset);
  const int total = request.max_frames > 0
                        ? std::min<int>(request.max_frames, static_cast<int>(dataset.index.frames.size()))
                        : static_cast<int>(dataset.index.frames.size());
  const Clock::time_point start = Clock::now();
  double last_report = -1.0;
  auto report = [&](const char* stage) {
    py::dict event;
    event["stage"] = stage;
    event["elapsed_s"] = SecondsSince(start);
    event["frames"] = total;
    args.progress(event);
  };
  RunSummary summary;
  std::function<void()> poll;
  if (!args.progress.is_none()) {
    report("start");
    poll = [&] {
      const double now = SecondsSince(start);
      if (now - last_report < 0.5) return;
      last_report = now;
      report("running");
    };
  }
  RunInterruptible([&] { summary = RunPipeline(request); }, poll);
  if (!args.progress.is_none()) report("done");
  py::dict result = SummaryDict(summary);
  result["out"] = std::filesystem::absolute(request.out_dir).lexically_normal().string();
  return result;
}

PyDataset DatasetOf(const py::object& dataset) {
  if (py::isinstance<PyDataset>(dataset)) return dataset.cast<PyDataset>();
  return OpenPyDataset(MakeDatasetOptions(dataset, "auto", py::none(), "", false));
}

struct SynthArgs {
  std::string preset;
  py::object rig;
  std::string scene;
  int frames = 0;
  double laps = 0.0;
  int seed = 0;
  double image_scale = 1.0;
  double rate = 10.0;
  int samples = synth::RenderOptions().samples_per_axis;
  double noise = 0.0;
  std::string sensor_noise;
  double lens_blur = 0.0;
  std::string tone;
  bool exposure_changes = false;
  bool vignetting = false;
  int motion_blur = 0;
  double exposure_time = synth::RenderEffects().exposure_time_s;
  double stand = 0.0;
  std::string stop;
  int threads = 0;
  bool force = false;
};

// synth_command.cc's options, from the Python arguments.
synth::SynthOptions MakeSynthOptions(const SynthArgs& a) {
  synth::SynthOptions options;
  if (a.seed < 0) throw UsageError("seed must be >= 0");
  options.preset = a.preset;
  if (!a.rig.is_none()) options.rig_path = PathString(a.rig);
  options.scene = a.scene;
  options.frames = a.frames;
  options.laps = a.laps;
  options.seed = static_cast<uint64_t>(a.seed);
  options.image_scale = a.image_scale;
  options.frame_rate_hz = a.rate;
  options.render.samples_per_axis = a.samples;
  options.render.effects.noise_sigma = a.noise;
  if (!a.sensor_noise.empty()) synth::ParseSensorNoise(a.sensor_noise, &options.render.effects);
  options.render.effects.lens_blur_sigma_px = a.lens_blur;
  if (!a.tone.empty()) synth::ParseTone(a.tone, &options.render.effects);
  options.render.effects.exposure_changes = a.exposure_changes;
  options.render.effects.vignetting = a.vignetting;
  options.render.effects.motion_blur_samples = a.motion_blur;
  options.render.effects.exposure_time_s = a.exposure_time;
  options.stops.stand_s = a.stand;
  if (!a.stop.empty()) {
    for (std::string_view stop : SplitFields(a.stop, ',')) options.stops.stops.push_back(synth::ParseStop(std::string(stop)));
  }
  options.render.threads = a.threads;
  options.render.seed = options.seed;
  options.force = a.force;
  options.Check();
  return options;
}

py::dict SynthPy(const SynthArgs& args, const py::object& out, const py::object& progress) {
  const synth::SynthOptions options = MakeSynthOptions(args);
  const std::string out_dir = PathString(out);
  std::atomic<int> done{0}, total{options.frames};
  int reported = -1;
  std::function<void()> poll;
  const Clock::time_point start = Clock::now();
  if (!progress.is_none()) {
    poll = [&] {
      if (done.load() == reported) return;
      reported = done.load();
      py::dict event;
      event["stage"] = "rendering";
      event["done"] = reported;
      event["total"] = total.load();
      event["elapsed_s"] = SecondsSince(start);
      progress(event);
    };
  }
  synth::SynthSummary summary;
  RunInterruptible(
      [&] {
        summary = synth::Synthesize(options, out_dir, [&](int d, int t) {
          total = t;
          done = d;
        });
      },
      poll);
  if (poll) poll();
  py::dict d;
  d["out"] = std::filesystem::absolute(out_dir).lexically_normal().string();
  d["frames"] = summary.frames;
  d["cameras"] = summary.cameras;
  d["route_length_m"] = summary.route_length_m;
  d["route_closed"] = summary.route_closed;
  d["lap_seconds"] = summary.lap_seconds;
  d["laps"] = summary.laps;
  d["megapixels_per_frame"] = summary.megapixels_per_frame;
  d["render_seconds"] = summary.render_seconds;
  return d;
}

}  // namespace

void BindRun(py::module_& m) {
  m.def(
      "_run_pipeline",
      [](const py::object& dataset, const py::object& out, const py::object& config, const py::object& threads,
         int frames, bool force, const py::object& progress, const py::object& tracks, const py::object& detector,
         const py::object& model) {
        RunArgs args{dataset, config, out, threads, frames, force, progress, tracks, detector, model};
        return RunPipelinePy(args, DatasetOf(dataset));
      },
      py::arg("dataset"), py::arg("out"), py::arg("config") = py::none(), py::arg("threads") = py::none(),
      py::arg("frames") = 0, py::arg("force") = false, py::arg("progress") = py::none(),
      py::arg("tracks") = py::none(), py::arg("detector") = py::none(), py::arg("model") = py::none());
}

void BindSynth(py::module_& m) {
  m.def(
      "synth",
      [](const py::object& out, const std::string& preset, const py::object& rig, const std::string& scene,
         int frames, double laps, int seed, double image_scale, double rate, int samples, double noise,
         bool exposure_changes, bool vignetting, int motion_blur, double exposure_time, double stand,
         const std::string& stop, int threads, bool force, const py::object& progress,
         const std::string& sensor_noise, double lens_blur, const std::string& tone) {
        SynthArgs a{preset, rig, scene, frames, laps, seed, image_scale, rate, samples, noise, sensor_noise,
                    lens_blur, tone, exposure_changes, vignetting, motion_blur, exposure_time, stand, stop,
                    threads, force};
        return SynthPy(a, out, progress);
      },
      py::arg("out"), py::arg("preset") = "", py::arg("rig") = py::none(), py::arg("scene") = "",
      py::arg("frames") = 0, py::arg("laps") = 0.0, py::arg("seed") = 0, py::arg("image_scale") = 1.0,
      py::arg("rate") = 10.0, py::arg("samples") = synth::RenderOptions().samples_per_axis, py::arg("noise") = 0.0,
      py::arg("exposure_changes") = false, py::arg("vignetting") = false, py::arg("motion_blur") = 0,
      py::arg("exposure_time") = synth::RenderEffects().exposure_time_s, py::arg("stand") = 0.0,
      py::arg("stop") = "", py::arg("threads") = 0, py::arg("force") = false, py::arg("progress") = py::none(),
      py::arg("sensor_noise") = "", py::arg("lens_blur") = 0.0, py::arg("tone") = "",
      "Renders a synthetic sequence with exact ground truth into `out`, as `mcvo synth` (same arguments, "
      "same files): a preset (kitti360, kitti360-3cam, stereo, mono, multicam6, irregular5) or a rig.json "
      "with a scene. progress(event) gets {'stage', 'done', 'total', 'elapsed_s'} as frames complete. "
      "Returns a summary dict; Ctrl-C cancels (nothing is left).");
}

}  // namespace mcvo::python
