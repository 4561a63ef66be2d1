// Frame delimiting by line silence (Modbus over serial line v1.02 §2.5.1.1: an RTU frame ends
// when the line has been idle for 3.5 character times; 1.75 ms fixed above 19200 bit/s). Passive:
// bytes and their arrival time in, complete frames out, plus the deadline at which the buffered
// bytes become a frame if nothing else arrives.
//
// A pty delivers bytes without their real spacing, so callers may also close a frame early when
// the protocol already knows its length (complete_now()).
//
// Thread contract: single-threaded value type.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "motion/core/clock.hpp"

namespace motion::serial {

class SilenceFramer {
 public:
  explicit SilenceFramer(Duration silence) : silence_(silence) {}

  void push(std::span<const std::uint8_t> bytes, TimePoint now);
  // The buffered bytes as a frame, when the line has been silent long enough at `now`.
  [[nodiscard]] std::optional<std::vector<std::uint8_t>> take_if_silent(TimePoint now);
  // The buffered bytes as a frame at once (the protocol knows the frame is complete).
  [[nodiscard]] std::vector<std::uint8_t> complete_now();
  // The first `size` buffered bytes as a frame (all of them when fewer); the rest stay buffered
  // with their arrival time (two frames that arrived without a silence between them).
  [[nodiscard]] std::vector<std::uint8_t> complete_prefix(std::size_t size);
  void clear() { buffer_.clear(); }

  [[nodiscard]] std::span<const std::uint8_t> pending() const { return buffer_; }
  // When take_if_silent() will return the pending bytes; kNever when nothing is pending.
  [[nodiscard]] TimePoint deadline() const { return buffer_.empty() ? kNever : last_byte_ + silence_; }
  [[nodiscard]] Duration silence() const { return silence_; }

 private:
  Duration silence_;
  std::vector<std::uint8_t> buffer_;
  TimePoint last_byte_{};
};

}  // namespace motion::serial
