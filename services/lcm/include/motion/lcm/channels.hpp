// Channel names of the public LCM API (without the configurable prefix). Documented in the
// README's "Channels" table; a change here is an API change.
#pragma once

#include <string>
#include <string_view>

namespace motion::lcm::channels {

inline constexpr std::string_view kRequest = "REQUEST";         // request_t, clients -> coordinator
inline constexpr std::string_view kSignedRequest = "SREQUEST";  // signed_request_t, clients -> coordinator
inline constexpr std::string_view kReply = "REPLY";             // reply_t, coordinator -> clients
inline constexpr std::string_view kAxisState = "AXIS_STATE";    // axis_state_t, gateways
inline constexpr std::string_view kEvent = "EVENT";             // event_t, gateways/coordinator
// The channel name (no plain channel has it) under which gateways sign their event_t with their
// gateway key, published on SGW_EVENT: apart from the coordinator's own signed events (SEVENT),
// which clients verify with the coordinator's key.
inline constexpr std::string_view kGatewayEvent = "GW_EVENT";
inline constexpr std::string_view kHealth = "HEALTH";             // health_t, every process
inline constexpr std::string_view kGatewayReply = "GW_REPLY";     // gateway_reply_t
inline constexpr std::string_view kSyncTrigger = "SYNC_TRIGGER";  // sync_trigger_t (deprecated: SYNC_TRIGGER2)
// sync_trigger2_t, coordinator -> gateways: the scheduled start (per-bus hand-over times).
inline constexpr std::string_view kSyncTrigger2 = "SYNC_TRIGGER2";
inline constexpr std::string_view kActiveMoves = "ACTIVE_MOVES";  // active_moves_t, coordinator -> gateways, tools
// active_moves_t, gateways -> a new coordinator: the rows a gateway last had from a coordinator
// that stopped heartbeating, so that its successor can end those requests.
inline constexpr std::string_view kOrphanedMoves = "ORPHANED_MOVES";
// drive_model_t, gateways -> coordinator, tools: what each axis's drive can execute.
inline constexpr std::string_view kDriveModel = "DRIVE_MODEL";
// arm_timing_t, gateways -> coordinator, tools: with each DRIVE_MODEL, how long arming takes.
inline constexpr std::string_view kArmTiming = "ARM_TIMING";
// line_timing_t, gateways -> coordinator, tools: with each DRIVE_MODEL, how long the gateway's own
// traffic (a serial line's exchange, a CAN bus's poll answers or SYNC) may hold the bus at a start.
inline constexpr std::string_view kLineTiming = "LINE_TIMING";
// trigger_heard_t, gateways -> coordinator, tools: when a gateway heard a SYNC_TRIGGER2 (the
// coordinator's adaptive trigger lead is measured from it).
inline constexpr std::string_view kTriggerHeard = "TRIGGER_HEARD";
// drive_model_request_t, anyone -> gateways: publish your DRIVE_MODEL now.
inline constexpr std::string_view kDriveModelRequest = "DRIVE_MODEL_REQUEST";
// ledger_stats_t, gateways -> tools: with each heartbeat, the counters of the gateway's command ledger.
inline constexpr std::string_view kLedgerStats = "LEDGER_STATS";
inline constexpr std::string_view kSimControl = "SIM_CONTROL";  // sim_control_t, tests -> motion-sim
inline constexpr std::string_view kSimReport = "SIM_REPORT";    // sim_report_t, motion-sim -> tests

// gateway_command_t for one bus.
inline std::string gateway_command(std::string_view bus) { return "GW_COMMAND_" + std::string(bus); }
// gateway_command2_t for one bus (motion values as integers of the drive models' grids).
inline std::string gateway_command2(std::string_view bus) { return "GW_COMMAND2_" + std::string(bus); }
// signed_gateway_command_t for one bus (the coordinator's commands signed with its key).
inline std::string signed_gateway_command(std::string_view bus) { return "GW_SCOMMAND_" + std::string(bus); }
// can_frame_t mirror of one bus.
inline std::string raw_frames(std::string_view bus) { return "RAW_" + std::string(bus); }

}  // namespace motion::lcm::channels
