// Drives one EventLoop for the bench_* programs, on the wall clock or on a manual clock advanced
// in 1 us steps (the protocol's own cost without the loop's wake-up latency). Header-only.
#pragma once

#include <chrono>
#include <functional>

#include "motion/core/clock.hpp"
#include "motion/core/event_loop.hpp"

namespace motion::bench {

class Pump {
 public:
  explicit Pump(ManualClock* manual) : manual_(manual), loop_(manual) {}
  EventLoop& loop() { return loop_; }
  [[nodiscard]] bool simulated() const { return manual_ != nullptr; }
  // Runs the loop until `done` or `limit` of this clock's time; false on timeout.
  bool until(const std::function<bool()>& done, Duration limit = std::chrono::seconds(10)) {
    const TimePoint end = loop_.now() + limit;
    while (!done()) {
      if (loop_.now() >= end) return false;
      if (manual_ != nullptr) {
        loop_.run_once(Duration::zero());
        if (done()) break;
        manual_->advance(std::chrono::microseconds(1));
      } else {
        loop_.run_once(std::chrono::milliseconds(5));
      }
    }
    return true;
  }

 private:
  ManualClock* manual_;
  EventLoop loop_;
};

}  // namespace motion::bench
