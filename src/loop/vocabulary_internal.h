// Private to src/loop/vocabulary*.cc: the vocabulary's storage and the two
// descriptor metrics.
//
// The tree is stored in breadth-first order: node 0 is the root, and the
// children of every node are consecutive, the children of node i before
// those of node i + 1. So the child counts alone define the tree (the first
// child of node i is 1 + the sum of the child counts of nodes 0..i-1), which
// is what the file stores. The leaves, in node order, are the words 0, 1, ...
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <thread>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "mcvo/loop/vocabulary.h"
#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"

namespace mcvo {

struct Vocabulary::Impl {
  DescriptorKind kind = DescriptorKind::kBinary;
  int descriptor_size = 0;  // bytes (binary) or floats (float) per descriptor
  int branching = 0;
  int levels = 0;
  std::vector<uint32_t> child_count;  // per node
  cv::Mat centres;                    // one row per node (the root's row is zeros): CV_8U or CV_32F
  std::vector<double> idf;            // per word

  // Derived by Finalize() from child_count.
  std::vector<uint32_t> first_child;  // per node (meaningless for leaves)
  std::vector<int32_t> word;          // per node: the word of a leaf, -1 for inner nodes
  int num_words = 0;

  // Derives first_child, word and num_words. The child counts must describe
  // a tree (MCVO_CHECK; Load validates a file's counts before).
  void Finalize();
  // Word of a descriptor row (pointer to descriptor_size bytes or floats):
  // down the tree by the nearest child centre, ties to the lower child.
  uint32_t Descend(const uint8_t* row) const;
  int RowBytes() const { return kind == DescriptorKind::kBinary ? descriptor_size : 4 * descriptor_size; }
};

namespace loop_internal {

// Hamming distance of two binary descriptors of `bytes` bytes.
inline int HammingDistance(const uint8_t* a, const uint8_t* b, int bytes) {
  int distance = 0;
  int i = 0;
  for (; i + 8 <= bytes; i += 8) {
    uint64_t x = 0, y = 0;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    distance += __builtin_popcountll(x ^ y);
  }
  for (; i < bytes; ++i) distance += __builtin_popcount(static_cast<unsigned>(a[i] ^ b[i]));
  return distance;
}

// Squared L2 distance of two float descriptors of n floats (summed in index
// order in double: the same number on every thread and every call).
inline double SquaredL2(const float* a, const float* b, int n) {
  double sum = 0.0;
  for (int i = 0; i < n; ++i) {
    const double d = static_cast<double>(a[i]) - static_cast<double>(b[i]);
    sum += d * d;
  }
  return sum;
}

// The two metrics behind one interface for the templated loops. Distance()
// orders candidates (smaller is nearer); SquaredDistance() is the k-means++
// seeding weight.
struct BinaryMetric {
  int size = 0;  // bytes
  int Distance(const uint8_t* a, const uint8_t* b) const { return HammingDistance(a, b, size); }
  double SquaredDistance(const uint8_t* a, const uint8_t* b) const {
    const double d = Distance(a, b);
    return d * d;
  }
};

struct FloatMetric {
  int size = 0;  // floats
  double Distance(const uint8_t* a, const uint8_t* b) const {
    return SquaredL2(reinterpret_cast<const float*>(a), reinterpret_cast<const float*>(b), size);
  }
  double SquaredDistance(const uint8_t* a, const uint8_t* b) const { return Distance(a, b); }
};

// Index of the row of `centres` in [first, first + count) nearest to `row`;
// ties go to the lowest index.
template <typename Metric>
int NearestRow(const Metric& metric, const cv::Mat& centres, int first, int count, const uint8_t* row) {
  int best = first;
  auto best_distance = metric.Distance(centres.ptr<uint8_t>(first), row);
  for (int i = first + 1; i < first + count; ++i) {
    const auto distance = metric.Distance(centres.ptr<uint8_t>(i), row);
    if (distance < best_distance) {
      best_distance = distance;
      best = i;
    }
  }
  return best;
}

// Runs work(begin, end) over [0, n) split into contiguous chunks, one per
// thread (at most `threads`, fewer when n < min_per_thread * threads). Each
// index is processed by exactly one call, so work that writes only to its
// own indices gives the same result at any thread count.
template <typename Work>
void ParallelChunks(size_t n, int threads, size_t min_per_thread, Work&& work) {
  const size_t by_size = std::max<size_t>(1, n / std::max<size_t>(1, min_per_thread));
  const size_t chunks = std::min<size_t>(static_cast<size_t>(std::max(1, threads)), by_size);
  if (chunks <= 1) {
    work(size_t{0}, n);
    return;
  }
  std::vector<std::thread> workers;
  workers.reserve(chunks - 1);
  try {
    for (size_t c = 1; c < chunks; ++c) {
      workers.push_back(StartThread([&] { return StrCat("thread ", c + 1, " of ", chunks); },
                                    [&work, n, chunks, c] { work(n * c / chunks, n * (c + 1) / chunks); }));
    }
  } catch (...) {
    for (std::thread& worker : workers) worker.join();  // their chunks are lost with the exception
    throw;
  }
  work(size_t{0}, n / chunks);
  for (std::thread& worker : workers) worker.join();
}

}  // namespace loop_internal
}  // namespace mcvo
