#include "motion/canopen/emcy.hpp"

#include <algorithm>

#include "frame_util.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/core/bytes.hpp"

namespace motion::canopen {

can::Frame encode_emcy(NodeId node, const Emergency& emergency) {
  std::array<std::uint8_t, 8> payload{};
  bytes::write_le<std::uint16_t>(payload, 0, emergency.error_code);
  payload[2] = emergency.error_register;
  std::copy(emergency.manufacturer.begin(), emergency.manufacturer.end(), payload.begin() + 3);
  return detail::standard_frame(emcy_cob_id(node), payload);
}

std::optional<Emergency> decode_emcy(std::span<const std::uint8_t> payload) {
  if (payload.size() != 8) return std::nullopt;
  Emergency emergency;
  emergency.error_code = *bytes::read_le<std::uint16_t>(payload, 0);
  emergency.error_register = payload[2];
  std::copy(payload.begin() + 3, payload.end(), emergency.manufacturer.begin());
  return emergency;
}

EmcyErrorClass classify_error_code(std::uint16_t code) {
  const auto high_byte = static_cast<std::uint8_t>(code >> 8);
  switch (high_byte >> 4) {
    case 0x0: return high_byte == 0x00 ? EmcyErrorClass::kNoError : EmcyErrorClass::kReserved;
    case 0x1: return high_byte == 0x10 ? EmcyErrorClass::kGeneric : EmcyErrorClass::kReserved;
    case 0x2: return EmcyErrorClass::kCurrent;
    case 0x3: return EmcyErrorClass::kVoltage;
    case 0x4: return EmcyErrorClass::kTemperature;
    case 0x5: return high_byte == 0x50 ? EmcyErrorClass::kHardware : EmcyErrorClass::kReserved;
    case 0x6: return EmcyErrorClass::kSoftware;
    case 0x7: return high_byte == 0x70 ? EmcyErrorClass::kAdditionalModules : EmcyErrorClass::kReserved;
    case 0x8:
      if (high_byte == 0x81) return EmcyErrorClass::kCommunication;
      if (high_byte == 0x82) return EmcyErrorClass::kProtocol;
      return EmcyErrorClass::kMonitoring;
    case 0x9: return high_byte == 0x90 ? EmcyErrorClass::kExternal : EmcyErrorClass::kReserved;
    case 0xF:
      if (high_byte == 0xF0) return EmcyErrorClass::kAdditionalFunctions;
      if (high_byte == 0xFF) return EmcyErrorClass::kDeviceSpecific;
      return EmcyErrorClass::kReserved;
    default: return EmcyErrorClass::kReserved;
  }
}

std::string_view to_string(EmcyErrorClass error_class) {
  switch (error_class) {
    case EmcyErrorClass::kNoError: return "error reset or no error";
    case EmcyErrorClass::kGeneric: return "generic error";
    case EmcyErrorClass::kCurrent: return "current";
    case EmcyErrorClass::kVoltage: return "voltage";
    case EmcyErrorClass::kTemperature: return "temperature";
    case EmcyErrorClass::kHardware: return "device hardware";
    case EmcyErrorClass::kSoftware: return "device software";
    case EmcyErrorClass::kAdditionalModules: return "additional modules";
    case EmcyErrorClass::kMonitoring: return "monitoring";
    case EmcyErrorClass::kCommunication: return "communication";
    case EmcyErrorClass::kProtocol: return "protocol error";
    case EmcyErrorClass::kExternal: return "external error";
    case EmcyErrorClass::kAdditionalFunctions: return "additional functions";
    case EmcyErrorClass::kDeviceSpecific: return "device specific";
    case EmcyErrorClass::kReserved: return "reserved";
  }
  return "reserved";
}

void EmcyConsumer::set_cob_id(NodeId node, std::uint32_t cob_id) {
  std::erase_if(custom_cob_ids_, [node](const auto& entry) { return entry.second == node; });
  custom_cob_ids_[cob_id] = node;
}

std::optional<NodeId> EmcyConsumer::node_for(std::uint32_t cob_id) const {
  if (const auto custom = custom_cob_ids_.find(cob_id); custom != custom_cob_ids_.end()) return custom->second;
  const auto info = classify_cob_id(cob_id);
  if (!info || info->kind != MessageKind::kEmcy) return std::nullopt;
  // A node that moved its EMCY elsewhere no longer owns its default COB-ID.
  const bool moved = std::any_of(custom_cob_ids_.begin(), custom_cob_ids_.end(),
                                 [&](const auto& entry) { return entry.second == info->node; });
  if (moved) return std::nullopt;
  return info->node;
}

bool EmcyConsumer::on_frame(const can::Frame& frame, TimePoint now) {
  if (!detail::is_standard_data_frame(frame)) return false;
  const auto node = node_for(frame.id);
  if (!node) return false;
  const auto emergency = decode_emcy(frame.payload());
  if (!emergency) return true;
  last_[*node] = *emergency;
  if (handler_) handler_(EmcyEvent{*node, *emergency, classify_error_code(emergency->error_code), now});
  return true;
}

std::optional<Emergency> EmcyConsumer::last(NodeId node) const {
  const auto it = last_.find(node);
  if (it == last_.end()) return std::nullopt;
  return it->second;
}

}  // namespace motion::canopen
