// Bounds-checked little/big-endian integer access over byte spans.
// Pure functions, no allocation; every wire codec of the project uses these so that byte order
// is decided in exactly one place. Thread-safe (stateless).
#pragma once

#include <array>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <type_traits>

namespace motion::bytes {

// Reads an N-byte little-endian integer at `offset`; nullopt when the span is too short.
template <std::integral T, std::size_t N = sizeof(T)>
[[nodiscard]] constexpr std::optional<T> read_le(std::span<const std::uint8_t> in, std::size_t offset = 0) {
  static_assert(N <= sizeof(T));
  if (offset > in.size() || in.size() - offset < N) return std::nullopt;
  std::uint64_t raw = 0;
  for (std::size_t i = 0; i < N; ++i) raw |= std::uint64_t{in[offset + i]} << (8 * i);
  if constexpr (std::is_signed_v<T> && N < 8) {
    const std::uint64_t sign = std::uint64_t{1} << (8 * N - 1);
    if (raw & sign) raw |= ~((sign << 1) - 1);  // sign-extend an N-byte value (e.g. 24-bit)
  }
  return static_cast<T>(raw);
}

template <std::integral T, std::size_t N = sizeof(T)>
[[nodiscard]] constexpr std::optional<T> read_be(std::span<const std::uint8_t> in, std::size_t offset = 0) {
  static_assert(N <= sizeof(T));
  if (offset > in.size() || in.size() - offset < N) return std::nullopt;
  std::uint64_t raw = 0;
  for (std::size_t i = 0; i < N; ++i) raw = (raw << 8) | in[offset + i];
  if constexpr (std::is_signed_v<T> && N < 8) {
    const std::uint64_t sign = std::uint64_t{1} << (8 * N - 1);
    if (raw & sign) raw |= ~((sign << 1) - 1);
  }
  return static_cast<T>(raw);
}

// `value`'s bits as unsigned: through the unsigned type of the same width, so that a signed char
// is not sign-extended first (the low bytes are the same either way).
template <std::integral T>
[[nodiscard]] constexpr std::uint64_t unsigned_bits(T value) {
  if constexpr (std::is_signed_v<T>) {
    return static_cast<std::make_unsigned_t<T>>(value);
  } else {
    return value;
  }
}

// Writes the low N bytes of `value` little-endian at `offset`; false when it does not fit.
template <std::integral T, std::size_t N = sizeof(T)>
constexpr bool write_le(std::span<std::uint8_t> out, std::size_t offset, T value) {
  if (offset > out.size() || out.size() - offset < N) return false;
  const std::uint64_t raw = unsigned_bits(value);
  for (std::size_t i = 0; i < N; ++i) out[offset + i] = static_cast<std::uint8_t>(raw >> (8 * i));
  return true;
}

template <std::integral T, std::size_t N = sizeof(T)>
constexpr bool write_be(std::span<std::uint8_t> out, std::size_t offset, T value) {
  if (offset > out.size() || out.size() - offset < N) return false;
  const std::uint64_t raw = unsigned_bits(value);
  for (std::size_t i = 0; i < N; ++i) out[offset + i] = static_cast<std::uint8_t>(raw >> (8 * (N - 1 - i)));
  return true;
}

}  // namespace motion::bytes
