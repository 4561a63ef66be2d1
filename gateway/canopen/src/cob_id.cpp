#include "motion/canopen/cob_id.hpp"

namespace motion::canopen {

std::optional<CobIdInfo> classify_cob_id(std::uint32_t id) {
  if (id > can::kMaxStandardId) return std::nullopt;
  const auto function = static_cast<FunctionCode>(id >> 7);
  const auto node = static_cast<NodeId>(id & 0x7F);
  const auto with_node = [&](MessageKind kind, std::uint8_t pdo_number = 0) -> std::optional<CobIdInfo> {
    if (!is_valid_node_id(node)) return std::nullopt;
    return CobIdInfo{kind, node, pdo_number};
  };
  switch (function) {
    case FunctionCode::kNmt:
      if (node != 0) return std::nullopt;
      return CobIdInfo{MessageKind::kNmt, 0, 0};
    case FunctionCode::kSyncEmcy:
      if (node == 0) return CobIdInfo{MessageKind::kSync, 0, 0};
      return with_node(MessageKind::kEmcy);
    case FunctionCode::kTime:
      if (node != 0) return std::nullopt;
      return CobIdInfo{MessageKind::kTime, 0, 0};
    case FunctionCode::kTpdo1:
    case FunctionCode::kTpdo2:
    case FunctionCode::kTpdo3:
    case FunctionCode::kTpdo4:
      return with_node(MessageKind::kTpdo, static_cast<std::uint8_t>((static_cast<unsigned>(function) - 1) / 2));
    case FunctionCode::kRpdo1:
    case FunctionCode::kRpdo2:
    case FunctionCode::kRpdo3:
    case FunctionCode::kRpdo4:
      return with_node(MessageKind::kRpdo, static_cast<std::uint8_t>((static_cast<unsigned>(function) - 2) / 2));
    case FunctionCode::kSdoTx: return with_node(MessageKind::kSdoResponse);
    case FunctionCode::kSdoRx: return with_node(MessageKind::kSdoRequest);
    case FunctionCode::kHeartbeat: return with_node(MessageKind::kHeartbeat);
  }
  return std::nullopt;  // 1101b, 1111b
}

}  // namespace motion::canopen
