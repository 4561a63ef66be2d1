// The page's write actions, as a browser sends them over the WebSocket (one JSON object):
//   {"type": "command", "token": "<the access token>", "tag": <any number the page chooses>,
//    "kind": "ENABLE" | "DISABLE" | "MOVE_ABSOLUTE" | "MOVE_RELATIVE" | "JOG" | "STOP" | "ESTOP" |
//            "HOME" | "FAULT_RESET",
//    "axes": ["x", ...], "values": [...], "velocity_scale": 0.5}
// parse_control checks a command whole before anything is sent: the access token (compared in
// constant time), the kind (the page's kinds only: set-position, outputs and parameters are for
// motionctl), the axes (configured, none twice; STOP and ESTOP may name none: every axis), the
// values (one finite number per axis for the moves and jog, none for the others) and the scales
// ((0, 1] or absent). What it returns is a request_t for motion-web's client, which signs it
// with the web view's own key; the axis limits and the key's role are the coordinator's to
// check, and its answer reaches the page as any other REPLY.
//
// The answer to the browser that sent the command (control_result) is a JSON object
//   {"type": "command_result", "tag": <its tag>, "ok": true, "id": "<client_id>/<request_id>"}
//   {"type": "command_result", "tag": <its tag or null>, "ok": false, "error": "<what was wrong>"}
//
// Thread contract: none (pure functions), but new_access_token (reads the kernel's random source).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include <motionlcm/request_t.hpp>

#include "motion/config/config.hpp"

namespace motion::web {

struct ControlRequest {
  std::int64_t tag = 0;
  motionlcm::request_t request{};  // kind, axes, values, scales (the rest zero); ids are the client's to fill
};
struct ControlError {
  std::optional<std::int64_t> tag;  // nullopt when the text had none (or was no JSON)
  std::string error;
};

[[nodiscard]] std::variant<ControlRequest, ControlError> parse_control(std::string_view text,
                                                                       const config::Config& config,
                                                                       std::string_view token);

[[nodiscard]] std::string control_accepted(std::int64_t tag, std::string_view request_id);
[[nodiscard]] std::string control_refused(const ControlError& error);

// 32 hex digits (128 bits) from getrandom(2); empty when the kernel has no random source.
[[nodiscard]] std::string new_access_token();

}  // namespace motion::web
