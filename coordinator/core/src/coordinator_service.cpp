#include "motion/coordinator/coordinator_service.hpp"

#include <spdlog/spdlog.h>

#include <span>

#include "motion/lcm/channels.hpp"

namespace motion::coordinator {

CoordinatorService::CoordinatorService(EventLoop& loop, lcm::Node& node, const config::Config& config, MovePlanner planner)
    : loop_(loop), node_(node), core_(config, std::move(planner), *this) {
  using motionlcm::request_t;
  node_.subscribe<request_t>(
      lcm::channels::kRequest,
      [this](const request_t& m, const std::string&) {
        core_.on_request(m, loop_.now());
        pump();
      },
      [this](const void* data, int size, const std::string& why) {
        const auto n = static_cast<std::size_t>(size > 0 ? size : 0);
        core_.on_malformed_request(std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(data), n), why, loop_.now());
        pump();
      });
  node_.subscribe<motionlcm::axis_state_t>(lcm::channels::kAxisState, [this](const motionlcm::axis_state_t& m, const std::string&) {
    core_.on_axis_state(m, loop_.now());
    pump();
  });
  node_.subscribe<motionlcm::gateway_reply_t>(lcm::channels::kGatewayReply, [this](const motionlcm::gateway_reply_t& m, const std::string&) {
    core_.on_gateway_reply(m, loop_.now());
    pump();
  });
  node_.subscribe<motionlcm::event_t>(lcm::channels::kEvent, [this](const motionlcm::event_t& m, const std::string&) {
    core_.on_event(m, loop_.now());
    pump();
  });
  node_.subscribe<motionlcm::health_t>(lcm::channels::kHealth, [this](const motionlcm::health_t& m, const std::string&) {
    core_.on_health(m, loop_.now());
    pump();
  });
  node_.subscribe<motionlcm::active_moves_t>(lcm::channels::kOrphanedMoves, [this](const motionlcm::active_moves_t& m, const std::string&) {
    core_.on_orphaned_moves(m, loop_.now());
    pump();
  });
  // A malformed request cannot be answered (its ids are unreadable): say so loudly on EVENT.
  node_.on_malformed([this](const std::string& what) {
    spdlog::warn("{}", what);
    core_.on_malformed_message(what, loop_.now());
    pump();
  });
  pump();
}

CoordinatorService::~CoordinatorService() {
  if (timer_ != 0) loop_.cancel(timer_);
}

void CoordinatorService::pump() {
  const TimePoint deadline = core_.process(loop_.now());
  if (timer_ != 0 && deadline == timer_deadline_) return;
  if (timer_ != 0) loop_.cancel(timer_);
  timer_ = 0;
  timer_deadline_ = deadline;
  if (deadline == kNever) return;
  timer_ = loop_.call_at(deadline, [this] {
    timer_ = 0;
    pump();
  });
}

void CoordinatorService::reply(const motionlcm::reply_t& reply) { node_.publish(lcm::channels::kReply, reply); }

void CoordinatorService::gateway_command(const std::string& bus, const motionlcm::gateway_command_t& command) {
  node_.publish(lcm::channels::gateway_command(bus), command);
}

void CoordinatorService::sync_trigger(const motionlcm::sync_trigger_t& trigger) { node_.publish(lcm::channels::kSyncTrigger, trigger); }

void CoordinatorService::active_moves(const motionlcm::active_moves_t& moves) { node_.publish(lcm::channels::kActiveMoves, moves); }

void CoordinatorService::event(const motionlcm::event_t& event) { node_.publish(lcm::channels::kEvent, event); }

}  // namespace motion::coordinator
