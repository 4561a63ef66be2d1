// CiA 301 §7.2.8 network management codecs: NMT node-control commands (COB-ID 000h, 2 bytes)
// and the error-control frames on 700h + node (boot-up, heartbeat). Pure functions, thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/types.hpp"

namespace motion::canopen {

// Command specifier, byte 0 of the NMT frame (CiA 301 §7.2.8.3.1).
enum class NmtCommand : std::uint8_t {
  kStart = 0x01,                // -> Operational
  kStop = 0x02,                 // -> Stopped
  kEnterPreOperational = 0x80,  // -> Pre-operational
  kResetNode = 0x81,            // application + communication reset, then boot-up
  kResetCommunication = 0x82,   // communication reset, then boot-up
};

// NMT state as carried by heartbeat and boot-up frames (CiA 301 §7.2.8.3.2).
enum class NmtState : std::uint8_t {
  kBootUp = 0x00,
  kStopped = 0x04,
  kOperational = 0x05,
  kPreOperational = 0x7F,
};

[[nodiscard]] std::string_view to_string(NmtCommand command);
[[nodiscard]] std::string_view to_string(NmtState state);

struct NmtRequest {
  NmtCommand command = NmtCommand::kStart;
  NodeId node = kAllNodes;  // 0 = every node
  friend constexpr bool operator==(const NmtRequest&, const NmtRequest&) = default;
};

[[nodiscard]] can::Frame encode_nmt(const NmtRequest& request);
// Exactly 2 bytes, a known command specifier and node-ID 0..127.
[[nodiscard]] std::optional<NmtRequest> decode_nmt(std::span<const std::uint8_t> payload);

// Boot-up is the heartbeat frame with state kBootUp.
[[nodiscard]] can::Frame encode_heartbeat(NodeId node, NmtState state);
// Exactly 1 byte holding one of the four states (bit 7, the node-guarding toggle, must be 0).
[[nodiscard]] std::optional<NmtState> decode_heartbeat(std::span<const std::uint8_t> payload);

}  // namespace motion::canopen
