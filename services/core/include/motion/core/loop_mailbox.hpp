// Hands work from other threads to an EventLoop's thread: post() from any thread queues a
// callback and wakes the loop (an eventfd it watches); the loop's thread runs the queued callbacks
// in the order they were posted. Bounded: post() refuses (returns false) when `capacity`
// callbacks are waiting, so a flood from another thread costs no more than that.
//
// Thread contract: construct and destroy on the loop's thread (it registers and unregisters its
// fd there); post() and pending() from any thread; callbacks run on the loop's thread. Callbacks
// still queued when the mailbox is destroyed are dropped, not run.
#pragma once

#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>

#include "motion/core/event_loop.hpp"

namespace motion {

class LoopMailbox {
 public:
  explicit LoopMailbox(EventLoop& loop, std::size_t capacity = 1024);
  ~LoopMailbox();
  LoopMailbox(const LoopMailbox&) = delete;
  LoopMailbox& operator=(const LoopMailbox&) = delete;

  [[nodiscard]] bool ok() const { return fd_ >= 0; }
  // Queues `callback` for the loop's thread. False (nothing queued) when full or not ok().
  bool post(std::function<void()> callback);
  [[nodiscard]] std::size_t pending() const;

 private:
  void drain();

  EventLoop& loop_;
  const std::size_t capacity_;
  int fd_ = -1;
  mutable std::mutex mutex_;
  std::deque<std::function<void()>> queue_;
};

}  // namespace motion
