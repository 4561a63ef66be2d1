// PowerUpWatch: a power cycle seen in the position samples of a drive that sends nothing at
// power-up (UIM342, ADAM), and what must not be taken for one.
#include <gtest/gtest.h>

#include "motion/gateway/power_up_watch.hpp"

namespace motion::gateway {
namespace {

using std::chrono::milliseconds;

TEST(PowerUpWatch, ACounterAtZeroOutOfReachIsAPowerUpOnce) {
  PowerUpWatch w;
  const TimePoint t0{};
  EXPECT_FALSE(w.sample(5000, 0, t0, false));
  const auto why = w.sample(0, 0, t0 + milliseconds(50), false);
  ASSERT_TRUE(why);
  EXPECT_NE(why->find("position counter 5000 -> 0 at rest within 50 ms"), std::string::npos) << *why;
  // Nothing left to compare with: the next 0 is not another one.
  EXPECT_FALSE(w.sample(0, 0, t0 + milliseconds(100), false));
}

TEST(PowerUpWatch, ZeroWithinReachOfADriveMovingTowardItIsNot) {
  PowerUpWatch w;
  const TimePoint t0{};
  EXPECT_FALSE(w.sample(-900, 10000, t0, false));  // 10000 counts/s toward 0: 1000 counts in 50 ms, twice that allowed
  EXPECT_FALSE(w.sample(0, 0, t0 + milliseconds(50), false));
  // Moving away from 0, it cannot get there: beyond the slack it is a power-up.
  PowerUpWatch away;
  EXPECT_FALSE(away.sample(900, 10000, t0, false));
  EXPECT_TRUE(away.sample(0, 0, t0 + milliseconds(50), false));
  // Within the slack it is not.
  PowerUpWatch near;
  EXPECT_FALSE(near.sample(static_cast<std::int64_t>(PowerUpWatch::kSlackCounts), 0, t0, false));
  EXPECT_FALSE(near.sample(0, 0, t0 + milliseconds(50), false));
}

TEST(PowerUpWatch, AMovingSampleOrOneAwayFromZeroIsNot) {
  PowerUpWatch w;
  const TimePoint t0{};
  EXPECT_FALSE(w.sample(5000, 0, t0, false));
  EXPECT_FALSE(w.sample(0, 300, t0 + milliseconds(50), false));  // passing through 0
  EXPECT_FALSE(w.sample(12, 0, t0 + milliseconds(100), false));
}

TEST(PowerUpWatch, TheDriversOwnOriginOrRebootIsNot) {
  PowerUpWatch w;
  const TimePoint t0{};
  EXPECT_FALSE(w.sample(5000, 0, t0, false));
  w.counter_set(0, t0 + milliseconds(10));  // set origin
  EXPECT_FALSE(w.sample(0, 0, t0 + milliseconds(50), false));
  EXPECT_FALSE(w.sample(7000, 0, t0 + milliseconds(100), false));
  w.forget();  // rebooted on purpose
  EXPECT_FALSE(w.sample(0, 0, t0 + milliseconds(150), false));
}

TEST(PowerUpWatch, AMoveOfOursToZeroSeenOnlyAtItsEndsIsNot) {
  // A long line polled slowly: the sample before the start at rest at 1280, the next at 0 at rest
  // after the whole move ran between them (lab bench, 12 ADAM per line).
  PowerUpWatch w;
  const TimePoint t0{};
  EXPECT_FALSE(w.sample(1280, 0, t0, false));
  w.travel_started(0);
  EXPECT_FALSE(w.sample(0, 0, t0 + milliseconds(1500), false));
  w.travel_ended();
  // A move to elsewhere explains no 0, and once the move ended a jump to 0 is a power-up again.
  EXPECT_FALSE(w.sample(1280, 0, t0 + milliseconds(3000), false));
  w.travel_started(5000);
  EXPECT_TRUE(w.sample(0, 0, t0 + milliseconds(4500), false));
  PowerUpWatch after;
  after.travel_started(0);
  after.travel_ended();
  EXPECT_FALSE(after.sample(1280, 0, t0, false));
  EXPECT_TRUE(after.sample(0, 0, t0 + milliseconds(1500), false));
  // The power stage turned off by nobody still tells, even during a move to 0.
  PowerUpWatch off;
  EXPECT_FALSE(off.sample(1280, 0, t0, false));
  off.travel_started(0);
  EXPECT_TRUE(off.sample(0, 0, t0 + milliseconds(1500), true));
}

TEST(PowerUpWatch, AfterASilenceOnlyThePowerStageTurnedOffByNobodyTells) {
  PowerUpWatch w;
  const TimePoint t0{};
  EXPECT_FALSE(w.sample(-20000, 10000, t0, false));  // moving toward 0 when it fell silent
  // 3 s later at 0: it could have got there, unless its power stage went off by itself.
  EXPECT_FALSE(w.sample(0, 0, t0 + milliseconds(3000), false));
  PowerUpWatch off;
  EXPECT_FALSE(off.sample(-20000, 10000, t0, false));
  const auto why = off.sample(0, 0, t0 + milliseconds(3000), true);
  ASSERT_TRUE(why);
  EXPECT_NE(why->find("power stage off"), std::string::npos) << *why;
}

}  // namespace
}  // namespace motion::gateway
