// Messages between the simulated-bus hub and its endpoints, one per SOCK_SEQPACKET datagram.
//
// Pure codec, no allocation on encode, thread-safe. Little-endian; byte 0 is the message type.
//   Hello      endpoint -> hub, first message: protocol version, own-echo flag, label.
//   Welcome    hub -> endpoint, reply to Hello: version, endpoint id, bitrate, bus name.
//   Frame      both ways: flags (extended, rtr, own echo), dlc, id, timestamp (hub -> endpoint:
//              simulated end-of-frame time, us since the Unix epoch; endpoint -> hub: 0), data.
//   SetOwnEcho endpoint -> hub.
//   BusEvent   hub -> endpoint: state, error class (kError* of bus.hpp), text.
//   TxRejected hub -> endpoint: a frame the hub refused (bus-off), for the sender's counters.
//   FrameBatch endpoint -> hub: frames handed over at once (can::Transport::send_batch), up to
//              kMaxBatchFrames: count, then per frame flags (extended, rtr), dlc, id, data. The
//              hub takes them together, as a CAN controller given them at once takes them: a
//              sender preempted between datagrams (the hub's own wake-up on the first one does
//              it on a small host) cannot leave a gap between them that the wire would not.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>

#include "motion/can/transport.hpp"
#include "motion/can_frame/frame.hpp"

namespace motion::simbus::wire {

inline constexpr std::uint16_t kProtocolVersion = 2;
// Every message fits (texts are truncated to kMaxText); receivers read with a buffer this size.
inline constexpr std::size_t kMaxMessageSize = 256;
inline constexpr std::size_t kMaxText = 200;

enum class Type : std::uint8_t {
  kHello = 1,
  kWelcome = 2,
  kFrame = 3,
  kSetOwnEcho = 4,
  kBusEvent = 5,
  kTxRejected = 6,
  kFrameBatch = 7
};

struct Hello {
  std::uint16_t version = kProtocolVersion;
  bool own_echo = false;
  std::string label;
  friend bool operator==(const Hello&, const Hello&) = default;
};
struct Welcome {
  std::uint16_t version = kProtocolVersion;
  std::uint32_t endpoint = 0;
  std::uint32_t bitrate = 0;  // 0: timing model off
  std::string bus_name;
  friend bool operator==(const Welcome&, const Welcome&) = default;
};
struct FrameMessage {
  can::Frame frame;
  bool own_echo = false;  // the receiver transmitted this frame itself
  friend bool operator==(const FrameMessage& a, const FrameMessage& b) {
    return a.frame == b.frame && a.frame.timestamp_us == b.frame.timestamp_us && a.own_echo == b.own_echo;
  }
};
struct SetOwnEcho {
  bool enabled = false;
  friend bool operator==(const SetOwnEcho&, const SetOwnEcho&) = default;
};
struct BusEventMessage {
  can::BusEvent event;
  friend bool operator==(const BusEventMessage& a, const BusEventMessage& b) {
    return a.event.state == b.event.state && a.event.error_class == b.event.error_class && a.event.text == b.event.text;
  }
};
struct TxRejected {
  std::uint32_t id = 0;
  bool extended = false;
  friend bool operator==(const TxRejected&, const TxRejected&) = default;
};

// 2 + 16 x 14 bytes: within kMaxMessageSize.
inline constexpr std::size_t kMaxBatchFrames = 16;
struct FrameBatch {
  std::array<can::Frame, kMaxBatchFrames> frames{};
  std::size_t count = 0;  // 1..kMaxBatchFrames
  [[nodiscard]] std::span<const can::Frame> view() const { return {frames.data(), count}; }
  friend bool operator==(const FrameBatch& a, const FrameBatch& b) { return std::ranges::equal(a.view(), b.view()); }
};

using Message = std::variant<Hello, Welcome, FrameMessage, SetOwnEcho, BusEventMessage, TxRejected, FrameBatch>;

// Writes `message` into `out`; returns the encoded size, 0 when `out` is too small, a frame is
// invalid (dlc > 8, id out of range) or a batch's count is outside 1..kMaxBatchFrames. Texts longer than kMaxText are truncated.
[[nodiscard]] std::size_t encode(const Message& message, std::span<std::uint8_t> out);
// Parses one datagram; nullopt for an unknown type, a wrong length or invalid field values.
[[nodiscard]] std::optional<Message> decode(std::span<const std::uint8_t> in);

}  // namespace motion::simbus::wire
