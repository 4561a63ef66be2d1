#include "motion/core/loop_mailbox.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

namespace motion {
namespace {

using namespace std::chrono_literals;

// Runs the loop until `done()` or 5 s; false on timeout.
template <typename Done>
bool pump(EventLoop& loop, Done done) {
  const auto until = std::chrono::steady_clock::now() + 5s;
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    loop.run_once(10ms);
  }
  return true;
}

TEST(LoopMailbox, CallbacksPostedFromAnotherThreadRunOnTheLoopThreadInOrder) {
  EventLoop loop;
  LoopMailbox mailbox(loop, 10000);
  ASSERT_TRUE(mailbox.ok());
  const auto loop_thread = std::this_thread::get_id();
  std::vector<int> seen;
  std::atomic<int> wrong_thread{0};
  std::thread poster([&] {
    for (int i = 0; i < 2000; ++i) {
      ASSERT_TRUE(mailbox.post([&, i] {
        if (std::this_thread::get_id() != loop_thread) ++wrong_thread;
        seen.push_back(i);
      }));
    }
  });
  ASSERT_TRUE(pump(loop, [&] { return seen.size() == 2000; }));
  poster.join();
  EXPECT_EQ(wrong_thread.load(), 0);
  for (int i = 0; i < 2000; ++i) ASSERT_EQ(seen[static_cast<std::size_t>(i)], i);
  EXPECT_EQ(mailbox.pending(), 0u);
}

TEST(LoopMailbox, AFullMailboxRefusesAndKeepsWhatItHolds) {
  EventLoop loop;
  LoopMailbox mailbox(loop, 3);
  int ran = 0;
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(mailbox.post([&] { ++ran; }));
  EXPECT_FALSE(mailbox.post([&] { ran += 100; }));
  EXPECT_EQ(mailbox.pending(), 3u);
  ASSERT_TRUE(pump(loop, [&] { return ran == 3; }));
  EXPECT_TRUE(mailbox.post([&] { ++ran; }));  // room again
  ASSERT_TRUE(pump(loop, [&] { return ran == 4; }));
}

TEST(LoopMailbox, ACallbackThatThrowsDoesNotDropTheOthers) {
  EventLoop loop;
  LoopMailbox mailbox(loop);
  int ran = 0;
  mailbox.post([&] { ++ran; });
  mailbox.post([] { throw std::runtime_error("boom"); });
  mailbox.post([&] { ++ran; });
  ASSERT_TRUE(pump(loop, [&] { return ran == 2; }));
}

TEST(LoopMailbox, CallbacksStillQueuedWhenItIsDestroyedAreDropped) {
  EventLoop loop;
  int ran = 0;
  {
    LoopMailbox mailbox(loop);
    mailbox.post([&] { ++ran; });
  }
  loop.run_once(20ms);  // its fd is no longer watched: nothing to run, nothing dangling
  EXPECT_EQ(ran, 0);
}

}  // namespace
}  // namespace motion
