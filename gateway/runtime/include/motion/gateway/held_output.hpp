// A GatewayOutput that can hold what passes through it: while held, statuses, events, replies,
// drive facts and lost positions are queued in order; release() hands them on, in that order.
// The CAN bus driver holds its output while its stacks fire a start: every stack's start frames
// then go out before any of them publishes (a signed publication costs 0.1–0.5 ms, which spread
// the start frames of a bus's second stack after its first one's replies).
// Thread contract: the owner's thread only (the loop's).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "motion/gateway/bus_driver.hpp"

namespace motion::gateway {

class HeldOutput final : public GatewayOutput {
 public:
  explicit HeldOutput(GatewayOutput& target) : target_(target) {}

  void axis_status(const std::string& axis, const DriveStatus& status) override;
  void axis_event(const std::string& axis, const DriveEvent& event) override;
  void command_reply(motionlcm::gateway_reply_t reply) override;
  void drive_facts(const std::string& axis, const DriveFacts& facts) override;
  void position_lost(const std::string& axis, const std::string& why) override;

  // Holds from now on (nested holds: released by the outermost release()).
  void hold() { ++holds_; }
  // Hands on what was held, in order, once the outermost hold is released.
  void release();
  [[nodiscard]] bool held() const { return holds_ > 0; }

 private:
  void pass(std::function<void(GatewayOutput&)> call);

  GatewayOutput& target_;
  int holds_ = 0;
  std::vector<std::function<void(GatewayOutput&)>> queue_;
};

}  // namespace motion::gateway
