// Initializer benchmark: scale error and initialisation delay of the metric
// initializer (include/mcvo/initializer/initializer.h) on synthetic tracks
// (tests/initializer/synthetic_rig_tracks.h) of every preset rig, over seeds,
// noise levels, motions (a car turning a 90 deg corner; a straight drive,
// pure translation) and with or without cross-camera observations (overlap).
//
// Per run: the segment's frames are fed from its first frame until the
// initializer returns; delay = frames fed, scale error = |travel over the
// window| / true travel - 1 (world = rig at the anchor frame, so this is the
// metric scale of the result). A run that never returns is a refusal.
// Writes <out>.md (aggregates) and <out>.csv (one row per run) and prints the
// table. Deterministic apart from the wall time line.
//
//   mcvo_bench_initializer [--out results/initializer_benchmark] [--seeds 6] [--threads 2] ...
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "initializer/synthetic_rig_tracks.h"
#include "mcvo/initializer/initializer.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/strings.h"

namespace mcvo {
namespace {

using testing::DriveSpec;
using testing::DriveTrajectory;
using testing::LandmarkOptions;
using testing::LandmarksAroundPath;
using testing::MakeRigTracks;
using testing::SyntheticRigTracks;
using testing::TrackOptions;

struct Job {
  std::string rig;
  std::string motion;  // "turn", "sharp" or "straight"
  bool overlap = true;
  double noise_px = 0.0;
  uint64_t seed = 0;
};

struct Outcome {
  bool initialised = false;
  int delay_frames = 0;
  double scale_error = 0.0;  // signed, relative
  double sigma = 0.0;        // the result's relative_scale_sigma
  int attempts = 0;
  std::string source;
  std::string reason;  // last waiting reason when refused
};

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> out;
  for (std::string_view token : SplitTokens(text, ",")) out.emplace_back(token);
  return out;
}

std::string SourceName(ScaleSource source) {
  switch (source) {
    case ScaleSource::kRigRotation:
      return "rotation";
    case ScaleSource::kCrossCamera:
      return "cross";
    case ScaleSource::kCombined:
      return "combined";
    case ScaleSource::kOverlapStart:
      return "overlap";
    case ScaleSource::kArbitrary:
      return "arbitrary";
  }
  return "?";
}

struct Settings {
  int frames = 20;
  double turn_step_m = 0.6;
  double turn_deg_per_frame = 3.0;
  int turn_straight_frames = 5;
  double sharp_step_m = 0.5;
  double sharp_deg_per_frame = 7.5;
  int features = 150;
  double straight_step_m = 0.8;
  InitializerOptions options;
};

Outcome RunJob(const Job& job, const Rig& rig, const Settings& settings) {
  DriveSpec spec;
  spec.num_frames = settings.frames;
  if (job.motion == "turn") {
    spec.step_m = settings.turn_step_m;
    spec.straight_frames = settings.turn_straight_frames;
    spec.turn_deg_per_frame = settings.turn_deg_per_frame;
    spec.pitch_roll_wobble_deg = 0.3;
  } else if (job.motion == "sharp") {
    spec.step_m = settings.sharp_step_m;
    spec.turn_deg_per_frame = settings.sharp_deg_per_frame;
    spec.pitch_roll_wobble_deg = 0.3;
  } else {
    spec.step_m = settings.straight_step_m;
  }
  const std::vector<Rigid3d> world_from_rig = DriveTrajectory(spec);
  LandmarkOptions landmark_options;
  landmark_options.seed = job.seed;
  TrackOptions track_options;
  track_options.seed = job.seed;
  track_options.pixel_noise_px = job.noise_px;
  track_options.cross_camera = job.overlap;
  track_options.max_features_per_camera = settings.features;
  const SyntheticRigTracks tracks = MakeRigTracks(
      rig, world_from_rig, LandmarksAroundPath(world_from_rig, landmark_options), track_options);
  Initializer initializer(rig, settings.options, 1);
  Outcome out;
  for (const RigFrameObservations& frame : tracks.frames) {
    ++out.delay_frames;
    const std::optional<InitializationResult> result = initializer.AddFrame(frame);
    if (!result) {
      out.reason = initializer.WaitingReason();
      continue;
    }
    const double truth =
        testing::AnchorFromRig(tracks, result->anchor_frame_index, result->frame_index.back())
            .translation.norm();
    out.initialised = true;
    out.scale_error = result->world_from_rig.back().translation.norm() / truth - 1.0;
    out.sigma = result->relative_scale_sigma;
    out.attempts = result->attempts;
    out.source = SourceName(result->source);
    out.reason.clear();
    return out;
  }
  return out;
}

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  const double pos = q * static_cast<double>(values.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(pos));
  const size_t j = std::min(i + 1, values.size() - 1);
  return values[i] + (pos - static_cast<double>(i)) * (values[j] - values[i]);
}

std::string Percent(double v) { return std::isnan(v) ? "-" : FormatFixed(100.0 * v, 2); }

int Main(int argc, char** argv) {
  std::string out = "results/initializer_benchmark";
  std::string rigs_text = "kitti360,kitti360_3cam,kitti360_stereo,irregular5,multicam6";
  std::string noise_text = "0.5,1,2";
  std::string motions_text = "turn,sharp,straight";
  std::string overlap_text = "on,off";
  int seeds = 4;
  int threads = 2;
  Settings settings;
  ArgParser args("mcvo_bench_initializer",
                 "Scale error and delay of the metric initializer on synthetic tracks.");
  args.AddString("out", &out, "PREFIX", "writes PREFIX.md and PREFIX.csv");
  args.AddString("rigs", &rigs_text, "LIST", "preset rigs (config/rigs/<name>.json), comma separated");
  args.AddString("noise", &noise_text, "LIST", "pixel noise levels (px), comma separated");
  args.AddString("motions", &motions_text, "LIST", "turn, sharp, straight");
  args.AddString("overlap", &overlap_text, "LIST", "cross-camera observations: on, off");
  args.AddInt("seeds", &seeds, "segments per configuration (seeds 1..N)");
  args.AddInt("threads", &threads, "runs in parallel (results do not depend on it)");
  args.AddInt("frames", &settings.frames, "frames per segment");
  args.AddDouble("turn-deg", &settings.turn_deg_per_frame, "heading change per frame in the turn");
  args.AddDouble("turn-step", &settings.turn_step_m, "distance per frame in the turn (m)");
  args.AddInt("turn-straight", &settings.turn_straight_frames, "frames driven straight before the turn");
  args.AddDouble("sharp-deg", &settings.sharp_deg_per_frame, "heading change per frame in the sharp turn");
  args.AddDouble("sharp-step", &settings.sharp_step_m, "distance per frame in the sharp turn (m)");
  args.AddInt("window", &settings.options.window_size, "initializer window size");
  args.AddInt("features", &settings.features, "tracked features per camera");
  args.AddDouble("max-sigma", &settings.options.max_relative_scale_sigma,
                 "initializer max_relative_scale_sigma");
  if (!args.Parse(argc - 1, argv + 1)) return 0;
  settings.options.Check();

  std::map<std::string, Rig> rigs;
  std::vector<Job> jobs;
  for (const std::string& motion : SplitList(motions_text)) {
    if (motion != "turn" && motion != "sharp" && motion != "straight")
      throw UsageError("unknown motion " + motion);
  }
  for (const std::string& rig : SplitList(rigs_text)) {
    rigs.emplace(rig, testing::LoadPresetRig(rig));
    for (const std::string& motion : SplitList(motions_text)) {
      for (const std::string& overlap : SplitList(overlap_text)) {
        for (const std::string& noise : SplitList(noise_text)) {
          for (int seed = 1; seed <= seeds; ++seed) {
            Job job;
            job.rig = rig;
            job.motion = motion;
            job.overlap = overlap == "on";
            job.noise_px = ParseDouble(noise).value_or(0.0);
            job.seed = static_cast<uint64_t>(seed);
            jobs.push_back(job);
          }
        }
      }
    }
  }
  const auto start = std::chrono::steady_clock::now();
  std::vector<Outcome> outcomes(jobs.size());
  ParallelFor(static_cast<int>(jobs.size()), std::max(1, threads), [&](int i) {
    const size_t j = static_cast<size_t>(i);
    outcomes[j] = RunJob(jobs[j], rigs.at(jobs[j].rig), settings);
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::ostringstream csv;
  csv << "rig,motion,overlap,noise_px,seed,initialised,delay_frames,scale_error,scale_sigma,source,attempts,"
         "reason\n";
  for (size_t i = 0; i < jobs.size(); ++i) {
    const Job& j = jobs[i];
    const Outcome& o = outcomes[i];
    std::string reason = o.reason;
    std::replace(reason.begin(), reason.end(), ',', ';');
    std::replace(reason.begin(), reason.end(), '"', '\'');
    csv << j.rig << ',' << j.motion << ',' << (j.overlap ? "on" : "off") << ',' << FormatDouble(j.noise_px)
        << ',' << j.seed << ',' << (o.initialised ? 1 : 0) << ',' << o.delay_frames << ','
        << (o.initialised ? FormatDouble(o.scale_error) : "") << ','
        << (o.initialised ? FormatDouble(o.sigma) : "") << ',' << o.source << ',' << o.attempts << ",\""
        << reason << "\"\n";
  }

  std::ostringstream md;
  const double sharp_radius = settings.sharp_step_m / (settings.sharp_deg_per_frame * M_PI / 180.0);
  const double turn_radius = settings.turn_step_m / (settings.turn_deg_per_frame * M_PI / 180.0);
  md << "# Initializer benchmark\n\n"
     << "Produced by `tools/bench_initializer.sh` (`mcvo_bench_initializer`). Synthetic tracks "
     << "(tests/initializer/synthetic_rig_tracks.h): random static landmarks (facades, ground, clutter) at "
        "1-40 m, "
     << "up to " << settings.features << " tracked features per camera, Gaussian pixel noise, segments of "
     << settings.frames << " frames at 10 Hz.\n\n"
     << "- turn: " << settings.turn_straight_frames << " frames straight, then "
     << FormatDouble(settings.turn_deg_per_frame) << " deg and " << FormatDouble(settings.turn_step_m)
     << " m per frame (a city corner, radius " << FormatFixed(turn_radius, 1) << " m);\n"
     << "- sharp: " << FormatDouble(settings.sharp_deg_per_frame) << " deg and "
     << FormatDouble(settings.sharp_step_m) << " m per frame from the first frame (radius "
     << FormatFixed(sharp_radius, 1) << " m, a tight turn at 18 km/h);\n"
     << "- straight: " << FormatDouble(settings.straight_step_m) << " m per frame, pure translation.\n\n"
     << "overlap on: cross-camera observations wherever two cameras see a landmark; off: none (the scale can "
        "only "
     << "come from the rig rotation). Default InitializerOptions (window " << settings.options.window_size
     << ", max_relative_scale_sigma " << FormatDouble(settings.options.max_relative_scale_sigma)
     << "); seeds 1.." << seeds << " per row.\n\n"
     << "Scale error: |rig travel over the initialisation window| / true travel - 1, in %, over the runs "
        "that "
     << "initialised: median and p90 of the absolute value, worst signed, and how many exceed 1 %. sigma: "
        "the "
     << "initializer's own estimate of the relative scale std (median). Delay: frames fed from the segment "
        "start "
     << "until the initializer returned (the window alone takes " << settings.options.window_size
     << "). Refused: runs that did not initialise within the segment (the initializer kept waiting).\n\n"
     << "| rig | motion | overlap | noise px | init | refused | median err % | p90 err % | worst err % | > 1 "
        "% | "
     << "median sigma % | median delay | max delay |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<double> all_z;
  int all_over_one_percent = 0;
  for (size_t i = 0; i < jobs.size();) {
    size_t end = i;
    std::vector<double> abs_err, sigmas, delays;
    double worst = std::nan("");
    int refused = 0, over_one_percent = 0;
    while (end < jobs.size() && jobs[end].rig == jobs[i].rig && jobs[end].motion == jobs[i].motion &&
           jobs[end].overlap == jobs[i].overlap && jobs[end].noise_px == jobs[i].noise_px) {
      const Outcome& o = outcomes[end];
      if (o.initialised) {
        abs_err.push_back(std::abs(o.scale_error));
        sigmas.push_back(o.sigma);
        delays.push_back(o.delay_frames);
        over_one_percent += std::abs(o.scale_error) > 0.01 ? 1 : 0;
        if (o.sigma > 0.0) all_z.push_back(std::abs(o.scale_error) / o.sigma);
        if (std::isnan(worst) || std::abs(o.scale_error) > std::abs(worst)) worst = o.scale_error;
      } else {
        ++refused;
      }
      ++end;
    }
    all_over_one_percent += over_one_percent;
    const Job& j = jobs[i];
    md << "| " << j.rig << " | " << j.motion << " | " << (j.overlap ? "on" : "off") << " | "
       << FormatDouble(j.noise_px) << " | " << abs_err.size() << " | " << refused << " | "
       << Percent(Quantile(abs_err, 0.5)) << " | " << Percent(Quantile(abs_err, 0.9)) << " | "
       << Percent(worst) << " | " << over_one_percent << " | " << Percent(Quantile(sigmas, 0.5)) << " | "
       << (delays.empty() ? std::string("-") : FormatFixed(Quantile(delays, 0.5), 1)) << " | "
       << (delays.empty() ? std::string("-")
                          : FormatFixed(*std::max_element(delays.begin(), delays.end()), 0))
       << " |\n";
    i = end;
  }
  int within[3] = {0, 0, 0};
  for (double z : all_z) {
    for (int k = 0; k < 3; ++k) within[k] += z <= k + 1 ? 1 : 0;
  }
  const double n_z = static_cast<double>(std::max<size_t>(all_z.size(), 1));
  md << "\nCalibration of sigma over the " << all_z.size() << " initialised runs: |error| <= 1 sigma in "
     << FormatFixed(100.0 * within[0] / n_z, 0) << " %, <= 2 sigma in "
     << FormatFixed(100.0 * within[1] / n_z, 0) << " %, <= 3 sigma in "
     << FormatFixed(100.0 * within[2] / n_z, 0) << " % (Gaussian: 68, 95, 99.7); worst "
     << "|error| / sigma "
     << FormatFixed(all_z.empty() ? 0.0 : *std::max_element(all_z.begin(), all_z.end()), 2)
     << ". Runs with a scale error above 1 %: " << all_over_one_percent << ".\n";
  std::ostringstream timing;
  timing << "\n"
         << jobs.size() << " runs in " << FormatFixed(seconds, 1) << " s wall time with " << threads
         << " threads.\n";
  std::cout << md.str() << timing.str();
  std::ofstream(out + ".md") << md.str() << timing.str();
  std::ofstream(out + ".csv") << csv.str();
  return 0;
}

}  // namespace
}  // namespace mcvo

int main(int argc, char** argv) {
  try {
    return mcvo::Main(argc, argv);
  } catch (const mcvo::UsageError& e) {
    std::cerr << "mcvo_bench_initializer: " << e.what() << "\n";
    return mcvo::kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << "mcvo_bench_initializer: " << e.what() << "\n";
    return mcvo::kExitBadInput;
  }
}
