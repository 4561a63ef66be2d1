// The transport-neutral SimpleCAN message `CW DL d0..d7` (manual §2.1, §2.2) and its CAN
// carriage (manual §2.5 "CAN-ID for SimpleCAN3.0"): extended data frame, identifier from
// producer/consumer/CW, DLC = DL, data = d0..d(DL-1). The serial gateway carriage is in
// uimessage.hpp.
// Thread contract: pure functions over values, thread-safe.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>

#include "motion/can_frame/frame.hpp"
#include "motion/uim342/errors.hpp"
#include "motion/uim342/identifier.hpp"

namespace motion::uim342 {

inline constexpr std::uint8_t kAckRequestBit = 0x80;     // CW bit 7 in instructions (§2.1)
inline constexpr std::uint8_t kFunctionCodeMask = 0x7F;  // CW bits 6..0
inline constexpr std::size_t kMaxDataLength = 8;

// CW DL d0..d7. Bytes beyond `length` are padding: kept zero by every function of this library
// and ignored by comparisons.
struct Message {
  std::uint8_t control_word = 0;
  std::uint8_t length = 0;  // DL, 0..8
  std::array<std::uint8_t, kMaxDataLength> data{};

  [[nodiscard]] std::span<const std::uint8_t> payload() const {
    return {data.data(), std::min<std::size_t>(length, kMaxDataLength)};
  }
  [[nodiscard]] std::uint8_t function_code() const { return control_word & kFunctionCodeMask; }
  [[nodiscard]] bool ack_requested() const { return (control_word & kAckRequestBit) != 0; }

  // Copies `payload` (at most 8 bytes) as d0..; fails with length_out_of_range otherwise.
  static Result<Message> make(std::uint8_t control_word, std::span<const std::uint8_t> payload);

  friend bool operator==(const Message& a, const Message& b) {
    return a.control_word == b.control_word && a.length == b.length &&
           std::equal(a.payload().begin(), a.payload().end(), b.payload().begin());
  }
};

// Who sends to whom on CAN. Host instructions: {kMasterId, target}; drive frames: {node, kMasterId}.
struct CanAddress {
  std::uint8_t producer = kMasterId;
  std::uint8_t consumer = kGlobalId;
  friend bool operator==(const CanAddress&, const CanAddress&) = default;
};
[[nodiscard]] constexpr CanAddress host_to(std::uint8_t target, std::uint8_t host = kMasterId) noexcept {
  return {host, target};
}
// Replies go to the master ID (not stated in §2.5, assumed); hosts must not rely on the consumer of
// drive frames.
[[nodiscard]] constexpr CanAddress drive_to_host(std::uint8_t node, std::uint8_t host = kMasterId) noexcept {
  return {node, host};
}

struct CanMessage {
  CanAddress address;
  Message message;
  friend bool operator==(const CanMessage&, const CanMessage&) = default;
};

// Extended data frame, DLC = DL. Fails on IDs above 127 or DL above 8.
[[nodiscard]] Result<can::Frame> encode_can(const CanMessage& message);
// Rejects standard and RTR frames, identifiers that are not SimpleCAN (reserved bits) and DLC > 8.
[[nodiscard]] Result<CanMessage> decode_can(const can::Frame& frame);

}  // namespace motion::uim342
