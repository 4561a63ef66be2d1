// The 7-bit packing of numeric data in UIM242 feedback frames (EN §6.2, §12.2).
//
// Every data byte carries 7 value bits (bit 7 is 0, so data never collides with the header and
// terminator bytes). Groups arrive most significant first: a 16-bit value takes 3 bytes, a 32-bit
// value 5 bytes, the 12-bit analog values 2 bytes. Pinned by the manual's MCF example
// (`AA 05 B0 02 0E 33 FF` = 0x8733, EN/CN #17); the 32- and 12-bit layouts follow by analogy
// (not stated: the manuals' conversion figures 10-1/10-2, 12-1/12-2 are missing). Signed fields are
// the two's complement of the unpacked 16/32-bit pattern.
// Thread contract: pure functions, thread-safe.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace motion::uim242 {

inline constexpr std::size_t kPacked12 = 2;  // bytes of a packed 12-bit value
inline constexpr std::size_t kPacked16 = 3;
inline constexpr std::size_t kPacked32 = 5;

// Shifts each byte's 7 data bits in from the right and keeps the low 32 bits (the spare top bits
// of the first byte fall off). Bit 7 of each byte is ignored.
[[nodiscard]] constexpr std::uint32_t unpack(std::span<const std::uint8_t> groups) noexcept {
  std::uint64_t value = 0;
  for (const std::uint8_t b : groups) value = (value << 7) | (b & 0x7Fu);
  return static_cast<std::uint32_t>(value);
}
[[nodiscard]] constexpr std::int16_t unpack_s16(std::span<const std::uint8_t> groups) noexcept {
  return static_cast<std::int16_t>(static_cast<std::uint16_t>(unpack(groups)));
}
[[nodiscard]] constexpr std::int32_t unpack_s32(std::span<const std::uint8_t> groups) noexcept {
  return static_cast<std::int32_t>(unpack(groups));
}

// Writes `value`'s 7-bit groups into `out` from the last byte backwards; bits that do not fit in
// out.size() groups are dropped (a 16-bit value fills 3 bytes: 2 + 7 + 7 bits).
constexpr void pack(std::uint32_t value, std::span<std::uint8_t> out) noexcept {
  for (std::size_t i = out.size(); i-- > 0;) {
    out[i] = static_cast<std::uint8_t>(value & 0x7Fu);
    value >>= 7;
  }
}

template <std::size_t N>
[[nodiscard]] constexpr std::array<std::uint8_t, N> packed(std::uint32_t value) noexcept {
  std::array<std::uint8_t, N> out{};
  pack(value, out);
  if constexpr (N == kPacked16) out[0] &= 0x03;  // only D15..D14 remain in the first group
  if constexpr (N == kPacked32) out[0] &= 0x0F;  // D31..D28
  if constexpr (N == kPacked12) out[0] &= 0x1F;  // D11..D7
  return out;
}

}  // namespace motion::uim242
