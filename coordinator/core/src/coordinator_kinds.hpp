// What the coordinator's source files share about request kinds and numbers (private to the
// coordinator library).
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>
#include "motion/lcm/request_kinds.hpp"

namespace motion::coordinator::detail {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using motionlcm::reply_t;
using motionlcm::request_t;

inline bool is_move(std::int8_t kind) { return kind == request_t::MOVE_ABSOLUTE || kind == request_t::MOVE_RELATIVE; }
// Requests whose axes keep moving after their command: their desired state is republished.
inline bool is_motion(std::int8_t kind) { return is_move(kind) || kind == request_t::JOG || kind == request_t::HOME; }
inline bool is_stop(std::int8_t kind) { return kind == request_t::STOP || kind == request_t::ESTOP; }
inline bool single_axis(std::int8_t kind) {
  return kind == request_t::SET_OUTPUTS || kind == request_t::PARAM_READ || kind == request_t::PARAM_WRITE;
}
inline bool terminal(std::int8_t status) {
  return status == reply_t::DONE || status == reply_t::REJECTED || status == reply_t::ABORTED ||
         status == reply_t::FAILED;
}

inline std::int8_t gateway_kind(std::int8_t request_kind) {
  switch (request_kind) {
    case request_t::JOG: return gateway_command_t::JOG;
    case request_t::STOP: return gateway_command_t::STOP;
    case request_t::ESTOP: return gateway_command_t::ESTOP;
    case request_t::HOME: return gateway_command_t::HOME;
    case request_t::ENABLE: return gateway_command_t::ENABLE;
    case request_t::DISABLE: return gateway_command_t::DISABLE;
    case request_t::FAULT_RESET: return gateway_command_t::FAULT_RESET;
    case request_t::SET_OUTPUTS: return gateway_command_t::SET_OUTPUTS;
    case request_t::PARAM_READ: return gateway_command_t::PARAM_READ;
    case request_t::PARAM_WRITE: return gateway_command_t::PARAM_WRITE;
    case request_t::SET_POSITION: return gateway_command_t::SET_POSITION;
    default: return 0;
  }
}

inline const char* kind_name(std::int8_t kind) { return lcm::request_kind_words(kind); }

inline double scale_or_one(double s) { return s > 0 && s <= 1 ? s : 1.0; }

inline std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// How often ACTIVE_MOVES is republished while motion requests are active.
inline constexpr std::chrono::milliseconds kActiveMovesPeriod{500};
// DRIVE_MODEL_REQUEST while an axis of a live gateway has no drive model.
inline constexpr std::chrono::milliseconds kModelRequestPeriod{1000};
// How long a move that could not be armed everywhere waits for its DISARM replies.
inline constexpr std::chrono::milliseconds kReleaseTimeout{500};

}  // namespace motion::coordinator::detail
