// FrameStream: background decoding of dataset images into a bounded ring.
//
// Frame i is decoded by whichever worker claims it, into slot i % prefetch.
// A worker may claim frame i only while i < next_out + prefetch, where
// next_out is the next frame the consumer will take: at most `prefetch`
// frames are decoded or being decoded at any time, and a slot is always free
// when it is claimed. Each frame is decoded independently of the others, so
// the output does not depend on the number of threads or on scheduling.
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <optional>
#include <string>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "mcvo/dataset/dataset.h"
#include "mcvo/dataset/image_container.h"
#include "mcvo/dataset/image_file.h"
#include "mcvo/util/error.h"
#include "mcvo/util/file.h"
#include "mcvo/util/parallel.h"
#include "mcvo/util/stage.h"

namespace mcvo {
namespace {

struct CameraSize {
  std::string name;
  int width = 0;
  int height = 0;
};

[[noreturn]] void ThrowWrongSize(const std::filesystem::path& path, int64_t width, int64_t height,
                                 const CameraSize& camera) {
  MCVO_THROW_INPUT(path.string(), ": image is ", width, " x ", height, " px but camera ", camera.name,
                   " expects ", camera.width, " x ", camera.height);
}

// The file's decode as it is (colour, 16-bit); the caller takes its grey
// with GreyOfDecodedImage. The size its header declares is checked first,
// before a decoder allocates the image (a small PNG may declare 30000 x
// 30000 px); either orientation passes there, as the EXIF orientation that
// cv::imread applies may turn the decode. Formats without a header reader
// are checked after the decode.
cv::Mat DecodeImage(const std::filesystem::path& path, const CameraSize& camera) {
  bool member = false;  // of an image container: a ROS bag's message (image_container.h)
  cv::Mat from_container = DecodeContainerImage(path, &member);
  if (member) {
    if (from_container.cols != camera.width || from_container.rows != camera.height)
      ThrowWrongSize(path, from_container.cols, from_container.rows, camera);
    return from_container;
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    const std::string why = WhyNotAFile(path);
    MCVO_THROW_INPUT(path.string(), ": image file ",
                     why == "does not exist" || why.empty() ? "missing" : why);
  }
  if (std::filesystem::file_size(path, ec) == 0 && !ec) MCVO_THROW_INPUT(path.string(), ": empty image file (0 bytes)");
  if (const std::optional<ImageHeader> header = ReadImageHeader(path)) {
    const bool upright = header->width == camera.width && header->height == camera.height;
    const bool turned = header->width == camera.height && header->height == camera.width;
    if (!upright && !turned) ThrowWrongSize(path, header->width, header->height, camera);
  }
  cv::Mat image;
  try {
    image = ReadImageFile(path);
  } catch (const cv::Exception& e) {
    MCVO_THROW_INPUT(path.string(), ": cannot decode image: ", e.what());
  }
  if (image.empty()) {
    MCVO_THROW_INPUT(path.string(), ": cannot decode image (not an image format OpenCV reads, or truncated)");
  }
  if (image.cols != camera.width || image.rows != camera.height) ThrowWrongSize(path, image.cols, image.rows, camera);
  return image;
}

}  // namespace

cv::Mat GreyOfDecodedImage(const cv::Mat& decoded) {
  if (decoded.empty()) return cv::Mat();
  cv::Mat eight = decoded;
  if (decoded.depth() == CV_16U) {
    // The high byte of each value: exactly what libpng's strip_16 gives
    // IMREAD_GRAYSCALE (convertTo would round instead).
    eight.create(decoded.size(), CV_MAKETYPE(CV_8U, decoded.channels()));
    const int values = decoded.cols * decoded.channels();
    for (int y = 0; y < decoded.rows; ++y) {
      const uint16_t* in = decoded.ptr<uint16_t>(y);
      uint8_t* out = eight.ptr<uint8_t>(y);
      for (int x = 0; x < values; ++x) out[x] = static_cast<uint8_t>(in[x] >> 8);
    }
  } else if (decoded.depth() != CV_8U) {
    decoded.convertTo(eight, CV_MAKETYPE(CV_8U, decoded.channels()));
  }
  if (eight.channels() == 1) return eight;
  cv::Mat grey;
  if (eight.channels() == 3) {
    cv::cvtColor(eight, grey, cv::COLOR_BGR2GRAY);
  } else if (eight.channels() == 4) {
    cv::cvtColor(eight, grey, cv::COLOR_BGRA2GRAY);
  } else {
    cv::extractChannel(eight, grey, 0);
  }
  return grey;
}

struct FrameStream::Impl {
  struct Slot {
    bool ready = false;
    FrameImages frame;
    StagedFailure error;
  };

  std::vector<DatasetFrame> frames;
  std::vector<CameraSize> cameras;
  int prefetch = 1;
  bool keep_decoded = false;

  std::mutex mutex;
  std::condition_variable work_cv;   // workers wait for a claimable frame
  std::condition_variable ready_cv;  // the consumer waits for its frame
  std::vector<Slot> slots;           // ring, frame i in slot i % prefetch
  int next_claim = 0;                // next frame a worker will decode
  int next_out = 0;                  // next frame Next() returns
  bool stop = false;
  StagedFailure failed;  // set once Next() has thrown: the stream stays stopped
  std::vector<std::thread> workers;
  std::vector<std::string> stages;  // of the thread that made the stream: the workers' outer stages

  FrameImages Decode(int i) const {
    const ScopedStage stage(StrCat("decoding the images of frame ", i));
    const DatasetFrame& source = frames[static_cast<size_t>(i)];
    FrameImages frame;
    frame.index = i;
    frame.t_ns = source.t_ns;
    frame.images.resize(source.images.size());
    const auto start = std::chrono::steady_clock::now();
    if (keep_decoded) frame.decoded.resize(source.images.size());
    for (size_t c = 0; c < source.images.size(); ++c) {
      if (source.images[c].empty()) continue;
      cv::Mat decoded = DecodeImage(source.images[c], cameras[c]);
      frame.images[c] = GreyOfDecodedImage(decoded);
      if (keep_decoded) frame.decoded[c] = std::move(decoded);
    }
    frame.decode_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return frame;
  }

  void Work() {
    const InheritedStages outer(stages);
    const int num_frames = static_cast<int>(frames.size());
    while (true) {
      int i = 0;
      {
        std::unique_lock<std::mutex> lock(mutex);
        work_cv.wait(lock,
                     [&] { return stop || next_claim >= num_frames || next_claim < next_out + prefetch; });
        if (stop || next_claim >= num_frames) return;
        i = next_claim++;
      }
      Slot result;
      result.ready = true;
      try {
        result.frame = Decode(i);
      } catch (...) {
        result.error = CaptureFailure();
      }
      {
        std::lock_guard<std::mutex> lock(mutex);
        slots[static_cast<size_t>(i % prefetch)] = std::move(result);
      }
      ready_cv.notify_all();
    }
  }

  void Stop() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      stop = true;
    }
    work_cv.notify_all();
    for (std::thread& worker : workers) {
      if (worker.joinable()) worker.join();
    }
  }
};

FrameStream::FrameStream(const DatasetIndex& index, const FrameStreamOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (options.threads < 0) throw UsageError(StrCat("threads: must be >= 0, got ", options.threads));
  if (options.prefetch < 1) throw UsageError(StrCat("prefetch: must be >= 1, got ", options.prefetch));
  impl_->frames = index.frames;
  for (const Camera& camera : index.rig.cameras)
    impl_->cameras.push_back({camera.name, camera.width, camera.height});
  for (const DatasetFrame& frame : impl_->frames) {
    MCVO_CHECK_MSG(frame.images.size() == impl_->cameras.size(), "frame with ", frame.images.size(),
                   " images for ", impl_->cameras.size(), " cameras");
  }
  impl_->prefetch = options.prefetch;
  impl_->keep_decoded = options.keep_decoded;
  impl_->slots.resize(static_cast<size_t>(options.prefetch));
  int threads = ResolveThreads(options.threads);
  threads =
      std::clamp(threads, 1, std::max(1, std::min(options.prefetch, static_cast<int>(index.frames.size()))));
  impl_->stages = CurrentStageList();
  try {
    for (int t = 0; t < threads; ++t) {
      impl_->workers.push_back(
          StartThread([&] { return StrCat("image decoder thread ", t + 1, " of ", threads); },
                      [impl = impl_.get()] { impl->Work(); }));
    }
  } catch (...) {
    impl_->Stop();  // joins the decoders already started
    throw;
  }
}

FrameStream::~FrameStream() { impl_->Stop(); }

std::optional<FrameImages> FrameStream::Next() {
  Impl& impl = *impl_;
  if (impl.failed) RethrowFailure(impl.failed);
  if (impl.next_out >= static_cast<int>(impl.frames.size())) return std::nullopt;
  Impl::Slot slot;
  {
    std::unique_lock<std::mutex> lock(impl.mutex);
    Impl::Slot& ring_slot = impl.slots[static_cast<size_t>(impl.next_out % impl.prefetch)];
    impl.ready_cv.wait(lock, [&] { return ring_slot.ready; });
    slot = std::move(ring_slot);
    ring_slot = Impl::Slot();
    ++impl.next_out;
  }
  if (slot.error) {
    impl.failed = slot.error;
    impl.Stop();
    RethrowFailure(slot.error);
  }
  impl.work_cv.notify_all();
  return std::move(slot.frame);
}

}  // namespace mcvo
