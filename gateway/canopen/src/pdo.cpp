#include "motion/canopen/pdo.hpp"

#include <array>

#include "motion/core/bytes.hpp"

namespace motion::canopen {
namespace {

constexpr std::uint64_t low_mask(unsigned bits) {
  return bits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
}

constexpr bool fits(std::uint64_t value, unsigned bits) {
  if (bits >= 64) return true;
  if ((value >> bits) == 0) return true;                                 // unsigned
  return static_cast<std::uint64_t>(sign_extend(value, bits)) == value;  // negative two's complement
}

}  // namespace

std::optional<std::size_t> pdo_payload_size(const PdoMapping& mapping) {
  std::size_t bits = 0;
  for (const auto& entry : mapping) {
    if (entry.bit_length == 0) return std::nullopt;
    bits += entry.bit_length;
  }
  if (bits > kMaxPdoBits) return std::nullopt;
  return (bits + 7) / 8;
}

std::optional<InlineBytes<kMaxPdoBytes>> pack_pdo(const PdoMapping& mapping, std::span<const std::uint64_t> values) {
  const auto size = pdo_payload_size(mapping);
  if (!size || values.size() != mapping.size()) return std::nullopt;
  // The whole payload is one 64-bit little-endian integer; objects occupy consecutive bit ranges.
  std::uint64_t packed = 0;
  unsigned offset = 0;
  for (std::size_t i = 0; i < mapping.size(); ++i) {
    const unsigned bits = mapping[i].bit_length;
    if (!fits(values[i], bits)) return std::nullopt;
    packed |= (values[i] & low_mask(bits)) << offset;
    offset += bits;
  }
  std::array<std::uint8_t, kMaxPdoBytes> buffer{};
  bytes::write_le<std::uint64_t>(buffer, 0, packed);
  return InlineBytes<kMaxPdoBytes>::from(std::span<const std::uint8_t>(buffer).first(*size));
}

std::optional<std::vector<std::uint64_t>> unpack_pdo(const PdoMapping& mapping, std::span<const std::uint8_t> payload) {
  const auto size = pdo_payload_size(mapping);
  if (!size || payload.size() != *size) return std::nullopt;
  std::array<std::uint8_t, kMaxPdoBytes> buffer{};
  std::copy(payload.begin(), payload.end(), buffer.begin());
  const std::uint64_t packed = *bytes::read_le<std::uint64_t>(buffer);
  std::vector<std::uint64_t> values;
  values.reserve(mapping.size());
  unsigned offset = 0;
  for (const auto& entry : mapping) {
    values.push_back((packed >> offset) & low_mask(entry.bit_length));
    offset += entry.bit_length;
  }
  return values;
}

}  // namespace motion::canopen
