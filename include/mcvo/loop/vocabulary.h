// Bag-of-words vocabulary: a hierarchical k-means tree over feature
// descriptors with TF-IDF weighting and the L1 score (Nister & Stewenius
// 2006; Galvez-Lopez & Tardos 2012, DBoW2), for binary descriptors (ORB,
// BRIEF: 8-bit rows of CV_8U, Hamming distance, k-majority centres) and
// float descriptors (XFeat, SuperPoint: CV_32F rows, L2 distance, mean
// centres). Loop closure (loop/loop_closer.h) puts one bag of words per
// multi-camera keyframe (the words of all its cameras) in a database.
//
//   Vocabulary vocabulary = TrainVocabulary(descriptors, {/*branching=*/8, /*levels=*/4});
//   vocabulary.Save("vocab.bin");
//   const Vocabulary loaded = Vocabulary::Load("vocab.bin");   // InputError naming the file on bad input
//   const BowVector bow = loaded.Transform(keyframe_descriptors);
//   const double s = BowScore(bow_a, bow_b);  // in [0, 1]; 1: the same words in the same proportions
//
// Deterministic: training with the same descriptors and options gives the
// same tree (seeded k-means++, fixed iteration order) at any thread count;
// Transform is a pure function.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace mcvo {

enum class DescriptorKind { kBinary, kFloat };

// Sparse bag-of-words vector: word id -> weight (TF-IDF), L1-normalised
// (weights sum to 1). Ordered by word id.
using BowVector = std::map<uint32_t, double>;

// DBoW2's L1 score: 1 - 0.5 * |a - b|_1 for L1-normalised vectors, in
// [0, 1]; 0 when either is empty. Computed as sum_w min(a_w, b_w) (equal for
// L1-normalised vectors) divided by the larger L1 norm, so that it is exactly
// 1 for identical vectors, exactly 0 for disjoint ones, and symmetric.
double BowScore(const BowVector& a, const BowVector& b);

struct VocabularyTrainOptions {
  // 8^4 = 4096 words at most: the default ORB vocabulary (config/vocabulary_orb.bin,
  // 32-byte centres, 201 KB; docs/loop-closure.md). DBoW2's ORB vocabulary uses 10^6.
  int branching = 8;        // k of the k-means at every node, in [2, 65535]
  int levels = 4;           // depth: at most branching^levels words, in [1, 32]
  int max_iterations = 10;  // k-means iterations per node (fewer once the assignment settles)
  uint64_t seed = 0;        // k-means++ seeding (each node draws from a hash of seed and node index)
  int threads = 0;          // 0: hardware concurrency; the result does not depend on it
  // Throws UsageError naming the field.
  void Check() const;
};

class Vocabulary {
 public:
  Vocabulary();
  ~Vocabulary();
  Vocabulary(Vocabulary&&) noexcept;
  Vocabulary& operator=(Vocabulary&&) noexcept;
  // Copies are deep (a vocabulary is immutable once trained or loaded; the
  // default ORB vocabulary is 201 KB).
  Vocabulary(const Vocabulary& other);
  Vocabulary& operator=(const Vocabulary& other);

  DescriptorKind kind() const;
  // Bytes per row (binary) or floats per row (float).
  int descriptor_size() const;
  int branching() const;
  int levels() const;
  int num_words() const;
  int num_nodes() const;  // the root, inner nodes and leaves (words)
  bool empty() const;     // default-constructed (or moved from)

  // Word of one descriptor row (descend the tree by nearest centre); the
  // row's type and size must match the vocabulary (MCVO_CHECK).
  uint32_t WordOf(const cv::Mat& descriptor_row) const;
  // Bag of words of a set of descriptors (rows; empty Mat: empty vector):
  // term frequency x IDF, L1-normalised; words of IDF 0 (seen in every
  // training image) are left out, so the vector is empty when all its words
  // have IDF 0. Throws InputError when the descriptor type or size does not
  // match the vocabulary's. MCVO_CHECKs that the vocabulary is not empty.
  BowVector Transform(const cv::Mat& descriptors) const;
  // IDF weight of a word (log(N / n_i) over the training images).
  double Idf(uint32_t word) const;

  // Binary file (magic, format version, kind, sizes, nodes, IDF weights,
  // a SHA-256; layout in src/loop/vocabulary_io.cc and docs/loop-closure.md). Save writes atomically. Load
  // throws InputError naming the file and what is wrong (not a vocabulary, truncated, unsupported version,
  // bad checksum).
  void Save(const std::filesystem::path& path) const;
  static Vocabulary Load(const std::filesystem::path& path);

  struct Impl;

 private:
  friend Vocabulary TrainVocabulary(const std::vector<cv::Mat>&, const VocabularyTrainOptions&);
  std::unique_ptr<Impl> impl_;
};

// Trains a vocabulary from the descriptors of training images (one Mat per
// image, rows = features; all of one type: CV_8UC1 binary or CV_32FC1 float,
// and one width). Hierarchical k-means, k-means++ seeding; binary centres by
// bitwise majority (an exact tie gives 0), float centres by the mean; nearest
// centre ties go to the lower index. A node becomes a leaf at depth `levels`
// or when its descriptors do not give two distinct centres. IDF = log(N /
// n_w), N the images with descriptors (empty Mats are skipped), n_w those
// with word w (as Transform assigns words). Throws InputError when there is
// no descriptor or the images disagree on type or width, or float
// descriptors are not finite; UsageError from options.Check().
Vocabulary TrainVocabulary(const std::vector<cv::Mat>& image_descriptors,
                           const VocabularyTrainOptions& options);

}  // namespace mcvo
