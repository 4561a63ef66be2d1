// reply_t.error_code and gateway_reply_t.error_code values: machine-readable causes of REJECTED /
// ABORTED / FAILED replies, one list for the coordinator and every gateway stack.
// Documented in the README; append only (clients switch on them).
#pragma once

#include <cstdint>

namespace motion {

enum class ReplyError : std::int32_t {
  kNone = 0,
  kMalformedRequest = 1,  // bad kind, array sizes, non-finite values, missing axes
  kUnknownAxis = 2,
  kOutsideLimits = 3,
  kAxisDisabled = 4,
  kAxisFaulted = 5,
  kAxisOffline = 6,  // no fresh state from the axis's gateway
  kGatewayOffline = 7,
  kAxisBusy = 8,          // another request moves this axis
  kDuplicateRequest = 9,  // same client_id + request_id already active
  kPlanningFailed = 10,
  kArmFailed = 11,   // a gateway could not load the move
  kDriveError = 12,  // a gateway reported FAILED without a more precise code of this list
  kTimeout = 13,
  kStopped = 14,               // preempted by a stop / e-stop request
  kAxisFault = 15,             // an axis of the group faulted, stalled or hit a limit mid-move
  kGatewayLost = 16,           // a gateway's heartbeat stopped mid-request
  kUnsupported = 17,           // the family/configuration cannot do this
  kBusy = 18,                  // the coordinator has max_active_requests in progress: retry later
  kUnauthorized = 19,          // a signed request whose key's role does not allow its kind
  kCoordinatorRestarted = 20,  // ended by the successor of the coordinator that served it (its axes were stopped)
  kNoDriveModel = 21,          // a move of an axis whose gateway has not published its drive model (DRIVE_MODEL) yet
  kPositionLost =
      22,  // a move or jog of an axis whose drive lost power: home it or set its position first (the last code)
};

// The wire value of `error` (the int32 of reply_t / gateway_reply_t).
[[nodiscard]] constexpr std::int32_t error_code(ReplyError error) noexcept { return static_cast<std::int32_t>(error); }

}  // namespace motion
