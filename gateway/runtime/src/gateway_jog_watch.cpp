// Gateway (gateway.hpp): the watch of jogging axes, which stops a jog before its axis's limit
// whatever its sender (README "Safety and faults"), and the motion each axis was last given.
#include <fmt/format.h>

#include <cmath>

#include <motionlcm/event_t.hpp>

#include "motion/gateway/gateway.hpp"
#include "motion/lcm/reply_error.hpp"

namespace motion::gateway {

void Gateway::forget_jog(const std::string& axis) {
  jogs_.erase(axis);
  pending_motion_.erase(axis);
}

void Gateway::track_jogs(const motionlcm::gateway_command_t& command) {
  using C = motionlcm::gateway_command_t;
  for (const auto& a : command.axes) {
    commanded_.insert(a.axis);
    switch (command.kind) {
      case C::STOP:
      case C::ESTOP:
      case C::DISABLE: forget_jog(a.axis); break;
      case C::JOG: {
        std::optional<JogWatch> watch;
        if (a.velocity != 0) watch = JogWatch{a.velocity, a.deceleration > 0 ? a.deceleration : a.acceleration};
        pending_motion_[a.axis] = {command.command_id, watch};
        break;
      }
      case C::ARM_MOVE:
      case C::HOME: pending_motion_[a.axis] = {command.command_id, std::nullopt}; break;
      default: break;
    }
  }
}

void Gateway::jog_reply(const motionlcm::gateway_reply_t& reply) {
  using R = motionlcm::gateway_reply_t;
  std::vector<std::string> watched;
  for (auto it = pending_motion_.begin(); it != pending_motion_.end();) {
    if (it->second.command_id != reply.command_id) {
      ++it;
      continue;
    }
    if (reply.status == R::FAILED) {
      it = pending_motion_.erase(it);  // the previous motion (and its watch) goes on
      continue;
    }
    // A jog or homing run replaces a jog once the driver has it; a move once it has started
    // (an armed move may still be disarmed).
    const bool move = !it->second.jog && (reply.status == R::ARMED || reply.status == R::ACCEPTED);
    if (move) {
      ++it;
      continue;
    }
    if (it->second.jog) {
      jogs_[it->first] = *it->second.jog;
      watched.push_back(it->first);
    } else {
      jogs_.erase(it->first);
    }
    it = pending_motion_.erase(it);
  }
  for (const auto& axis : watched) check_jog(axis);
}

void Gateway::check_jog(const std::string& axis) {
  // A jog is watched from the moment it is handed to the driver, not from its reply: a drive may
  // run at the new speed before the driver has confirmed every step of the jog.
  std::optional<JogWatch> jog;
  if (const auto pending = pending_motion_.find(axis); pending != pending_motion_.end() && pending->second.jog) {
    jog = pending->second.jog;
  } else if (const auto watched = jogs_.find(axis); watched != jogs_.end()) {
    jog = watched->second;
  }
  const auto status = last_status_.find(axis);
  if (!jog || status == last_status_.end()) return;
  const CountLimits& limits = limits_.at(axis);
  if (!jog_must_stop(*jog, limits, status->second.position_counts, status->second.velocity_counts, poll_hz_)) return;
  const double limit = limits.limit_toward(jog->velocity);
  const auto pending = pending_motion_.find(axis);
  const std::int64_t unconfirmed =
      pending != pending_motion_.end() && pending->second.jog ? pending->second.command_id : 0;  // 0: none
  forget_jog(axis);
  const auto stop = own_command(motionlcm::gateway_command_t::STOP, {axis});
  const config::Axis& cfg = *axes_.at(axis);
  DriveEvent e;
  e.kind = motionlcm::event_t::LIMIT;
  e.severity = motionlcm::event_t::WARNING;
  e.code = error_code(ReplyError::kOutsideLimits);
  e.text = fmt::format(
      "axis {} jogging toward its limit {:.6g} {} ({:.6g} counts): {} at {:.6g} {} ({} counts, {:.6g} {}/s)", axis,
      limits.position_units(limit), cfg.unit, limit, driver_ ? "stopped" : "no bus driver to stop it",
      limits.position_units(static_cast<double>(status->second.position_counts)), cfg.unit,
      status->second.position_counts, std::abs(status->second.velocity_counts) / cfg.steps_per_unit, cfg.unit);
  // Before the STOP: the driver may fail the jog while it takes the STOP.
  if (unconfirmed != 0) stopped_at_limit_[unconfirmed] = e.text;
  if (driver_) driver_->execute(stop);
  axis_event(axis, e);
}

}  // namespace motion::gateway
