// The coordinator on the wire: the passive core (coordinator.hpp) driven by a process's
// EventLoop and LCM node. It subscribes REQUEST, AXIS_STATE, GW_REPLY, EVENT and HEALTH and hands
// each message to the core with the loop's `now`; what the core sends goes out on REPLY,
// GW_COMMAND_<bus>, SYNC_TRIGGER, ACTIVE_MOVES and EVENT, stamped with wall_time_us(). After every
// message, and at the deadline process() returned, the core runs what is due: one loop timer,
// re-armed at the next deadline.
//
// Thread contract: loop thread only. Never blocks.
#pragma once

#include <string>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/coordinator/coordinator.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/node.hpp"

namespace motion::coordinator {

class CoordinatorService final : private CoordinatorOutput {
 public:
  // `loop`, `node` and `config` must outlive the service.
  CoordinatorService(EventLoop& loop, lcm::Node& node, const config::Config& config, MovePlanner planner);
  ~CoordinatorService() override;
  CoordinatorService(const CoordinatorService&) = delete;
  CoordinatorService& operator=(const CoordinatorService&) = delete;

  [[nodiscard]] std::size_t active_requests() const { return core_.active_requests(); }
  // Buses whose gateway has not been heard within gateway_timeout_ms (see Coordinator).
  [[nodiscard]] std::vector<std::string> buses_without_gateway() const { return core_.buses_without_gateway(loop_.now()); }

 private:
  // Runs the core at the loop's now and re-arms the timer at the deadline it returns.
  void pump();

  void reply(const motionlcm::reply_t& reply) override;
  void gateway_command(const std::string& bus, const motionlcm::gateway_command_t& command) override;
  void sync_trigger(const motionlcm::sync_trigger_t& trigger) override;
  void active_moves(const motionlcm::active_moves_t& moves) override;
  void event(const motionlcm::event_t& event) override;

  EventLoop& loop_;
  lcm::Node& node_;
  Coordinator core_;
  EventLoop::TimerId timer_ = 0;
  TimePoint timer_deadline_ = kNever;
};

}  // namespace motion::coordinator
