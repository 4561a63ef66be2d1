#include "motion/coordinator/move_planner.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace motion::coordinator {
namespace {

const char* kConfig = R"(
buses: [{name: can0, transport: simcan:can0}]
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5, setup: {acceleration_unit: rate}}
  - {name: yd, family: uim342, bus: can0, node_id: 6, setup: {acceleration_unit: time}}
  - {name: ad, family: uc57, bus: can0, node_id: 1}
axes:
  - {name: x, drive: xd, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 50, acceleration: 400}}
  - {name: y, drive: yd, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 50, acceleration: 400}}
  - {name: a, drive: ad, steps_per_unit: 10, limits: {min: -100, max: 100, velocity: 50, acceleration: 400}}
)";

TEST(MovePlanner, Uim342ProfilesAreIntegerPulsesAndArrivalsAgree) {
  const auto config = *config::load_string(kConfig).config;
  const auto planner = make_move_planner(config);
  std::vector<PlanInput> in{{"x", config::Family::kUim342, 0, 64000, 50 * 640, 400 * 640},
                            {"y", config::Family::kUim342, 1000, -12345, 50 * 640, 400 * 640},
                            {"a", config::Family::kUc57, 0, 333, 500, 4000}};
  auto result = planner(in, 1.0, 1.0);
  ASSERT_TRUE(std::holds_alternative<MovePlan>(result)) << std::get<std::string>(result);
  const auto& plan = std::get<MovePlan>(result);
  ASSERT_EQ(plan.axes.size(), 3u);
  EXPECT_EQ(plan.axes[0].target_counts, 64000);
  EXPECT_EQ(plan.axes[1].target_counts, -12345);
  // UIM342 SP is an integer pulse/s; rate-mode AC/DC are integer pulse/s^2.
  EXPECT_EQ(plan.axes[0].velocity, std::round(plan.axes[0].velocity));
  EXPECT_EQ(plan.axes[0].acceleration, std::round(plan.axes[0].acceleration));
  EXPECT_EQ(plan.axes[1].velocity, std::round(plan.axes[1].velocity));
  // The slowest axis sets the time; every axis arrives within the predicted spread.
  EXPECT_GT(plan.duration_s, 0.5);
  for (const auto& a : plan.axes) EXPECT_NEAR(a.duration_s, plan.duration_s, plan.predicted_skew_us * 1e-6 + 1e-9) << a.axis;
  EXPECT_LT(plan.predicted_skew_us, 1000.0);
  for (const auto& a : plan.axes) {
    EXPECT_LE(a.velocity, 50 * (a.axis == "a" ? 10 : 640) + 1e-6) << a.axis;
  }
}

TEST(MovePlanner, ZeroLimitIsAPlanningError) {
  const auto config = *config::load_string(kConfig).config;
  auto result = make_move_planner(config)({{"x", config::Family::kUim342, 0, 100, 0, 1000}}, 1.0, 1.0);
  ASSERT_TRUE(std::holds_alternative<std::string>(result));
  EXPECT_NE(std::get<std::string>(result).find("x"), std::string::npos) << std::get<std::string>(result);
}

}  // namespace
}  // namespace motion::coordinator
