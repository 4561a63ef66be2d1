// Names of the status and kind constants of the public messages, for people and for JSON:
// reply_t statuses, health_t states, event_t kinds and severities (lower case words, as motionctl
// prints them). request_t kinds are in request_kinds.hpp.
// Thread contract: none (pure functions).
#pragma once

#include <cstdint>

namespace motion::lcm {

// DONE, REJECTED, ABORTED, FAILED: the last reply a request gets.
[[nodiscard]] bool reply_is_terminal(std::int8_t status);
// "accepted" ... "failed"; "unknown" for a value no constant has.
[[nodiscard]] const char* reply_status_name(std::int8_t status);
// "starting", "ok", "degraded", "fault", "stopping"; "?" for a value no constant has.
[[nodiscard]] const char* health_state_name(std::int8_t state);
// "alarm" ... "unowned motion"; "unknown" for a value no constant has.
[[nodiscard]] const char* event_kind_name(std::int16_t kind);
// "info", "warning", "error"; "unknown" for a value no constant has.
[[nodiscard]] const char* event_severity_name(std::int8_t severity);

}  // namespace motion::lcm
