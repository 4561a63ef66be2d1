// Steps the Uc57Stack command tests share (commands_test.cpp, stop_and_state_test.cpp) on the
// test bench of harness.hpp: enabling axes, arming a move, and the order of states and replies.
// Thread contract: single-threaded test code.
#pragma once

#include <algorithm>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "harness.hpp"

namespace motion::uc57_driver::testing {

using Cmd = motionlcm::gateway_command_t;
using Reply = motionlcm::gateway_reply_t;

inline constexpr std::int8_t status(std::int8_t s) { return s; }

inline void enable(Bench& bench, const std::vector<std::string>& axes) {
  const auto c = bench.command(Cmd::ENABLE, axes);
  bench.execute(c);
  bench.run_for(std::chrono::milliseconds(500));
  ASSERT_EQ(bench.replies_of(c.command_id).back().status, status(Reply::DONE))
      << bench.replies_of(c.command_id).back().reason;
}

// How many statuses had gone out when `id` got its reply `s` (the size of the log if it never did).
inline std::size_t statuses_before_reply(const Bench& bench, std::int64_t id, std::int8_t s) {
  for (std::size_t i = 0; i < bench.replies.size(); ++i) {
    if (bench.replies[i].command_id == id && bench.replies[i].status == s) return bench.replied_after[i];
  }
  return bench.status_log.size();
}

// The last status of `axis` among the first `count` published.
inline std::optional<gateway::DriveStatus> last_status_before(const Bench& bench, const std::string& axis,
                                                              std::size_t count) {
  for (std::size_t i = std::min(count, bench.status_log.size()); i-- > 0;) {
    if (bench.status_log[i].first == axis) return bench.status_log[i].second;
  }
  return std::nullopt;
}

inline Cmd arm(Bench& bench, std::vector<std::pair<std::string, std::int64_t>> targets, std::int64_t trigger) {
  std::vector<std::string> names;
  names.reserve(targets.size());
  for (auto& t : targets) names.push_back(t.first);
  auto c = bench.command(Cmd::ARM_MOVE, names, trigger);
  for (std::size_t i = 0; i < targets.size(); ++i) {
    c.axes[i].target_counts = targets[i].second;
    c.axes[i].velocity = 3200;  // 60 RPM at 3200 pulses/rev
    c.axes[i].acceleration = 32000;
    c.axes[i].deceleration = 32000;
  }
  bench.execute(c);
  return c;
}

}  // namespace motion::uc57_driver::testing
