// A watch on the host for the multi-process benchmarks (bench_e2e, bench_lab): a thread woken
// every millisecond on an absolute monotonic timer, under SCHED_FIFO where the process may use
// it, notes each wake-up more than `late` after its time, with the wall-clock interval it covers.
// Under SCHED_FIFO no process of the lab can hold it back; what still does is the host itself
// (hypervisor steal, an interrupt storm, a kernel worker). A start late in a move overlapping
// such a stall was late for the host's sake, not the programs'. Header-only.
//
// Thread contract: the watch thread runs from construction to destruction; stalls_in(),
// count() and realtime() may be called from any thread.
#pragma once

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace motion::bench {

class HostStallWatch {
 public:
  struct Stall {
    std::int64_t from_utime = 0;  // wall clock: when the watch was due to wake
    std::int64_t to_utime = 0;    // when it woke
  };

  explicit HostStallWatch(std::chrono::microseconds late = std::chrono::microseconds(200)) : late_(late) {
    thread_ = std::thread([this] { run(); });
  }
  ~HostStallWatch() {
    stop_ = true;
    thread_.join();
  }
  HostStallWatch(const HostStallWatch&) = delete;
  HostStallWatch& operator=(const HostStallWatch&) = delete;

  // The longest stall overlapping [from_utime, to_utime] (wall-clock µs), in µs; 0 if none.
  [[nodiscard]] std::int64_t worst_in(std::int64_t from_utime, std::int64_t to_utime) const {
    const std::lock_guard lock(mutex_);
    std::int64_t worst = 0;
    for (const Stall& s : stalls_) {
      if (s.to_utime >= from_utime && s.from_utime <= to_utime) worst = std::max(worst, s.to_utime - s.from_utime);
    }
    return worst;
  }
  [[nodiscard]] std::size_t count() const {
    const std::lock_guard lock(mutex_);
    return stalls_.size();
  }
  // The watch runs under SCHED_FIFO (otherwise the lab's own processes can delay it too).
  [[nodiscard]] bool realtime() const { return realtime_; }
  [[nodiscard]] std::chrono::microseconds late() const { return late_; }

 private:
  static std::int64_t ns(const timespec& t) { return std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec; }

  void run() {
    sched_param param{};
    param.sched_priority = 60;
    realtime_ = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
    timespec next{};
    clock_gettime(CLOCK_MONOTONIC, &next);
    while (!stop_) {
      next.tv_nsec += 1'000'000;
      if (next.tv_nsec >= 1'000'000'000) {
        next.tv_nsec -= 1'000'000'000;
        ++next.tv_sec;
      }
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) != 0) {}
      timespec woke{};
      timespec wall{};
      clock_gettime(CLOCK_MONOTONIC, &woke);
      clock_gettime(CLOCK_REALTIME, &wall);
      const std::int64_t late_ns = ns(woke) - ns(next);
      if (late_ns > std::chrono::duration_cast<std::chrono::nanoseconds>(late_).count()) {
        const std::int64_t to = ns(wall) / 1000;
        const std::lock_guard lock(mutex_);
        stalls_.push_back({to - late_ns / 1000, to});
      }
      if (late_ns > 1'000'000) next = woke;  // no burst of catch-up wake-ups after a long stall
    }
  }

  std::chrono::microseconds late_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> realtime_{false};
  mutable std::mutex mutex_;
  std::vector<Stall> stalls_;
  std::thread thread_;
};

}  // namespace motion::bench
