// The one poll loop of a process (drake-iiwa-driver style): file descriptors (LCM, CAN
// transports, serial ports, Unix sockets) and timers, dispatched from a single thread.
//
// Contract: all methods must be called from the loop's thread (callbacks included). run()
// blocks in ppoll(2) until an fd is ready or the earliest timer is due (a nanosecond timeout: timers
// keep to the kernel's timer slack, not whole milliseconds): never a busy wait.
// A callback that throws is caught and logged; the exception never leaves the loop (so it cannot
// cross an LCM or C callback). Callbacks may add/remove fds and timers, including their own.
//
// Fresh news before deadlines: each round handles the readable fds, then the due timers. A timer
// judged on news older than kStaleNews (a slow callback ran since the fds were last polled: a
// file system stall, a burst) first gets one more zero-wait poll of the fds, so a timeout fires
// only if what arrived meanwhile does not answer it (a heartbeat that waited in a socket is not
// "lost").
#pragma once

#include <csignal>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <unordered_map>
#include <vector>

#include "motion/core/clock.hpp"

namespace motion {

class EventLoop {
 public:
  using FdCallback = std::function<void()>;
  using TimerCallback = std::function<void()>;
  using TimerId = std::uint64_t;

  // The clock drives timer deadlines; it must outlive the loop. Defaults to the steady clock.
  explicit EventLoop(const ClockSource* clock = nullptr);
  ~EventLoop();
  EventLoop(const EventLoop&) = delete;
  EventLoop& operator=(const EventLoop&) = delete;

  [[nodiscard]] TimePoint now() const { return clock_->now(); }
  [[nodiscard]] const ClockSource& clock() const { return *clock_; }

  // Calls `on_readable` whenever `fd` polls readable (or hung up / errored: the callback's read
  // then reports it). Replaces any previous watch of the same fd.
  void watch(int fd, FdCallback on_readable);
  void unwatch(int fd);

  // One-shot timer at `deadline`; periodic timer every `period` starting at now()+period.
  TimerId call_at(TimePoint deadline, TimerCallback callback);
  TimerId call_after(Duration delay, TimerCallback callback) { return call_at(now() + delay, std::move(callback)); }
  TimerId call_every(Duration period, TimerCallback callback);
  void cancel(TimerId id);

  // Stops run() cleanly on these signals (signalfd; the signals are blocked for the thread).
  void stop_on_signals(std::initializer_list<int> signals = {SIGINT, SIGTERM});
  [[nodiscard]] int stop_signal() const { return stop_signal_; }

  // Runs until stop(). Returns the number of callback exceptions caught (0 on a clean run).
  std::uint64_t run();
  // One poll round waiting at most `max_wait` (tests, and loops driven from outside).
  void run_once(Duration max_wait);
  void stop() { stopping_ = true; }
  [[nodiscard]] bool stopping() const { return stopping_; }

 private:
  struct Timer {
    TimePoint deadline;
    Duration period;  // zero = one-shot
    TimerCallback callback;
  };
  // How old the fds' last poll may be when a timer runs before they are polled again.
  static constexpr Duration kStaleNews = std::chrono::milliseconds(1);

  void dispatch_timers();
  // ppoll(2) waiting at most `wait`, then the callbacks of the readable fds.
  void poll_fds(Duration wait);
  template <typename F>
  void guarded(F&& f);

  SystemSteadyClock default_clock_;
  const ClockSource* clock_;
  std::unordered_map<int, std::shared_ptr<FdCallback>> fds_;
  std::map<TimerId, Timer> timers_;
  std::multimap<TimePoint, TimerId> deadlines_;
  TimePoint polled_at_{};  // when poll_fds last returned from ppoll
  TimerId next_timer_id_ = 1;
  bool stopping_ = false;
  int signal_fd_ = -1;
  int stop_signal_ = 0;
  std::uint64_t callback_errors_ = 0;
};

}  // namespace motion
