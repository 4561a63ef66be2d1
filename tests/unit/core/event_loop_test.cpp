#include "motion/core/event_loop.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <csignal>
#include <stdexcept>
#include <thread>
#include <vector>

namespace motion {
namespace {

using std::chrono::milliseconds;

TEST(EventLoop, OneShotTimersRunInDeadlineOrder) {
  EventLoop loop;
  std::vector<int> order;
  loop.call_after(milliseconds(20), [&] { order.push_back(2); });
  loop.call_after(milliseconds(5), [&] { order.push_back(1); });
  loop.call_after(milliseconds(30), [&] { loop.stop(); });
  loop.run();
  EXPECT_EQ(order, (std::vector<int>{1, 2}));
}

TEST(EventLoop, CancelledTimerNeverRuns) {
  EventLoop loop;
  bool ran = false;
  const auto id = loop.call_after(milliseconds(5), [&] { ran = true; });
  loop.cancel(id);
  loop.call_after(milliseconds(15), [&] { loop.stop(); });
  loop.run();
  EXPECT_FALSE(ran);
}

TEST(EventLoop, PeriodicTimerKeepsItsPhase) {
  EventLoop loop;
  std::vector<TimePoint> ticks;
  loop.call_every(milliseconds(10), [&] {
    ticks.push_back(loop.now());
    if (ticks.size() == 5) loop.stop();
  });
  const TimePoint start = loop.now();
  loop.run();
  ASSERT_EQ(ticks.size(), 5u);
  // Never early: the n-th tick is at or after start + n*period.
  for (std::size_t i = 0; i < ticks.size(); ++i) {
    EXPECT_GE(ticks[i] - start, milliseconds(10 * static_cast<int>(i + 1)));
  }
}

TEST(EventLoop, FdCallbackRunsWhenReadableAndCanUnwatchItself) {
  EventLoop loop;
  int pipefd[2];
  ASSERT_EQ(::pipe(pipefd), 0);
  int calls = 0;
  loop.watch(pipefd[0], [&] {
    char c;
    ASSERT_EQ(::read(pipefd[0], &c, 1), 1);
    EXPECT_EQ(c, 'x');
    ++calls;
    loop.unwatch(pipefd[0]);
    loop.stop();
  });
  ASSERT_EQ(::write(pipefd[1], "x", 1), 1);
  loop.run();
  EXPECT_EQ(calls, 1);
  ::close(pipefd[0]);
  ::close(pipefd[1]);
}

// A pipe whose read end the loop watches: `arrived` counts the bytes it read.
struct WatchedPipe {
  explicit WatchedPipe(EventLoop& loop) {
    EXPECT_EQ(::pipe(fd), 0);
    loop.watch(fd[0], [this] {
      char c;
      if (::read(fd[0], &c, 1) == 1) ++arrived;
    });
  }
  ~WatchedPipe() {
    ::close(fd[0]);
    ::close(fd[1]);
  }
  WatchedPipe(const WatchedPipe&) = delete;
  WatchedPipe& operator=(const WatchedPipe&) = delete;
  void send() const { EXPECT_EQ(::write(fd[1], "x", 1), 1); }
  int fd[2]{-1, -1};
  int arrived = 0;
};

// The gateway's heartbeat check ran 680 ms after the last heartbeat it had READ while three more
// waited in its socket: an fd callback (a file write) had stalled the loop, and the round's
// timers ran before the fds were polled again.
TEST(EventLoop, ATimerDueAfterAStalledFdCallbackSeesWhatArrivedMeanwhile) {
  EventLoop loop;
  WatchedPipe news(loop);  // the heartbeats
  int trigger[2];
  ASSERT_EQ(::pipe(trigger), 0);
  loop.watch(trigger[0], [&] {
    char c;
    ASSERT_EQ(::read(trigger[0], &c, 1), 1);
    news.send();                                    // arrives during the stall
    std::this_thread::sleep_for(milliseconds(20));  // the stall
  });
  int seen_by_timer = -1;
  loop.call_after(milliseconds(5), [&] {  // due during the stall
    seen_by_timer = news.arrived;
    loop.stop();
  });
  ASSERT_EQ(::write(trigger[1], "t", 1), 1);
  loop.run();
  EXPECT_EQ(seen_by_timer, 1) << "the timer ran on old news";
  ::close(trigger[0]);
  ::close(trigger[1]);
}

TEST(EventLoop, ATimerAfterAStalledTimerSeesWhatArrivedMeanwhile) {
  EventLoop loop;
  WatchedPipe news(loop);
  const TimePoint due = loop.now() + milliseconds(2);
  loop.call_at(due, [&] {
    news.send();
    std::this_thread::sleep_for(milliseconds(20));
  });
  int seen_by_timer = -1;
  loop.call_at(due, [&] {  // due in the same round, after the stalled one
    seen_by_timer = news.arrived;
    loop.stop();
  });
  loop.run();
  EXPECT_EQ(seen_by_timer, 1) << "the timer ran on old news";
}

TEST(EventLoop, ThrowingCallbackIsContainedAndCounted) {
  EventLoop loop;
  bool later_ran = false;
  loop.call_after(milliseconds(1), [] { throw std::runtime_error("boom"); });
  loop.call_after(milliseconds(5), [&] {
    later_ran = true;
    loop.stop();
  });
  EXPECT_EQ(loop.run(), 1u);
  EXPECT_TRUE(later_ran);
}

TEST(EventLoop, StopsOnSignal) {
  EventLoop loop;
  loop.stop_on_signals({SIGUSR1});
  loop.call_after(milliseconds(5), [] { ::raise(SIGUSR1); });
  bool timed_out = false;
  loop.call_after(std::chrono::seconds(5), [&] {
    timed_out = true;
    loop.stop();
  });
  loop.run();
  EXPECT_FALSE(timed_out);
  EXPECT_EQ(loop.stop_signal(), SIGUSR1);
}

}  // namespace
}  // namespace motion
