#include "motion/lcm/malformed_limiter.hpp"

namespace motion::lcm {

bool MalformedLimiter::admit(TimePoint now) {
  ++total_;
  if (!started_ || now >= window_start_ + window_) {
    // A new window; a summary still owed for the last one stays owed (take_summary).
    started_ = true;
    window_start_ = now;
    reported_in_window_ = 0;
  }
  if (reported_in_window_ < per_window_) {
    ++reported_in_window_;
    return true;
  }
  ++suppressed_;
  ++suppressed_total_;
  return false;
}

std::uint64_t MalformedLimiter::take_summary(TimePoint now) {
  if (suppressed_ == 0 || now < window_start_ + window_) return 0;
  const std::uint64_t n = suppressed_;
  suppressed_ = 0;
  return n;
}

}  // namespace motion::lcm
