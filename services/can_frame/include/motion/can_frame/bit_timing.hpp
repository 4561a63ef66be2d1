// Bit-exact timing of classic CAN 2.0 frames on the wire (ISO 11898-1): the simulated bus's
// arbitration and delivery times, and the wire-time budgets of the gateway stacks.
//
// Pure functions of the frame content: no clock, no allocation, thread-safe. A frame on the wire
// is SOF, arbitration and control fields, data, CRC-15 (bit-stuffed: after five equal bits the
// transmitter inserts one complementary bit, from SOF through the CRC sequence), then the fixed
// CRC delimiter, ACK slot, ACK delimiter, 7-bit EOF and the 3-bit interframe space.
#pragma once

#include <cstdint>
#include <span>

#include "motion/can_frame/frame.hpp"
#include "motion/core/clock.hpp"

namespace motion::can {

// Fixed-form bits after the stuffed region: CRC delimiter (1), ACK slot (1), ACK delimiter (1), EOF (7).
inline constexpr std::uint32_t kTrailerBits = 10;
// Intermission between two frames: the wire is busy for it, receivers already have the frame.
inline constexpr std::uint32_t kInterframeBits = 3;

struct FrameBits {
  std::uint32_t unstuffed = 0;  // SOF through CRC sequence, before stuffing
  std::uint32_t stuff = 0;      // stuff bits inserted into that region
  std::uint32_t total = 0;      // unstuffed + stuff + kTrailerBits + kInterframeBits
  std::uint16_t crc = 0;        // the frame's CRC-15
  // Bits from SOF to the end of EOF: the moment receivers accept the frame.
  [[nodiscard]] std::uint32_t to_end_of_frame() const { return total - kInterframeBits; }
};

// CRC-15/CAN (polynomial 0x4599, init 0) over `bits` (one bit per element, 0 or 1, MSB first).
[[nodiscard]] std::uint16_t crc15(std::span<const std::uint8_t> bits);
// CRC-15/CAN over whole bytes, MSB first (check value: "123456789" -> 0x059E).
[[nodiscard]] std::uint16_t crc15_bytes(std::span<const std::uint8_t> bytes);

// Exact on-wire length of `frame`. Precondition: a valid frame (dlc <= 8, id fits its format);
// the dlc is clamped to 8 otherwise (an RTR frame carries its DLC but no data bytes).
[[nodiscard]] FrameBits frame_bits(const Frame& frame);

// Duration of `bits` bit times at `bitrate` bit/s, rounded to the nanosecond (computed on the
// whole count, so long sequences do not accumulate per-bit rounding). bitrate > 0.
[[nodiscard]] Duration bits_duration(std::uint64_t bits, std::uint32_t bitrate);
// Time the frame occupies the wire, interframe space included.
[[nodiscard]] Duration frame_duration(const Frame& frame, std::uint32_t bitrate);

// Arbitration field as transmitted (SOF, identifier, SRR/IDE, RTR), left-aligned in 33 bits so
// that comparing keys compares the fields bit by bit; dominant (0) wins, so the lower key wins.
// A standard frame beats an extended frame with the same base id (its dominant IDE/RTR meet the
// extended frame's recessive SRR/IDE); a data frame beats the RTR frame with the same id.
[[nodiscard]] std::uint64_t arbitration_key(const Frame& frame);
// True when `a` wins arbitration against `b` (equal fields: neither wins).
[[nodiscard]] inline bool wins_arbitration(const Frame& a, const Frame& b) {
  return arbitration_key(a) < arbitration_key(b);
}

}  // namespace motion::can
