#include "motion/core/loop_mailbox.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cstdint>
#include <exception>
#include <utility>

#include <spdlog/spdlog.h>

namespace motion {

LoopMailbox::LoopMailbox(EventLoop& loop, std::size_t capacity)
    : loop_(loop), capacity_(capacity), fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {
  if (fd_ >= 0) loop_.watch(fd_, [this] { drain(); });
}

LoopMailbox::~LoopMailbox() {
  if (fd_ < 0) return;
  loop_.unwatch(fd_);
  ::close(fd_);
}

bool LoopMailbox::post(std::function<void()> callback) {
  if (fd_ < 0) return false;
  {
    const std::lock_guard lock(mutex_);
    if (queue_.size() >= capacity_) return false;
    queue_.push_back(std::move(callback));
  }
  const std::uint64_t one = 1;
  // A full counter (2^64 - 2 wake-ups not yet read) cannot happen: drain() reads it to zero.
  [[maybe_unused]] const auto written = ::write(fd_, &one, sizeof one);
  return true;
}

std::size_t LoopMailbox::pending() const {
  const std::lock_guard lock(mutex_);
  return queue_.size();
}

void LoopMailbox::drain() {
  std::uint64_t count = 0;
  [[maybe_unused]] const auto read = ::read(fd_, &count, sizeof count);
  std::deque<std::function<void()>> batch;
  {
    const std::lock_guard lock(mutex_);
    batch.swap(queue_);
  }
  // One callback that throws does not take the rest of the batch with it.
  for (auto& callback : batch) {
    try {
      callback();
    } catch (const std::exception& e) { spdlog::error("a callback posted to the event loop threw: {}", e.what()); }
  }
}

}  // namespace motion
