// Bus load as one endpoint sees it: the wire time of the frames it sent and received (nominal
// lengths with the interframe space, stuff bits not counted: nominal_bits) over one-second
// windows, as a fraction of the bit rate. What a transport reports as Statistics::bus_load.
//
// Passive: frames and `now` in, the load out; no clock of its own. A single-threaded value type.
#pragma once

#include <cstdint>

#include "motion/can_frame/frame.hpp"
#include "motion/core/clock.hpp"

namespace motion::can {

class LoadMeter {
 public:
  static constexpr Duration kWindow = std::chrono::seconds(1);

  // bitrate 0: unknown (the load stays 0).
  explicit LoadMeter(std::uint32_t bitrate = 0) : bitrate_(bitrate) {}
  void set_bitrate(std::uint32_t bitrate) { bitrate_ = bitrate; }
  [[nodiscard]] std::uint32_t bitrate() const { return bitrate_; }

  // A frame that was on the wire at about `now`.
  void add(const Frame& frame, TimePoint now);
  // The load of the last closed window (a window closes with the first frame a second or more
  // after it opened); a window open for longer than a second gives its own average, so a bus
  // that went quiet falls toward 0. 0 with no bit rate or no frame yet.
  [[nodiscard]] double load(TimePoint now) const;
  // Bits of `frame` on the wire without stuff bits (a lower bound of its exact length).
  [[nodiscard]] static std::uint32_t nominal_bits(const Frame& frame);

 private:
  [[nodiscard]] double ratio(std::uint64_t bits, Duration elapsed) const;

  std::uint32_t bitrate_ = 0;
  bool started_ = false;
  TimePoint window_start_{};
  std::uint64_t window_bits_ = 0;
  double last_load_ = 0.0;
};

}  // namespace motion::can
