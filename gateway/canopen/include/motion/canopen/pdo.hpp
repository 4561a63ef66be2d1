// CiA 301 §7.2.2 PDO payloads and §7.5.2.35-38 PDO parameter objects: mapping entries
// (index << 16 | sub-index << 8 | bit length), packing/unpacking a payload from a mapping, and
// the object addresses of the communication (1400h/1800h) and mapping (1600h/1A00h) records.
// Pure functions, thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "motion/canopen/types.hpp"

namespace motion::canopen {

inline constexpr std::size_t kMaxPdoBits = 64;
inline constexpr std::size_t kMaxPdoBytes = 8;

struct PdoMappingEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::uint8_t bit_length = 0;
  friend constexpr bool operator==(const PdoMappingEntry&, const PdoMappingEntry&) = default;
};
using PdoMapping = std::vector<PdoMappingEntry>;

[[nodiscard]] constexpr std::uint32_t encode_mapping_entry(const PdoMappingEntry& entry) {
  return (std::uint32_t{entry.index} << 16) | (std::uint32_t{entry.subindex} << 8) | entry.bit_length;
}
[[nodiscard]] constexpr PdoMappingEntry decode_mapping_entry(std::uint32_t value) {
  return {static_cast<std::uint16_t>(value >> 16), static_cast<std::uint8_t>(value >> 8),
          static_cast<std::uint8_t>(value)};
}

// Payload length in bytes; nullopt when an entry has length 0 or the total exceeds 64 bits.
[[nodiscard]] std::optional<std::size_t> pdo_payload_size(const PdoMapping& mapping);

// Objects are packed back to back, least significant bit first (CiA 301 §7.2.2.2). A value fits
// its entry when it is an unsigned number below 2^bits or the two's-complement sign extension of
// its low `bits` bits (negative numbers passed as static_cast<std::uint64_t>(int)). nullopt when
// the mapping is invalid, the value count differs from the entry count, or a value does not fit.
[[nodiscard]] std::optional<InlineBytes<kMaxPdoBytes>> pack_pdo(const PdoMapping& mapping,
                                                                std::span<const std::uint64_t> values);
// Raw values (low `bits` bits, zero-extended; see sign_extend()). The payload must have exactly
// the mapped length: short PDOs are not processed (CiA 301 EMCY 8210h), and this codec also
// rejects longer ones (8220h) instead of silently ignoring the extra bytes.
[[nodiscard]] std::optional<std::vector<std::uint64_t>> unpack_pdo(const PdoMapping& mapping,
                                                                   std::span<const std::uint8_t> payload);

[[nodiscard]] constexpr std::int64_t sign_extend(std::uint64_t raw, unsigned bits) {
  if (bits == 0 || bits >= 64) return static_cast<std::int64_t>(raw);
  const std::uint64_t sign = std::uint64_t{1} << (bits - 1);
  const std::uint64_t value = raw & ((sign << 1) - 1);
  return static_cast<std::int64_t>((value ^ sign) - sign);
}

// Which kind of PDO a parameter record belongs to, seen from the node that owns the record.
enum class PdoDirection : std::uint8_t {
  kReceive,   // RPDO: 1400h + (n-1) communication, 1600h + (n-1) mapping
  kTransmit,  // TPDO: 1800h + (n-1) communication, 1A00h + (n-1) mapping
};
inline constexpr std::uint16_t kMaxPdoNumber = 512;

[[nodiscard]] constexpr std::uint16_t pdo_communication_index(PdoDirection direction, std::uint16_t number) {
  return static_cast<std::uint16_t>((direction == PdoDirection::kReceive ? 0x1400u : 0x1800u) + number - 1u);
}
[[nodiscard]] constexpr std::uint16_t pdo_mapping_index(PdoDirection direction, std::uint16_t number) {
  return static_cast<std::uint16_t>((direction == PdoDirection::kReceive ? 0x1600u : 0x1A00u) + number - 1u);
}

// Communication record sub-indices and COB-ID flags (CiA 301 §7.5.2.35/36).
inline constexpr std::uint8_t kPdoCobIdSub = 1;
inline constexpr std::uint8_t kPdoTransmissionTypeSub = 2;
inline constexpr std::uint8_t kPdoInhibitTimeSub = 3;
inline constexpr std::uint8_t kPdoEventTimerSub = 5;
inline constexpr std::uint32_t kPdoCobIdInvalid = 0x80000000;   // bit 31: PDO does not exist
inline constexpr std::uint32_t kPdoCobIdNoRtr = 0x40000000;     // bit 30: no RTR allowed
inline constexpr std::uint32_t kPdoCobIdExtended = 0x20000000;  // bit 29: 29-bit CAN-ID

}  // namespace motion::canopen
