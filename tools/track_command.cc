// `mcvo track`: runs the frontend over a whole sequence and writes the track
// file (docs/track-format.md) with the features and the cross-camera matches,
// so the back end can run without the images, plus per-frame statistics (CSV)
// and, on request, per-stage timings (JSON).
//
// Order of work: flags and config, dataset metadata, then the tracker (which
// builds every detector and loads and checks any network model), then the
// output files, and only then the first image is decoded: a bad model or an
// unwritable output is reported at start-up, never at frame 1000.
#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "command.h"
#include "dataset_args.h"
#include "mcvo/config/config.h"
#include "mcvo/config/option_bounds.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/frontend/detector.h"
#include "mcvo/frontend/multi_camera_tracker.h"
#include "mcvo/frontend/opencv_threads.h"
#include "mcvo/frontend/track_file.h"
#include "mcvo/io/json_util.h"
#include "mcvo/pipeline/frame_source.h"
#include "mcvo/util/args.h"
#include "mcvo/util/cancel.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/output_folder.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/progress.h"
#include "mcvo/util/strings.h"

namespace mcvo::tools {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

template <typename Enum, size_t N>
Enum ParseEnumFlag(const EnumName<Enum> (&table)[N], const std::string& flag, const std::string& text) {
  if (const std::optional<Enum> value = EnumFromName(table, text)) return *value;
  throw UsageError(StrCat("--", flag, ": unknown value '", text, "' (known: ", EnumNameList(table), ")"));
}

// Whole-run sums behind the summary log line and the --timing file.
struct RunTotals {
  int camera_frames = 0;  // camera images that were present
  int64_t inliers = 0, outliers = 0;
  double sfd_sum = 0.0;
  int sfd_count = 0;
  // Final length of every track (feature id -> frames seen): the mean track
  // length of the paper counts how long features survive, not their age now.
  std::map<uint64_t, int> track_lengths;
  // Seconds per stage, summed over frames (and over cameras for the stages
  // that run per camera); write and total of this command's loop.
  FrontendStageSeconds stages;
  double write = 0.0, total = 0.0;
  int64_t cross_matches = 0;

  void Add(const FrontendItem& item) {
    const MultiCameraFrame& frame = item.frame;
    stages.Add(item);
    cross_matches += static_cast<int64_t>(frame.cross_matches.size());
    for (const CameraFrameResult& camera : frame.cameras) {
      const CameraFrameStats& s = camera.stats;
      if (s.image_missing) continue;
      ++camera_frames;
      inliers += s.ransac_inliers;
      outliers += s.ransac_outliers;
      if (!camera.features.empty()) {
        sfd_sum += s.sfd;
        ++sfd_count;
      }
      for (const TrackedFeature& f : camera.features) track_lengths[f.id] = f.track_length;
    }
  }
  double MeanTrackLength() const {
    if (track_lengths.empty()) return 0.0;
    double sum = 0.0;
    for (const auto& [id, length] : track_lengths) sum += length;
    return sum / static_cast<double>(track_lengths.size());
  }
  double InlierRatio() const {
    return inliers + outliers > 0 ? static_cast<double>(inliers) / static_cast<double>(inliers + outliers)
                                  : 0.0;
  }
  double MeanSfd() const { return sfd_count > 0 ? sfd_sum / sfd_count : 0.0; }
};

void AppendStatsRows(const MultiCameraFrame& frame, const Rig& rig, std::string* csv) {
  for (size_t c = 0; c < frame.cameras.size(); ++c) {
    const CameraFrameStats& s = frame.cameras[c].stats;
    *csv += StrCat(frame.frame_index, ",", frame.t_ns, ",", rig.cameras[c].name, ",", s.tracked, ",",
                   s.new_features, ",", s.ransac_inliers, ",", s.ransac_outliers, ",",
                   FormatDouble(s.mean_track_length), ",", FormatDouble(s.sfd), ",", s.image_missing ? 1 : 0,
                   ",", CountCrossCameraMatches(frame, static_cast<int>(c)), ",", s.lost_lk, ",",
                   s.lost_forward_backward, ",", s.lost_anchor, ",", s.untextured, "\n");
  }
}

// The --timing file: wall-clock numbers, so NOT deterministic (docs/track-format.md).
void WriteTiming(const std::filesystem::path& path, const RunTotals& t, const std::string& detector,
                 const std::string& selection, int cameras, int tracker_threads, int decode_threads) {
  const double n = std::max(1, t.stages.frames);
  nlohmann::ordered_json json;
  json["note"] =
      "wall-clock timings, not deterministic. Stage seconds are per rig frame, summed over cameras "
      "(the work of one frame on one core; cross_camera: summed over camera pairs); decode is the decoding "
      "of the images on the decoding threads (summed over cameras); clahe is the contrast equalisation "
      "before "
      "the pyramid; track_wall is the wall time of MultiCameraTracker::Track (cameras, then camera pairs, in "
      "parallel); decode_wait is the time "
      "the tracking thread was blocked waiting for decoded images (0 when the decoding threads keep up); "
      "write is the time of the writing thread, which runs beside the tracking thread; "
      "total is the wall time per frame.";
  json["detector"] = detector;
  json["selection"] = selection;
  json["frames"] = t.stages.frames;
  json["cameras"] = cameras;
  json["tracker_threads"] = tracker_threads;
  json["decode_threads"] = decode_threads;
  nlohmann::ordered_json seconds;
  for (const auto& [stage, value] : t.stages.PerFrame()) seconds[stage] = value;
  seconds["write"] = t.write / n;
  seconds["total"] = t.total / n;
  json["seconds_per_frame"] = seconds;
  nlohmann::ordered_json fps;
  for (const auto& [key, value] : seconds.items()) {
    fps[key] = value.get<double>() > 0.0 ? 1.0 / value.get<double>() : 0.0;
  }
  json["frames_per_second"] = fps;
  nlohmann::ordered_json quality;
  quality["tracks"] = t.track_lengths.size();
  quality["mean_track_length"] = t.MeanTrackLength();
  quality["inlier_ratio"] = t.InlierRatio();
  quality["mean_sfd"] = t.MeanSfd();
  quality["cross_camera_matches_per_frame"] = static_cast<double>(t.cross_matches) / n;
  json["quality"] = quality;
  WriteFileAtomic(path, io_internal::PrettyJson(json));
}

int RunTrack(int argc, const char* const* argv) {
  DatasetArgs dataset;
  std::string config_path, detector_name, model_path, selection_name, out_path, stats_path, timing_path;
  int threads = -1;
  int max_frames = 0;
  ArgParser args("mcvo track", "Tracks features through a whole sequence and writes a track file.");
  AddDatasetArgs(&args, &dataset, /*dataset_required=*/true);
  args.AddString("config", &config_path, "FILE",
                 "pipeline config (docs/config.md); default: built-in defaults");
  args.AddString("detector", &detector_name, "NAME",
                 "shi_tomasi | orb | xfeat | superpoint (overrides the config)");
  args.AddString("model", &model_path, "FILE", "ONNX model of xfeat / superpoint (overrides the config)");
  args.AddString("selection", &selection_name, "NAME",
                 "three_priority | quadtree | score (overrides the config)");
  args.AddInt("threads", &threads,
              "threads over cameras and for decoding; 0: all cores (overrides the config)");
  args.AddInt("frames", &max_frames, "track the first N frames only; 0: all");
  args.AddString("out", &out_path, "FILE", "track file to write (docs/track-format.md)", true);
  args.AddString("stats", &stats_path, "FILE", "per-frame, per-camera statistics CSV (docs/track-format.md)");
  args.AddString("timing", &timing_path, "FILE",
                 "per-stage seconds per frame and summary metrics as JSON (wall-clock: not deterministic)");
  args.AddEpilog(
      "The track file and the statistics are identical at any thread count.\n"
      "example: mcvo track --dataset seq/kitti360 --detector orb --out tracks.bin --stats stats.csv\n");
  if (!args.Parse(argc, argv)) return kExitOk;
  if (args.WasGiven("threads") && threads < 0) throw UsageError("--threads: must be >= 0");
  if (max_frames < 0) throw UsageError("--frames: must be >= 0");

  PipelineOptions options = config_path.empty() ? PipelineOptions() : ReadPipelineOptions(config_path);
  if (!detector_name.empty())
    options.frontend.detector = ParseEnumFlag(kDetectorTypeNames, "detector", detector_name);
  if (!selection_name.empty()) {
    options.frontend.selection = ParseEnumFlag(kFeatureSelectionNames, "selection", selection_name);
  }
  if (!model_path.empty()) options.frontend.model_path = model_path;
  if (threads >= 0) options.runtime.threads = threads;
  if (IsLearnedDetector(options.frontend.detector) && options.frontend.model_path.empty()) {
    throw UsageError(StrCat("--detector ", EnumToName(kDetectorTypeNames, options.frontend.detector),
                            " needs --model FILE (or /frontend/model_path in the config)"));
  }
  options.Check();
  const int worker_threads = ResolveThreads(options.runtime.threads);

  // The config's camera selection applies unless --cameras overrides it (as
  // in `mcvo run`, so a track file made with a preset replays with it).
  DatasetOptions dataset_options = MakeDatasetOptions(dataset);
  if (dataset_options.cameras.empty()) dataset_options.cameras = options.dataset.cameras;
  const DatasetIndex index = OpenDataset(dataset_options);
  CheckOptionsAgainstRig(options, index.rig,
                         config_path.empty() ? std::string("built-in defaults") : config_path);
  // Never written over or inside an input (util/output_folder.h).
  const std::vector<std::filesystem::path> inputs = {dataset_options.root, index.root, config_path,
                                                     options.frontend.model_path};
  CheckOutputFile(out_path, inputs, "--out");
  if (!stats_path.empty()) CheckOutputFile(stats_path, inputs, "--stats");
  if (!timing_path.empty()) CheckOutputFile(timing_path, inputs, "--timing");
  // Start-up: the frame source builds each camera's detector (model file
  // and layout checked here), before any image is decoded. It is `mcvo
  // run`'s: the frontend on a producer thread ahead of this one, which
  // writes the track file.
  const ScopedSerialOpenCv serial_opencv;  // mcvo's threads only (frontend/opencv_threads.h)
  FrameSource source(index, options.frontend, /*tracks=*/{}, worker_threads);
  const MultiCameraTracker& tracker = *source.tracker();
  const int descriptor_size = tracker.DescriptorSize();

  for (const std::string& line : index.log) MCVO_LOG(kInfo, "dataset: ", line);
  TrackFileHeader header;
  for (const Camera& camera : index.rig.cameras) header.camera_names.push_back(camera.name);
  header.descriptor_size = descriptor_size;
  header.descriptor_type = descriptor_size == 0 ? 0 : tracker.DescriptorType();
  header.detector = EnumToName(kDetectorTypeNames, options.frontend.detector);
  // The thread count does not change the result (and must not change the
  // file's bytes): the recorded config has runtime.threads = 0.
  PipelineOptions recorded = options;
  recorded.runtime.threads = 0;
  header.config_json = PipelineOptionsToJson(recorded);
  TrackFileWriter writer(out_path, header);
  std::optional<AtomicFileWriter> stats_file;
  if (!stats_path.empty()) stats_file.emplace(stats_path);
  // The timing file is written at the end; a folder that is not there is reported now.
  const std::filesystem::path timing_dir = std::filesystem::path(timing_path).parent_path();
  if (!timing_path.empty() && !timing_dir.empty() && !std::filesystem::is_directory(timing_dir)) {
    MCVO_THROW_INPUT(timing_path, ": folder ", timing_dir.string(), " does not exist");
  }
  std::string csv =
      "frame,t_ns,camera,tracked,new,ransac_inliers,ransac_outliers,mean_track_length,sfd,image_missing,"
      "cross_matches,lost_lk,lost_forward_backward,lost_anchor,untextured\n";

  const int total_frames = max_frames > 0 ? std::min<int>(max_frames, static_cast<int>(index.frames.size()))
                                          : static_cast<int>(index.frames.size());
  MCVO_LOG(kInfo, "track: ", index.name, " (", index.format, "), ", total_frames, " frames, ",
           index.rig.NumCameras(), " cameras, detector ", header.detector, ", selection ",
           EnumToName(kFeatureSelectionNames, options.frontend.selection), ", ", worker_threads, " threads");
  std::string pair_names;
  for (const auto& [a, b] : tracker.CrossCameraPairs()) {
    pair_names += StrCat(pair_names.empty() ? "" : ", ", index.rig.cameras[static_cast<size_t>(a)].name, "-",
                         index.rig.cameras[static_cast<size_t>(b)].name);
  }
  MCVO_LOG(kInfo, "track: cross-camera matching of ",
           pair_names.empty() ? std::string("no camera pairs") : "the pairs " + pair_names);
  ProgressBar progress("track", total_frames, "frames");
  RunTotals totals;
  const Clock::time_point run_start = Clock::now();
  source.Start(total_frames);
  while (std::optional<FrontendItem> item = source.Next()) {
    ThrowIfCancelled();
    const Clock::time_point start = Clock::now();
    writer.Write(item->frame);
    AppendStatsRows(item->frame, index.rig, &csv);
    totals.write += SecondsSince(start);
    totals.Add(*item);
    progress.Update(totals.stages.frames);
  }
  progress.Finish();
  totals.total = SecondsSince(run_start);
  writer.Commit();
  if (stats_file) {
    stats_file->stream() << csv;
    stats_file->Commit();
  }
  if (!timing_path.empty()) {
    WriteTiming(timing_path, totals, header.detector,
                EnumToName(kFeatureSelectionNames, options.frontend.selection), index.rig.NumCameras(),
                worker_threads, worker_threads);
  }
  MCVO_LOG(kInfo, "track: ", totals.stages.frames, " frames in ", FormatFixed(totals.total, 2), " s (",
           FormatFixed(totals.stages.frames / std::max(totals.total, 1e-9), 2), " fps); mean track length ",
           FormatFixed(totals.MeanTrackLength(), 2), " frames over ", totals.track_lengths.size(),
           " tracks; RANSAC inlier ratio ", FormatFixed(totals.InlierRatio(), 4), "; mean SFD ",
           FormatFixed(totals.MeanSfd(), 3), "; ",
           FormatFixed(static_cast<double>(totals.cross_matches) / std::max(1, totals.stages.frames), 1),
           " cross-camera matches per frame; wrote ", out_path);
  return kExitOk;
}

const CommandRegistrar kRegistrar("track",
                                  {"track features through a sequence and write a track file", RunTrack});

}  // namespace
}  // namespace mcvo::tools
