// The names of request_t's kinds, from one table: as the constants spell them (MOVE_RELATIVE: logs,
// CSV, generated test cases) and in words (relative move: replies and log lines for people).
// Thread contract: none (pure functions).
#pragma once

#include <cstdint>
#include <string>

#include <motionlcm/request_t.hpp>

namespace motion::lcm {

// "MOVE_ABSOLUTE" ... "SET_POSITION"; "UNKNOWN" for a value no constant has.
[[nodiscard]] const char* request_kind_name(std::int8_t kind);
// "move" ... "set position"; "unknown" for a value no constant has.
[[nodiscard]] const char* request_kind_words(std::int8_t kind);
// MOVE_ABSOLUTE, MOVE_RELATIVE, JOG, HOME: the kinds that set axes in motion.
[[nodiscard]] bool request_kind_moves(std::int8_t kind);
// "move request 7 of client 'alice/ctl'": how refusals name a request whose ids cannot be trusted
// (the C++ client finds its own requests in SECURITY events by it).
[[nodiscard]] std::string request_label(const motionlcm::request_t& request);

}  // namespace motion::lcm
