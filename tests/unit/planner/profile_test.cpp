#include "motion/planner/profile.hpp"

#include <gtest/gtest.h>

namespace motion::planner {
namespace {

TEST(TimeOptimalShape, TrapezoidByHand) {
  // 1000 counts, v 200, a = d = 400: ramps 200/400 = 0.5 s covering 0.5*400*0.5^2 = 50 counts each;
  // cruise (1000 - 100) / 200 = 4.5 s; total 5.5 s.
  const TrapezoidShape s = time_optimal_shape(1000.0, 200.0, 400.0, 400.0);
  EXPECT_DOUBLE_EQ(s.peak_velocity, 200.0);
  EXPECT_DOUBLE_EQ(s.t_acc_s, 0.5);
  EXPECT_DOUBLE_EQ(s.t_cruise_s, 4.5);
  EXPECT_DOUBLE_EQ(s.t_dec_s, 0.5);
  EXPECT_DOUBLE_EQ(s.duration_s(), 5.5);
  EXPECT_DOUBLE_EQ(s.travelled(1000.0, 0.25), 12.5);   // 0.5*400*0.25^2
  EXPECT_DOUBLE_EQ(s.travelled(1000.0, 1.0), 150.0);   // 50 + 200*0.5
  EXPECT_DOUBLE_EQ(s.travelled(1000.0, 5.25), 987.5);  // 1000 - 0.5*400*0.25^2
  EXPECT_DOUBLE_EQ(s.velocity(5.25), 100.0);           // 400*0.25
  EXPECT_DOUBLE_EQ(s.velocity(3.0), 200.0);
}

TEST(TimeOptimalShape, TriangleWhenCruiseIsUnreachable) {
  // 100 counts, v cap 1000, a = d = 100: ramps to 1000 would need 2 * 1000^2/200 = 10000 counts.
  // Peak sqrt(2*100*100*100/200) = 100 counts/s, ramps 100/100 = 1 s each, 50 counts each.
  const TrapezoidShape s = time_optimal_shape(100.0, 1000.0, 100.0, 100.0);
  EXPECT_DOUBLE_EQ(s.peak_velocity, 100.0);
  EXPECT_DOUBLE_EQ(s.t_cruise_s, 0.0);
  EXPECT_DOUBLE_EQ(s.duration_s(), 2.0);
  EXPECT_DOUBLE_EQ(s.travelled(100.0, 1.0), 50.0);
}

TEST(TimeOptimalShape, SeparateDeceleration) {
  // 1000 counts, v 100, a 100, d 50: accel 1 s / 50 counts, decel 2 s / 100 counts,
  // cruise 850/100 = 8.5 s; total 11.5 s.
  const TrapezoidShape s = time_optimal_shape(1000.0, 100.0, 100.0, 50.0);
  EXPECT_DOUBLE_EQ(s.t_acc_s, 1.0);
  EXPECT_DOUBLE_EQ(s.t_cruise_s, 8.5);
  EXPECT_DOUBLE_EQ(s.t_dec_s, 2.0);
  EXPECT_DOUBLE_EQ(s.travelled(1000.0, 10.5), 975.0);  // 1000 - 0.5*50*1^2
}

TEST(AxisProfile, NegativeMoveSamplesBackwardsAndEndsExactly) {
  // 500 -> -500: the 1000-count trapezoid above, mirrored.
  const AxisProfile p = time_optimal_profile(500, -500, 200.0, 400.0, 400.0);
  EXPECT_EQ(p.distance_counts(), -1000);
  EXPECT_DOUBLE_EQ(p.sample(1.0).position_counts, 350.0);  // 500 - 150
  EXPECT_DOUBLE_EQ(p.sample(1.0).velocity_counts_per_s, -200.0);
  EXPECT_EQ(p.sample(-1.0).position_counts, 500.0);
  EXPECT_EQ(p.sample(p.duration_s()).position_counts, -500.0);
  EXPECT_EQ(p.sample(100.0).velocity_counts_per_s, 0.0);
}

TEST(AxisProfile, StillAxisHasNoDuration) {
  const AxisProfile p = time_optimal_profile(42, 42, 1.0, 1.0, 1.0);
  EXPECT_TRUE(p.is_still());
  EXPECT_EQ(p.duration_s(), 0.0);
  EXPECT_EQ(p.sample(0.5).position_counts, 42.0);
  EXPECT_EQ(p.sample(0.5).velocity_counts_per_s, 0.0);
}

}  // namespace
}  // namespace motion::planner
