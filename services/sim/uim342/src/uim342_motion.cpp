// Motion, inputs and faults of the simulated UIM342: reboot state, BG/ST/MO/OG effects on the
// shared kinematics (§3.2, §3.3, §5.10-§5.22), motion-end notifications (§2.4), input logic with
// trigger filters and parameter groups (§4, §5.13, §5.26, §5.27), stall and alarms (§1.5, §2.4),
// and the fault-injection controls.
#include <algorithm>
#include <cmath>
#include <limits>

#include "motion/sim/uim342_drive.hpp"
#include "motion/uim342/parameters.hpp"

namespace motion::sim {
namespace {

namespace u = uim342;

template <typename E>
constexpr std::size_t at(E e) {
  return static_cast<std::size_t>(e);
}

// A ramp with nothing to cover (time-based AC/DC with |v| <= SS) is a jump; the kinematics want
// a finite rate.
constexpr double kInstantRate = 1e12;
constexpr std::size_t kInputCount = 3;

std::int8_t kind(std::int8_t value) { return value; }  // LCM constants are not ODR-usable

}  // namespace

// Power-up and SY[1]: both are reported as POWERED_UP (the ground truth of a reboot).
void Uim342Drive::reboot(TimePoint now) {
  if (motion_.active) halt(now, 0);
  active_ = persisted_;
  // The desired values DV[2..4] and the motion mode live in RAM only.
  active_.groups[0].speed = active_.groups[0].relative = active_.groups[0].absolute = 0;
  mode_ = u::MotionMode::kJog;
  ptp_relative_ = false;
  node_id_ = active_.node_id;  // PP changes take effect here (§5.1)
  group_id_ = active_.group_id;
  selected_group_ = 0;
  in_position_ = stalled_ = locked_ = error_ = emergency_stopping_ = false;
  // The shaft stays where it is; the counter starts at 0 and the resolution stored in EEPROM
  // takes effect (§5.9, §5.7: micro-steps apply after a restart).
  shaft_base_full_steps_ = shaft_full_steps(now);
  kinematics_ = Kinematics{};  // the position counter starts at 0
  counts_base_ = 0;
  applied_micro_steps_ = std::max<std::uint16_t>(active_.driver[at(u::MotorDriver::kMicrostepping)], 1);
  motion_ = Motion{};
  origin_offset_ = relative_origin_ = 0;
  output_ = false;
  error_history_ = {};
  accepted_inputs_ = inputs_;  // the pins keep their levels
  pending_inputs_ = {};
  context_.report(kind(motionlcm::sim_report_t::POWERED_UP), 0, 0, 0);
  driver_on_ = false;
  auto_enable_at_ = kNever;
  if (active_.initial_config[at(u::InitialConfig::kAutoDriverOn)] != 0) {
    // IC[0] with the MT[3] delay (§5.2, §5.9).
    auto_enable_at_ = now + std::chrono::milliseconds(active_.driver[at(u::MotorDriver::kAutoEnableDelayMs)]);
    if (auto_enable_at_ <= now) {
      driver_on_ = true;
      auto_enable_at_ = kNever;
    }
  }
  // Edge actions with FG = 0 run once at power-up, the one matching the present level.
  for (std::size_t port = 0; port < kInputCount; ++port) {
    const auto& actions = active_.input_logic[port];
    const bool high = inputs_[port];
    const u::EdgeAction action = high ? actions.rising : actions.falling;
    if (!action.wait_for_edge)
      run_input_action(port, high ? u::Edge::kRising : u::Edge::kFalling, action.action, now, 0);
  }
}

TimePoint Uim342Drive::process(TimePoint now) {
  if (auto_enable_at_ <= now) {
    driver_on_ = true;
    auto_enable_at_ = kNever;
  }
  TimePoint next = auto_enable_at_;
  for (std::size_t port = 0; port < kInputCount; ++port) {
    PendingInput& pending = pending_inputs_[port];
    if (pending.due <= now) {
      pending.due = kNever;
      // Accepted only if the level held for the whole filter time (§4.2, §5.27 "filter"; assumed).
      if (inputs_[port] == pending.level && accepted_inputs_[port] != pending.level)
        accept_input(port, pending.level, now, pending.utime);
    }
    next = std::min(next, pending.due);
  }
  sample_home_switch(now);
  finish_if_done(now);
  if (motion_.active) next = std::min(next, kinematics_.end_time());
  if (motion_.active && home_switch_) next = std::min(next, now + std::chrono::milliseconds(1));
  return next;
}

void Uim342Drive::sample_home_switch(TimePoint now) {
  if (!home_switch_) return;
  const auto& sw = *home_switch_;
  const bool on = sw.side * (kinematics_.position_counts(now) - sw.edge) >= 0;
  const bool level = on ? sw.active_level : !sw.active_level;
  if (level != inputs_[sw.port]) set_input(sw.port, level, now, 0);
}

bool Uim342Drive::control(const motionlcm::sim_control_t& control, TimePoint now) {
  process(now);
  switch (control.action) {
    case motionlcm::sim_control_t::STALL: stall(now, control.utime); return true;
    case motionlcm::sim_control_t::ALARM:
      if (control.value <= 0 || control.value > 0xFF) return false;
      raise_alarm(static_cast<u::AlarmCode>(control.value), now, control.utime);
      return true;
    case motionlcm::sim_control_t::SET_INPUT:
      if (control.value < 1 || control.value > static_cast<int>(kInputCount)) return false;
      set_input(static_cast<std::size_t>(control.value - 1), control.level != 0, now, control.utime);
      return true;
    default: return false;  // the host handles the others (CRC_ERRORS: its frames are discarded on the wire)
  }
}

// ---- Motion ------------------------------------------------------------------------------------

Kinematics::State Uim342Drive::motion_state(TimePoint now) const {
  Kinematics::State state = kinematics_.at(now);
  if (now >= kinematics_.end_time()) {
    state.moving = false;
    state.velocity = 0;
  }
  return state;
}

double Uim342Drive::ramp_rate(std::uint32_t wire_value, double velocity) const {
  const double rate = u::acceleration_from_wire(wire_value, acceleration_unit(), velocity, active_.cut_in_speed);
  return std::isfinite(rate) && rate > 0 ? rate : kInstantRate;
}

Profile Uim342Drive::profile(const MotionGroup& group, double velocity) const {
  Profile p;
  p.velocity = velocity;
  p.acceleration = ramp_rate(group.acceleration, velocity);
  p.deceleration = ramp_rate(group.deceleration, velocity);
  p.cut_in = active_.cut_in_speed;
  return p;
}

std::int32_t Uim342Drive::speed(TimePoint now) const {
  const double v = std::round(motion_state(now).velocity);
  return static_cast<std::int32_t>(std::clamp(v, double{std::numeric_limits<std::int32_t>::min()},
                                              double{std::numeric_limits<std::int32_t>::max()}));
}

void Uim342Drive::begin(TimePoint now, std::int64_t utime) {
  const MotionGroup& desired = active_.groups[0];
  if (mode_ == u::MotionMode::kJog) {
    start_jog(now, desired.speed, desired, utime);
  } else {
    // Relative targets count from the position at BG.
    start_ptp(now, ptp_relative_ ? position(now) + desired.relative : desired.absolute, desired, utime);
  }
}

void Uim342Drive::start_ptp(TimePoint now, std::int64_t target, const MotionGroup& group, std::int64_t utime) {
  // The direction comes from target - position, not from the sign of SP (§3.2). SP = 0 would
  // never arrive: the drive holds (the manual is silent: assumed).
  const double speed_magnitude = std::abs(static_cast<double>(group.speed));
  if (speed_magnitude == 0 && target != position(now)) return;
  kinematics_.move_to(now, target + origin_offset_, profile(group, std::max(speed_magnitude, 1.0)));
  mode_ = u::MotionMode::kPtp;
  motion_ = Motion{true, true, false, target, 0};
  in_position_ = emergency_stopping_ = false;
  relative_origin_ = position(now);
  context_.report(kind(motionlcm::sim_report_t::MOTION_STARTED), utime, position(now), target);
}

void Uim342Drive::start_jog(TimePoint now, double velocity, const MotionGroup& group, std::int64_t utime) {
  kinematics_.jog(now, profile(group, velocity));
  mode_ = u::MotionMode::kJog;
  const std::int64_t here = position(now);
  motion_ = Motion{true, false, false, here, 0};
  in_position_ = emergency_stopping_ = false;
  relative_origin_ = here;
  context_.report(kind(motionlcm::sim_report_t::MOTION_STARTED), utime, here, here);
}

void Uim342Drive::stop_with(TimePoint now, double rate, bool emergency, std::int64_t utime) {
  if (!motion_.active) return;
  kinematics_.stop(now, rate, active_.cut_in_speed);
  motion_.aborted = true;  // PAIF stays 0 (§3.7, §5.12 do not say: assumed)
  motion_.ended_by_utime = utime;
  emergency_stopping_ = emergency;
  finish_if_done(now);
}

void Uim342Drive::halt(TimePoint now, std::int64_t utime) {
  if (!motion_.active) return;
  kinematics_.halt(now);
  motion_.aborted = true;
  motion_.ended_by_utime = utime;
  finish_if_done(now);
}

void Uim342Drive::set_origin(TimePoint now) {
  origin_offset_ = kinematics_.position_counts(now);
  relative_origin_ = 0;
}

void Uim342Drive::finish_if_done(TimePoint now) {
  if (!motion_.active) return;
  if (moving(now)) return;
  motion_.active = false;
  emergency_stopping_ = false;
  const std::int64_t here = position(now);
  if (motion_.ptp && !motion_.aborted) {
    in_position_ = true;
    notify(u::PositionReachedNotification{static_cast<std::int32_t>(here)});  // IE[8]
  }
  context_.report(kind(motionlcm::sim_report_t::MOTION_FINISHED), motion_.ended_by_utime, here,
                  motion_.ptp ? motion_.target : here);
}

void Uim342Drive::stall(TimePoint now, std::int64_t utime) {
  // §1.5 / IL[16]: stop and hold the shaft, or switch the driver off.
  halt(now, utime);
  if (active_.stall_behaviour == static_cast<std::uint16_t>(u::StallBehaviour::kDriverOff)) driver_on_ = false;
  stalled_ = true;  // TLIF
  notify(u::AlarmNotification{u::AlarmCode::kStall});
}

void Uim342Drive::raise_alarm(u::AlarmCode alarm, TimePoint now, std::int64_t utime) {
  switch (alarm) {
    case u::AlarmCode::kStall: stall(now, utime); return;
    case u::AlarmCode::kEmergencyStopLock:  // locked until a reboot
      locked_ = true;
      stop_with(now, static_cast<double>(active_.stop_deceleration), true, utime);
      break;
    case u::AlarmCode::kBelowLowerLimit:  // limit stops use SD (§5.17)
    case u::AlarmCode::kAboveUpperLimit:
      stop_with(now, static_cast<double>(active_.stop_deceleration), true, utime);
      break;
    default: break;  // speed, encoder, battery and unknown alarms: reported only
  }
  notify(u::AlarmNotification{alarm});
}

// ---- Inputs (§4) -------------------------------------------------------------------------------

void Uim342Drive::set_input(std::size_t port, bool level, TimePoint now, std::int64_t utime) {
  inputs_[port] = level;
  PendingInput& pending = pending_inputs_[port];
  pending.due = kNever;
  if (level == accepted_inputs_[port]) return;  // a glitch shorter than the filter time
  const std::uint16_t mode = active_.trigger[port];
  if (mode == u::kTriggerContinuous || mode == u::kTriggerOneTime) {
    accept_input(port, level, now, utime);
  } else {
    pending = PendingInput{level, now + std::chrono::milliseconds(mode), utime};
  }
}

void Uim342Drive::accept_input(std::size_t port, bool level, TimePoint now, std::int64_t utime) {
  accepted_inputs_[port] = level;
  const u::Edge edge = level ? u::Edge::kRising : u::Edge::kFalling;
  notify(u::InputEdgeNotification{static_cast<u::InputPort>(port), edge});  // IE[port]
  u::InputActions& actions = active_.input_logic[port];
  run_input_action(port, edge, (level ? actions.rising : actions.falling).action, now, utime);
  if (active_.trigger[port] == u::kTriggerOneTime) {
    // One-time mode: the port's actions are used up until IL[i] is written again (§4.2).
    actions.rising.action = actions.falling.action = u::InputAction::kNone;
  }
}

void Uim342Drive::input_emergency_stop(TimePoint now, std::int64_t utime) {
  stop_with(now, static_cast<double>(active_.stop_deceleration), true, utime);
  if (active_.initial_config[at(u::InitialConfig::kLockOnInputEstop)] != 0) {  // IC[3]
    locked_ = true;
    notify(u::AlarmNotification{u::AlarmCode::kEmergencyStopLock});
  }
}

void Uim342Drive::run_input_action(std::size_t port, u::Edge edge, u::InputAction action, TimePoint now,
                                   std::int64_t utime) {
  using A = u::InputAction;
  // Parameter group of this edge: 2 + 2 * port, +1 for the falling edge (§5.13).
  const MotionGroup group = active_.groups[2 + 2 * port + (edge == u::Edge::kFalling ? 1 : 0)];
  const double velocity_now = motion_state(now).velocity;
  // "Reversed" actions go against the present motion, negative when at rest.
  const double reverse = velocity_now < 0 ? 1.0 : -1.0;
  const bool can_move = driver_on_ && !locked_;
  const auto relative_move = [&](double direction, std::int32_t distance) {
    if (can_move)
      start_ptp(now, position(now) + static_cast<std::int64_t>(direction) * std::abs(std::int64_t{distance}), group,
                utime);
  };
  const auto decelerate = [&] { stop_with(now, ramp_rate(group.deceleration, velocity_now), false, utime); };
  switch (action) {
    case A::kNone: break;
    case A::kDriverOff:
      halt(now, utime);
      driver_on_ = false;
      break;
    case A::kEmergencyStop: input_emergency_stop(now, utime); break;
    case A::kDecelerateStop: decelerate(); break;
    case A::kOriginThenReverseRelative:
      set_origin(now);
      relative_move(reverse, group.relative);
      break;
    case A::kOriginThenEmergencyStop:
      set_origin(now);
      input_emergency_stop(now, utime);
      break;
    case A::kOriginThenDecelerateStop:
      set_origin(now);
      decelerate();
      break;
    case A::kJogReverse:
      if (can_move) start_jog(now, reverse * std::abs(static_cast<double>(group.speed)), group, utime);
      break;
    case A::kJog:
      if (can_move) start_jog(now, group.speed, group, utime);
      break;
    case A::kReverseRelative: relative_move(reverse, group.relative); break;
    case A::kRelative:
      if (can_move) start_ptp(now, position(now) + group.relative, group, utime);
      break;
    case A::kAbsolute:
      if (can_move) start_ptp(now, group.absolute, group, utime);
      break;
  }
}

}  // namespace motion::sim
