#include "motion/gateway/command_ledger.hpp"

namespace motion::gateway {

std::int64_t system_wall_clock(TimePoint now) {
  // Steady -> wall: the offset between the two clocks at this moment.
  const auto steady_now = SteadyClock::now();
  return wall_time_us() - std::chrono::duration_cast<std::chrono::microseconds>(steady_now - now).count();
}

WallClock or_system_clock(WallClock clock) { return clock ? std::move(clock) : WallClock{system_wall_clock}; }

std::string_view to_string(Lifecycle state) {
  switch (state) {
    case Lifecycle::kLoading: return "loading";
    case Lifecycle::kArmed: return "armed";
    case Lifecycle::kStarted: return "started";
    case Lifecycle::kDone: return "done";
    case Lifecycle::kFailed: return "failed";
    case Lifecycle::kStopped: return "stopped";
  }
  return "?";
}

std::optional<Lifecycle> lifecycle_of(std::int8_t reply_status) {
  switch (reply_status) {
    case motionlcm::gateway_reply_t::ACCEPTED: return Lifecycle::kLoading;
    case motionlcm::gateway_reply_t::ARMED: return Lifecycle::kArmed;
    case motionlcm::gateway_reply_t::STARTED: return Lifecycle::kStarted;
    case motionlcm::gateway_reply_t::DONE: return Lifecycle::kDone;
    case motionlcm::gateway_reply_t::FAILED: return Lifecycle::kFailed;
    default: return std::nullopt;
  }
}

ReplyBuilder::ReplyBuilder(const motionlcm::gateway_command_t& command) {
  reply_.command_id = command.command_id;
  reply_.param = command.param;
}

ReplyBuilder::ReplyBuilder(std::int64_t command_id) { reply_.command_id = command_id; }

ReplyBuilder& ReplyBuilder::status(std::int8_t status) {
  reply_.status = status;
  return *this;
}

ReplyBuilder& ReplyBuilder::reason(std::string reason) {
  reply_.reason = std::move(reason);
  return *this;
}

ReplyBuilder& ReplyBuilder::error(std::int32_t code) {
  reply_.error_code = code;
  return *this;
}

ReplyBuilder& ReplyBuilder::failed(std::int32_t code, std::string reason) {
  reply_.status = motionlcm::gateway_reply_t::FAILED;
  reply_.error_code = code;
  reply_.reason = std::move(reason);
  return *this;
}

ReplyBuilder& ReplyBuilder::started(std::int64_t trigger_utime, std::string mechanism, double predicted_skew_us) {
  reply_.trigger_utime = trigger_utime;
  reply_.start_mechanism = std::move(mechanism);
  reply_.predicted_skew_us = predicted_skew_us;
  return *this;
}

ReplyBuilder& ReplyBuilder::param(const motionlcm::param_t& param) {
  reply_.param = param;
  return *this;
}

ReplyBuilder& ReplyBuilder::bus(std::string bus) {
  reply_.bus = std::move(bus);
  return *this;
}

}  // namespace motion::gateway
