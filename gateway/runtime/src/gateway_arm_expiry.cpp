// The Gateway's release of armed moves that no trigger starts (arm_watch.hpp, README "Safety and
// faults"): the expiry, the timer, and the DISARM of its own that releases a move in the driver.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include <motionlcm/event_t.hpp>

#include "motion/gateway/gateway.hpp"
#include "motion/lcm/reply_error.hpp"

namespace motion::gateway {

Duration Gateway::arm_expiry(const config::Config& config, const ArmingBuilder& arming) {
  const auto& c = config.coordinator;
  if (c.arm_expiry_ms > 0) return std::chrono::milliseconds(c.arm_expiry_ms);
  // The coordinator triggers at the latest arm_timeout_ms plus the slowest bus's arming line time
  // after it sent the ARM_MOVE (trigger_lead_ms later on the wire for a move of several buses);
  // gateway_timeout_ms on top covers LCM, the host and the trigger's own scheduling. The line time
  // is bounded per bus by every drive of it armed (or readied as a bystander) at its slowest.
  double line_us = 0;
  if (arming) {
    for (const auto& bus : config.buses) {
      double slowest_us = 0;
      for (const config::Axis* axis : config.axes_on_bus(bus.name)) {
        const auto timing = arming(*axis);
        if (const auto* t = std::get_if<motionlcm::arm_timing_t>(&timing))
          slowest_us = std::max({slowest_us, t->arm_line_us, t->arm_bystander_us});
      }
      const auto drives = std::count_if(config.drives.begin(), config.drives.end(),
                                        [&name = bus.name](const config::Drive& d) { return d.bus == name; });
      line_us = std::max(line_us, slowest_us * static_cast<double>(drives));
    }
  }
  return std::chrono::milliseconds(c.arm_timeout_ms + c.trigger_lead_ms + c.gateway_timeout_ms) +
         std::chrono::microseconds(static_cast<std::int64_t>(std::ceil(line_us)));
}

void Gateway::set_arming_builder(ArmingBuilder builder) {
  arming_builder_ = std::move(builder);
  arm_watch_.set_expiry(arm_expiry(config_, arming_builder_));
  spdlog::info("bus {}: a move armed for a trigger is released unfired after {} ms", bus_,
               std::chrono::duration_cast<std::chrono::milliseconds>(arm_watch_.expiry()).count());
}

void Gateway::rearm_expiry_timer() {
  if (arm_timer_ != 0) loop_.cancel(arm_timer_);
  arm_timer_ = 0;
  const TimePoint next = arm_watch_.next_deadline();
  if (next == kNever) return;
  // From the loop, never from inside a driver's reply: the release calls the driver.
  arm_timer_ = loop_.call_at(next, [this] {
    arm_timer_ = 0;
    release_expired();
  });
}

void Gateway::release_expired() {
  for (const auto& move : arm_watch_.due(loop_.now())) {
    const std::string why = arm_watch_.reason(move);
    const auto disarm = own_command(motionlcm::gateway_command_t::DISARM, move.axes, move.trigger_id);
    for (const auto& axis : move.axes) {
      DriveEvent e;
      e.kind = motionlcm::event_t::TIMEOUT;
      e.severity = motionlcm::event_t::WARNING;
      e.code = error_code(ReplyError::kTimeout);
      e.text = why;
      axis_event(axis, e);
    }
    spdlog::warn("bus {}: releasing command {} by DISARM {}: {}", bus_, move.command_id, disarm.command_id, why);
    if (driver_) driver_->execute(disarm);
  }
  rearm_expiry_timer();
}

}  // namespace motion::gateway
