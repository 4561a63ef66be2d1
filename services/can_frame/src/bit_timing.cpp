#include "motion/can_frame/bit_timing.hpp"

#include <algorithm>
#include <array>

namespace motion::can {
namespace {

// SOF..CRC of the longest frame: extended header (39 bits incl. DLC) + 64 data + 15 CRC.
constexpr std::size_t kMaxStuffedRegion = 39 + 64 + 15;

// The unstuffed bits of a frame, SOF first.
class BitWriter {
 public:
  void put(std::uint32_t value, unsigned width) {
    for (unsigned i = width; i-- > 0;) bits_[size_++] = static_cast<std::uint8_t>((value >> i) & 1U);
  }
  [[nodiscard]] std::span<const std::uint8_t> bits() const { return {bits_.data(), size_}; }

 private:
  std::array<std::uint8_t, kMaxStuffedRegion> bits_{};
  std::size_t size_ = 0;
};

constexpr std::uint32_t kDominant = 0;
constexpr std::uint32_t kRecessive = 1;

void put_header(BitWriter& w, const Frame& frame) {
  const std::uint32_t rtr = frame.rtr ? kRecessive : kDominant;
  w.put(kDominant, 1);  // SOF
  if (frame.extended) {
    w.put(frame.id >> 18, 11);       // base identifier
    w.put(kRecessive, 1);            // SRR
    w.put(kRecessive, 1);            // IDE
    w.put(frame.id & 0x3FFFFU, 18);  // identifier extension
    w.put(rtr, 1);
    w.put(kDominant, 2);  // r1, r0
  } else {
    w.put(frame.id, 11);
    w.put(rtr, 1);
    w.put(kDominant, 1);  // IDE
    w.put(kDominant, 1);  // r0
  }
}

std::uint32_t count_stuff_bits(std::span<const std::uint8_t> bits) {
  std::uint32_t stuff = 0;
  std::uint8_t level = 2;  // matches nothing before SOF
  unsigned run = 0;
  for (const std::uint8_t bit : bits) {
    run = bit == level ? run + 1 : 1;
    level = bit;
    if (run == 5) {
      // The inserted complementary bit starts the next run.
      ++stuff;
      level = static_cast<std::uint8_t>(level ^ 1U);
      run = 1;
    }
  }
  return stuff;
}

// One bit through the CAN CRC register (ISO 11898-1, 10.3.4).
std::uint32_t crc15_step(std::uint32_t crc, std::uint32_t bit) {
  const std::uint32_t feedback = bit ^ ((crc >> 14) & 1U);
  crc = (crc << 1) & 0x7FFFU;
  return feedback != 0 ? crc ^ 0x4599U : crc;
}

}  // namespace

std::uint16_t crc15(std::span<const std::uint8_t> bits) {
  std::uint32_t crc = 0;
  for (const std::uint8_t bit : bits) crc = crc15_step(crc, bit & 1U);
  return static_cast<std::uint16_t>(crc);
}

std::uint16_t crc15_bytes(std::span<const std::uint8_t> bytes) {
  std::uint32_t crc = 0;
  for (const std::uint8_t byte : bytes) {
    for (unsigned i = 8; i-- > 0;) crc = crc15_step(crc, (byte >> i) & 1U);
  }
  return static_cast<std::uint16_t>(crc);
}

FrameBits frame_bits(const Frame& frame) {
  const std::uint8_t dlc = std::min<std::uint8_t>(frame.dlc, 8);
  BitWriter w;
  put_header(w, frame);
  w.put(dlc, 4);
  if (!frame.rtr) {
    for (std::size_t i = 0; i < dlc; ++i) w.put(frame.data[i], 8);
  }
  FrameBits out;
  out.crc = crc15(w.bits());
  w.put(out.crc, 15);
  out.unstuffed = static_cast<std::uint32_t>(w.bits().size());
  out.stuff = count_stuff_bits(w.bits());
  out.total = out.unstuffed + out.stuff + kTrailerBits + kInterframeBits;
  return out;
}

Duration bits_duration(std::uint64_t bits, std::uint32_t bitrate) {
  constexpr std::uint64_t kNanosPerSecond = 1'000'000'000;
  return Duration{static_cast<Duration::rep>((bits * kNanosPerSecond + bitrate / 2) / bitrate)};
}

Duration frame_duration(const Frame& frame, std::uint32_t bitrate) {
  return bits_duration(frame_bits(frame).total, bitrate);
}

std::uint64_t arbitration_key(const Frame& frame) {
  BitWriter w;
  put_header(w, frame);
  // Standard: SOF, id, RTR, IDE (r0 is control, but IDE decides against an extended frame).
  // Extended: SOF, base id, SRR, IDE, id extension, RTR.
  const std::size_t arbitration_bits = frame.extended ? 33 : 14;
  std::uint64_t key = 0;
  const auto bits = w.bits();
  for (std::size_t i = 0; i < 33; ++i) key = (key << 1) | (i < arbitration_bits ? bits[i] : 0U);
  return key;
}

}  // namespace motion::can
