// Power-cycle detection for drive families that send nothing when they power up (UIM342, ADAM
// Modbus): a drive whose position counter restarts at 0 shows the power cycle only in what it
// answers afterwards. One watch per drive, fed every position sample of the drive's own counter
// (before any offset the driver adds). A sample that reads 0 at rest where the last one was
// farther than the drive could travel in between (twice the last speed over the time between the
// samples when it was moving toward 0, plus kSlackCounts), or that reads 0 at rest with its power
// stage turned off by nobody where the last sample was beyond kSlackCounts, is a power-up. Not caught: a power cycle while the counter was
// within that reach of 0 (then the position lost is at most that reach). Drivers tell the watch when they set the counter
// themselves (origin, preset, reboot), so that is not taken for one, and when they start a move
// whose target is 0: between two samples far apart (a long line polled slowly) the whole move can
// run, and the drive arriving at its target is not a power-up (not caught then: a power cycle
// during that move; the move still ends where it should).
// Passive value type: no I/O, no clock of its own; the driver's thread only.
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "motion/core/clock.hpp"

namespace motion::gateway {

class PowerUpWatch {
 public:
  static constexpr double kSlackCounts = 64;

  // A sample of the drive's counter and speed (counts/s) at `now`; `switched_off`: its power
  // stage went off without a command of the driver's. Why it shows a power-up, or nothing. The
  // sample becomes the one the next is compared with (after a power-up: none).
  [[nodiscard]] std::optional<std::string> sample(std::int64_t counter, double speed, TimePoint now,
                                                  bool switched_off) {
    std::optional<std::string> why;
    if (last_ && *last_ != 0 && counter == 0 && speed == 0) {
      const double dt = std::chrono::duration<double>(now - last_at_).count();
      // Moving away from 0 (or at rest), it cannot get there without stopping and turning back.
      const bool toward_zero = (last_speed_ > 0 && *last_ < 0) || (last_speed_ < 0 && *last_ > 0);
      const double reach = (toward_zero ? 2.0 * std::abs(last_speed_) * dt : 0.0) + kSlackCounts;
      // A move of ours to 0 explains the jump (not a power stage turned off by nobody).
      const bool jumped = !travel_to_zero_ && std::abs(static_cast<double>(*last_)) > reach;
      // Switched off at rest, exactly at 0, from a counter beyond the slack: not a stop of ours.
      if (jumped || (switched_off && std::abs(static_cast<double>(*last_)) > kSlackCounts)) {
        why = fmt::format("position counter {} -> 0 at rest within {:.0f} ms{}", *last_, dt * 1000.0,
                          switched_off ? ", power stage off" : "");
      }
    }
    if (why) {
      last_.reset();
    } else {
      last_ = counter;
      last_at_ = now;
      last_speed_ = speed;
    }
    return why;
  }
  // The driver set the counter to `counter` itself (origin, preset position).
  void counter_set(std::int64_t counter, TimePoint now) {
    last_ = counter;
    last_at_ = now;
    last_speed_ = 0;
  }
  // The driver rebooted the drive itself, or its counter is unknown: nothing to compare with.
  void forget() { last_.reset(); }
  // The driver started a move of the drive to `target` (its own counter); until travel_ended(),
  // a sample at 0 at rest is that move arriving when the target is within kSlackCounts of 0.
  void travel_started(std::int64_t target) { travel_to_zero_ = std::abs(static_cast<double>(target)) <= kSlackCounts; }
  // The move ended (arrived, failed or stopped): samples are judged by their distance again.
  void travel_ended() { travel_to_zero_ = false; }

 private:
  std::optional<std::int64_t> last_;
  TimePoint last_at_{};
  double last_speed_ = 0;
  bool travel_to_zero_ = false;
};

}  // namespace motion::gateway
