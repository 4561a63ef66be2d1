// CiA 301 §7.3.3 predefined connection set: the 11-bit COB-ID is a 4-bit function code
// (bits 10..7) followed by the 7-bit node-ID (bits 6..0). Pure functions, thread-safe.
#pragma once

#include <cstdint>
#include <optional>

#include "motion/canopen/types.hpp"

namespace motion::canopen {

enum class FunctionCode : std::uint8_t {
  kNmt = 0x0,
  kSyncEmcy = 0x1,  // SYNC with node-ID 0, EMCY with node-ID 1..127
  kTime = 0x2,
  kTpdo1 = 0x3,
  kRpdo1 = 0x4,
  kTpdo2 = 0x5,
  kRpdo2 = 0x6,
  kTpdo3 = 0x7,
  kRpdo3 = 0x8,
  kTpdo4 = 0x9,
  kRpdo4 = 0xA,
  kSdoTx = 0xB,      // server -> client (responses), 580h + n
  kSdoRx = 0xC,      // client -> server (requests), 600h + n
  kHeartbeat = 0xE,  // heartbeat, boot-up and node guarding, 700h + n
};

inline constexpr std::uint32_t kNmtCobId = 0x000;
inline constexpr std::uint32_t kSyncCobId = 0x080;
inline constexpr std::uint32_t kTimeCobId = 0x100;

[[nodiscard]] constexpr std::uint32_t cob_id(FunctionCode function, NodeId node) {
  return (std::uint32_t{static_cast<std::uint8_t>(function)} << 7) | node;
}
[[nodiscard]] constexpr std::uint32_t emcy_cob_id(NodeId node) { return cob_id(FunctionCode::kSyncEmcy, node); }
[[nodiscard]] constexpr std::uint32_t sdo_request_cob_id(NodeId node) { return cob_id(FunctionCode::kSdoRx, node); }
[[nodiscard]] constexpr std::uint32_t sdo_response_cob_id(NodeId node) { return cob_id(FunctionCode::kSdoTx, node); }
[[nodiscard]] constexpr std::uint32_t heartbeat_cob_id(NodeId node) { return cob_id(FunctionCode::kHeartbeat, node); }
// Default PDO COB-IDs; `number` is 1..4 (TPDO n: 180h/280h/380h/480h + node, RPDO n: 200h/...).
[[nodiscard]] constexpr std::uint32_t tpdo_cob_id(std::uint8_t number, NodeId node) {
  return 0x180u + 0x100u * (number - 1u) + node;
}
[[nodiscard]] constexpr std::uint32_t rpdo_cob_id(std::uint8_t number, NodeId node) {
  return 0x200u + 0x100u * (number - 1u) + node;
}

// What a received identifier is under the predefined connection set.
enum class MessageKind : std::uint8_t {
  kNmt,
  kSync,
  kTime,
  kEmcy,
  kTpdo,
  kRpdo,
  kSdoResponse,
  kSdoRequest,
  kHeartbeat,
};

struct CobIdInfo {
  MessageKind kind = MessageKind::kNmt;
  NodeId node = 0;              // 0 for NMT, SYNC and TIME
  std::uint8_t pdo_number = 0;  // 1..4 for PDOs, 0 otherwise
  friend constexpr bool operator==(const CobIdInfo&, const CobIdInfo&) = default;
};

// nullopt for identifiers outside the predefined set (function codes 1101b/1111b, LSS 7E4h/7E5h,
// node-ID 0 where a node is required, anything above 7FFh).
[[nodiscard]] std::optional<CobIdInfo> classify_cob_id(std::uint32_t cob_id);

}  // namespace motion::canopen
