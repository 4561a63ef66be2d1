#include "motion/sim/kinematics.hpp"

#include <gtest/gtest.h>

#include <random>

namespace motion::sim {
namespace {

TimePoint at_s(double s) {
  return TimePoint{} + std::chrono::duration_cast<Duration>(std::chrono::duration<double>(s));
}
double secs(TimePoint t) { return std::chrono::duration<double>(t - TimePoint{}).count(); }

TEST(Kinematics, TrapezoidFromRest) {
  // v 1000, a = d = 1000: 1 s to full speed (500 counts), 9 s cruise (9000), 1 s down (500).
  Kinematics k;
  k.move_to(at_s(0), 10000, {1000, 1000, 1000, 0});
  EXPECT_NEAR(secs(k.end_time()), 11.0, 1e-6);
  EXPECT_NEAR(k.at(at_s(1)).position, 500, 1e-6);
  EXPECT_NEAR(k.at(at_s(1)).velocity, 1000, 1e-6);
  EXPECT_NEAR(k.at(at_s(6)).position, 5500, 1e-6);
  EXPECT_NEAR(k.at(at_s(10.5)).position, 10000 - 125, 1e-6);  // 0.5 s before the end: 0.5*1000*0.5^2
  EXPECT_TRUE(k.moving(at_s(10.9)));
  EXPECT_FALSE(k.moving(at_s(11.001)));
  EXPECT_EQ(k.position_counts(at_s(12)), 10000);
}

TEST(Kinematics, TriangleWhenTheMoveIsTooShortForCruise) {
  // 400 counts at a = d = 1000 cannot reach 1000 counts/s: peak sqrt(400*1000) = 632.46 at 0.632 s.
  Kinematics k;
  k.move_to(at_s(0), 400, {1000, 1000, 1000, 0});
  EXPECT_NEAR(secs(k.end_time()), 2 * std::sqrt(0.4), 1e-6);
  EXPECT_NEAR(k.at(at_s(std::sqrt(0.4))).velocity, std::sqrt(400000.0), 1e-3);
  EXPECT_EQ(k.position_counts(at_s(2)), 400);
}

TEST(Kinematics, CutInSpeedShortensTheRamps) {
  // cut-in 200: accelerate 200 -> 1000 in 0.8 s (480 counts), cruise 9040 counts (9.04 s),
  // decelerate 1000 -> 200 in 0.8 s (480), then stop at once.
  Kinematics k;
  k.move_to(at_s(0), 10000, {1000, 1000, 1000, 200});
  EXPECT_NEAR(secs(k.end_time()), 10.64, 1e-6);
  EXPECT_NEAR(k.at(at_s(0)).velocity, 200, 1e-6);
  EXPECT_EQ(k.position_counts(at_s(11)), 10000);
}

TEST(Kinematics, AsymmetricRampsAndNegativeDirection) {
  // -3000 counts, v 1000, a 2000 (0.5 s, 250), d 500 (2 s, 1000): cruise 1750 counts = 1.75 s.
  Kinematics k;
  k.move_to(at_s(0), -3000, {1000, 2000, 500, 0});
  EXPECT_NEAR(secs(k.end_time()), 0.5 + 1.75 + 2.0, 1e-6);
  EXPECT_NEAR(k.at(at_s(0.5)).velocity, -1000, 1e-6);
  EXPECT_EQ(k.position_counts(at_s(5)), -3000);
}

TEST(Kinematics, JogHoldsItsVelocityUntilStopped) {
  Kinematics k;
  k.jog(at_s(0), {-500, 1000, 2000, 0});
  EXPECT_TRUE(k.jogging());
  EXPECT_EQ(k.end_time(), kNever);
  EXPECT_NEAR(k.at(at_s(0.5)).velocity, -500, 1e-6);
  EXPECT_NEAR(k.at(at_s(2.5)).position, -125 - 1000, 1e-6);  // 0.5 s ramp (125) + 2 s at 500
  k.stop(at_s(2.5), 1000);
  EXPECT_NEAR(secs(k.end_time()), 3.0, 1e-6);  // 500 / 1000
  EXPECT_FALSE(k.moving(at_s(3.01)));
  EXPECT_EQ(k.position_counts(at_s(4)), -1125 - 125);
}

TEST(Kinematics, NewTargetBehindReversesThroughRest) {
  Kinematics k;
  k.move_to(at_s(0), 10000, {1000, 1000, 1000, 0});
  k.move_to(at_s(2), 0, {1000, 1000, 1000, 0});  // at 1500 counts, 1000 counts/s forward
  // Decelerates 1 s to rest at 2000, then travels back 2000 counts: 1 + 1 + 1 s.
  EXPECT_GT(k.at(at_s(2.5)).velocity, 0);
  EXPECT_NEAR(k.at(at_s(3)).position, 2000, 1e-6);
  EXPECT_NEAR(secs(k.end_time()), 3 + 3.0, 1e-6);
  EXPECT_EQ(k.position_counts(at_s(7)), 0);
}

TEST(Kinematics, NewTargetAheadContinuesWithoutStopping) {
  Kinematics k;
  k.move_to(at_s(0), 10000, {1000, 1000, 1000, 0});
  const double v_before = k.at(at_s(5)).velocity;
  k.move_to(at_s(5), 20000, {1000, 1000, 1000, 0});
  EXPECT_NEAR(k.at(at_s(5)).velocity, v_before, 1e-6);
  EXPECT_NEAR(k.at(at_s(5.5)).velocity, 1000, 1e-6);
  EXPECT_EQ(k.position_counts(at_s(30)), 20000);
}

TEST(Kinematics, HaltStopsAtOnceAndSetPositionRedefinesTheCounter) {
  Kinematics k;
  k.move_to(at_s(0), 10000, {1000, 1000, 1000, 0});
  k.halt(at_s(1));
  EXPECT_FALSE(k.moving(at_s(1)));
  EXPECT_EQ(k.position_counts(at_s(2)), 500);
  k.set_position(at_s(2), -7);
  EXPECT_EQ(k.position_counts(at_s(3)), -7);
}

TEST(Kinematics, RandomMovesEndExactlyAndRespectTheSpeedLimit) {
  std::mt19937 rng(42);
  std::uniform_int_distribution<std::int64_t> target(-200000, 200000);
  std::uniform_real_distribution<double> speed(10, 50000), rate(10, 500000), cut(0, 500);
  for (int i = 0; i < 2000; ++i) {
    Kinematics k;
    const Profile p{speed(rng), rate(rng), rate(rng), cut(rng)};
    const std::int64_t goal = target(rng);
    k.move_to(at_s(0), goal, p);
    const double end = secs(k.end_time());
    ASSERT_TRUE(std::isfinite(end) || goal == 0) << i;
    const double limit = std::max(p.velocity, p.cut_in) * (1 + 1e-9) + 1e-6;
    for (int j = 0; j <= 50 && std::isfinite(end); ++j) {
      const auto s = k.at(at_s(end * j / 50.0));
      ASSERT_LE(std::abs(s.velocity), limit) << "move " << i;
      ASSERT_LE(std::abs(s.position), static_cast<double>(std::abs(goal)) + 1e-6) << "overshoot in move " << i;
    }
    ASSERT_EQ(k.position_counts(at_s((std::isfinite(end) ? end : 0) + 1)), goal) << i;
  }
}

}  // namespace
}  // namespace motion::sim
