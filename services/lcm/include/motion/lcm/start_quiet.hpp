// The quiet interval around a scheduled start (SYNC_TRIGGER2), for every process that publishes
// while one goes out.
//
// An LCM publication wakes every process of the multicast group, each on a CPU: a reply or a
// state published while the gateways of a start hand their frames to the wire delays their fires
// on a host with few CPUs. So a process that hears or sends a trigger holds its publications
// (lcm::Node::quiet_until) from kBefore before the first bus's send time until kAfter after the
// act time, and never longer than kLongest (a slow line's long lead: the interval then begins
// kLongest before its end). A gateway holds everything it says; the coordinator keeps its commands
// and triggers going out at once (Node::publish_at_once).
//
// Thread contract: loop thread only (the loop and node's); no call blocks.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>

#include <motionlcm/sync_trigger2_t.hpp>

#include "motion/core/event_loop.hpp"
#include "motion/lcm/node.hpp"

namespace motion::lcm {

// Wall-clock microseconds (wall_time_us()).
struct QuietInterval {
  std::int64_t from_utime = 0;
  std::int64_t until_utime = 0;
};

class StartQuiet {
 public:
  static constexpr auto kBefore = std::chrono::microseconds(500);
  static constexpr auto kAfter = std::chrono::microseconds(500);
  static constexpr auto kLongest = std::chrono::microseconds(10000);
  // Intervals waiting for their beginning, at most, whatever triggers a sender publishes: past
  // that the one of the oldest trigger id is dropped.
  static constexpr std::size_t kMostWaiting = 64;

  // The quiet interval of `trigger` (its first num_buses send times; nullopt without any).
  [[nodiscard]] static std::optional<QuietInterval> interval_of(const motionlcm::sync_trigger2_t& trigger);

  // `loop` and `node` must outlive this object.
  StartQuiet(EventLoop& loop, Node& node) : loop_(loop), node_(node) {}
  StartQuiet(const StartQuiet&) = delete;
  StartQuiet& operator=(const StartQuiet&) = delete;
  ~StartQuiet();

  // Keeps the node quiet over `interval`: at once when it has begun, else from a loop timer at its
  // beginning. The same trigger id again replaces its interval.
  void keep(std::int64_t trigger_id, QuietInterval interval);
  // keep() with interval_of(trigger); nothing for a trigger without a send time.
  void keep(const motionlcm::sync_trigger2_t& trigger);
  [[nodiscard]] std::size_t waiting() const { return waiting_.size(); }

 private:
  EventLoop& loop_;
  Node& node_;
  std::map<std::int64_t, EventLoop::TimerId> waiting_;  // trigger id -> the beginning of its interval
};

}  // namespace motion::lcm
