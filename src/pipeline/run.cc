#include "mcvo/pipeline/run.h"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "loop_stage.h"
#include "mcvo/config/option_bounds.h"
#include "mcvo/dataset/image_container.h"
#include "mcvo/eval/evaluate.h"
#include "mcvo/frontend/cross_camera.h"
#include "mcvo/frontend/opencv_threads.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/loop/vocabulary.h"
#include "mcvo/pipeline/frame_source.h"
#include "mcvo/util/cancel.h"
#include "mcvo/util/enum_names.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/output_folder.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/progress.h"
#include "mcvo/util/sha256.h"
#include "mcvo/util/strings.h"
#include "odometry_stage.h"
#include "refine_stage.h"
#include "relocalise_segments.h"
#include "run_outputs.h"

namespace mcvo {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A one-camera rig runs monocular, at an arbitrary scale (estimator.h
// "Monocular"), where the camera's lever arm to the rig origin, in metres,
// cannot be applied: the rig origin is moved to the camera's centre (its
// orientation kept), and the ground truth with it, so that the trajectory,
// the map and the evaluation are all of the camera's centre.
DatasetIndex MonocularIndex(DatasetIndex index) {
  Camera& camera = index.rig.cameras.front();
  const Eigen::Vector3d centre = camera.cam_from_rig.Inverse().translation;  // in the rig frame
  if (centre.norm() == 0.0) return index;
  index.log.push_back(StrCat("one camera: monocular at an arbitrary scale; the trajectory is of ",
                             camera.name, "'s centre (its lever arm of ", FormatFixed(centre.norm(), 3),
                             " m to the rig origin needs the metric scale), the ground truth moved with it"));
  camera.cam_from_rig.translation.setZero();
  index.origin_moved_to = centre;
  if (index.ground_truth) {
    const Rigid3d rig_from_centre(Eigen::Quaterniond::Identity(), centre);
    for (StampedPose& pose : index.ground_truth->poses)
      pose.world_from_body = pose.world_from_body * rig_from_centre;
  }
  return index;
}

// The dataset as seen by one of its cameras alone (the monocular fallback).
// With refined extrinsics (refine.refine_extrinsics) every output uses the
// refined rig (rig_refined.json, the COLMAP model's cameras): `posed` with
// them; nothing otherwise.
std::optional<DatasetIndex> IndexWithRefinedRig(const DatasetIndex& posed,
                                                const pipeline_internal::RefineOutcome& refine) {
  if (!refine.extrinsics_refined) return std::nullopt;
  DatasetIndex index = posed;
  for (size_t c = 0; c < index.rig.cameras.size() && c < refine.ba.cam_from_rig.size(); ++c) {
    index.rig.cameras[c].cam_from_rig = refine.ba.cam_from_rig[c];
  }
  return index;
}

DatasetIndex CameraOfIndex(const DatasetIndex& index, int camera) {
  DatasetIndex out = index;
  const size_t c = static_cast<size_t>(camera);
  out.rig.cameras = {index.rig.cameras[c]};
  for (DatasetFrame& frame : out.frames) frame.images = {frame.images[c]};
  if (c < index.masks.size()) out.masks = {index.masks[c]};
  out.log.clear();
  return out;
}

// The run's closing lines: frames, accuracy, the warning, where it went.
void LogRunSummary(const RunSummary& summary, const std::filesystem::path& out_dir) {
  MCVO_LOG(kInfo, "run: ", summary.frames, " frames (", summary.posed_frames, " posed, ", summary.keyframes,
           " keyframes, ", summary.segments, " segment(s)) in ", FormatFixed(summary.seconds, 2), " s (",
           FormatFixed(summary.frames_per_second, 2), " fps)");
  if (summary.evaluated && summary.scale_arbitrary) {
    MCVO_LOG(kInfo, "run: ATE rmse ", FormatFixed(summary.ate_rmse_m, 3), " m (",
             FormatFixed(summary.ate_percent_of_path, 3), " % of ", FormatFixed(summary.gt_path_length_m, 1),
             " m), arbitrary scale: 1 unit = ", FormatFixed(summary.unit_m, 4), " m (",
             EnumToName(kAlignmentModeNames, summary.alignment), " alignment)");
  } else if (summary.evaluated) {
    MCVO_LOG(kInfo, "run: ATE rmse ", FormatFixed(summary.ate_rmse_m, 3), " m (",
             FormatFixed(summary.ate_percent_of_path, 3), " % of ", FormatFixed(summary.gt_path_length_m, 1),
             " m), scale error ", FormatFixed(summary.scale_error_percent, 3), " % (",
             EnumToName(kAlignmentModeNames, summary.alignment), " alignment)");
  }
  if (!summary.warning.empty()) MCVO_LOG(kWarning, "run: ", summary.warning);
  MCVO_LOG(kInfo, "run: wrote ", out_dir.string());
}

// Every file and folder the run reads, for the output folder's check that
// --out is, contains or lies inside none of them: the dataset folder, the
// folders of its images (a frames.csv may list them anywhere), its masks,
// the config, the track file, the vocabulary and the detector's model.
std::vector<std::filesystem::path> RunInputPaths(const RunRequest& request, const DatasetIndex& index,
                                                 const std::filesystem::path& vocabulary) {
  std::vector<std::filesystem::path> inputs = {
      request.dataset.root, index.root, request.config_path,
      request.tracks,       vocabulary, std::filesystem::path(request.options.frontend.model_path)};
  std::set<std::filesystem::path> folders;
  for (const DatasetFrame& frame : index.frames) {
    for (const std::filesystem::path& image : frame.images) {
      if (!image.empty()) folders.insert(image.parent_path());
    }
  }
  inputs.insert(inputs.end(), folders.begin(), folders.end());
  for (const Camera& camera : index.rig.cameras) inputs.emplace_back(camera.mask_path);
  return inputs;
}

// Size and modification time of the files a run reads while it runs (the
// images of its frames, the track file), taken when they are hashed, before
// the run reads them, and compared after: a file changed in between is not
// what run.json's hash says was processed.
struct FileStamp {
  std::filesystem::path path;
  off_t size = -1;
  int64_t mtime_ns = -1;
  bool operator==(const FileStamp& other) const {
    return path == other.path && size == other.size && mtime_ns == other.mtime_ns;
  }
};

std::vector<FileStamp> StampRunFiles(const DatasetIndex& index, const std::filesystem::path& tracks,
                                     int frames) {
  std::vector<FileStamp> stamps;
  auto add = [&](const std::filesystem::path& path) {
    FileStamp stamp;
    stamp.path = path;
    struct stat info {};
    if (::stat(path.c_str(), &info) == 0) {
      stamp.size = info.st_size;
      stamp.mtime_ns = static_cast<int64_t>(info.st_mtim.tv_sec) * 1000000000 + info.st_mtim.tv_nsec;
    }
    stamps.push_back(stamp);
  };
  if (!tracks.empty()) {
    add(tracks);
    return stamps;
  }
  const int n = std::min(frames, static_cast<int>(index.frames.size()));
  for (int f = 0; f < n; ++f) {
    for (const std::filesystem::path& path : index.frames[f].images) {
      if (path.empty()) continue;
      const std::filesystem::path container = ImageContainerFile(path);  // a ROS bag's image: the bag
      add(container.empty() ? path : container);
    }
  }
  return stamps;
}

void CheckRunFilesUnchanged(const std::vector<FileStamp>& before, const DatasetIndex& index,
                            const std::filesystem::path& tracks, int frames) {
  const std::vector<FileStamp> after = StampRunFiles(index, tracks, frames);
  for (size_t i = 0; i < before.size() && i < after.size(); ++i) {
    if (!(before[i] == after[i])) {
      MCVO_THROW_INPUT(before[i].path.string(),
                       ": changed while the run read it (size or modification time); nothing was written, "
                       "run again on a dataset that stays as it is");
    }
  }
}

}  // namespace

DatasetIndex OpenRunDataset(const DatasetOptions& options) {
  DatasetIndex index = OpenDataset(options);
  return index.rig.NumCameras() == 1 ? MonocularIndex(std::move(index)) : index;
}

std::filesystem::path RunVocabularyPath(const PipelineOptions& options) {
  if (!options.loop.enabled) return {};
  return options.loop.vocabulary_path.empty() ? DefaultVocabularyPath() : options.loop.vocabulary_path;
}

std::vector<std::pair<std::string, std::string>> HashRunInputs(const DatasetIndex& index,
                                                               const std::filesystem::path& tracks,
                                                               int frames,
                                                               const std::filesystem::path& vocabulary,
                                                               int threads) {
  std::vector<std::pair<std::string, std::string>> inputs;
  inputs.emplace_back("rig_sha256", Sha256Hex(RigToJson(index.rig, index.root)));
  if (!tracks.empty()) {
    inputs.emplace_back("tracks_sha256", Sha256File(tracks));
  } else {
    // One hash over the per-image hashes, in frame and camera order; the
    // files are hashed on `threads` threads, each into its own slot.
    const int n = std::min(frames, static_cast<int>(index.frames.size()));
    std::vector<const std::filesystem::path*> paths;
    for (int f = 0; f < n; ++f) {
      for (const std::filesystem::path& path : index.frames[f].images) paths.push_back(&path);
    }
    std::vector<std::string> hashes(paths.size());
    ParallelFor(static_cast<int>(paths.size()), threads, [&](int i) {
      const std::filesystem::path& path = *paths[static_cast<size_t>(i)];
      // A ROS bag's image: the hash of its message's bytes (image_container.h).
      hashes[static_cast<size_t>(i)] = path.empty() ? std::string("missing") : Sha256OfImage(path);
    });
    Sha256 images;
    for (const std::string& hash : hashes) {
      images.Update(hash);
      images.Update("\n");
    }
    inputs.emplace_back("images_sha256", images.HexDigest());
  }
  inputs.emplace_back("dataset_sha256", HashDatasetContent(index, frames));
  if (!vocabulary.empty()) inputs.emplace_back("vocabulary_sha256", Sha256File(vocabulary));
  return inputs;
}

std::string HashDatasetContent(const DatasetIndex& index, int frames) {
  Sha256 hash;
  const int n = std::min(frames, static_cast<int>(index.frames.size()));
  hash.Update(StrCat("frames ", n, "\n"));
  for (int f = 0; f < n; ++f) {
    std::string line = std::to_string(index.frames[f].t_ns);
    for (const std::filesystem::path& path : index.frames[f].images) line += path.empty() ? " -" : " +";
    hash.Update(line + "\n");
  }
  if (index.ground_truth) {
    const Trajectory& gt = *index.ground_truth;
    hash.Update(StrCat("ground truth ", gt.poses.size(), " ", gt.has_time, " ", gt.has_frame_index, "\n"));
    for (const StampedPose& pose : gt.poses) {
      const Eigen::Quaterniond& q = pose.world_from_body.rotation;
      const Eigen::Vector3d& t = pose.world_from_body.translation;
      hash.Update(StrCat(pose.t_ns, " ", pose.frame_index, " ", FormatDouble(t.x()), " ", FormatDouble(t.y()),
                         " ", FormatDouble(t.z()), " ", FormatDouble(q.x()), " ", FormatDouble(q.y()), " ",
                         FormatDouble(q.z()), " ", FormatDouble(q.w()), "\n"));
    }
  }
  for (size_t c = 0; c < index.masks.size(); ++c) {
    const cv::Mat& mask = index.masks[c];
    hash.Update(StrCat("mask ", c, " ", mask.cols, "x", mask.rows, " ", mask.type(), "\n"));
    for (int row = 0; row < mask.rows; ++row) {
      hash.Update(
          std::string_view(reinterpret_cast<const char*>(mask.ptr(row)), mask.cols * mask.elemSize()));
    }
  }
  return hash.HexDigest();
}

std::string PosingFailureCategory(const std::string& reason) {
  auto has = [&](const char* text) { return reason.find(text) != std::string::npos; };
  if (has("parallax")) {
    return "too little parallax for the initializer (the rig stood or crept, or all it tracked was far)";
  }
  if (has("pure translation") || has("not observable") || has("poorly observable"))
    return kScaleNeverObservable;
  if (has("rig pose failed") || has("tracking lost")) return "tracking lost";
  if (has("correspondences")) return "too few tracked features";
  if (has("too few cameras pass")) return "too few cameras track enough features with enough parallax";
  if (reason.empty() || has("window")) return "too few frames to initialise";
  return reason;
}

std::string MostFrequentPosingFailure(const std::vector<std::string>& unposed_reasons) {
  std::map<std::string, int> counts;
  for (const std::string& reason : unposed_reasons) ++counts[PosingFailureCategory(reason)];
  std::string top = "unknown";
  int best = 0;
  for (const auto& [text, n] : counts) {
    if (n > best) {
      best = n;
      top = text;
    }
  }
  return top;
}

std::string RunPosingWarning(int frames, int posed, const std::vector<std::string>& unposed_reasons) {
  if (frames <= 0 || 2 * posed >= frames) return {};
  const std::string head =
      StrCat(posed == 0 ? "no frame posed" : StrCat("only ", posed, " of ", frames, " frames posed"), " (",
             FormatFixed(100.0 * posed / frames, 1), " %): ");
  return head + MostFrequentPosingFailure(unposed_reasons);
}

namespace {

// Every camera that /initializer/required_cameras names is in the rig.
void CheckRequiredCameras(const RunRequest& request, const DatasetIndex& index) {
  for (const std::string& name : request.options.initializer.required_cameras) {
    if (index.rig.FindCamera(name) < 0) {
      MCVO_THROW_INPUT(request.config_source, ": /initializer/required_cameras: camera \"", name,
                       "\" is not in the rig of ", index.root.string());
    }
  }
}

}  // namespace

// `mcvo run` as a sequence of stages: open the dataset and check the
// request; the frame source (frame_source.h) feeding the odometry stage
// (odometry_stage.h); relocalisation after tracking losses
// (relocalise_segments.h); loop closure (loop_stage.h); the outputs
// (run_outputs.h) written into a staging folder that is renamed onto the
// output folder when complete.
RunSummary RunPipeline(const RunRequest& request) {
  const ScopedSerialOpenCv serial_opencv;  // mcvo's threads only (frontend/opencv_threads.h)
  const PipelineOptions& options = request.options;
  options.Check();
  DatasetOptions dataset_options = request.dataset;
  if (dataset_options.cameras.empty()) dataset_options.cameras = options.dataset.cameras;
  const DatasetIndex index = OpenRunDataset(dataset_options);
  CheckOptionsAgainstRig(options, index.rig, request.config_source);
  const bool monocular = index.rig.NumCameras() == 1;
  const Rig& rig = index.rig;
  const int threads = ResolveThreads(options.runtime.threads);
  CheckRequiredCameras(request, index);
  const std::filesystem::path vocabulary_path = RunVocabularyPath(options);
  // The output folder (util/output_folder.h): checked against the inputs,
  // locked, written in a staging folder that moves into place when complete.
  OutputFolderOptions out_options;
  out_options.force = request.force;
  out_options.kind = "run";
  out_options.inputs = RunInputPaths(request, index, vocabulary_path);
  OutputFolder out(request.out_dir, out_options);
  const std::filesystem::path& absolute_out = out.path();

  // Frame source and vocabulary, set up before anything is decoded so that a
  // bad model, a mismatched track file or a bad vocabulary fail at start-up.
  // Loop closure describes the keyframes from the frontend's decode when it
  // tracks images (loop_image_cache.h).
  const bool keep_images = options.loop.enabled && request.tracks.empty();
  FrameSource source(index, options.frontend, request.tracks, threads, keep_images);
  std::optional<Vocabulary> vocabulary;
  std::optional<pipeline_internal::RunLoopStage> loop_stage;
  if (options.loop.enabled) {
    vocabulary = Vocabulary::Load(vocabulary_path);
    loop_stage.emplace(index, *vocabulary, options, keep_images, threads);
  }

  const int total_frames = request.max_frames > 0
                               ? std::min<int>(request.max_frames, static_cast<int>(index.frames.size()))
                               : static_cast<int>(index.frames.size());
  // The inputs as run.json records them, hashed before anything reads them.
  const std::vector<std::pair<std::string, std::string>> input_hashes =
      HashRunInputs(index, request.tracks, total_frames, vocabulary_path, threads);
  const std::vector<FileStamp> input_stamps = StampRunFiles(index, request.tracks, total_frames);
  ThrowIfCancelled();
  for (const std::string& line : index.log) MCVO_LOG(kInfo, "dataset: ", line);
  MCVO_LOG(kInfo, "run: ", index.name, " (", index.format, "), ", total_frames, " frames, ", rig.NumCameras(),
           " cameras, ", request.tracks.empty() ? "tracking images" : "replaying " + request.tracks.string(),
           ", ", threads, " threads");

  // Odometry: the frontend on its own thread, the estimator in frame order.
  source.Start(total_frames);
  pipeline_internal::OdometryStage odometry_stage(rig, options, threads);
  RunSummary summary;
  ProgressBar progress("run", total_frames, "frames");
  const Clock::time_point run_start = Clock::now();
  FrontendStageSeconds frontend_stages;
  while (std::optional<FrontendItem> item = source.Next()) {
    frontend_stages.Add(*item);
    odometry_stage.Add(ToObservations(rig, item->frame), item->seconds);
    if (loop_stage) {
      loop_stage->AddFrame(item->frame.frame_index, std::move(item->images), std::move(item->decoded),
                           odometry_stage);
    }
    ++summary.frames;
    progress.Update(summary.frames);
    ThrowIfCancelled();
  }
  progress.Finish();
  pipeline_internal::OdometryOutput odometry = odometry_stage.Finish();
  // After the monocular fallback (odometry_stage.cc) everything is of the
  // one camera it used: the map, the evaluation, the outputs.
  std::optional<DatasetIndex> fallback_index;
  if (odometry.monocular_camera >= 0) {
    fallback_index = MonocularIndex(CameraOfIndex(index, odometry.monocular_camera));
    for (const std::string& line : fallback_index->log) {
      if (line.rfind("one camera", 0) == 0) MCVO_LOG(kInfo, "dataset: ", line);
    }
  }
  const DatasetIndex& posed = fallback_index ? *fallback_index : index;
  summary.scale_arbitrary = monocular || fallback_index.has_value();
  // After a tracking loss: the new segment located in the old one's map.
  pipeline_internal::RelocalisationSummary relocalisation;
  if (vocabulary) {
    relocalisation =
        pipeline_internal::RelocaliseSegments(posed, *vocabulary, options.loop, threads, &odometry);
  }
  const double odometry_seconds = SecondsSince(run_start);
  ThrowIfCancelled();

  // Loop closure, then every pose and landmark moved with its keyframe's correction.
  pipeline_internal::LoopOutcome loops;
  pipeline_internal::OdometryBeforeLoops before_loops;
  if (loop_stage) {
    loops = loop_stage->Close(posed, odometry, summary.scale_arbitrary);
    loop_stage.reset();
    before_loops = pipeline_internal::ApplyLoopCorrection(loops, &odometry);
  }
  summary.loops_accepted = loops.accepted;
  ThrowIfCancelled();
  int map_observations_dropped = 0;
  SparseMap map = pipeline_internal::BuildSparseMap(posed, odometry.keyframes, odometry.landmarks,
                                                    options.backend, &map_observations_dropped);
  // Global refinement: one rig bundle adjustment over the whole map.
  const pipeline_internal::RefineOutcome refine = pipeline_internal::RefineGlobally(
      posed.rig, options.refine, &loops, options.loop.pose_graph, summary.scale_arbitrary, &map, &odometry);
  ThrowIfCancelled();
  summary.seconds = SecondsSince(run_start);
  summary.frames_per_second = summary.seconds > 0 ? summary.frames / summary.seconds : 0.0;
  summary.posed_frames = static_cast<int>(odometry.poses.size());
  summary.keyframes = static_cast<int>(odometry.keyframes.size());
  summary.segments = odometry.segments;
  summary.segments_relocalised = relocalisation.applied;
  std::vector<std::string> unposed_reasons;
  for (const pipeline_internal::FrameRecord& record : odometry.records) {
    if (odometry.poses.count(record.estimate.frame_index) == 0) {
      unposed_reasons.push_back(record.estimate.waiting_reason);
    }
  }
  summary.warning = RunPosingWarning(summary.frames, summary.posed_frames, unposed_reasons);

  // Outputs, then the finished folder moved into place.
  pipeline_internal::RunOutputsInput outputs;
  outputs.request = &request;
  const std::optional<DatasetIndex> refined_rig_index = IndexWithRefinedRig(posed, refine);
  outputs.index = refined_rig_index ? &*refined_rig_index : &posed;
  outputs.opened = &index;
  outputs.threads = threads;
  outputs.total_frames = total_frames;
  outputs.vocabulary_path = vocabulary_path;
  outputs.final_dir = absolute_out;
  outputs.odometry = &odometry;
  outputs.loops = vocabulary ? &loops : nullptr;
  outputs.before_loops = &before_loops;
  outputs.refine = &refine;
  outputs.map = &map;
  outputs.map_observations_dropped = map_observations_dropped;
  outputs.odometry_seconds = odometry_seconds;
  if (request.tracks.empty()) outputs.frontend_stages = &frontend_stages;
  outputs.inputs = &input_hashes;
  pipeline_internal::WriteRunOutputs(outputs, out.staging(), &summary);
  CheckRunFilesUnchanged(input_stamps, index, request.tracks, total_frames);
  ThrowIfCancelled();
  out.Commit();

  LogRunSummary(summary, absolute_out);
  return summary;
}

}  // namespace mcvo
