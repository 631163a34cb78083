// The pyramid level for a megapixel bound and the mask on a coarser level
// (dataset/image_level.h), shared by Shi-Tomasi detection and loop-closure
// features.
#include "mcvo/dataset/image_level.h"

#include <gtest/gtest.h>

#include <cstdint>

namespace mcvo {
namespace {

TEST(ImageLevelTest, LevelForMegapixels) {
  // The KITTI-360 rig at full resolution: the fisheyes (1.96 Mpx) halve once,
  // the pinholes (0.53 Mpx) stay.
  EXPECT_EQ(LevelForMegapixels(1400, 1400, 1.0, 4), 1);
  EXPECT_EQ(LevelForMegapixels(1408, 376, 1.0, 4), 0);
  EXPECT_EQ(LevelForMegapixels(1000, 1000, 1.0, 4), 0);  // exactly at the bound
  EXPECT_EQ(LevelForMegapixels(1001, 1000, 1.0, 4), 1);
  EXPECT_EQ(LevelForMegapixels(4000, 4000, 1.0, 4), 2);   // 16 -> 4 -> 1 Mpx
  EXPECT_EQ(LevelForMegapixels(4000, 4000, 0.01, 3), 3);  // capped
  EXPECT_EQ(LevelForMegapixels(4000, 4000, 0.0, 4), 0);   // no bound
  EXPECT_EQ(LevelForMegapixels(4000, 4000, -1.0, 4), 0);
}

TEST(ImageLevelTest, CoarseMaskKeepsOnlyFullyValidPixels) {
  cv::Mat mask(5, 7, CV_8UC1, cv::Scalar(255));
  mask.at<uint8_t>(2, 3) = 0;  // covered by coarse (1, 1)
  mask.at<uint8_t>(4, 6) = 0;  // the odd last row and column: coarse (2, 3)
  const cv::Mat coarse = CoarseMask(mask, 1);
  ASSERT_EQ(coarse.cols, 4);
  ASSERT_EQ(coarse.rows, 3);
  for (int y = 0; y < coarse.rows; ++y) {
    for (int x = 0; x < coarse.cols; ++x) {
      const bool invalid = (y == 1 && x == 1) || (y == 2 && x == 3);
      EXPECT_EQ(coarse.at<uint8_t>(y, x), invalid ? 0 : 255) << x << "," << y;
    }
  }
  const cv::Mat twice = CoarseMask(mask, 2);
  ASSERT_EQ(twice.cols, 2);
  ASSERT_EQ(twice.rows, 2);
  EXPECT_EQ(twice.at<uint8_t>(0, 0), 0);
  EXPECT_EQ(twice.at<uint8_t>(0, 1), 255);
  EXPECT_EQ(twice.at<uint8_t>(1, 1), 0);
  EXPECT_TRUE(cv::countNonZero(CoarseMask(mask, 0) != mask) == 0);
}

}  // namespace
}  // namespace mcvo
