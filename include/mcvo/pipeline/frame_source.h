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
#include <string>
#include <utility>
#include <vector>

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
  // With keep_images (images tracked, not a track file): the frame's grey
  // images and their decodes (FrameImages), for the loop closer; empty
  // otherwise.
  std::vector<cv::Mat> images, decoded;
};

// The frontend's seconds per stage, summed over the frames added (wall
// time, not deterministic; for logs, run.json's timing and benchmarks):
// decode (on the decoding threads), decode_wait, track_wall (the producer
// thread, FrontendItem), and the stages of the camera trackers summed over
// the cameras (CameraFrameStats) and cross_camera over the camera pairs.
// All zero but track_wall for a replayed track file.
struct FrontendStageSeconds {
  int frames = 0;
  double decode = 0.0, decode_wait = 0.0, clahe = 0.0, pyramid = 0.0, lk = 0.0, detect = 0.0, ransac = 0.0,
         anchor = 0.0, select = 0.0, cross_camera = 0.0, track_wall = 0.0;

  void Add(const FrontendItem& item);
  // name -> seconds per frame, in the order of the profile (names as in
  // `mcvo track --timing`: decode, decode_wait, clahe, pyramid, lk,
  // detection, ransac, anchor, selection, cross_camera, track_wall).
  std::vector<std::pair<std::string, double>> PerFrame() const;
};

class FrameSource {
 public:
  // tracks: a track file to replay (its cameras must be the dataset's, in
  // order), or empty to track the dataset's images with `frontend` on
  // `threads` threads. Throws InputError.
  // keep_images: hand each tracked frame's images on (FrontendItem::images
  // and decoded), so that the loop closer need not decode keyframes again.
  FrameSource(const DatasetIndex& index, const FrontendOptions& frontend, const std::filesystem::path& tracks,
              int threads, bool keep_images = false);
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
