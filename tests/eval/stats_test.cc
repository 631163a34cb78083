#include <cmath>

#include <gtest/gtest.h>

#include "mcvo/eval/stats.h"

namespace mcvo {
namespace {

TEST(ComputeStats, HandComputed) {
  // {1, 2, 3, 4}: mean 2.5, median (2 + 3) / 2, rmse sqrt(30 / 4),
  // population std sqrt((2.25 + 0.25 + 0.25 + 2.25) / 4) = sqrt(1.25).
  const ErrorStats s = ComputeStats({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));
  EXPECT_EQ(s.min, 1.0);
  EXPECT_EQ(s.max, 4.0);
  // Odd count: the middle value.
  EXPECT_EQ(ComputeStats({5.0, 1.0, 2.0}).median, 2.0);
}

TEST(ComputeStats, EmptyAndSingle) {
  const ErrorStats empty = ComputeStats({});
  EXPECT_EQ(empty.count, 0u);
  EXPECT_EQ(empty.rmse, 0.0);
  const ErrorStats one = ComputeStats({3.0});
  EXPECT_EQ(one.rmse, 3.0);
  EXPECT_EQ(one.std, 0.0);
  EXPECT_EQ(one.median, 3.0);
}

}  // namespace
}  // namespace mcvo
