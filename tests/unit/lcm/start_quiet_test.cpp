// The quiet interval around a scheduled start (StartQuiet): where it lies, and when the node is
// quiet.
#include "motion/lcm/start_quiet.hpp"

#include <gtest/gtest.h>

#include "motion/core/clock.hpp"
#include "motion/testing/lcm_url.hpp"

namespace motion::lcm {
namespace {

using std::chrono::milliseconds;

motionlcm::sync_trigger2_t trigger(std::int64_t act_utime, std::vector<std::int64_t> send_utime) {
  motionlcm::sync_trigger2_t t{};
  t.trigger_id = 7;
  t.act_utime = act_utime;
  t.num_buses = static_cast<std::int32_t>(send_utime.size());
  for (std::size_t i = 0; i < send_utime.size(); ++i) t.buses.push_back("bus" + std::to_string(i));
  t.send_utime = std::move(send_utime);
  return t;
}

// From 0.5 ms before the first send time until 0.5 ms after the act time, 10 ms at most (then its
// last 10 ms); only the send times the trigger counts (num_buses) are looked at.
TEST(StartQuiet, TheIntervalRunsFromJustBeforeTheFirstSendUntilJustAfterTheActTime) {
  const std::int64_t act = 1'000'000'000;
  auto i = StartQuiet::interval_of(trigger(act, {act - 6'000, act - 100}));
  ASSERT_TRUE(i);
  EXPECT_EQ(i->from_utime, act - 6'500);
  EXPECT_EQ(i->until_utime, act + 500);
  i = StartQuiet::interval_of(trigger(act, {act - 9'000}));  // exactly 10 ms
  ASSERT_TRUE(i);
  EXPECT_EQ(i->from_utime, act - 9'500);
  i = StartQuiet::interval_of(trigger(act, {act - 100, act - 250'000}));  // a slow line's long lead
  ASSERT_TRUE(i);
  EXPECT_EQ(i->from_utime, act + 500 - 10'000);
  EXPECT_EQ(i->until_utime, act + 500);
  i = StartQuiet::interval_of(trigger(act, {act + 2'000}));  // a send time after the act time
  ASSERT_TRUE(i);
  EXPECT_EQ(i->from_utime, act + 1'500);
  EXPECT_EQ(i->until_utime, act + 2'500);
  auto t = trigger(act, {act - 100, act - 8'000});
  t.num_buses = 1;  // the second send time is not counted
  i = StartQuiet::interval_of(t);
  ASSERT_TRUE(i);
  EXPECT_EQ(i->from_utime, act - 600);
  t.num_buses = 5;  // more than it carries: the two it has
  i = StartQuiet::interval_of(t);
  ASSERT_TRUE(i);
  EXPECT_EQ(i->from_utime, act - 8'500);
  EXPECT_FALSE(StartQuiet::interval_of(trigger(act, {})));
  t.num_buses = -1;
  EXPECT_FALSE(StartQuiet::interval_of(t));
}

// The node is quiet over the interval, from a timer when it begins later; intervals waiting for
// their beginning are bounded whatever a sender publishes.
TEST(StartQuiet, TheNodeIsQuietOverTheIntervalAndAtMost64Wait) {
  EventLoop loop;
  Node node(loop, {testing::unique_lcm_url(10), "T13_"});
  ASSERT_TRUE(node.ok());
  const auto run_for = [&](milliseconds d) {
    const TimePoint end = loop.now() + d;
    while (loop.now() < end) loop.run_once(milliseconds(1));
  };
  {
    StartQuiet quiet(loop, node);
    const std::int64_t now = wall_time_us();
    quiet.keep(1, {now + 40'000, now + 80'000});
    EXPECT_FALSE(node.quiet());
    EXPECT_EQ(quiet.waiting(), 1u);
    run_for(milliseconds(55));
    EXPECT_TRUE(node.quiet()) << "the interval has begun";
    EXPECT_EQ(quiet.waiting(), 0u);
    run_for(milliseconds(45));
    EXPECT_FALSE(node.quiet()) << "the interval has ended";
    // Begun already: quiet at once.
    quiet.keep(2, {wall_time_us() - 1'000, wall_time_us() + 20'000});
    EXPECT_TRUE(node.quiet());
    node.end_quiet();
    // The same trigger again replaces its interval.
    quiet.keep(3, {wall_time_us() + 500'000, wall_time_us() + 510'000});
    quiet.keep(3, {wall_time_us() + 600'000, wall_time_us() + 610'000});
    EXPECT_EQ(quiet.waiting(), 1u);
    for (std::int64_t id = 100; id < 200; ++id) quiet.keep(id, {wall_time_us() + 500'000, wall_time_us() + 510'000});
    EXPECT_EQ(quiet.waiting(), StartQuiet::kMostWaiting);
  }  // destroyed: its timers are cancelled (ASan would see one that ran)
  run_for(milliseconds(650));
  EXPECT_FALSE(node.quiet());
}

}  // namespace
}  // namespace motion::lcm
