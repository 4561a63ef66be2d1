#include "motion/canopen/nmt.hpp"

#include <array>

#include "frame_util.hpp"
#include "motion/canopen/cob_id.hpp"

namespace motion::canopen {

std::string_view to_string(NmtCommand command) {
  switch (command) {
    case NmtCommand::kStart: return "start remote node";
    case NmtCommand::kStop: return "stop remote node";
    case NmtCommand::kEnterPreOperational: return "enter pre-operational";
    case NmtCommand::kResetNode: return "reset node";
    case NmtCommand::kResetCommunication: return "reset communication";
  }
  return "unknown NMT command";
}

std::string_view to_string(NmtState state) {
  switch (state) {
    case NmtState::kBootUp: return "boot-up";
    case NmtState::kStopped: return "stopped";
    case NmtState::kOperational: return "operational";
    case NmtState::kPreOperational: return "pre-operational";
  }
  return "unknown NMT state";
}

can::Frame encode_nmt(const NmtRequest& request) {
  const std::array<std::uint8_t, 2> payload{static_cast<std::uint8_t>(request.command), request.node};
  return detail::standard_frame(kNmtCobId, payload);
}

std::optional<NmtRequest> decode_nmt(std::span<const std::uint8_t> payload) {
  if (payload.size() != 2 || payload[1] > kMaxNodeId) return std::nullopt;
  const auto command = static_cast<NmtCommand>(payload[0]);
  switch (command) {
    case NmtCommand::kStart:
    case NmtCommand::kStop:
    case NmtCommand::kEnterPreOperational:
    case NmtCommand::kResetNode:
    case NmtCommand::kResetCommunication: return NmtRequest{command, payload[1]};
  }
  return std::nullopt;
}

can::Frame encode_heartbeat(NodeId node, NmtState state) {
  const std::array<std::uint8_t, 1> payload{static_cast<std::uint8_t>(state)};
  return detail::standard_frame(heartbeat_cob_id(node), payload);
}

std::optional<NmtState> decode_heartbeat(std::span<const std::uint8_t> payload) {
  if (payload.size() != 1) return std::nullopt;
  const auto state = static_cast<NmtState>(payload[0]);
  switch (state) {
    case NmtState::kBootUp:
    case NmtState::kStopped:
    case NmtState::kOperational:
    case NmtState::kPreOperational: return state;
  }
  return std::nullopt;
}

}  // namespace motion::canopen
