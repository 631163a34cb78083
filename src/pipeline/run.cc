#include "mcvo/pipeline/run.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <utility>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mcvo/backend/estimator.h"
#include "mcvo/colmap/colmap_model.h"
#include "mcvo/config/config.h"
#include "mcvo/eval/report.h"
#include "mcvo/eval/report_html.h"
#include "mcvo/frontend/multi_camera_tracker.h"
#include "mcvo/frontend/track_file.h"
#include "mcvo/io/json_util.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/io/trajectory_io.h"
#include "mcvo/loop/loop_closer.h"
#include "mcvo/loop/pose_graph.h"
#include "mcvo/loop/vocabulary.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/logging.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/progress.h"
#include "mcvo/util/sha256.h"
#include "mcvo/util/strings.h"
#include "odometry_stage.h"
#include "relocalise_segments.h"

namespace mcvo {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A frame from the frontend (tracked now, or read from a track file) and the
// wall time it took.
struct FrontendItem {
  MultiCameraFrame frame;
  double seconds = 0.0;
};

// Single-producer single-consumer queue with a bounded size; the producer's
// exception is handed to the consumer.
class FrameQueue {
 public:
  explicit FrameQueue(size_t capacity) : capacity_(capacity) {}

  void Push(FrontendItem item) {
    std::unique_lock<std::mutex> lock(mutex_);
    not_full_.wait(lock, [&] { return items_.size() < capacity_ || cancelled_; });
    if (cancelled_) return;
    items_.push_back(std::move(item));
    not_empty_.notify_one();
  }
  void Close(std::exception_ptr error) {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
    error_ = std::move(error);
    not_empty_.notify_one();
  }
  void Cancel() {
    std::lock_guard<std::mutex> lock(mutex_);
    cancelled_ = true;
    not_full_.notify_all();
  }
  bool cancelled() {
    std::lock_guard<std::mutex> lock(mutex_);
    return cancelled_;
  }
  // The next item; nullopt at the end. Rethrows the producer's exception.
  std::optional<FrontendItem> Pop() {
    std::unique_lock<std::mutex> lock(mutex_);
    not_empty_.wait(lock, [&] { return !items_.empty() || closed_; });
    if (!items_.empty()) {
      FrontendItem item = std::move(items_.front());
      items_.pop_front();
      not_full_.notify_one();
      return item;
    }
    if (error_) std::rethrow_exception(error_);
    return std::nullopt;
  }

 private:
  const size_t capacity_;
  std::mutex mutex_;
  std::condition_variable not_full_, not_empty_;
  std::deque<FrontendItem> items_;
  bool closed_ = false;
  bool cancelled_ = false;
  std::exception_ptr error_;
};

RigFrameObservations ToObservations(const Rig& rig, const MultiCameraFrame& frame) {
  RigFrameObservations obs;
  obs.frame_index = frame.frame_index;
  obs.t_ns = frame.t_ns;
  const int n = rig.NumCameras();
  obs.cameras.resize(n);
  obs.camera_missing.assign(n, false);
  for (int c = 0; c < n; ++c) {
    const CameraFrameResult& camera = frame.cameras[c];
    obs.camera_missing[c] = camera.stats.image_missing;
    obs.cameras[c].reserve(camera.features.size());
    for (const TrackedFeature& f : camera.features) {
      const Eigen::Vector2d pixel = f.pixel.cast<double>();
      const std::optional<Eigen::Vector3d> bearing = rig.cameras[c].Unproject(pixel);
      if (!bearing) continue;
      obs.cameras[c].push_back({f.id, pixel, bearing->normalized()});
    }
  }
  for (const CrossCameraMatch& m : frame.cross_matches) {
    const Eigen::Vector2d pixel = m.pixel_b.cast<double>();
    const std::optional<Eigen::Vector3d> bearing = rig.cameras[m.camera_b].Unproject(pixel);
    if (!bearing) continue;
    obs.cross_camera.push_back({m.camera_a, m.id_a, m.camera_b, pixel, bearing->normalized()});
  }
  return obs;
}

void CheckOutputFolder(const std::filesystem::path& out_dir, bool force) {
  std::error_code ec;
  if (std::filesystem::exists(out_dir, ec)) {
    if (!std::filesystem::is_directory(out_dir, ec))
      MCVO_THROW_INPUT(out_dir.string(), ": exists and is not a folder");
    if (!std::filesystem::is_empty(out_dir, ec) && !force) {
      MCVO_THROW_INPUT(out_dir.string(), ": folder exists and is not empty (use --force to replace it)");
    }
  }
}

// The run's sparse map: keyframes in frame order with their images and the
// observations of landmarks that have a final position and lie within
// kMapMaxErrorFactor x the back end's outlier threshold of it, measured as
// the back end does (the angle between the observed bearing and the
// direction to the landmark, in pixels at the virtual focal length); the
// landmarks they observe, in id order. The filter matters: an observation is
// recorded when its keyframe leaves the window, and the landmark goes on
// being refined after that (a track that slid onto another point is
// re-triangulated from its later observations).
constexpr double kMapMaxErrorFactor = 2.0;
SparseMap BuildSparseMap(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                         const std::map<int64_t, Eigen::Vector3d>& landmarks, const BackendOptions& backend,
                         int* dropped) {
  const Rig& rig = index.rig;
  const double max_angle_rad = kMapMaxErrorFactor * backend.outlier_threshold_px / backend.virtual_focal_px;
  *dropped = 0;
  SparseMap map;
  std::set<int64_t> observed;
  for (const KeyframeEstimate& kf : keyframes) {
    MapKeyframe out;
    out.frame_index = kf.frame_index;
    out.t_ns = kf.t_ns;
    out.segment = kf.segment;
    out.world_from_rig = kf.world_from_rig;
    if (kf.frame_index >= 0 && kf.frame_index < static_cast<int>(index.frames.size())) {
      // Absolute: the dataset's paths include its root, which may be relative.
      for (const std::filesystem::path& image : index.frames[static_cast<size_t>(kf.frame_index)].images) {
        out.images.push_back(image.empty() ? image : std::filesystem::absolute(image).lexically_normal());
      }
    }
    for (const MapObservation& ob : kf.observations) {
      auto landmark = landmarks.find(ob.landmark_id);
      if (landmark == landmarks.end()) continue;
      const Camera& camera = rig.cameras[static_cast<size_t>(ob.camera)];
      const Rigid3d cam_from_world = camera.cam_from_rig * kf.world_from_rig.Inverse();
      const std::optional<Eigen::Vector3d> bearing = camera.Unproject(ob.pixel);
      const Eigen::Vector3d direction = (cam_from_world * landmark->second).normalized();
      const double angle =
          bearing ? std::acos(std::clamp(bearing->normalized().dot(direction), -1.0, 1.0)) : M_PI;
      if (!(angle <= max_angle_rad)) {
        ++*dropped;
        continue;
      }
      out.observations.push_back(ob);
      observed.insert(ob.landmark_id);
    }
    map.keyframes.push_back(std::move(out));
  }
  std::stable_sort(map.keyframes.begin(), map.keyframes.end(),
                   [](const MapKeyframe& a, const MapKeyframe& b) { return a.frame_index < b.frame_index; });
  for (const auto& [id, position] : landmarks) {
    if (observed.count(id) != 0) map.landmarks.push_back({id, position});
  }
  return map;
}

// Loop closure over the finished keyframes (in frame order): each keyframe
// goes into the bag-of-words database with its images and landmarks and is
// verified against earlier places; accepted loops and the odometry between
// consecutive keyframes form the pose graph.
struct LoopOutcome {
  std::vector<LoopAttempt> attempts;
  int verified = 0;
  int accepted = 0;
  bool applied = false;                 // the pose graph ran and its result is used
  std::vector<Rigid3d> keyframe_after;  // per keyframe (== before when not applied)
  PoseGraphResult graph;
  LoopTiming timing;
  double image_seconds = 0.0;
  double pose_graph_seconds = 0.0;
};

LoopOutcome CloseLoops(const DatasetIndex& index, const std::vector<KeyframeEstimate>& keyframes,
                       const Vocabulary& vocabulary, const LoopOptions& options, int threads) {
  LoopOutcome out;
  const Rig& rig = index.rig;
  LoopCloser closer(rig, index.masks, vocabulary, options.closure, threads);
  for (const KeyframeEstimate& kf : keyframes) {
    const LoopKeyframe lk = pipeline_internal::ToLoopKeyframe(index, kf, threads, &out.image_seconds);
    for (LoopAttempt& attempt : closer.AddKeyframe(lk)) {
      out.verified += attempt.verified ? 1 : 0;
      out.accepted += attempt.accepted ? 1 : 0;
      out.attempts.push_back(std::move(attempt));
    }
  }
  out.timing = closer.timing();
  for (const KeyframeEstimate& kf : keyframes) out.keyframe_after.push_back(kf.world_from_rig);
  if (out.accepted == 0) return out;

  std::vector<PoseGraphEdge> edges;
  for (size_t k = 1; k < keyframes.size(); ++k) {
    PoseGraphEdge edge;
    edge.from = static_cast<int>(k - 1);
    edge.to = static_cast<int>(k);
    edge.from_T_to = keyframes[k - 1].world_from_rig.Inverse() * keyframes[k].world_from_rig;
    edges.push_back(edge);
  }
  for (const LoopAttempt& attempt : out.attempts) {
    if (!attempt.accepted) continue;
    PoseGraphEdge edge;
    edge.from = attempt.candidate;
    edge.to = attempt.query;
    edge.from_T_to = attempt.candidate_from_query;
    edge.loop = true;
    edges.push_back(edge);
  }
  const Clock::time_point start = Clock::now();
  out.graph = OptimizePoseGraph(out.keyframe_after, edges, options.pose_graph);
  out.pose_graph_seconds = SecondsSince(start);
  if (out.graph.ok) {
    out.keyframe_after = out.graph.world_from_node;
    out.applied = true;
  } else {
    MCVO_LOG(kWarning, "run: loop closure: pose graph failed (", out.graph.reason,
             "); trajectory left as is");
  }
  return out;
}

std::string LoopsCsv(const std::vector<LoopAttempt>& attempts) {
  std::string csv =
      "query_keyframe,query_frame,candidate_keyframe,candidate_frame,score,normalized_score,matches,inliers,"
      "cameras_with_inliers,verified,accepted,correction_m,correction_deg,reason\n";
  for (const LoopAttempt& a : attempts) {
    csv += StrCat(a.query, ",", a.query_frame, ",", a.candidate, ",", a.candidate_frame, ",",
                  FormatDouble(a.score), ",", FormatDouble(a.normalized_score), ",", a.matches, ",",
                  a.inliers, ",", a.cameras_with_inliers, ",", a.verified ? 1 : 0, ",", a.accepted ? 1 : 0,
                  ",", FormatDouble(a.correction_m), ",", FormatDouble(a.correction_deg), ",",
                  CsvQuote(a.reason), "\n");
  }
  return csv;
}

}  // namespace

std::filesystem::path RunVocabularyPath(const PipelineOptions& options) {
  if (!options.loop.enabled) return {};
  return options.loop.vocabulary_path.empty() ? DefaultVocabularyPath() : options.loop.vocabulary_path;
}

std::vector<std::pair<std::string, std::string>> HashRunInputs(const DatasetIndex& index,
                                                               const std::filesystem::path& tracks,
                                                               int frames,
                                                               const std::filesystem::path& vocabulary) {
  std::vector<std::pair<std::string, std::string>> inputs;
  inputs.emplace_back("rig_sha256", Sha256Hex(RigToJson(index.rig, index.root)));
  if (!tracks.empty()) {
    inputs.emplace_back("tracks_sha256", Sha256File(tracks));
  } else {
    // One hash over the per-image hashes, in frame and camera order.
    Sha256 images;
    const int n = std::min(frames, static_cast<int>(index.frames.size()));
    for (int f = 0; f < n; ++f) {
      for (const std::filesystem::path& path : index.frames[f].images) {
        images.Update(path.empty() ? std::string("missing") : Sha256File(path));
        images.Update("\n");
      }
    }
    inputs.emplace_back("images_sha256", images.HexDigest());
  }
  if (!vocabulary.empty()) inputs.emplace_back("vocabulary_sha256", Sha256File(vocabulary));
  return inputs;
}

std::string RunPosingWarning(int frames, int posed, int cameras,
                             const std::vector<std::string>& unposed_reasons) {
  if (frames <= 0 || 2 * posed >= frames) return {};
  const std::string head =
      StrCat(posed == 0 ? "no frame posed" : StrCat("only ", posed, " of ", frames, " frames posed"), " (",
             FormatFixed(100.0 * posed / frames, 1), " %): ");
  if (cameras == 1) return head + "one camera: the metric scale is not observable (no monocular mode yet)";
  // Each waiting reason in a category a user can act on; the most frequent wins.
  auto category = [](const std::string& reason) -> std::string {
    auto has = [&](const char* text) { return reason.find(text) != std::string::npos; };
    if (has("one camera")) return "one camera: the metric scale is not observable";
    if (has("parallax")) return "the rig never moved enough for the initializer (parallax too small)";
    if (has("pure translation") || has("not observable") || has("poorly observable"))
      return "the metric scale was never observable (the rig did not turn and no cameras overlap)";
    if (has("rig pose failed") || has("tracking lost")) return "tracking lost";
    if (has("correspondences")) return "too few tracked features";
    if (has("too few cameras pass")) return "too few cameras track enough features with enough parallax";
    if (reason.empty() || has("window")) return "too few frames to initialise";
    return reason;
  };
  std::map<std::string, int> counts;
  for (const std::string& reason : unposed_reasons) ++counts[category(reason)];
  std::string top = "unknown";
  int best = 0;
  for (const auto& [text, n] : counts) {
    if (n > best) {
      best = n;
      top = text;
    }
  }
  return head + top;
}

RunSummary RunPipeline(const RunRequest& request) {
  const PipelineOptions& options = request.options;
  options.Check();
  CheckOutputFolder(request.out_dir, request.force);
  DatasetOptions dataset_options = request.dataset;
  if (dataset_options.cameras.empty()) dataset_options.cameras = options.dataset.cameras;
  const DatasetIndex index = OpenDataset(dataset_options);
  const Rig& rig = index.rig;
  const int threads = ResolveThreads(options.runtime.threads);
  for (const std::string& name : options.initializer.required_cameras) {
    if (rig.FindCamera(name) < 0) {
      MCVO_THROW_INPUT(request.config_source, ": /initializer/required_cameras: camera \"", name,
                       "\" is not in the rig of ", index.root.string());
    }
  }

  // Frame source, set up before anything is decoded so that a bad model or
  // a mismatched track file is reported at start-up.
  std::unique_ptr<TrackFileReader> track_reader;
  std::unique_ptr<MultiCameraTracker> tracker;
  if (!request.tracks.empty()) {
    track_reader = std::make_unique<TrackFileReader>(request.tracks);
    const auto& names = track_reader->header().camera_names;
    std::vector<std::string> rig_names;
    for (const Camera& camera : rig.cameras) rig_names.push_back(camera.name);
    if (names != rig_names) {
      std::string have, want;
      for (const auto& n : names) have += (have.empty() ? "" : ",") + n;
      for (const auto& n : rig_names) want += (want.empty() ? "" : ",") + n;
      MCVO_THROW_INPUT(request.tracks.string(), ": cameras [", have, "] do not match the dataset's [", want,
                       "] (use --cameras to select the same cameras)");
    }
  } else {
    tracker = std::make_unique<MultiCameraTracker>(rig, index.masks, options.frontend, threads);
  }
  // Loop closure's vocabulary, read now so that a bad file stops the run
  // before any work.
  const std::filesystem::path vocabulary_path = RunVocabularyPath(options);
  std::optional<Vocabulary> vocabulary;
  if (options.loop.enabled) vocabulary = Vocabulary::Load(vocabulary_path);

  // Staging folder, renamed onto out_dir when everything is written.
  const std::filesystem::path absolute_out = std::filesystem::absolute(request.out_dir).lexically_normal();
  CreateDirectories(absolute_out.parent_path());
  TemporaryFolder staging(absolute_out.parent_path() /
                          (absolute_out.filename().string() + ".tmp-" + std::to_string(::getpid())));
  std::error_code ec;
  std::filesystem::remove_all(staging.path(), ec);
  CreateDirectories(staging.path());

  const int total_frames = request.max_frames > 0
                               ? std::min<int>(request.max_frames, static_cast<int>(index.frames.size()))
                               : static_cast<int>(index.frames.size());
  for (const std::string& line : index.log) MCVO_LOG(kInfo, "dataset: ", line);
  MCVO_LOG(kInfo, "run: ", index.name, " (", index.format, "), ", total_frames, " frames, ", rig.NumCameras(),
           " cameras, ", request.tracks.empty() ? "tracking images" : "replaying " + request.tracks.string(),
           ", ", threads, " threads");

  // Producer: the frontend on its own thread, one bounded queue ahead.
  FrameQueue queue(4);
  std::thread producer([&] {
    std::exception_ptr error;
    try {
      if (track_reader) {
        int produced = 0;
        while (produced < total_frames && !queue.cancelled()) {
          const Clock::time_point start = Clock::now();
          std::optional<MultiCameraFrame> frame = track_reader->Next();
          if (!frame) break;
          queue.Push({std::move(*frame), SecondsSince(start)});
          ++produced;
        }
      } else {
        FrameStreamOptions stream_options;
        stream_options.threads = threads;
        FrameStream stream(index, stream_options);
        int produced = 0;
        while (produced < total_frames && !queue.cancelled()) {
          const Clock::time_point start = Clock::now();
          std::optional<FrameImages> images = stream.Next();
          if (!images) break;
          MultiCameraFrame frame = tracker->Track(images->index, images->t_ns, images->images);
          queue.Push({std::move(frame), SecondsSince(start)});
          ++produced;
        }
      }
    } catch (...) {
      error = std::current_exception();
    }
    queue.Close(error);
  });
  struct JoinOnExit {
    std::thread* thread;
    FrameQueue* queue;
    ~JoinOnExit() {
      queue->Cancel();
      if (thread->joinable()) thread->join();
    }
  } join_on_exit{&producer, &queue};

  // Consumer: the odometry stage, in frame order.
  pipeline_internal::OdometryStage odometry_stage(rig, options, threads);
  RunSummary summary;
  ProgressBar progress("run", total_frames, "frames");
  const Clock::time_point run_start = Clock::now();
  while (std::optional<FrontendItem> item = queue.Pop()) {
    odometry_stage.Add(ToObservations(rig, item->frame), item->seconds);
    ++summary.frames;
    progress.Update(summary.frames);
  }
  progress.Finish();
  pipeline_internal::OdometryOutput odometry = odometry_stage.Finish();
  // After a tracking loss: the new segment located in the old one's map.
  pipeline_internal::RelocalisationSummary relocalisation;
  if (vocabulary) {
    relocalisation =
        pipeline_internal::RelocaliseSegments(index, *vocabulary, options.loop, threads, &odometry);
  }
  std::map<int, StampedPose>& poses = odometry.poses;
  std::vector<KeyframeEstimate>& keyframes = odometry.keyframes;
  std::map<int64_t, Eigen::Vector3d>& landmarks = odometry.landmarks;
  const std::vector<ScaleLogEntry>& scale_log = odometry.scale_log;
  const std::map<int, int>& reverse_posed = odometry.reverse_posed;
  const pipeline_internal::StageSeconds& totals = odometry.totals;
  const std::string stats_csv = pipeline_internal::FrameStatsCsv(rig, odometry);
  const std::string timing_csv = pipeline_internal::TimingCsv(odometry);
  const double vo_seconds = SecondsSince(run_start);

  // Loop closure, then every pose and landmark moved with its keyframe's
  // correction.
  LoopOutcome loops;
  if (vocabulary) loops = CloseLoops(index, keyframes, *vocabulary, options.loop, threads);
  if (vocabulary) {
    MCVO_LOG(kInfo, "run: loop closure: ", keyframes.size(), " keyframes, ", loops.verified,
             " candidates verified, ", loops.accepted, " loop(s) accepted",
             loops.applied ? ", pose graph applied" : "");
  }
  summary.loops_accepted = loops.accepted;
  std::map<int, StampedPose> poses_vo;
  std::vector<KeyframeEstimate> keyframes_vo;
  if (loops.applied) {
    poses_vo = poses;
    keyframes_vo = keyframes;
    std::vector<int64_t> node_t_ns;
    std::vector<Rigid3d> node_before;
    for (const KeyframeEstimate& kf : keyframes) {
      node_t_ns.push_back(kf.t_ns);
      node_before.push_back(kf.world_from_rig);
    }
    std::vector<int64_t> pose_t_ns;
    std::vector<Rigid3d> pose_before;
    for (const auto& [frame_index, pose] : poses) {
      pose_t_ns.push_back(pose.t_ns);
      pose_before.push_back(pose.world_from_body);
    }
    const std::vector<Rigid3d> pose_after =
        CorrectPoses(node_t_ns, node_before, loops.keyframe_after, pose_t_ns, pose_before);
    size_t k = 0;
    for (auto& [frame_index, pose] : poses) pose.world_from_body = pose_after[k++];
    // A landmark moves with the last keyframe that observed it (its final
    // position was estimated while that keyframe was in the window).
    std::map<int64_t, size_t> last_observer;
    for (size_t i = 0; i < keyframes.size(); ++i) {
      for (const MapObservation& ob : keyframes[i].observations) last_observer[ob.landmark_id] = i;
    }
    for (auto& [id, position] : landmarks) {
      auto it = last_observer.find(id);
      if (it == last_observer.end()) continue;
      position = loops.keyframe_after[it->second] * (node_before[it->second].Inverse() * position);
    }
    for (size_t i = 0; i < keyframes.size(); ++i) keyframes[i].world_from_rig = loops.keyframe_after[i];
  }
  int map_observations_dropped = 0;
  const SparseMap map =
      BuildSparseMap(index, keyframes, landmarks, options.backend, &map_observations_dropped);
  summary.seconds = SecondsSince(run_start);
  summary.frames_per_second = summary.seconds > 0 ? summary.frames / summary.seconds : 0.0;
  summary.posed_frames = static_cast<int>(poses.size());
  summary.keyframes = static_cast<int>(keyframes.size());
  summary.segments = odometry.segments;
  summary.segments_relocalised = relocalisation.applied;
  {
    std::vector<std::string> unposed_reasons;
    for (const pipeline_internal::FrameRecord& record : odometry.records) {
      if (poses.count(record.estimate.frame_index) == 0)
        unposed_reasons.push_back(record.estimate.waiting_reason);
    }
    summary.warning =
        RunPosingWarning(summary.frames, summary.posed_frames, rig.NumCameras(), unposed_reasons);
  }

  // Outputs.
  Trajectory trajectory;
  trajectory.has_time = true;
  trajectory.has_frame_index = true;
  for (const auto& [frame_index, pose] : poses) trajectory.poses.push_back(pose);
  Trajectory keyframe_trajectory;
  keyframe_trajectory.has_time = true;
  keyframe_trajectory.has_frame_index = true;
  for (const KeyframeEstimate& kf : keyframes) {
    StampedPose pose;
    pose.t_ns = kf.t_ns;
    pose.frame_index = kf.frame_index;
    pose.world_from_body = kf.world_from_rig;
    keyframe_trajectory.poses.push_back(pose);
  }
  std::sort(keyframe_trajectory.poses.begin(), keyframe_trajectory.poses.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.frame_index < b.frame_index; });
  const std::filesystem::path& dir = staging.path();
  WriteTrajectory(dir / "trajectory.tum", trajectory, TrajectoryFormat::kTum);
  WriteTrajectory(dir / "trajectory_kitti.txt", trajectory, TrajectoryFormat::kKittiIndexed);
  WriteTrajectory(dir / "trajectory_euroc.csv", trajectory, TrajectoryFormat::kEuroc);
  WriteTrajectory(dir / "keyframes.tum", keyframe_trajectory, TrajectoryFormat::kTum);
  Trajectory trajectory_vo;
  if (loops.applied) {
    // Before loop closure: the odometry's poses.
    trajectory_vo.has_time = true;
    trajectory_vo.has_frame_index = true;
    for (const auto& [frame_index, pose] : poses_vo) trajectory_vo.poses.push_back(pose);
    WriteTrajectory(dir / "trajectory_vo.tum", trajectory_vo, TrajectoryFormat::kTum);
    Trajectory keyframes_before;
    keyframes_before.has_time = true;
    keyframes_before.has_frame_index = true;
    for (const KeyframeEstimate& kf : keyframes_vo) {
      StampedPose pose;
      pose.t_ns = kf.t_ns;
      pose.frame_index = kf.frame_index;
      pose.world_from_body = kf.world_from_rig;
      keyframes_before.poses.push_back(pose);
    }
    WriteTrajectory(dir / "keyframes_vo.tum", keyframes_before, TrajectoryFormat::kTum);
  }
  if (vocabulary) WriteFileAtomic(dir / "loops.csv", LoopsCsv(loops.attempts));
  std::string scale_csv = "frame,t_ns,segment,event,applied";
  for (const Camera& camera : rig.cameras) scale_csv += ",scale_" + camera.name;
  scale_csv +=
      ",measured_ratio,measured_sigma,gain,applied_ratio,scale_sigma,rms_residual_m,singular_value_ratio,"
      "rms_reprojection_px,note\n";
  for (const ScaleLogEntry& e : scale_log) {
    scale_csv += StrCat(e.frame_index, ",", e.t_ns, ",", e.segment, ",", e.event, ",", e.applied ? 1 : 0);
    for (int c = 0; c < rig.NumCameras(); ++c) {
      scale_csv += ",";
      if (c < static_cast<int>(e.camera_scales.size())) scale_csv += FormatDouble(e.camera_scales[c]);
    }
    scale_csv +=
        StrCat(",", FormatDouble(e.measured_ratio), ",", FormatDouble(e.measured_sigma), ",",
               FormatDouble(e.gain), ",", FormatDouble(e.applied_ratio), ",", FormatDouble(e.scale_sigma),
               ",", FormatDouble(e.rms_residual_m), ",", FormatDouble(e.singular_value_ratio), ",",
               FormatDouble(e.rms_reprojection_px), ",", CsvQuote(e.note), "\n");
  }
  WriteFileAtomic(dir / "scale_log.csv", scale_csv);
  WriteFileAtomic(dir / "frame_stats.csv", stats_csv);
  WriteFileAtomic(dir / "timing.csv", timing_csv);

  std::optional<EvalResult> eval_result, eval_vo;
  if (index.ground_truth && trajectory.poses.size() >= MinPosesForAlignment(options.eval.align)) {
    try {
      eval_result = EvaluateTrajectory(*index.ground_truth, trajectory, options.eval,
                                       (index.root / "groundtruth").string(), "trajectory.tum");
      const EvalResult& result = *eval_result;
      CreateDirectories(dir / "eval");
      WriteEvalOutputs(dir / "eval", result);
      summary.evaluated = true;
      summary.ate_rmse_m = result.ate_translation_m.rmse;
      summary.gt_path_length_m = result.gt_matched_path_length_m;
      summary.ate_percent_of_path =
          summary.gt_path_length_m > 0 ? 100.0 * summary.ate_rmse_m / summary.gt_path_length_m : 0.0;
      summary.scale_error_percent = result.scale.scale_error_percent;
      if (loops.applied) {
        eval_vo = EvaluateTrajectory(*index.ground_truth, trajectory_vo, options.eval,
                                     (index.root / "groundtruth").string(), "trajectory_vo.tum");
        CreateDirectories(dir / "eval_vo");
        WriteEvalOutputs(dir / "eval_vo", *eval_vo);
      }
    } catch (const InputError& e) {
      MCVO_LOG(kWarning, "run: evaluation skipped: ", e.what());
    }
  }

  // The COLMAP model of the keyframes and landmarks.
  nlohmann::ordered_json colmap_json;
  double colmap_seconds = 0.0;
  if (options.colmap.enabled) {
    ColmapExportOptions colmap_options = options.colmap.export_options;
    colmap_options.threads = threads;
    const Clock::time_point colmap_start = Clock::now();
    const ColmapExportReport colmap = WriteColmapModel(
        rig, map, std::filesystem::absolute(index.root).lexically_normal(), colmap_options, dir / "colmap");
    colmap_seconds = SecondsSince(colmap_start);
    // The description names the staging folder: say "<out>/colmap" instead.
    std::string description = DescribeColmapExport(colmap);
    const std::string staged = (dir / "colmap").string();
    for (size_t at = description.find(staged); at != std::string::npos; at = description.find(staged, at)) {
      description.replace(at, staged.size(), (absolute_out / "colmap").string());
    }
    for (std::string_view line : SplitFields(description, '\n')) {
      if (!Trim(line).empty()) MCVO_LOG(kInfo, "run: colmap: ", line);
    }
    colmap_json["images"] = colmap.images;
    colmap_json["points"] = colmap.points;
    colmap_json["observations"] = colmap.observations;
    colmap_json["mean_track_length"] = colmap.mean_track_length;
    colmap_json["mean_reprojection_error_px"] = colmap.mean_reprojection_error_px;
    colmap_json["observations_dropped"] = colmap.observations_dropped;
    colmap_json["landmarks_dropped"] = colmap.landmarks_dropped;
    nlohmann::ordered_json cameras_json = nlohmann::ordered_json::array();
    for (const ColmapCameraExport& camera : colmap.camera_exports) {
      nlohmann::ordered_json c;
      c["name"] = camera.name;
      c["model"] = std::string(ColmapCameraModelName(camera.camera.model));
      c["fitted"] = camera.fitted;
      c["undistorted"] = camera.undistorted;
      if (camera.fitted) {
        c["fit_rms_px"] = camera.fit_rms_px;
        c["fit_max_px"] = camera.fit_max_px;
      }
      c["observations_written"] = camera.observations_written;
      c["observations_dropped"] = camera.observations_dropped;
      cameras_json.push_back(c);
    }
    colmap_json["cameras"] = cameras_json;
    colmap_json["notes"] = colmap.notes;
  }

  // report.html / report.md: deterministic content only (no timings).
  PipelineOptions recorded = options;
  recorded.runtime.threads = 0;  // the thread count does not change the results
  const nlohmann::ordered_json recorded_config =
      nlohmann::ordered_json::parse(PipelineOptionsToJson(recorded));
  if (options.output.report) {
    ReportInputs report;
    report.title = StrCat("mcvo run: ", index.name, ", ", rig.NumCameras(), " camera(s)");
    if (eval_result) {
      report.eval = &*eval_result;
      if (loops.applied) {
        report.estimate_before_loop_closure =
            ApplyAlignment(trajectory_vo, eval_result->gt_world_from_est_world);
      }
      report.ground_truth = *index.ground_truth;
    } else {
      report.estimate = trajectory;
      if (loops.applied) report.estimate_before_loop_closure = trajectory_vo;
    }
    for (const ScaleLogEntry& e : scale_log) {
      report.scale_log.push_back(
          {e.frame_index, e.t_ns, e.segment, e.event, e.camera_scales, e.applied, e.note});
    }
    for (const Camera& camera : rig.cameras) report.camera_names.push_back(camera.name);
    report.settings = recorded_config;
    report.summary_rows = {{"program", StrCat("mcvo ", request.version)},
                           {"dataset", StrCat(index.name, " (", index.format, ")")},
                           {"input", request.tracks.empty() ? "images" : "track file"},
                           {"frames", StrCat(summary.frames)},
                           {"posed frames", StrCat(summary.posed_frames)},
                           {"keyframes", StrCat(summary.keyframes)},
                           {"segments", StrCat(summary.segments)},
                           {"segments relocalised after a loss",
                            StrCat(summary.segments_relocalised, " of ", summary.segments - 1)},
                           {"posed by the reverse pass (scale applied back)", StrCat(reverse_posed.size())}};
    if (!summary.warning.empty()) report.summary_rows.push_back({"warning", summary.warning});
    WriteReports(dir, report);
  }

  // run.json: what was run, on what, what came out.
  nlohmann::ordered_json run;
  run["program"] = "mcvo";
  run["version"] = request.version;
  run["command_line"] = request.command_line;
  run["config_source"] = request.config_source;
  run["config"] = recorded_config;
  nlohmann::ordered_json dataset;
  dataset["root"] = index.root.string();
  dataset["format"] = index.format;
  dataset["name"] = index.name;
  dataset["frames"] = total_frames;
  nlohmann::ordered_json cameras = nlohmann::ordered_json::array();
  for (const Camera& camera : rig.cameras) cameras.push_back(camera.name);
  dataset["cameras"] = cameras;
  run["dataset"] = dataset;
  nlohmann::ordered_json inputs;
  for (const auto& [key, hash] : HashRunInputs(index, request.tracks, total_frames, vocabulary_path))
    inputs[key] = hash;
  run["inputs"] = inputs;
  nlohmann::ordered_json outputs;
  std::vector<std::filesystem::path> files;
  // colmap/images/ holds links to (or copies of) the input images, whose
  // hashes are under "inputs", or images remapped from them: not hashed.
  const std::filesystem::path colmap_images = dir / "colmap" / "images";
  for (auto it = std::filesystem::recursive_directory_iterator(dir);
       it != std::filesystem::recursive_directory_iterator(); ++it) {
    if (it->path() == colmap_images) {
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_symlink() && it->is_regular_file()) files.push_back(it->path());
  }
  std::sort(files.begin(), files.end());
  for (const auto& path : files) {
    outputs[std::filesystem::relative(path, dir).generic_string()] = Sha256File(path);
  }
  run["outputs_sha256"] = outputs;
  nlohmann::ordered_json result;
  result["frames"] = summary.frames;
  result["posed_frames"] = summary.posed_frames;
  result["keyframes"] = summary.keyframes;
  result["segments"] = summary.segments;
  result["segments_relocalised"] = summary.segments_relocalised;
  result["frames_posed_by_reverse_pass"] = reverse_posed.size();
  if (odometry.fallback_sigma > 0.0) result["initializer_fallback_sigma"] = odometry.fallback_sigma;
  if (!summary.warning.empty()) result["warning"] = summary.warning;
  if (summary.evaluated) {
    result["ate_rmse_m"] = summary.ate_rmse_m;
    result["ate_percent_of_path"] = summary.ate_percent_of_path;
    result["scale_error_percent"] = summary.scale_error_percent;
    result["gt_path_length_m"] = summary.gt_path_length_m;
  }
  result["sparse_map_keyframes"] = map.keyframes.size();
  result["sparse_map_landmarks"] = map.landmarks.size();
  result["sparse_map_observations_dropped"] = map_observations_dropped;
  if (vocabulary) {
    result["loop_candidates_verified"] = loops.verified;
    result["loops_accepted"] = loops.accepted;
    result["loop_closure_applied"] = loops.applied;
    if (loops.applied && eval_vo) {
      result["ate_rmse_m_before_loop_closure"] = eval_vo->ate_translation_m.rmse;
      result["scale_error_percent_before_loop_closure"] = eval_vo->scale.scale_error_percent;
    }
  }
  run["result"] = result;
  if (!colmap_json.is_null()) run["colmap"] = colmap_json;
  nlohmann::ordered_json timing;
  timing["note"] = "wall-clock, not deterministic; seconds per frame, means over the run";
  timing["threads"] = threads;
  timing["seconds_total"] = summary.seconds;
  timing["frames_per_second"] = summary.frames_per_second;
  const double n = std::max(1, summary.frames);
  timing["frontend_s"] = totals.frontend / n;
  timing["initializer_s"] = totals.initializer / n;
  timing["pnp_s"] = totals.pnp / n;
  timing["ba_s"] = totals.ba / n;
  timing["marginalization_s"] = totals.marginalization / n;
  timing["scale_correction_s"] = totals.scale / n;
  timing["backend_s"] = totals.backend / n;
  timing["colmap_export_s_total"] = colmap_seconds;
  timing["odometry_s_total"] = vo_seconds;
  timing["reverse_pass_s_total"] = odometry.reverse_seconds;
  if (vocabulary) {
    const double keyframe_count = std::max<size_t>(1, keyframes.size());
    timing["loop_image_read_s_per_keyframe"] = loops.image_seconds / keyframe_count;
    timing["loop_features_s_per_keyframe"] = loops.timing.features_s / keyframe_count;
    timing["loop_query_s_per_keyframe"] = loops.timing.query_s / keyframe_count;
    timing["loop_verification_s_per_keyframe"] = loops.timing.verification_s / keyframe_count;
    timing["pose_graph_s_total"] = loops.pose_graph_seconds;
  }
  run["timing"] = timing;
  WriteFileAtomic(dir / "run.json", io_internal::PrettyJson(run));

  if (std::filesystem::exists(absolute_out, ec)) std::filesystem::remove_all(absolute_out, ec);
  std::filesystem::rename(dir, absolute_out, ec);
  if (ec)
    MCVO_THROW_INPUT(absolute_out.string(), ": cannot move the finished run into place: ", ec.message());
  staging.Release();

  MCVO_LOG(kInfo, "run: ", summary.frames, " frames (", summary.posed_frames, " posed, ", summary.keyframes,
           " keyframes, ", summary.segments, " segment(s)) in ", FormatFixed(summary.seconds, 2), " s (",
           FormatFixed(summary.frames_per_second, 2), " fps)");
  if (summary.evaluated) {
    MCVO_LOG(kInfo, "run: ATE rmse ", FormatFixed(summary.ate_rmse_m, 3), " m (",
             FormatFixed(summary.ate_percent_of_path, 3), " % of ", FormatFixed(summary.gt_path_length_m, 1),
             " m), scale error ", FormatFixed(summary.scale_error_percent, 3), " % (",
             EnumToName(kAlignmentModeNames, options.eval.align), " alignment)");
  }
  if (!summary.warning.empty()) MCVO_LOG(kWarning, "run: ", summary.warning);
  MCVO_LOG(kInfo, "run: wrote ", absolute_out.string());
  return summary;
}

}  // namespace mcvo
