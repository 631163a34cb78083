#include "loop_image_cache.h"

#include <chrono>
#include <set>
#include <utility>

#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"
#include "relocalise_segments.h"

namespace mcvo::pipeline_internal {

namespace {

size_t ColorBytes(const std::vector<ColmapColorSamples>& colors) {
  size_t bytes = 0;
  for (const ColmapColorSamples& c : colors) {
    bytes += c.pixels.size() * sizeof(Eigen::Vector2d) + c.colors.size() * sizeof(Eigen::Vector3d) +
             c.has_color.size() / 8;
  }
  return bytes;
}

}  // namespace

LoopImageCache::LoopImageCache(const LoopCloser& closer, int num_cameras, bool sample_colors,
                               size_t max_bytes, int threads)
    : closer_(closer),
      num_cameras_(num_cameras),
      sample_colors_(sample_colors),
      max_bytes_(max_bytes),
      threads_(std::max(1, threads)) {}

void LoopImageCache::Add(int frame_index, std::vector<cv::Mat> images, std::vector<cv::Mat> decoded,
                         const OdometryStage& stage) {
  if (static_cast<int>(images.size()) == num_cameras_ && decoded.size() == images.size()) {
    images_[frame_index] = Images{std::move(images), std::move(decoded)};
  }
  const std::vector<KeyframeEstimate>& finished = stage.FinishedKeyframes();
  for (; keyframes_seen_ < finished.size(); ++keyframes_seen_) Extract(finished[keyframes_seen_]);
  const std::vector<int> pending = stage.PendingFrames();
  const std::set<int> keep(pending.begin(), pending.end());
  for (auto it = images_.begin(); it != images_.end();) {
    it = keep.count(it->first) != 0 ? std::next(it) : images_.erase(it);
  }
}

void LoopImageCache::Finish(const std::vector<KeyframeEstimate>& keyframes) {
  for (const KeyframeEstimate& keyframe : keyframes) {
    if (entries_.count(keyframe.frame_index) == 0) Extract(keyframe);
  }
  images_.clear();
}

void LoopImageCache::Extract(const KeyframeEstimate& keyframe) {
  auto it = images_.find(keyframe.frame_index);
  if (it == images_.end()) return;
  if (full_) {
    ++over_budget_;
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  const Images& images = it->second;
  LoopKeyframe lk = LoopKeyframeWithoutImages(keyframe, num_cameras_);
  lk.images = images.grey;
  Entry entry;
  entry.features = closer_.ExtractImageFeatures(lk, threads_);
  if (sample_colors_) {
    entry.colors.resize(static_cast<size_t>(num_cameras_));
    ParallelFor(num_cameras_, threads_, [&](int c) {
      const cv::Mat& decoded = images.decoded[static_cast<size_t>(c)];
      entry.colors[static_cast<size_t>(c)] =
          decoded.empty() ? ColmapColorSamples() : SampleKeyframeColors(decoded, keyframe, c);
    });
  }
  const size_t bytes = LoopCloser::ImageFeaturesBytes(*entry.features) + ColorBytes(entry.colors);
  if (bytes_ + bytes > max_bytes_) {
    ++over_budget_;
    full_ = true;  // later keyframes are not extracted either
  } else {
    bytes_ += bytes;
    entries_[keyframe.frame_index] = std::move(entry);
  }
  seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

const LoopImageCache::Entry* LoopImageCache::Find(const KeyframeEstimate& keyframe) const {
  auto it = entries_.find(keyframe.frame_index);
  if (it == entries_.end()) return nullptr;
  const LoopKeyframe lk = LoopKeyframeWithoutImages(keyframe, num_cameras_);
  return LoopCloser::ImageFeaturesFit(*it->second.features, lk) ? &it->second : nullptr;
}

}  // namespace mcvo::pipeline_internal
