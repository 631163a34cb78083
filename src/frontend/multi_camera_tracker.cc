// Cameras are tracked on worker threads (std::thread per Track() call; a
// frame's work per camera is milliseconds to tens of milliseconds, so thread
// start-up is negligible), each camera into its own pre-sized slot. After the
// join, new feature ids are assigned in camera order, so ids and every output
// are independent of the thread count and of scheduling.
//
// OpenCV's own parallel loops (LK over points, pyramid and corner response
// over rows) compute each output element independently of how the work is
// split, so their results do not depend on cv::getNumThreads();
// multi_camera_tracker_test checks threads 1 vs 2 bit for bit.
#include "mcvo/frontend/multi_camera_tracker.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>

#include "mcvo/frontend/detector.h"
#include "mcvo/util/error.h"

namespace mcvo {

struct MultiCameraTracker::Impl {
  std::vector<std::unique_ptr<CameraTracker>> trackers;
  int threads = 1;
  uint64_t next_id = 1;  // 0 means "not assigned yet"
};

MultiCameraTracker::MultiCameraTracker(const Rig& rig, const std::vector<cv::Mat>& masks,
                                       const FrontendOptions& options, int threads)
    : impl_(std::make_unique<Impl>()) {
  if (!masks.empty() && static_cast<int>(masks.size()) != rig.NumCameras()) {
    MCVO_THROW_INPUT("frontend: ", masks.size(), " masks for a rig of ", rig.NumCameras(), " cameras");
  }
  impl_->threads = std::max(1, threads);
  for (int c = 0; c < rig.NumCameras(); ++c) {
    const cv::Mat mask = masks.empty() ? cv::Mat() : masks[static_cast<size_t>(c)];
    impl_->trackers.push_back(std::make_unique<CameraTracker>(rig.cameras[static_cast<size_t>(c)], mask,
                                                              options, CreateDetector(options)));
  }
}

MultiCameraTracker::~MultiCameraTracker() = default;

MultiCameraFrame MultiCameraTracker::Track(int frame_index, int64_t t_ns,
                                           const std::vector<cv::Mat>& images) {
  const size_t n = impl_->trackers.size();
  if (images.size() != n) {
    MCVO_THROW_INPUT("frontend: frame ", frame_index, " has ", images.size(), " images for ", n, " cameras");
  }
  MultiCameraFrame frame;
  frame.frame_index = frame_index;
  frame.t_ns = t_ns;
  frame.cameras.resize(n);
  std::vector<std::exception_ptr> errors(n);
  std::atomic<size_t> next_camera{0};
  auto work = [&]() {
    for (size_t c = next_camera++; c < n; c = next_camera++) {
      try {
        frame.cameras[c] = impl_->trackers[c]->Track(images[c]);
      } catch (...) {
        errors[c] = std::current_exception();
      }
    }
  };
  const size_t workers = std::min(n, static_cast<size_t>(impl_->threads));
  std::vector<std::thread> pool;
  for (size_t w = 1; w < workers; ++w) pool.emplace_back(work);
  work();
  for (std::thread& thread : pool) thread.join();
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);  // the first failing camera, in camera order
  }
  for (size_t c = 0; c < n; ++c) impl_->trackers[c]->AssignNewIds(&impl_->next_id, &frame.cameras[c]);
  return frame;
}

int MultiCameraTracker::DescriptorSize() const {
  return impl_->trackers.empty() ? 0 : impl_->trackers.front()->DescriptorSize();
}
int MultiCameraTracker::DescriptorType() const {
  return impl_->trackers.empty() ? CV_32F : impl_->trackers.front()->DescriptorType();
}

}  // namespace mcvo
