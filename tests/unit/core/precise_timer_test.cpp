#include "motion/core/precise_timer.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace motion {
namespace {

using std::chrono::milliseconds;

TEST(PreciseTimer, OnTheSteadyClockItIsATimerfdThatFiresOnceNotEarlyAndCanBeRearmedFromItsCallback) {
  EventLoop loop;
  PreciseTimer timer(loop);
  EXPECT_TRUE(timer.absolute());
  std::vector<TimePoint> fired;
  const TimePoint first = loop.now() + milliseconds(5);
  timer.arm(first, [&] {
    fired.push_back(loop.now());
    timer.arm(first + milliseconds(5), [&] { fired.push_back(loop.now()); });
  });
  loop.call_after(milliseconds(40), [&] { loop.stop(); });
  loop.run();
  ASSERT_EQ(fired.size(), 2U);
  EXPECT_GE(fired[0], first);
  EXPECT_GE(fired[1], first + milliseconds(5));
  EXPECT_FALSE(timer.armed());
}

TEST(PreciseTimer, CancelledOrReplacedDeadlinesNeverRun) {
  EventLoop loop;
  PreciseTimer timer(loop);
  int old_ran = 0;
  int new_ran = 0;
  timer.arm(loop.now() + milliseconds(5), [&] { ++old_ran; });
  timer.arm(loop.now() + milliseconds(10), [&] { ++new_ran; });  // replaces it
  PreciseTimer cancelled(loop);
  bool ran = false;
  cancelled.arm(loop.now() + milliseconds(5), [&] { ran = true; });
  cancelled.cancel();
  loop.call_after(milliseconds(30), [&] { loop.stop(); });
  loop.run();
  EXPECT_EQ(old_ran, 0);
  EXPECT_EQ(new_ran, 1);
  EXPECT_FALSE(ran);
}

TEST(PreciseTimer, OnAManualClockItFallsBackToTheLoopsTimers) {
  ManualClock clock(TimePoint{} + std::chrono::seconds(1));
  EventLoop loop(&clock);
  PreciseTimer timer(loop);
  EXPECT_FALSE(timer.absolute());
  bool ran = false;
  timer.arm(clock.now() + milliseconds(10), [&] { ran = true; });
  loop.run_once(Duration::zero());
  EXPECT_FALSE(ran);
  clock.advance(milliseconds(10));
  loop.run_once(Duration::zero());
  EXPECT_TRUE(ran);
}

TEST(PreciseTimer, TimerSlackCanBeLowered) { EXPECT_TRUE(minimal_timer_slack()); }

}  // namespace
}  // namespace motion
