// The estimator's scale filter (scale_filter.h): the formulas of its header,
// checked by hand-computed values.
#include "mcvo/backend/scale_filter.h"

#include <cmath>

#include <gtest/gtest.h>

namespace mcvo {
namespace {

TEST(ScaleFilter, VarianceStartsAtTheInitialisersAndGrowsWithDistance) {
  ScaleFilterOptions options;
  options.drift_per_100m = 0.01;  // 1 % per 100 m: 1e-6 per metre
  ScaleFilter filter(options);
  filter.Start(0.02, Eigen::Vector3d::Zero());
  EXPECT_DOUBLE_EQ(filter.variance(), 4e-4);
  filter.Travel(Eigen::Vector3d(30.0, 40.0, 0.0));  // 50 m
  EXPECT_NEAR(filter.variance(), 4e-4 + 50e-6, 1e-15);
  filter.Travel(Eigen::Vector3d(30.0, 40.0, 0.0));  // standing still
  EXPECT_NEAR(filter.variance(), 4e-4 + 50e-6, 1e-15);
  EXPECT_NEAR(filter.sigma(), std::sqrt(4.5e-4), 1e-15);
}

TEST(ScaleFilter, FirstTravelWithoutStartOnlyRecordsThePosition) {
  ScaleFilter filter;
  filter.Travel(Eigen::Vector3d(100.0, 0.0, 0.0));
  EXPECT_EQ(filter.variance(), 0.0);
  filter.Travel(Eigen::Vector3d(200.0, 0.0, 0.0));
  EXPECT_NEAR(filter.variance(), 1e-4, 1e-15);  // 100 m at 1 % per 100 m
}

TEST(ScaleFilter, AMeasurementIsFusedWithTheKalmanGainInLogScale) {
  ScaleFilter filter;
  filter.Start(0.03, Eigen::Vector3d::Zero());  // v = 9e-4
  const ScaleFilter::Update update = filter.Measure(1.05, 0.03);  // sigma^2 = 9e-4: gain 1/2
  EXPECT_EQ(update.outcome, ScaleFilter::Outcome::kApply);
  EXPECT_DOUBLE_EQ(update.gain, 0.5);
  EXPECT_NEAR(update.factor, std::sqrt(1.05), 1e-12);  // exp(log(1.05) / 2)
  EXPECT_NEAR(update.innovation_sigmas, std::log(1.05) / std::sqrt(18e-4), 1e-12);
  EXPECT_NEAR(filter.variance(), 4.5e-4, 1e-15);
}

TEST(ScaleFilter, AnOutlierChangesNothing) {
  ScaleFilter filter;
  filter.Start(0.01, Eigen::Vector3d::Zero());  // v = 1e-4
  // S = sqrt(2e-4) = 1.41 %; a 10 % ratio is 6.7 S away (> 4).
  const ScaleFilter::Update update = filter.Measure(1.10, 0.01);
  EXPECT_EQ(update.outcome, ScaleFilter::Outcome::kOutlier);
  EXPECT_EQ(update.gain, 0.0);
  EXPECT_EQ(update.factor, 1.0);
  EXPECT_NEAR(update.innovation_sigmas, std::log(1.10) / std::sqrt(2e-4), 1e-12);
  EXPECT_DOUBLE_EQ(filter.variance(), 1e-4);
}

TEST(ScaleFilter, ASmallChangeIsNotAppliedButStillShrinksTheVariance) {
  ScaleFilterOptions options;
  options.min_change = 0.002;
  ScaleFilter filter(options);
  filter.Start(0.01, Eigen::Vector3d::Zero());
  const ScaleFilter::Update update = filter.Measure(1.003, 0.01);  // k = exp(log(1.003) / 2) - 1 = 0.15 %
  EXPECT_EQ(update.outcome, ScaleFilter::Outcome::kBelowMinChange);
  EXPECT_NEAR(update.factor, std::sqrt(1.003), 1e-12);
  EXPECT_NEAR(filter.variance(), 0.5e-4, 1e-15);
}

}  // namespace
}  // namespace mcvo
