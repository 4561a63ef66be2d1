#include "motion/core/precise_timer.hpp"

#include <gtest/gtest.h>

#include <cerrno>
#include <cstring>
#include <optional>
#include <string>
#include <thread>
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

// With a spin the loop wakes early and waits for the deadline busy: the callback never runs
// before its deadline, and a loop timer due inside the spin runs after it (the loop was held).
TEST(PreciseTimer, ASpinWakesEarlyButNeverRunsTheCallbackBeforeItsDeadline) {
  EventLoop loop;
  PreciseTimer timer(loop);
  timer.set_spin(milliseconds(100));
  std::vector<std::string> order;
  TimePoint ran_at{};
  const TimePoint deadline = loop.now() + milliseconds(200);
  timer.arm(deadline, [&] {
    ran_at = SteadyClock::now();
    order.emplace_back("precise");
  });
  loop.call_at(deadline - milliseconds(50), [&] { order.emplace_back("loop timer"); });
  loop.call_after(milliseconds(400), [&] { loop.stop(); });
  loop.run();
  EXPECT_GE(ran_at, deadline);
  EXPECT_EQ(order, (std::vector<std::string>{"precise", "loop timer"}));
  // Replaced while armed: the new deadline is the one waited for.
  std::vector<TimePoint> fired;
  const TimePoint second = loop.now() + milliseconds(150);
  timer.arm(loop.now() + milliseconds(120), [&] { fired.push_back(TimePoint{}); });
  timer.arm(second, [&] { fired.push_back(SteadyClock::now()); });
  loop.call_after(milliseconds(300), [&] { loop.stop(); });
  loop.run();
  ASSERT_EQ(fired.size(), 1U);
  EXPECT_GE(fired[0], second);
}

TEST(PreciseTimer, TimerSlackCanBeLowered) { EXPECT_TRUE(minimal_timer_slack()); }

// A thread under normal scheduling gets the slice it asks for where the kernel has custom slices
// (6.12 and later), and the kernel's default back with 0; an older kernel ignores the request.
TEST(FairSlice, TheThreadsSliceIsTheOneItAskedForOrTheKernelsDefault) {
  std::optional<Duration> asked;
  std::optional<Duration> back;
  std::optional<Duration> fifo;
  int fifo_error = 0;
  std::thread([&] {  // a thread of its own: the test's main thread keeps its slice
    asked = fair_slice(std::chrono::microseconds(100));
    back = fair_slice(Duration::zero());
    if (fifo_scheduling(10)) {
      fifo = fair_slice(std::chrono::microseconds(100));
      fifo_error = errno;
    } else {
      fifo_error = EPERM;  // not permitted here: what fair_slice would say
    }
  })
      .join();
  ASSERT_TRUE(asked) << std::strerror(errno);
  ASSERT_TRUE(back);
  EXPECT_FALSE(fifo) << "a SCHED_FIFO thread was put back under normal scheduling";
  EXPECT_EQ(fifo_error, EPERM);
  if (*asked == Duration::zero()) GTEST_SKIP() << "this kernel has no custom slices (before Linux 6.12)";
  EXPECT_EQ(*asked, std::chrono::microseconds(100));
  EXPECT_GT(*back, std::chrono::microseconds(100)) << "the kernel's default slice";
}

}  // namespace
}  // namespace motion
