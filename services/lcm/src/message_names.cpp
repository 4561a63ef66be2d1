#include "motion/lcm/message_names.hpp"

#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/reply_t.hpp>

namespace motion::lcm {

bool reply_is_terminal(std::int8_t status) {
  using R = motionlcm::reply_t;
  return status == R::DONE || status == R::REJECTED || status == R::ABORTED || status == R::FAILED;
}

const char* reply_status_name(std::int8_t status) {
  using R = motionlcm::reply_t;
  switch (status) {
    case R::ACCEPTED: return "accepted";
    case R::STARTED: return "started";
    case R::PROGRESS: return "progress";
    case R::DONE: return "done";
    case R::REJECTED: return "rejected";
    case R::ABORTED: return "aborted";
    case R::FAILED: return "failed";
    default: return "unknown";
  }
}

const char* health_state_name(std::int8_t state) {
  using H = motionlcm::health_t;
  switch (state) {
    case H::STARTING: return "starting";
    case H::OK: return "ok";
    case H::DEGRADED: return "degraded";
    case H::FAULT: return "fault";
    case H::STOPPING: return "stopping";
    default: return "?";
  }
}

const char* event_kind_name(std::int16_t kind) {
  using E = motionlcm::event_t;
  switch (kind) {
    case E::ALARM: return "alarm";
    case E::STALL: return "stall";
    case E::LIMIT: return "limit";
    case E::INPUT_EDGE: return "input edge";
    case E::EMCY: return "emergency";
    case E::ERROR_REPORT: return "error report";
    case E::TIMEOUT: return "timeout";
    case E::OFFLINE: return "offline";
    case E::ONLINE: return "online";
    case E::REBOOT: return "reboot";
    case E::BUS_OFF: return "bus off";
    case E::BUS_RECOVERED: return "bus recovered";
    case E::CONFIG_MISMATCH: return "config mismatch";
    case E::MOTION_COMPLETE: return "motion complete";
    case E::HEARTBEAT_LOST: return "heartbeat lost";
    case E::PROTOCOL_ERROR: return "protocol error";
    case E::GATEWAY_RESTARTED: return "gateway restarted";
    case E::STOP_UNCONFIRMED: return "stop unconfirmed";
    case E::UNOWNED_MOTION: return "unowned motion";
    default: return "unknown";
  }
}

const char* event_severity_name(std::int8_t severity) {
  using E = motionlcm::event_t;
  switch (severity) {
    case E::INFO: return "info";
    case E::WARNING: return "warning";
    case E::ERROR: return "error";
    default: return "unknown";
  }
}

}  // namespace motion::lcm
