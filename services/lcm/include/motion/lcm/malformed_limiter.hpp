// Rate limit for reports of malformed messages: a flood of bad datagrams must not flood the log
// (or whatever the report feeds, e.g. the coordinator's PROTOCOL_ERROR events).
//
// At most `per_window` reports pass in each window (starting at the first report after the
// previous window ended); the rest are counted, and take_summary() hands out that count once the
// window is over. Every message is counted in total() whether reported or not.
//
// Thread contract: a plain value, used from one thread (the Node's loop thread).
#pragma once

#include <cstdint>

#include "motion/core/clock.hpp"

namespace motion::lcm {

class MalformedLimiter {
 public:
  MalformedLimiter() = default;  // 5 reports per second
  MalformedLimiter(int per_window, Duration window) : per_window_(per_window), window_(window) {}

  // Counts one malformed message at `now`; true when it may be reported.
  bool admit(TimePoint now);
  // The end of the current window while reports are suppressed in it (when a summary is due).
  [[nodiscard]] bool summary_pending() const { return suppressed_ > 0; }
  [[nodiscard]] TimePoint window_end() const { return window_start_ + window_; }
  // Suppressed since the last summary, once the window is over (else 0); resets the count.
  std::uint64_t take_summary(TimePoint now);

  [[nodiscard]] std::uint64_t total() const { return total_; }
  [[nodiscard]] std::uint64_t suppressed_total() const { return suppressed_total_; }
  [[nodiscard]] Duration window() const { return window_; }
  [[nodiscard]] int per_window() const { return per_window_; }

 private:
  int per_window_ = 5;
  Duration window_ = std::chrono::seconds(1);
  TimePoint window_start_{};
  bool started_ = false;
  int reported_in_window_ = 0;
  std::uint64_t suppressed_ = 0;
  std::uint64_t total_ = 0;
  std::uint64_t suppressed_total_ = 0;
};

}  // namespace motion::lcm
