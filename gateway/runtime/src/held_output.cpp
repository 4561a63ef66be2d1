#include "motion/gateway/held_output.hpp"

#include <utility>

namespace motion::gateway {

void HeldOutput::pass(std::function<void(GatewayOutput&)> call) {
  if (holds_ > 0) {
    queue_.push_back(std::move(call));
    return;
  }
  call(target_);
}

void HeldOutput::axis_status(const std::string& axis, const DriveStatus& status) {
  pass([axis, status](GatewayOutput& out) { out.axis_status(axis, status); });
}

void HeldOutput::axis_event(const std::string& axis, const DriveEvent& event) {
  pass([axis, event](GatewayOutput& out) { out.axis_event(axis, event); });
}

void HeldOutput::command_reply(motionlcm::gateway_reply_t reply) {
  pass([reply = std::move(reply)](GatewayOutput& out) { out.command_reply(reply); });
}

void HeldOutput::drive_facts(const std::string& axis, const DriveFacts& facts) {
  pass([axis, facts](GatewayOutput& out) { out.drive_facts(axis, facts); });
}

void HeldOutput::position_lost(const std::string& axis, const std::string& why) {
  pass([axis, why](GatewayOutput& out) { out.position_lost(axis, why); });
}

void HeldOutput::release() {
  if (holds_ == 0 || --holds_ > 0) return;
  // A call handed on may come back here (a publication's handler): it passes straight through.
  std::vector<std::function<void(GatewayOutput&)>> queued;
  queued.swap(queue_);
  for (auto& call : queued) call(target_);
}

}  // namespace motion::gateway
