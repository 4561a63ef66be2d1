#include "motion/can_frame/load_meter.hpp"

#include <algorithm>

namespace motion::can {

std::uint32_t LoadMeter::nominal_bits(const Frame& frame) {
  // SOF, arbitration, control, CRC, delimiters, ACK, EOF and the 3-bit intermission around the
  // data field; stuff bits are not counted (at most about a fifth more), which keeps this cheap
  // on every frame a transport sends or receives (bit_timing's exact count computes the CRC).
  const std::uint32_t overhead = frame.extended ? 67U : 47U;
  return overhead + (frame.rtr ? 0U : 8U * std::min<std::uint32_t>(frame.dlc, 8U));
}

double LoadMeter::ratio(std::uint64_t bits, Duration elapsed) const {
  return static_cast<double>(bits) / (static_cast<double>(bitrate_) * std::chrono::duration<double>(elapsed).count());
}

void LoadMeter::add(const Frame& frame, TimePoint now) {
  if (!started_) {
    started_ = true;
    window_start_ = now;
  } else if (const Duration elapsed = now - window_start_; elapsed >= kWindow) {
    // The window closes with this frame: its bits over its length (a quiet gap of several
    // windows makes one long window, which averages the quiet time in).
    last_load_ = bitrate_ == 0 ? 0.0 : ratio(window_bits_, elapsed);
    window_start_ = now;
    window_bits_ = 0;
  }
  window_bits_ += nominal_bits(frame);
}

double LoadMeter::load(TimePoint now) const {
  if (!started_ || bitrate_ == 0) return 0.0;
  // A window open for over a second (no frame has closed it): its own average, which falls as
  // the quiet time grows.
  if (const Duration elapsed = now - window_start_; elapsed >= kWindow) return ratio(window_bits_, elapsed);
  return last_load_;
}

}  // namespace motion::can
