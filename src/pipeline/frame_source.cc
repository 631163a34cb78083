#include "mcvo/pipeline/frame_source.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "mcvo/frontend/track_file.h"
#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/stage.h"

namespace mcvo {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

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
  void Close(StagedFailure error) {
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
    if (error_) RethrowFailure(error_);
    return std::nullopt;
  }

 private:
  const size_t capacity_;
  std::mutex mutex_;
  std::condition_variable not_full_, not_empty_;
  std::deque<FrontendItem> items_;
  bool closed_ = false;
  bool cancelled_ = false;
  StagedFailure error_;
};

}  // namespace

struct FrameSource::Impl {
  const DatasetIndex& index;
  const int threads;
  std::unique_ptr<TrackFileReader> track_reader;
  std::unique_ptr<MultiCameraTracker> tracker;
  FrameQueue queue{4};
  std::thread producer;

  const bool keep_images;

  Impl(const DatasetIndex& index_in, int threads_in, bool keep_images_in)
      : index(index_in), threads(threads_in), keep_images(keep_images_in) {}

  void Produce(int total_frames, const std::vector<std::string>& stages) {
    const InheritedStages outer(stages);
    StagedFailure error;
    try {
      if (track_reader) {
        int produced = 0;
        while (produced < total_frames && !queue.cancelled()) {
          const ScopedStage stage(StrCat("frontend: reading tracks of frame ", produced));
          const Clock::time_point start = Clock::now();
          std::optional<MultiCameraFrame> frame = track_reader->Next();
          if (!frame) break;
          const double seconds = SecondsSince(start);
          FrontendItem item;
          item.frame = std::move(*frame);
          item.track_seconds = seconds;
          item.seconds = seconds;
          queue.Push(std::move(item));
          ++produced;
        }
      } else {
        FrameStreamOptions stream_options;
        stream_options.threads = threads;
        stream_options.keep_decoded = keep_images;
        FrameStream stream(index, stream_options);
        int produced = 0;
        while (produced < total_frames && !queue.cancelled()) {
          const Clock::time_point start = Clock::now();
          std::optional<FrameImages> images = stream.Next();
          const double decode_wait = SecondsSince(start);
          if (!images) break;
          const ScopedStage stage(StrCat("frontend: tracking frame ", images->index));
          const Clock::time_point track_start = Clock::now();
          MultiCameraFrame frame = tracker->Track(images->index, images->t_ns, images->images);
          FrontendItem item;
          item.frame = std::move(frame);
          item.decode_wait_seconds = decode_wait;
          item.track_seconds = SecondsSince(track_start);
          item.seconds = SecondsSince(start);
          item.decode_seconds = images->decode_seconds;
          if (keep_images) {
            item.images = std::move(images->images);
            item.decoded = std::move(images->decoded);
          }
          queue.Push(std::move(item));
          ++produced;
        }
      }
    } catch (...) {
      error = CaptureFailure();
    }
    queue.Close(std::move(error));
  }
};

FrameSource::FrameSource(const DatasetIndex& index, const FrontendOptions& frontend,
                         const std::filesystem::path& tracks, int threads, bool keep_images)
    : impl_(std::make_unique<Impl>(index, threads, keep_images)) {
  const Rig& rig = index.rig;
  if (!tracks.empty()) {
    impl_->track_reader = std::make_unique<TrackFileReader>(tracks);
    const auto& names = impl_->track_reader->header().camera_names;
    std::vector<std::string> rig_names;
    for (const Camera& camera : rig.cameras) rig_names.push_back(camera.name);
    if (names != rig_names) {
      std::string have, want;
      for (const auto& n : names) have += (have.empty() ? "" : ",") + n;
      for (const auto& n : rig_names) want += (want.empty() ? "" : ",") + n;
      MCVO_THROW_INPUT(tracks.string(), ": cameras [", have, "] do not match the dataset's [", want,
                       "] (use --cameras to select the same cameras)");
    }
  } else {
    impl_->tracker = std::make_unique<MultiCameraTracker>(rig, index.masks, frontend, threads);
  }
}

FrameSource::~FrameSource() {
  impl_->queue.Cancel();
  if (impl_->producer.joinable()) impl_->producer.join();
}

void FrameSource::Start(int frames) {
  MCVO_CHECK(!impl_->producer.joinable());
  impl_->producer =
      StartThread([] { return std::string("the frontend thread"); },
                  [this, frames, stages = CurrentStageList()] { impl_->Produce(frames, stages); });
}

std::optional<FrontendItem> FrameSource::Next() { return impl_->queue.Pop(); }

const MultiCameraTracker* FrameSource::tracker() const { return impl_->tracker.get(); }

void FrontendStageSeconds::Add(const FrontendItem& item) {
  ++frames;
  decode += item.decode_seconds;
  decode_wait += item.decode_wait_seconds;
  track_wall += item.track_seconds;
  for (const CrossCameraPairStats& pair : item.frame.cross_pair_stats) cross_camera += pair.seconds;
  for (const CameraFrameResult& camera : item.frame.cameras) {
    const CameraFrameStats& s = camera.stats;
    clahe += s.seconds_clahe;
    pyramid += s.seconds_pyramid;
    lk += s.seconds_lk;
    detect += s.seconds_detect;
    ransac += s.seconds_ransac;
    anchor += s.seconds_anchor;
    select += s.seconds_select;
  }
}

std::vector<std::pair<std::string, double>> FrontendStageSeconds::PerFrame() const {
  const double n = std::max(1, frames);
  return {{"decode", decode / n},
          {"decode_wait", decode_wait / n},
          {"clahe", clahe / n},
          {"pyramid", pyramid / n},
          {"lk", lk / n},
          {"detection", detect / n},
          {"ransac", ransac / n},
          {"anchor", anchor / n},
          {"selection", select / n},
          {"cross_camera", cross_camera / n},
          {"track_wall", track_wall / n}};
}

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

}  // namespace mcvo
