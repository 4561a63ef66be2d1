#include "motion/core/event_loop.hpp"

#include <poll.h>
#include <sys/signalfd.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <exception>

#include <spdlog/spdlog.h>

namespace motion {

EventLoop::EventLoop(const ClockSource* clock) : clock_(clock != nullptr ? clock : &default_clock_) {}

EventLoop::~EventLoop() {
  if (signal_fd_ >= 0) ::close(signal_fd_);
}

template <typename F>
void EventLoop::guarded(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    ++callback_errors_;
    spdlog::error("event loop: callback threw: {}", e.what());
  } catch (...) {
    ++callback_errors_;
    spdlog::error("event loop: callback threw a non-standard exception");
  }
}

void EventLoop::watch(int fd, FdCallback on_readable) {
  fds_[fd] = std::make_shared<FdCallback>(std::move(on_readable));
}

void EventLoop::unwatch(int fd) { fds_.erase(fd); }

EventLoop::TimerId EventLoop::call_at(TimePoint deadline, TimerCallback callback) {
  const TimerId id = next_timer_id_++;
  timers_.emplace(id, Timer{deadline, Duration::zero(), std::move(callback)});
  deadlines_.emplace(deadline, id);
  return id;
}

EventLoop::TimerId EventLoop::call_every(Duration period, TimerCallback callback) {
  const TimerId id = next_timer_id_++;
  const TimePoint first = now() + period;
  timers_.emplace(id, Timer{first, period, std::move(callback)});
  deadlines_.emplace(first, id);
  return id;
}

void EventLoop::cancel(TimerId id) {
  // The deadline entry stays in the multimap and is skipped when it comes due.
  timers_.erase(id);
}

void EventLoop::stop_on_signals(std::initializer_list<int> signals) {
  sigset_t mask;
  sigemptyset(&mask);
  for (int s : signals) sigaddset(&mask, s);
  pthread_sigmask(SIG_BLOCK, &mask, nullptr);
  if (signal_fd_ >= 0) ::close(signal_fd_);
  signal_fd_ = ::signalfd(-1, &mask, SFD_NONBLOCK | SFD_CLOEXEC);
  if (signal_fd_ < 0) {
    spdlog::error("event loop: signalfd failed: {}", std::strerror(errno));
    return;
  }
  watch(signal_fd_, [this] {
    signalfd_siginfo info{};
    while (::read(signal_fd_, &info, sizeof info) == static_cast<ssize_t>(sizeof info)) {
      stop_signal_ = static_cast<int>(info.ssi_signo);
      stopping_ = true;
    }
  });
}

void EventLoop::dispatch_timers() {
  const TimePoint t = now();
  // Collect due timers first: callbacks may add timers that are already due, which then run in
  // the next round instead of starving fds.
  std::vector<TimerId> due;
  while (!deadlines_.empty() && deadlines_.begin()->first <= t) {
    due.push_back(deadlines_.begin()->second);
    deadlines_.erase(deadlines_.begin());
  }
  for (TimerId id : due) {
    if (timers_.find(id) == timers_.end()) continue;  // cancelled
    if (now() - polled_at_ > kStaleNews) {
      poll_fds(Duration::zero());  // fresh news first (header)
      if (stopping_) return;
    }
    auto it = timers_.find(id);
    if (it == timers_.end()) continue;  // cancelled by what was just read
    TimerCallback callback;
    if (it->second.period > Duration::zero()) {
      // Periodic: next deadline from the previous one (no drift), skipping missed periods.
      Timer& timer = it->second;
      do { timer.deadline += timer.period; } while (timer.deadline <= t);
      deadlines_.emplace(timer.deadline, id);
      callback = timer.callback;
    } else {
      callback = std::move(it->second.callback);
      timers_.erase(it);
    }
    guarded(callback);
    if (stopping_) return;
  }
}

void EventLoop::poll_fds(Duration wait) {
  std::vector<pollfd> pfds;
  pfds.reserve(fds_.size());
  for (const auto& [fd, cb] : fds_) pfds.push_back(pollfd{fd, POLLIN, 0});
  // ppoll takes a timespec: a timer is due within the kernel's timer slack (~50 us), not rounded
  // up to the next millisecond as poll(2) would; bit-timed simulated buses, SYNC periods and
  // request -> ACK hops depend on it.
  const auto capped = std::min<Duration>(wait, std::chrono::seconds(60));
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(capped).count();
  const timespec timeout{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
  const int n = ::ppoll(pfds.data(), pfds.size(), &timeout, nullptr);
  polled_at_ = now();
  if (n < 0 && errno != EINTR) { spdlog::error("event loop: poll failed: {}", std::strerror(errno)); }
  if (n <= 0) return;
  for (const auto& p : pfds) {
    if (p.revents == 0) continue;
    auto it = fds_.find(p.fd);
    if (it == fds_.end()) continue;  // unwatched by an earlier callback this round
    auto callback = it->second;      // keep alive even if the callback unwatches itself
    guarded(*callback);
    if (stopping_) return;
  }
}

void EventLoop::run_once(Duration max_wait) {
  // Drop stale deadline entries of cancelled timers so they do not shorten the poll timeout.
  while (!deadlines_.empty() && timers_.find(deadlines_.begin()->second) == timers_.end()) {
    deadlines_.erase(deadlines_.begin());
  }
  Duration wait = max_wait;
  if (!deadlines_.empty()) { wait = std::min(wait, std::max(Duration::zero(), deadlines_.begin()->first - now())); }
  poll_fds(wait);
  if (stopping_) return;
  dispatch_timers();
}

std::uint64_t EventLoop::run() {
  stopping_ = false;
  while (!stopping_) run_once(std::chrono::seconds(60));
  return callback_errors_;
}

}  // namespace motion
