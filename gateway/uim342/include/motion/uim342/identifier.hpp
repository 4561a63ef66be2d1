// SimpleCAN 3.0 addressing: the 7-bit IDs and the 29-bit CAN identifier layout.
// Manual §2.5 "CAN-ID for SimpleCAN3.0": the identifier is SID[10:0] followed by
// EID[17:0]:
//   bits 28..24 producer ID bits 4..0   bits 23..19 consumer ID bits 4..0   bit 18 = 0
//   bits 17..16 producer ID bits 6..5   bits 15..14 consumer ID bits 6..5   bits 13..8 = 0
//   bits  7..0  control word (CW)
// The producer is the sender (the host uses 4), the consumer the addressee. IDs above 31 use the
// high bits in the EID part. Thread contract: pure constexpr functions, thread-safe.
#pragma once

#include <cstdint>

#include "motion/uim342/errors.hpp"

namespace motion::uim342 {

inline constexpr std::uint8_t kGlobalId = 0;   // every drive accepts it (§1.1)
inline constexpr std::uint8_t kMasterId = 4;   // producer ID the host must use (§2.5)
inline constexpr std::uint8_t kMinNodeId = 5;  // node and group IDs: 5..126 (PP table §5.1)
inline constexpr std::uint8_t kMaxNodeId = 126;
inline constexpr std::uint8_t kMaxId = 127;  // largest value the 7-bit fields can carry

// What an ID value can denote. Node and group IDs share one range, so the value alone cannot
// tell them apart (PP[7] / PP[8] decide which a drive uses).
enum class IdKind : std::uint8_t {
  kGlobal,        // 0
  kMaster,        // 1..4: outside the node range; 4 is the host's producer ID (§2.5 example)
  kNodeOrGroup,   // 5..126
  kUnassignable,  // 127: encodable, but not a valid node/group ID
  kOutOfRange,    // > 127: does not fit the 7-bit fields
};

[[nodiscard]] constexpr IdKind classify_id(unsigned id) noexcept {
  if (id == kGlobalId) return IdKind::kGlobal;
  if (id <= kMasterId) return IdKind::kMaster;
  if (id <= kMaxNodeId) return IdKind::kNodeOrGroup;
  if (id == kMaxId) return IdKind::kUnassignable;
  return IdKind::kOutOfRange;
}
[[nodiscard]] constexpr bool is_valid_node_id(unsigned id) noexcept { return id >= kMinNodeId && id <= kMaxNodeId; }

// The three fields of a SimpleCAN identifier.
struct CanIdFields {
  std::uint8_t producer = 0;      // sender
  std::uint8_t consumer = 0;      // addressee
  std::uint8_t control_word = 0;  // CW
  friend bool operator==(const CanIdFields&, const CanIdFields&) = default;
};

// The manual's two-register form (for controllers with separate SID/EID registers).
struct SidEid {
  std::uint16_t sid = 0;  // 11 bits
  std::uint32_t eid = 0;  // 18 bits
  friend bool operator==(const SidEid&, const SidEid&) = default;
};

namespace detail {
inline constexpr std::uint32_t kLowIdMask = 0x1F;   // ID bits 4..0
inline constexpr std::uint32_t kHighIdMask = 0x60;  // ID bits 6..5
inline constexpr std::uint32_t kReservedMask = (1u << 18) | 0x3F00u;
}  // namespace detail

[[nodiscard]] constexpr SidEid split_can_id(std::uint32_t can_id) noexcept {
  return {static_cast<std::uint16_t>((can_id >> 18) & 0x7FF), can_id & 0x3FFFF};
}
[[nodiscard]] constexpr std::uint32_t join_can_id(SidEid parts) noexcept {
  return (std::uint32_t{parts.sid} << 18) | (parts.eid & 0x3FFFF);
}

// Fails with CodecErrc::kIdOutOfRange when an ID exceeds 127.
[[nodiscard]] inline Result<std::uint32_t> encode_can_id(CanIdFields f) {
  if (f.producer > kMaxId || f.consumer > kMaxId) return CodecErrc::kIdOutOfRange;
  const std::uint32_t p = f.producer;
  const std::uint32_t c = f.consumer;
  return ((p & detail::kLowIdMask) << 24) | ((c & detail::kLowIdMask) << 19) | ((p & detail::kHighIdMask) << 11) |
         ((c & detail::kHighIdMask) << 9) | f.control_word;
}

// Fails on identifiers above 29 bits and on set reserved bits (18, 13..8): such a frame is not
// SimpleCAN 3.0 (e.g. another protocol on the same bus).
[[nodiscard]] inline Result<CanIdFields> decode_can_id(std::uint32_t can_id) {
  if (can_id > 0x1FFFFFFFu) return CodecErrc::kIdentifierOutOfRange;
  if ((can_id & detail::kReservedMask) != 0) return CodecErrc::kReservedBitsSet;
  const auto id_at = [can_id](unsigned low_shift, unsigned high_shift) {
    return static_cast<std::uint8_t>(((can_id >> low_shift) & detail::kLowIdMask) |
                                     ((can_id >> high_shift) & detail::kHighIdMask));
  };
  return CanIdFields{id_at(24, 11), id_at(19, 9), static_cast<std::uint8_t>(can_id & 0xFF)};
}

}  // namespace motion::uim342
