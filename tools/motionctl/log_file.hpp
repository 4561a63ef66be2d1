// The LCM event log as motionctl log reads it: every record's header checked before LCM decodes it
// (a corrupt or truncated file reported with its byte offset), this system's requests, replies and
// axis states decoded, other channels counted. Blocking file I/O; no shared state.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

namespace motion::ctl {

template <typename Msg>
struct Logged {
  std::int64_t log_utime;  // when lcm-logger received it
  Msg msg;
};

struct LogContents {
  std::int64_t first_utime = 0;
  std::int64_t last_utime = 0;
  std::int64_t events = 0;
  std::map<std::string, std::int64_t> channel_counts;  // every channel, full names
  std::int64_t undecodable = 0;                        // ours by name but failed to decode
  std::vector<std::string> undecodable_channels;
  std::vector<Logged<motionlcm::request_t>> requests;
  std::vector<Logged<motionlcm::reply_t>> replies;
  std::vector<Logged<motionlcm::axis_state_t>> states;
  std::optional<std::string> corruption;  // the first damage found; reading stopped there
  std::optional<std::string> truncated;   // a truncated final record (warning only)
};

// Reads the log at `path`, decoding the channels of `prefix`; nullopt when it cannot be opened (the
// reason is printed on stderr).
std::optional<LogContents> read_log(const std::string& path, const std::string& prefix);

}  // namespace motion::ctl
