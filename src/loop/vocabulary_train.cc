// Hierarchical k-means (Nister & Stewenius 2006) with k-means++ seeding
// (Arthur & Vassilvitskii 2007), as DBoW2 trains its vocabularies.
//
// The tree grows level by level. Every node's split depends only on its
// descriptors, the options and its own seed (a hash of the training seed and
// the node's breadth-first index), never on which thread runs it or when:
//  - nodes with many descriptors are split one after the other, their
//    nearest-centre assignments (independent per row) spread over the
//    threads; the centre updates then run on one thread in row order;
//  - the many small nodes of the lower levels are split in parallel, one
//    node per thread at a time, into their own result slots;
//  - children get their breadth-first indices after the level is done, in
//    parent order.
// So the tree is the same at any thread count.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <thread>

#include <opencv2/core.hpp>

#include "mcvo/loop/vocabulary.h"
#include "mcvo/util/error.h"
#include "mcvo/util/hash.h"
#include "mcvo/util/parallel.h"
#include "vocabulary_internal.h"

namespace mcvo {
namespace {

using loop_internal::BinaryMetric;
using loop_internal::FloatMetric;
using loop_internal::ParallelChunks;

// Rows per thread below which splitting work over threads is not worth a thread.
constexpr size_t kRowsPerThread = 2048;

struct Cluster {
  std::vector<uint8_t> centre;    // row bytes
  std::vector<uint32_t> members;  // rows of the training matrix
};

template <typename Metric>
class NodeSplitter {
 public:
  NodeSplitter(const cv::Mat& rows, Metric metric, int row_bytes, const VocabularyTrainOptions& options)
      : rows_(rows), metric_(metric), row_bytes_(row_bytes), options_(options) {}

  // Splits `members` into at most `branching` non-empty clusters (fewer when
  // the node has fewer distinct descriptors), in the order their seeds were drawn.
  std::vector<Cluster> Split(uint64_t node_index, const std::vector<uint32_t>& members, int threads) const {
    const size_t n = members.size();
    const int k = options_.branching;
    cv::Mat centres = Seed(node_index, members, threads);
    const int count = centres.rows;
    if (count < 2) return {};
    std::vector<int> assignment(n, 0);
    Assign(centres, members, threads, &assignment);
    std::vector<int> next(n, 0);
    for (int iteration = 0; iteration < options_.max_iterations; ++iteration) {
      UpdateCentres(members, assignment, &centres);
      Assign(centres, members, threads, &next);
      if (next == assignment) break;
      assignment.swap(next);
    }
    // `assignment` is the nearest-centre partition for the final centres
    // (the same rule as Vocabulary::WordOf). Empty clusters are dropped.
    std::vector<Cluster> clusters(static_cast<size_t>(count));
    for (size_t i = 0; i < n; ++i) clusters[static_cast<size_t>(assignment[i])].members.push_back(members[i]);
    std::vector<Cluster> out;
    out.reserve(static_cast<size_t>(k));
    for (int c = 0; c < count; ++c) {
      Cluster& cluster = clusters[static_cast<size_t>(c)];
      if (cluster.members.empty()) continue;
      cluster.centre.assign(centres.ptr<uint8_t>(c), centres.ptr<uint8_t>(c) + row_bytes_);
      out.push_back(std::move(cluster));
    }
    return out;
  }

 private:
  const uint8_t* Row(uint32_t r) const { return rows_.ptr<uint8_t>(static_cast<int>(r)); }

  // k-means++: the first centre uniformly, each next one with probability
  // proportional to the squared distance to the nearest centre chosen so
  // far; stops early when every descriptor coincides with a centre.
  cv::Mat Seed(uint64_t node_index, const std::vector<uint32_t>& members, int threads) const {
    const size_t n = members.size();
    SplitMix64Rng rng(HashWords({options_.seed, node_index}));
    cv::Mat centres(0, row_bytes_, CV_8U);
    const auto add_centre = [&](size_t i) {
      cv::Mat row(1, row_bytes_, CV_8U);
      std::memcpy(row.ptr<uint8_t>(0), Row(members[i]), static_cast<size_t>(row_bytes_));
      centres.push_back(row);
    };
    add_centre(static_cast<size_t>(rng.Next() % n));
    std::vector<double> nearest(n, std::numeric_limits<double>::infinity());
    while (centres.rows < options_.branching) {
      const uint8_t* last = centres.ptr<uint8_t>(centres.rows - 1);
      ParallelChunks(n, threads, kRowsPerThread, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
          nearest[i] = std::min(nearest[i], metric_.SquaredDistance(last, Row(members[i])));
        }
      });
      double total = 0.0;
      for (double d : nearest) total += d;
      if (!(total > 0.0)) break;
      const double target = rng.Uniform(0.0, total);
      double cumulative = 0.0;
      size_t pick = n;
      size_t last_positive = n;
      for (size_t i = 0; i < n; ++i) {
        if (nearest[i] <= 0.0) continue;
        last_positive = i;
        cumulative += nearest[i];
        if (cumulative > target) {
          pick = i;
          break;
        }
      }
      add_centre(pick < n ? pick : last_positive);  // rounding at the very end: the last candidate
    }
    return centres;
  }

  void Assign(const cv::Mat& centres, const std::vector<uint32_t>& members, int threads,
              std::vector<int>* assignment) const {
    ParallelChunks(members.size(), threads, kRowsPerThread, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        (*assignment)[i] = loop_internal::NearestRow(metric_, centres, 0, centres.rows, Row(members[i]));
      }
    });
  }

  // New centres from the assignment, in row order; a cluster left empty keeps its centre.
  void UpdateCentres(const std::vector<uint32_t>& members, const std::vector<int>& assignment,
                     cv::Mat* centres) const;

  const cv::Mat& rows_;
  Metric metric_;
  int row_bytes_;
  const VocabularyTrainOptions& options_;
};

// Binary: k-majority voting (Grana et al. 2013), bit by bit: a centre bit is
// 1 when more than half of the cluster's descriptors have it set; an exact
// tie gives 0.
template <>
void NodeSplitter<BinaryMetric>::UpdateCentres(const std::vector<uint32_t>& members,
                                               const std::vector<int>& assignment, cv::Mat* centres) const {
  const int k = centres->rows;
  const int bits = 8 * row_bytes_;
  std::vector<int> ones(static_cast<size_t>(k * bits), 0);
  std::vector<int> sizes(static_cast<size_t>(k), 0);
  for (size_t i = 0; i < members.size(); ++i) {
    const int c = assignment[i];
    ++sizes[static_cast<size_t>(c)];
    const uint8_t* row = Row(members[i]);
    int* counts = &ones[static_cast<size_t>(c) * static_cast<size_t>(bits)];
    for (int byte = 0; byte < row_bytes_; ++byte) {
      const unsigned value = row[byte];
      if (value == 0) continue;
      for (int bit = 0; bit < 8; ++bit) counts[8 * byte + bit] += static_cast<int>((value >> bit) & 1u);
    }
  }
  for (int c = 0; c < k; ++c) {
    const int size = sizes[static_cast<size_t>(c)];
    if (size == 0) continue;
    uint8_t* centre = centres->ptr<uint8_t>(c);
    const int* counts = &ones[static_cast<size_t>(c) * static_cast<size_t>(bits)];
    for (int byte = 0; byte < row_bytes_; ++byte) {
      unsigned value = 0;
      for (int bit = 0; bit < 8; ++bit) {
        if (2 * counts[8 * byte + bit] > size) value |= 1u << bit;
      }
      centre[byte] = static_cast<uint8_t>(value);
    }
  }
}

// Float: the mean, summed in double in row order.
template <>
void NodeSplitter<FloatMetric>::UpdateCentres(const std::vector<uint32_t>& members,
                                              const std::vector<int>& assignment, cv::Mat* centres) const {
  const int k = centres->rows;
  const int dims = metric_.size;
  std::vector<double> sums(static_cast<size_t>(k * dims), 0.0);
  std::vector<int> sizes(static_cast<size_t>(k), 0);
  for (size_t i = 0; i < members.size(); ++i) {
    const int c = assignment[i];
    ++sizes[static_cast<size_t>(c)];
    const float* row = reinterpret_cast<const float*>(Row(members[i]));
    double* sum = &sums[static_cast<size_t>(c) * static_cast<size_t>(dims)];
    for (int d = 0; d < dims; ++d) sum[d] += row[d];
  }
  for (int c = 0; c < k; ++c) {
    const int size = sizes[static_cast<size_t>(c)];
    if (size == 0) continue;
    float* centre = reinterpret_cast<float*>(centres->ptr<uint8_t>(c));
    const double* sum = &sums[static_cast<size_t>(c) * static_cast<size_t>(dims)];
    for (int d = 0; d < dims; ++d) centre[d] = static_cast<float>(sum[d] / size);
  }
}

struct PendingNode {
  uint32_t index = 0;  // breadth-first
  int depth = 0;
  std::vector<uint32_t> members;
};

// Grows the tree of `impl` (child_count, centres) over the rows of `rows`.
template <typename Metric>
void GrowTree(const cv::Mat& rows, Metric metric, const VocabularyTrainOptions& options, int threads,
              Vocabulary::Impl* impl) {
  const int row_bytes = impl->RowBytes();
  const NodeSplitter<Metric> splitter(rows, metric, row_bytes, options);
  std::vector<std::vector<uint8_t>> centres(1, std::vector<uint8_t>(static_cast<size_t>(row_bytes), 0));
  impl->child_count.assign(1, 0);
  std::vector<PendingNode> level(1);
  level[0].members.resize(static_cast<size_t>(rows.rows));
  for (int r = 0; r < rows.rows; ++r) level[0].members[static_cast<size_t>(r)] = static_cast<uint32_t>(r);

  while (!level.empty()) {
    std::vector<std::vector<Cluster>> splits(level.size());
    const auto splittable = [&](const PendingNode& node) {
      return node.depth < options.levels && node.members.size() > 1;
    };
    // Large nodes one by one, their rows over the threads.
    std::vector<size_t> small;
    for (size_t j = 0; j < level.size(); ++j) {
      if (!splittable(level[j])) continue;
      if (threads > 1 && level[j].members.size() >= kRowsPerThread * static_cast<size_t>(threads)) {
        splits[j] = splitter.Split(level[j].index, level[j].members, threads);
      } else {
        small.push_back(j);
      }
    }
    // Small nodes in parallel, one node per thread at a time.
    ParallelFor(static_cast<int>(small.size()), std::max(threads, 1), [&](int s) {
      const PendingNode& node = level[small[static_cast<size_t>(s)]];
      splits[small[static_cast<size_t>(s)]] = splitter.Split(node.index, node.members, 1);
    });

    // Children get their indices in parent order.
    std::vector<PendingNode> next_level;
    for (size_t j = 0; j < level.size(); ++j) {
      std::vector<Cluster>& clusters = splits[j];
      if (clusters.size() < 2) continue;  // a leaf
      impl->child_count[level[j].index] = static_cast<uint32_t>(clusters.size());
      for (Cluster& cluster : clusters) {
        PendingNode child;
        child.index = static_cast<uint32_t>(impl->child_count.size());
        child.depth = level[j].depth + 1;
        child.members = std::move(cluster.members);
        impl->child_count.push_back(0);
        centres.push_back(std::move(cluster.centre));
        next_level.push_back(std::move(child));
      }
    }
    level = std::move(next_level);
  }

  impl->centres = cv::Mat(static_cast<int>(centres.size()), impl->descriptor_size,
                          impl->kind == DescriptorKind::kBinary ? CV_8UC1 : CV_32FC1);
  for (size_t i = 0; i < centres.size(); ++i) {
    std::memcpy(impl->centres.ptr<uint8_t>(static_cast<int>(i)), centres[i].data(),
                static_cast<size_t>(row_bytes));
  }
}

}  // namespace

Vocabulary TrainVocabulary(const std::vector<cv::Mat>& image_descriptors,
                           const VocabularyTrainOptions& options) {
  options.Check();
  // One type and width for all images; empty images are skipped.
  int type = -1;
  int cols = 0;
  int64_t total_rows = 0;
  int images = 0;
  for (size_t i = 0; i < image_descriptors.size(); ++i) {
    const cv::Mat& d = image_descriptors[i];
    if (d.empty()) continue;
    if (d.type() != CV_8UC1 && d.type() != CV_32FC1) {
      MCVO_THROW_INPUT("training descriptors of image ", i, ": OpenCV type ", d.type(),
                       ", expected CV_8UC1 (binary) or CV_32FC1 (float) rows");
    }
    if (type < 0) {
      type = d.type();
      cols = d.cols;
    } else if (d.type() != type || d.cols != cols) {
      MCVO_THROW_INPUT("training descriptors of image ", i, ": ", d.cols, " columns of type ", d.type(),
                       ", but the first image has ", cols, " columns of type ", type);
    }
    if (type == CV_32FC1 && !cv::checkRange(d)) {
      MCVO_THROW_INPUT("training descriptors of image ", i, ": non-finite values");
    }
    total_rows += d.rows;
    ++images;
  }
  if (total_rows == 0)
    MCVO_THROW_INPUT("no training descriptors (", image_descriptors.size(), " images, all empty)");
  if (total_rows > std::numeric_limits<int32_t>::max()) {
    MCVO_THROW_INPUT("too many training descriptors: ", total_rows);
  }

  // All rows in one continuous matrix, and the image of each row.
  cv::Mat rows(static_cast<int>(total_rows), cols, type);
  std::vector<int> image_of_row(static_cast<size_t>(total_rows));
  int r = 0;
  int image = 0;
  for (const cv::Mat& d : image_descriptors) {
    if (d.empty()) continue;
    d.copyTo(rows.rowRange(r, r + d.rows));
    std::fill(image_of_row.begin() + r, image_of_row.begin() + r + d.rows, image);
    r += d.rows;
    ++image;
  }

  const int threads = ResolveThreads(options.threads);
  Vocabulary vocabulary;
  Vocabulary::Impl& impl = *vocabulary.impl_;
  impl.kind = type == CV_8UC1 ? DescriptorKind::kBinary : DescriptorKind::kFloat;
  impl.descriptor_size = cols;
  impl.branching = options.branching;
  impl.levels = options.levels;
  if (impl.kind == DescriptorKind::kBinary) {
    GrowTree(rows, BinaryMetric{cols}, options, threads, &impl);
  } else {
    GrowTree(rows, FloatMetric{cols}, options, threads, &impl);
  }
  impl.Finalize();

  // IDF from the words of the training images as Transform finds them:
  // log(N / n_w), N images, n_w of them with word w.
  std::vector<uint32_t> word_of_row(static_cast<size_t>(total_rows));
  ParallelChunks(word_of_row.size(), threads, kRowsPerThread, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i)
      word_of_row[i] = impl.Descend(rows.ptr<uint8_t>(static_cast<int>(i)));
  });
  std::vector<int> images_with_word(static_cast<size_t>(impl.num_words), 0);
  std::vector<int> last_image(static_cast<size_t>(impl.num_words), -1);
  for (size_t i = 0; i < word_of_row.size(); ++i) {
    const uint32_t w = word_of_row[i];
    if (last_image[w] == image_of_row[i]) continue;
    // Rows of one image are consecutive: a word seen again in the same image is not counted twice.
    last_image[w] = image_of_row[i];
    ++images_with_word[w];
  }
  impl.idf.assign(static_cast<size_t>(impl.num_words), 0.0);
  for (size_t w = 0; w < impl.idf.size(); ++w) {
    if (images_with_word[w] > 0) impl.idf[w] = std::log(static_cast<double>(images) / images_with_word[w]);
  }
  return vocabulary;
}

}  // namespace mcvo
