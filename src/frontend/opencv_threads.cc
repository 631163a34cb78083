#include "mcvo/frontend/opencv_threads.h"

#include <mutex>

#include <opencv2/core.hpp>

namespace mcvo {
namespace {

std::mutex& Mutex() {
  static std::mutex mutex;
  return mutex;
}
int open_scopes = 0;      // guarded by Mutex()
int saved_threads = -1;   // OpenCV's setting before the first open scope

}  // namespace

ScopedSerialOpenCv::ScopedSerialOpenCv() {
  const std::lock_guard<std::mutex> lock(Mutex());
  if (open_scopes++ == 0) {
    saved_threads = cv::getNumThreads();
    cv::setNumThreads(0);
  }
}

ScopedSerialOpenCv::~ScopedSerialOpenCv() {
  const std::lock_guard<std::mutex> lock(Mutex());
  if (--open_scopes == 0) cv::setNumThreads(saved_threads);
}

}  // namespace mcvo
