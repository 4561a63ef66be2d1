// Time for the whole project. Protocol cores never read a clock: they are handed `now` and
// return their next deadline. Processes own one ClockSource and pass it down, so tests can use a
// ManualClock. Thread contract: SteadyClock is thread-safe; ManualClock is single-threaded.
#pragma once

#include <chrono>
#include <cstdint>

namespace motion {

using SteadyClock = std::chrono::steady_clock;
using TimePoint = SteadyClock::time_point;
using Duration = std::chrono::nanoseconds;

class ClockSource {
 public:
  virtual ~ClockSource() = default;
  [[nodiscard]] virtual TimePoint now() const = 0;
};

class SystemSteadyClock final : public ClockSource {
 public:
  [[nodiscard]] TimePoint now() const override { return SteadyClock::now(); }
};

// A clock that moves only when told to (unit tests of timers and protocol deadlines).
class ManualClock final : public ClockSource {
 public:
  explicit ManualClock(TimePoint start = TimePoint{}) : now_(start) {}
  [[nodiscard]] TimePoint now() const override { return now_; }
  void advance(Duration d) { now_ += d; }
  void set(TimePoint t) { now_ = t; }

 private:
  TimePoint now_;
};

// Microseconds since the Unix epoch (CLOCK_REALTIME): the `utime` of every LCM message, and the
// common time base of gateways on different machines (NTP/PTP-synchronized in a real lab).
[[nodiscard]] inline std::int64_t wall_time_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// "No deadline": what a passive core returns when it has nothing scheduled.
inline constexpr TimePoint kNever = TimePoint::max();

}  // namespace motion
