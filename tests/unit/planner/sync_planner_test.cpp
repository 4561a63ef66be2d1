#include "motion/planner/sync_planner.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "axis_builder.hpp"

namespace motion::planner {
namespace {

using testing::make_axis;

// X: 0 -> 10 mm at 100 counts/mm = 1000 counts, v 2 mm/s = 200 c/s, a 4 mm/s^2 = 400 c/s^2.
// Y: 0 -> 5 mm at 100 counts/mm = 500 counts, v 0.5 mm/s = 50 c/s, a 4 mm/s^2 = 400 c/s^2.
std::vector<AxisRequest> two_axes() {
  return {make_axis({.name = "x",
                     .target_user = 10.0,
                     .counts_per_user = 100.0,
                     .max_velocity_user_per_s = 2.0,
                     .max_acceleration_user_per_s2 = 4.0}),
          make_axis({.name = "y",
                     .target_user = 5.0,
                     .counts_per_user = 100.0,
                     .max_velocity_user_per_s = 0.5,
                     .max_acceleration_user_per_s2 = 4.0})};
}

TEST(SyncPlanner, TwoAxesByHand) {
  // Unit-move caps: V = min(200/1000, 50/500) = 0.1 /s (set by y), A = min(400/1000, 400/500) = 0.4 /s^2
  // (set by x). t_acc = t_dec = 0.1/0.4 = 0.25 s, each ramp covers 0.1^2/(2*0.4) = 0.0125 of the move;
  // cruise (1 - 0.025)/0.1 = 9.75 s; total 10.25 s.
  // x: v = 1000*0.1 = 100 c/s, a = 1000*0.4 = 400 c/s^2; y: v = 50 c/s, a = 200 c/s^2.
  const auto result = plan_synchronized(two_axes());
  ASSERT_TRUE(result.ok()) << result.error().message();
  const SyncPlan& plan = result.value();
  EXPECT_NEAR(plan.time_law.t_acc_s, 0.25, 1e-12);
  EXPECT_NEAR(plan.time_law.t_cruise_s, 9.75, 1e-12);
  EXPECT_NEAR(plan.duration_s(), 10.25, 1e-12);
  EXPECT_EQ(plan.target_counts[0], 1000);
  EXPECT_EQ(plan.target_counts[1], 500);
  EXPECT_NEAR(plan.axes[0].shape.peak_velocity, 100.0, 1e-9);
  EXPECT_NEAR(plan.axes[0].shape.acceleration, 400.0, 1e-9);
  EXPECT_NEAR(plan.axes[1].shape.peak_velocity, 50.0, 1e-9);
  EXPECT_NEAR(plan.axes[1].shape.acceleration, 200.0, 1e-9);
  EXPECT_EQ(plan.axes[1].shape.t_cruise_s, plan.axes[0].shape.t_cruise_s);
  // Mid-cruise at t = 5 s: s = 0.0125 + 0.1*4.75 = 0.4875 -> x 487.5, y 243.75.
  const Eigen::VectorXd at5 = plan.positions_counts_at(5.0);
  EXPECT_NEAR(at5[0], 487.5, 1e-9);
  EXPECT_NEAR(at5[1], 243.75, 1e-9);
  EXPECT_NEAR(plan.velocities_counts_per_s_at(5.0)[1], 50.0, 1e-9);
}

TEST(SyncPlanner, SpeedOverrideScalesVelocityOnly) {
  // velocity_scale 0.5: V = 0.05, A = 0.4: t_acc = 0.125 s, ramps 2 * 0.05^2/0.8 = 0.00625,
  // cruise 0.99375/0.05 = 19.875 s; total 20.125 s.
  const auto result = plan_synchronized(two_axes(), PlanOptions{.velocity_scale = 0.5});
  ASSERT_TRUE(result.ok());
  EXPECT_NEAR(result.value().duration_s(), 20.125, 1e-12);
  EXPECT_NEAR(result.value().axes[1].shape.peak_velocity, 25.0, 1e-9);
}

TEST(SyncPlanner, SeparateDecelerationInUserUnits) {
  // 0 -> 10 units at 100 counts/unit: 1000 counts, v 100 c/s, a 100 c/s^2, d 50 c/s^2 ->
  // 1 s + 8.5 s + 2 s = 11.5 s (see the profile test).
  const std::vector<AxisRequest> axes{make_axis({.target_user = 10.0,
                                                 .counts_per_user = 100.0,
                                                 .max_velocity_user_per_s = 1.0,
                                                 .max_acceleration_user_per_s2 = 1.0,
                                                 .max_deceleration_user_per_s2 = 0.5})};
  const auto result = plan_synchronized(axes);
  ASSERT_TRUE(result.ok());
  EXPECT_NEAR(result.value().time_law.t_dec_s, 2.0, 1e-12);
  EXPECT_NEAR(result.value().duration_s(), 11.5, 1e-12);
}

TEST(SyncPlanner, OneAxisIsItsOwnTimeOptimalProfile) {
  const std::vector<AxisRequest> axes{make_axis({.start_user = -3.0,
                                                 .target_user = 7.25,
                                                 .counts_per_user = 400.0,
                                                 .max_velocity_user_per_s = 3.0,
                                                 .max_acceleration_user_per_s2 = 11.0})};
  const auto result = plan_synchronized(axes, PlanOptions{.velocity_scale = 0.8, .acceleration_scale = 0.5});
  ASSERT_TRUE(result.ok());
  const AxisProfile expected =
      time_optimal_profile(-1200, 2900, 0.8 * 3.0 * 400.0, 0.5 * 11.0 * 400.0, 0.5 * 11.0 * 400.0);
  EXPECT_NEAR(result.value().duration_s(), expected.duration_s(), 1e-9);
  EXPECT_NEAR(result.value().axes[0].shape.peak_velocity, expected.shape.peak_velocity, 1e-9);
}

TEST(SyncPlanner, ZeroDistanceAxisStaysStill) {
  auto axes = two_axes();
  axes.push_back(make_axis({.name = "z", .start_user = 3.0, .target_user = 3.0, .counts_per_user = 10.0}));
  const auto result = plan_synchronized(axes);
  ASSERT_TRUE(result.ok());
  const SyncPlan& plan = result.value();
  EXPECT_NEAR(plan.duration_s(), 10.25, 1e-12);  // z (which has slow limits) does not slow the move
  for (double t = -1.0; t < 12.0; t += 0.5) {
    EXPECT_EQ(plan.positions_counts_at(t)[2], 30.0);
    EXPECT_EQ(plan.velocities_counts_per_s_at(t)[2], 0.0);
  }
}

TEST(SyncPlanner, AllAxesStillGiveAZeroDurationPlan) {
  const std::vector<AxisRequest> axes{make_axis({.start_user = 1.0, .target_user = 1.0}),
                                      make_axis({.start_user = -2.0, .target_user = -2.0})};
  const auto result = plan_synchronized(axes);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.value().duration_s(), 0.0);
  EXPECT_EQ(result.value().positions_counts_at(0.0)[1], -2.0);
}

TEST(SyncPlanner, OneCountMoveIsATriangle) {
  // 1 count, v 1000 c/s, a 100 c/s^2: peak sqrt(2*1*100*100/200) = 10 c/s, 0.1 s + 0.1 s.
  const std::vector<AxisRequest> axes{make_axis({.start_user = 0.0,
                                                 .target_user = 1.0,
                                                 .max_velocity_user_per_s = 1000.0,
                                                 .max_acceleration_user_per_s2 = 100.0})};
  const auto result = plan_synchronized(axes);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.value().time_law.t_cruise_s, 0.0);
  EXPECT_NEAR(result.value().axes[0].shape.peak_velocity, 10.0, 1e-12);
  EXPECT_NEAR(result.value().duration_s(), 0.2, 1e-12);
  EXPECT_EQ(result.value().positions_counts_at(0.2)[0], 1.0);
}

TEST(SyncPlanner, HugeMoveEndsExactlyInCounts) {
  // 2^50 counts: still exact in a double, sampling ends on the integer target.
  const double huge = 1125899906842624.0;
  const std::vector<AxisRequest> axes{make_axis({.start_user = -1.0,
                                                 .target_user = huge,
                                                 .max_velocity_user_per_s = 1e6,
                                                 .max_acceleration_user_per_s2 = 1e5,
                                                 .max_position_user = 2 * huge}),
                                      make_axis({.start_user = 5.0,
                                                 .target_user = 6.0,
                                                 .max_velocity_user_per_s = 1e6,
                                                 .max_acceleration_user_per_s2 = 1e5})};
  const auto result = plan_synchronized(axes);
  ASSERT_TRUE(result.ok());
  const SyncPlan& plan = result.value();
  EXPECT_EQ(plan.target_counts[0], 1125899906842624);
  EXPECT_EQ(plan.positions_counts_at(plan.duration_s())[0], huge);
  EXPECT_EQ(plan.positions_counts_at(plan.duration_s())[1], 6.0);
  EXPECT_NEAR(plan.duration_s(), (huge + 1.0) / 1e6 + 1e6 / 1e5, 1e-3);  // D/v + v/a
}

// ---- errors ---------------------------------------------------------------------------------

PlanFailure plan_error(const std::vector<AxisRequest>& axes, const PlanOptions& options = {}) {
  const auto result = plan_synchronized(axes, options);
  EXPECT_FALSE(result.ok());
  return result.ok() ? PlanFailure{} : result.error();
}

TEST(SyncPlannerErrors, TargetOutsideLimitsNamesAxisAndLimit) {
  auto axes = two_axes();
  axes.push_back(make_axis({.name = "z", .target_user = 120.0, .min_position_user = 0.0, .max_position_user = 100.0}));
  const PlanFailure f = plan_error(axes);
  EXPECT_EQ(f.code, PlanErrc::kTargetAboveMax);
  EXPECT_EQ(f.error_code(), PlanErrc::kTargetAboveMax);
  EXPECT_STREQ(f.error_code().category().name(), "planner");
  EXPECT_EQ(f.axis_index, 2u);
  EXPECT_EQ(f.axis_name, "z");
  EXPECT_EQ(f.limit, 100.0);
  EXPECT_NE(f.message().find("axis 2 'z'"), std::string::npos) << f.message();
  EXPECT_NE(f.message().find("max_position 100"), std::string::npos) << f.message();

  axes.back().target_user = -0.5;
  EXPECT_EQ(plan_error(axes).code, PlanErrc::kTargetBelowMin);
}

TEST(SyncPlannerErrors, EveryInvalidInputHasItsReason) {
  const auto with = [](auto change) {
    AxisRequest axis = make_axis({.name = "a", .target_user = 1.0});
    change(axis);
    return plan_error({make_axis({.name = "ok", .target_user = 1.0}), axis});
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(with([&](AxisRequest& a) { a.target_user = nan; }).code, PlanErrc::kNonFiniteInput);
  EXPECT_EQ(with([&](AxisRequest& a) { a.start_user = inf; }).code, PlanErrc::kNonFiniteInput);
  EXPECT_EQ(with([&](AxisRequest& a) { a.limits.max_velocity_user_per_s = inf; }).code, PlanErrc::kNonFiniteInput);
  EXPECT_EQ(with([&](AxisRequest& a) { a.limits.min_position_user = nan; }).code, PlanErrc::kNonFiniteInput);
  EXPECT_EQ(with([&](AxisRequest& a) { a.counts_per_user = 0.0; }).code, PlanErrc::kNonPositiveScale);
  EXPECT_EQ(with([&](AxisRequest& a) { a.counts_per_user = -2.0; }).code, PlanErrc::kNonPositiveScale);
  EXPECT_EQ(with([&](AxisRequest& a) { a.limits.max_velocity_user_per_s = 0.0; }).code, PlanErrc::kNonPositiveLimit);
  EXPECT_EQ(with([&](AxisRequest& a) { a.limits.max_acceleration_user_per_s2 = -1.0; }).code,
            PlanErrc::kNonPositiveLimit);
  EXPECT_EQ(with([&](AxisRequest& a) { a.limits.max_deceleration_user_per_s2 = 0.0; }).code,
            PlanErrc::kNonPositiveLimit);
  EXPECT_EQ(with([&](AxisRequest& a) {
              a.limits.min_position_user = 5.0;
              a.limits.max_position_user = 4.0;
            }).code,
            PlanErrc::kInvalidPositionRange);
  EXPECT_EQ(with([&](AxisRequest& a) {
              a.target_user = 1e16;
              a.limits.max_position_user = inf;
            }).code,
            PlanErrc::kCountsOutOfRange);
  const PlanFailure f = with([&](AxisRequest& a) { a.counts_per_user = 0.0; });
  EXPECT_EQ(f.axis_index, 1u);
  EXPECT_EQ(f.axis_name, "a");
}

TEST(SyncPlannerErrors, RequestLevelErrors) {
  EXPECT_EQ(plan_error({}).code, PlanErrc::kNoAxes);
  const std::vector<AxisRequest> axes{make_axis({.target_user = 1.0})};
  EXPECT_EQ(plan_error(axes, {.velocity_scale = 0.0}).code, PlanErrc::kInvalidSpeedScale);
  EXPECT_EQ(plan_error(axes, {.acceleration_scale = 1.5}).code, PlanErrc::kInvalidSpeedScale);
  EXPECT_EQ(plan_error(axes, {.velocity_scale = std::nan("")}).code, PlanErrc::kNonFiniteInput);
  EXPECT_EQ(plan_error(axes, {.velocity_scale = -1.0}).axis_index, kNoAxis);
}

TEST(SyncPlannerErrors, CategoryMessages) {
  EXPECT_EQ(std::error_code(PlanErrc::kQuantizationImpossible).message(),
            "no drive-representable value within the axis limits");
  EXPECT_EQ(planner_category().message(9999), "unknown planner error");
}

TEST(SyncPlannerErrors, UnboundedPositionLimitsAreAllowed) {
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<AxisRequest> axes{
      make_axis({.target_user = 720.0, .min_position_user = -inf, .max_position_user = inf})};
  EXPECT_TRUE(plan_synchronized(axes).ok());
}

}  // namespace
}  // namespace motion::planner
