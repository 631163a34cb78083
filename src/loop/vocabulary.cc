// The vocabulary's queries: words of descriptors, bags of words, the L1
// score. Training: vocabulary_train.cc; the file format: vocabulary_io.cc.
#include "mcvo/loop/vocabulary.h"

#include <algorithm>
#include <cmath>

#include "mcvo/util/error.h"
#include "vocabulary_internal.h"

namespace mcvo {

using loop_internal::BinaryMetric;
using loop_internal::FloatMetric;
using loop_internal::NearestRow;

double BowScore(const BowVector& a, const BowVector& b) {
  if (a.empty() || b.empty()) return 0.0;
  // For L1-normalised vectors with non-negative weights,
  //   1 - 0.5 |a - b|_1 = sum_i min(a_i, b_i)
  // (|a_i - b_i| = a_i + b_i - 2 min(a_i, b_i), and sum a_i = sum b_i = 1),
  // and the sum of the minima runs over the common words only. Dividing by
  // the larger of the two L1 norms (1 up to rounding) makes the score exactly
  // 1 for identical vectors, 0 for disjoint ones, symmetric (both vectors
  // are summed in word order), and within [0, 1] for any non-negative
  // vectors.
  double common = 0.0;
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->first < ib->first) {
      ++ia;
    } else if (ib->first < ia->first) {
      ++ib;
    } else {
      common += std::min(ia->second, ib->second);
      ++ia;
      ++ib;
    }
  }
  double norm_a = 0.0, norm_b = 0.0;
  for (const auto& [word, weight] : a) norm_a += std::abs(weight);
  for (const auto& [word, weight] : b) norm_b += std::abs(weight);
  const double norm = std::max(norm_a, norm_b);
  if (!(norm > 0.0)) return 0.0;
  return std::clamp(common / norm, 0.0, 1.0);
}

void VocabularyTrainOptions::Check() const {
  if (branching < 2 || branching > 65535) {
    throw UsageError(StrCat("branching: must be in [2, 65535], got ", branching));
  }
  if (levels < 1 || levels > 32) throw UsageError(StrCat("levels: must be in [1, 32], got ", levels));
  if (max_iterations < 1) throw UsageError(StrCat("max_iterations: must be >= 1, got ", max_iterations));
  if (threads < 0) throw UsageError(StrCat("threads: must be >= 0, got ", threads));
}

void Vocabulary::Impl::Finalize() {
  const size_t n = child_count.size();
  first_child.assign(n, 0);
  word.assign(n, -1);
  num_words = 0;
  uint64_t next = 1;
  for (size_t i = 0; i < n; ++i) {
    first_child[i] = static_cast<uint32_t>(next);
    if (child_count[i] == 0) {
      word[i] = num_words++;
    } else {
      MCVO_CHECK(next > i);
      next += child_count[i];
    }
  }
  MCVO_CHECK(next == n);
  MCVO_CHECK(static_cast<int>(idf.size()) == num_words || idf.empty());
}

uint32_t Vocabulary::Impl::Descend(const uint8_t* row) const {
  uint32_t node = 0;
  if (kind == DescriptorKind::kBinary) {
    const BinaryMetric metric{descriptor_size};
    while (child_count[node] > 0) {
      node = static_cast<uint32_t>(NearestRow(metric, centres, static_cast<int>(first_child[node]),
                                              static_cast<int>(child_count[node]), row));
    }
  } else {
    const FloatMetric metric{descriptor_size};
    while (child_count[node] > 0) {
      node = static_cast<uint32_t>(NearestRow(metric, centres, static_cast<int>(first_child[node]),
                                              static_cast<int>(child_count[node]), row));
    }
  }
  return static_cast<uint32_t>(word[node]);
}

Vocabulary::Vocabulary() : impl_(std::make_unique<Impl>()) {}
Vocabulary::~Vocabulary() = default;
Vocabulary::Vocabulary(Vocabulary&&) noexcept = default;
Vocabulary& Vocabulary::operator=(Vocabulary&&) noexcept = default;

Vocabulary::Vocabulary(const Vocabulary& other)
    : impl_(other.impl_ ? std::make_unique<Impl>(*other.impl_) : std::make_unique<Impl>()) {
  impl_->centres = impl_->centres.clone();  // cv::Mat copies share their data
}

Vocabulary& Vocabulary::operator=(const Vocabulary& other) {
  if (this != &other) *this = Vocabulary(other);
  return *this;
}

DescriptorKind Vocabulary::kind() const { return impl_ ? impl_->kind : DescriptorKind::kBinary; }
int Vocabulary::descriptor_size() const { return impl_ ? impl_->descriptor_size : 0; }
int Vocabulary::branching() const { return impl_ ? impl_->branching : 0; }
int Vocabulary::levels() const { return impl_ ? impl_->levels : 0; }
int Vocabulary::num_words() const { return impl_ ? impl_->num_words : 0; }
int Vocabulary::num_nodes() const { return impl_ ? static_cast<int>(impl_->child_count.size()) : 0; }
bool Vocabulary::empty() const { return num_words() == 0; }

uint32_t Vocabulary::WordOf(const cv::Mat& descriptor_row) const {
  MCVO_CHECK_MSG(!empty(), "WordOf on an empty vocabulary");
  const int type = impl_->kind == DescriptorKind::kBinary ? CV_8UC1 : CV_32FC1;
  MCVO_CHECK_MSG(descriptor_row.rows == 1 && descriptor_row.type() == type &&
                     descriptor_row.cols == impl_->descriptor_size,
                 "descriptor row ", descriptor_row.rows, "x", descriptor_row.cols, " of type ",
                 descriptor_row.type(), " does not match the vocabulary's 1x", impl_->descriptor_size,
                 " of type ", type);
  return impl_->Descend(descriptor_row.ptr<uint8_t>(0));
}

BowVector Vocabulary::Transform(const cv::Mat& descriptors) const {
  MCVO_CHECK_MSG(!empty(), "Transform on an empty vocabulary");
  BowVector bow;
  if (descriptors.empty()) return bow;
  const bool binary = impl_->kind == DescriptorKind::kBinary;
  const int type = binary ? CV_8UC1 : CV_32FC1;
  if (descriptors.type() != type || descriptors.cols != impl_->descriptor_size) {
    MCVO_THROW_INPUT("descriptors of ", descriptors.cols, " ",
                     descriptors.depth() == CV_8U ? "bytes" : "elements", " (OpenCV type ",
                     descriptors.type(), ") do not match the vocabulary's ", impl_->descriptor_size,
                     binary ? "-byte binary descriptors" : "-float descriptors");
  }
  // Term frequency n_w / n (n: all descriptors of the image) times IDF;
  // words of IDF 0 (in every training image) carry no weight and are left out.
  std::map<uint32_t, int> counts;
  for (int r = 0; r < descriptors.rows; ++r) ++counts[impl_->Descend(descriptors.ptr<uint8_t>(r))];
  const double n = descriptors.rows;
  double sum = 0.0;
  for (const auto& [word, count] : counts) {
    const double weight = (count / n) * impl_->idf[word];
    if (weight > 0.0) {
      bow.emplace_hint(bow.end(), word, weight);
      sum += weight;
    }
  }
  if (!(sum > 0.0)) return {};
  for (auto& [word, weight] : bow) weight /= sum;
  return bow;
}

double Vocabulary::Idf(uint32_t word) const {
  MCVO_CHECK_MSG(impl_ && word < impl_->idf.size(), "word ", word, " out of range (", num_words(), " words)");
  return impl_->idf[word];
}

}  // namespace mcvo
