// The frame source of `mcvo run` and `mcvo track`: the frontend on images
// (MultiCameraTracker over a FrameStream, which decodes ahead on threads of
// its own) or the replay of a track file of `mcvo track`, on a producer
// thread of its own, a bounded queue ahead of the consumer (the odometry
// stage; the track file writer), which takes the frames in frame order. Everything
// that can be wrong with the source (a track file of other cameras, a
// detector model that does not load) is found by the constructor, before
// any frame is decoded; an error while producing reaches the consumer from
// Next().
#pragma once

#include <filesystem>
#include <memory>
#include <optional>

#include "mcvo/camera/camera.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/frontend/frontend_options.h"
#include "mcvo/frontend/multi_camera_tracker.h"
#include "mcvo/map/observations.h"

namespace mcvo {

// A frame from the frontend (tracked now, or read from a track file) and the
// wall time it took on the producer thread: waiting for its decoded images
// (0 when decoding keeps ahead), tracking (or reading it from the file), and
// both together; and the decoding of its images on the decoding thread
// (summed over cameras; 0 for a track file).
struct FrontendItem {
  MultiCameraFrame frame;
  double decode_wait_seconds = 0.0;
  double track_seconds = 0.0;
  double seconds = 0.0;
  double decode_seconds = 0.0;
};

class FrameSource {
 public:
  // tracks: a track file to replay (its cameras must be the dataset's, in
  // order), or empty to track the dataset's images with `frontend` on
  // `threads` threads. Throws InputError.
  FrameSource(const DatasetIndex& index, const FrontendOptions& frontend, const std::filesystem::path& tracks,
              int threads);
  // Cancels the producer and joins it.
  ~FrameSource();
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  // Starts producing the first `frames` frames.
  void Start(int frames);
  // The next frame in order; nullopt at the end. Rethrows the producer's
  // exception.
  std::optional<FrontendItem> Next();
  // The tracker of images (its detector and camera pairs); null when a
  // track file is replayed. Its Track is called on the producer thread only.
  const MultiCameraTracker* tracker() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The estimator's input from a frontend frame: each feature's pixel and unit
// bearing (features whose pixel the camera model cannot unproject dropped),
// the cross-camera matches likewise.
RigFrameObservations ToObservations(const Rig& rig, const MultiCameraFrame& frame);

}  // namespace mcvo
