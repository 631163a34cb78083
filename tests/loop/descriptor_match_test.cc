// HammingKnnMatch against OpenCV's brute-force matcher, which it replaces in
// loop verification: the same neighbours, order and distances, ties
// included, at any thread count.
#include "mcvo/loop/descriptor_match.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

namespace mcvo {
namespace {

// Random 32-byte descriptors with only the low `bits` bits of each byte
// free, so that many distances tie.
cv::Mat RandomDescriptors(int rows, int bits, uint64_t seed) {
  cv::Mat d(rows, 32, CV_8UC1);
  cv::RNG rng(seed);
  const int mask = (1 << bits) - 1;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < 32; ++c) d.at<uint8_t>(r, c) = static_cast<uint8_t>(rng.uniform(0, 256) & mask);
  }
  return d;
}

void ExpectSameAsOpenCv(const cv::Mat& query, const cv::Mat& train, int k, int threads) {
  SCOPED_TRACE("k " + std::to_string(k) + ", train rows " + std::to_string(train.rows) + ", threads " +
               std::to_string(threads));
  std::vector<std::vector<cv::DMatch>> expected;
  cv::BFMatcher(cv::NORM_HAMMING).knnMatch(query, train, expected, k);
  const std::vector<std::vector<cv::DMatch>> got = HammingKnnMatch(query, train, k, threads);
  ASSERT_EQ(got.size(), expected.size());
  int ties = 0;
  for (size_t r = 0; r < got.size(); ++r) {
    ASSERT_EQ(got[r].size(), expected[r].size()) << "row " << r;
    for (size_t m = 0; m < got[r].size(); ++m) {
      EXPECT_EQ(got[r][m].queryIdx, expected[r][m].queryIdx) << "row " << r;
      EXPECT_EQ(got[r][m].trainIdx, expected[r][m].trainIdx) << "row " << r << " match " << m;
      EXPECT_EQ(got[r][m].distance, expected[r][m].distance) << "row " << r << " match " << m;
      if (m > 0 && got[r][m].distance == got[r][m - 1].distance) ++ties;
    }
  }
  // The comparison covers tie-breaking only where there are ties.
  if (k > 1 && train.rows > 1) {
    EXPECT_GT(ties, 0);
  }
}

TEST(DescriptorMatchTest, SameNeighboursAsOpenCvBruteForceMatcher) {
  const cv::Mat query = RandomDescriptors(600, 2, 1);  // more rows than one block (128) per thread
  const cv::Mat train = RandomDescriptors(400, 2, 2);
  for (int k : {1, 2, 3}) {
    for (int threads : {1, 2, 3}) ExpectSameAsOpenCv(query, train, k, threads);
  }
  // Fewer train rows than k: every train row, nearest first.
  ExpectSameAsOpenCv(query, train.rowRange(0, 2), 3, 2);
  ExpectSameAsOpenCv(query, train.rowRange(0, 1), 2, 2);
}

TEST(DescriptorMatchTest, EmptyInputsGiveNoMatches) {
  const cv::Mat train = RandomDescriptors(10, 8, 3);
  EXPECT_TRUE(HammingKnnMatch(cv::Mat(), train, 2, 2).empty());
  const std::vector<std::vector<cv::DMatch>> none =
      HammingKnnMatch(RandomDescriptors(5, 8, 4), cv::Mat(), 2, 2);
  ASSERT_EQ(none.size(), 5u);
  for (const auto& row : none) EXPECT_TRUE(row.empty());
}

}  // namespace
}  // namespace mcvo
