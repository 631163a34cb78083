// Standing still on a rendered route (include/mcvo/synth/stops.h).
#include "mcvo/synth/stops.h"

#include <cmath>

#include <gtest/gtest.h>

#include "mcvo/util/error.h"

namespace mcvo::synth {
namespace {

double Slope(const StopPlan& plan, double t, double h = 1e-5) {
  return (plan.RouteSeconds(t + h) - plan.RouteSeconds(t - h)) / (2 * h);
}

TEST(StopPlan, WithoutStopsRouteTimeIsSequenceTime) {
  const StopPlan plan;
  EXPECT_TRUE(plan.Empty());
  for (double t : {0.0, 0.1, 3.7, 1000.0}) EXPECT_EQ(plan.RouteSeconds(t), t);
  EXPECT_FALSE(plan.Standing(1.0));
}

TEST(StopPlan, StandAtTheStartThenPullsAwaySmoothly) {
  StopPlan plan;
  plan.stand_s = 2.0;
  plan.ramp_s = 4.0;
  plan.Check();
  for (double t : {0.0, 0.5, 1.999}) {
    EXPECT_EQ(plan.RouteSeconds(t), 0.0) << t;
    EXPECT_TRUE(plan.Standing(t)) << t;
  }
  EXPECT_FALSE(plan.Standing(2.5));
  // Speed factor: 0 at the end of the stand, 1 after the ramp, continuous at both.
  EXPECT_NEAR(Slope(plan, 2.0), 0.0, 1e-4);
  EXPECT_NEAR(Slope(plan, 4.0), 0.5, 1e-6);  // smoothstep(0.5)
  EXPECT_NEAR(Slope(plan, 6.0), 1.0, 1e-4);
  // The ramp gains half of its duration: route time lags by stand + ramp / 2.
  EXPECT_NEAR(plan.RouteSeconds(6.0), 2.0, 1e-12);
  EXPECT_NEAR(plan.RouteSeconds(10.0), 6.0, 1e-12);
  // Non-decreasing everywhere.
  double previous = 0.0;
  for (double t = 0.0; t < 12.0; t += 0.01) {
    const double tau = plan.RouteSeconds(t);
    EXPECT_GE(tau, previous - 1e-15) << t;
    previous = tau;
  }
}

TEST(StopPlan, StopOnTheWaySlowsStandsAndPullsAway) {
  StopPlan plan;
  plan.ramp_s = 2.0;
  plan.stops.push_back({10.0, 3.0});  // slows 10-12, stands 12-15, pulls away 15-17
  plan.Check();
  EXPECT_FALSE(plan.Empty());
  EXPECT_DOUBLE_EQ(plan.RouteSeconds(5.0), 5.0);
  EXPECT_NEAR(Slope(plan, 10.0), 1.0, 1e-4);
  EXPECT_NEAR(plan.RouteSeconds(12.0), 11.0, 1e-12);
  EXPECT_NEAR(plan.RouteSeconds(13.5), 11.0, 1e-12);
  EXPECT_TRUE(plan.Standing(13.5));
  EXPECT_FALSE(plan.Standing(11.0));
  EXPECT_NEAR(Slope(plan, 12.0), 0.0, 1e-4);
  EXPECT_NEAR(Slope(plan, 15.0), 0.0, 1e-4);
  EXPECT_NEAR(plan.RouteSeconds(17.0), 12.0, 1e-12);
  EXPECT_NEAR(plan.RouteSeconds(20.0), 15.0, 1e-12);  // lags by duration + ramp
}

TEST(StopPlan, BadPlansThrowNamingTheField) {
  StopPlan plan;
  plan.stand_s = -1.0;
  EXPECT_THROW(plan.Check(), UsageError);
  plan = StopPlan();
  plan.ramp_s = 0.0;
  EXPECT_THROW(plan.Check(), UsageError);
  plan = StopPlan();
  plan.stand_s = 2.0;
  plan.stops.push_back({3.0, 1.0});  // during the stand's ramp (ends at 6 s)
  try {
    plan.Check();
    ADD_FAILURE() << "no throw";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("stop 1"), std::string::npos) << e.what();
  }
  plan.stops = {{6.0, 1.0}, {8.0, 1.0}};  // the second begins before the first ends (6 + 8 + 1)
  EXPECT_THROW(plan.Check(), UsageError);
  plan.stops = {{6.0, 0.0}};
  EXPECT_THROW(plan.Check(), UsageError);
  plan.stops = {{6.0, NAN}};
  EXPECT_THROW(plan.Check(), UsageError);
}

TEST(StopPlan, ParseStop) {
  const Stop s = ParseStop("12.5:3");
  EXPECT_EQ(s.at_s, 12.5);
  EXPECT_EQ(s.duration_s, 3.0);
  EXPECT_THROW(ParseStop("12"), UsageError);
  EXPECT_THROW(ParseStop("a:b"), UsageError);
  EXPECT_THROW(ParseStop("1:2:3"), UsageError);
}

}  // namespace
}  // namespace mcvo::synth
