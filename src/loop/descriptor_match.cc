#include "mcvo/loop/descriptor_match.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <limits>

#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"

namespace mcvo {
namespace {

// 32-byte binary descriptors (ORB) as four 64-bit words, for Hamming
// distances by popcount.
using Descriptor256 = std::array<uint64_t, 4>;

std::vector<Descriptor256> PackDescriptors(const cv::Mat& descriptors) {
  MCVO_CHECK_MSG(descriptors.empty() || (descriptors.type() == CV_8UC1 && descriptors.cols == 32),
                 "loop closure: descriptors must be 32-byte rows, got ", descriptors.cols, " columns");
  std::vector<Descriptor256> packed(static_cast<size_t>(descriptors.rows));
  for (int r = 0; r < descriptors.rows; ++r) {
    std::memcpy(packed[static_cast<size_t>(r)].data(), descriptors.ptr<uint8_t>(r), 32);
  }
  return packed;
}

// The query rows [begin, end) against every train row (nearest first, a
// tie keeping the lower train row first, as cv::batchDistance inserts).
// On x86-64 a second copy of this loop is compiled for the POPCNT
// instruction and chosen at load time where the CPU has it (every x86-64
// CPU since 2008); without it, a popcount is a libgcc call and took most
// of the loop stage's time.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("popcnt", "default")))
#endif
void MatchRows(const std::vector<Descriptor256>& q, const std::vector<Descriptor256>& t, int kk, int begin,
               int end, std::vector<std::vector<cv::DMatch>>* knn) {
  std::vector<int> best_d(static_cast<size_t>(kk)), best_i(static_cast<size_t>(kk));
  for (int r = begin; r < end; ++r) {
    std::fill(best_d.begin(), best_d.end(), std::numeric_limits<int>::max());
    std::fill(best_i.begin(), best_i.end(), -1);
    const Descriptor256& row = q[static_cast<size_t>(r)];
    for (int j = 0; j < static_cast<int>(t.size()); ++j) {
      const Descriptor256& other = t[static_cast<size_t>(j)];
      const int d = __builtin_popcountll(row[0] ^ other[0]) + __builtin_popcountll(row[1] ^ other[1]) +
                    __builtin_popcountll(row[2] ^ other[2]) + __builtin_popcountll(row[3] ^ other[3]);
      if (kk == 0 || d >= best_d[static_cast<size_t>(kk - 1)]) continue;
      int slot = kk - 1;
      for (; slot > 0 && best_d[static_cast<size_t>(slot - 1)] > d; --slot) {
        best_d[static_cast<size_t>(slot)] = best_d[static_cast<size_t>(slot - 1)];
        best_i[static_cast<size_t>(slot)] = best_i[static_cast<size_t>(slot - 1)];
      }
      best_d[static_cast<size_t>(slot)] = d;
      best_i[static_cast<size_t>(slot)] = j;
    }
    std::vector<cv::DMatch>& out = (*knn)[static_cast<size_t>(r)];
    for (int s = 0; s < kk && best_i[static_cast<size_t>(s)] >= 0; ++s) {
      out.emplace_back(r, best_i[static_cast<size_t>(s)], static_cast<float>(best_d[static_cast<size_t>(s)]));
    }
  }
}

}  // namespace

std::vector<std::vector<cv::DMatch>> HammingKnnMatch(const cv::Mat& query, const cv::Mat& train, int k,
                                                     int threads) {
  const std::vector<Descriptor256> q = PackDescriptors(query), t = PackDescriptors(train);
  const int kk = std::min<int>(k, static_cast<int>(t.size()));
  std::vector<std::vector<cv::DMatch>> knn(q.size());
  constexpr int kMinRowsPerBlock = 128;
  const int rows = static_cast<int>(q.size());
  const int blocks = std::max(1, std::min(ResolveThreads(threads), rows / kMinRowsPerBlock));
  ParallelFor(blocks, blocks, [&](int block) {
    const int begin = static_cast<int>(static_cast<int64_t>(rows) * block / blocks);
    const int end = static_cast<int>(static_cast<int64_t>(rows) * (block + 1) / blocks);
    MatchRows(q, t, kk, begin, end, &knn);
  });
  return knn;
}

}  // namespace mcvo
