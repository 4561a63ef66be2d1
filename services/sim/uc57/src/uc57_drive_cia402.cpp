// Uc57DriveSim (uc57_drive.hpp): CiA 402 device control (UC57 manual §4.2.1/§4.2.2), profile
// position (§4.2.4), profile velocity (§4.2.5), homing (§4.2.6), faults (§6), status and I/O.
#include "motion/sim/uc57_drive.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "motion/cia402/modes.hpp"
#include "motion/cia402/uc57_homing.hpp"
#include "motion/cia402/words.hpp"
#include "uc57_drive_detail.hpp"

namespace motion::sim {
namespace {

namespace od = cia402::uc57;
namespace idx = cia402::uc57::index;
using cia402::ControlBit;
using cia402::State;
using cia402::StatusBit;
using namespace uc57_detail;  // NOLINT(google-build-using-namespace)

}  // namespace

// ------------------------------------------------------------------------------------------------
// CiA 402 device control

void Uc57DriveSim::on_controlword(std::uint16_t controlword) {
  const std::uint16_t previous = controlword_;
  controlword_ = controlword;
  if (state_ == State::kFault && cia402::rising_edge(previous, controlword, ControlBit::kFaultReset)) {
    try_fault_reset();
  } else {
    // "3+4": 0x0F in Ready to switch on goes on to Operation enabled; the fault-reset edge counts once.
    std::uint16_t edge_base = previous;
    for (int step = 0; step < 3; ++step) {
      const auto transition = cia402::find_command_transition(state_, edge_base, controlword);
      if (!transition || transition->trigger == cia402::Trigger{cia402::Command::kFaultReset}) break;
      enter_state(transition->to);
      edge_base = controlword;
    }
  }
  if (state_ == State::kOperationEnabled) on_operation_mode_bits(previous, controlword);
}

void Uc57DriveSim::enter_state(State next) {
  const State before = state_;
  state_ = next;
  if (before != State::kOperationEnabled || next == State::kOperationEnabled) return;
  if (motor_energised(next)) {  // quick stop, disable operation: ramp down with 6084h
    stop_motion(stop_deceleration(idx::kProfileDeceleration));
  } else if (motion_.active || activity_ != Activity::kIdle) {
    kinematics_.halt(now_);  // output stage off: the motor stops where it is
    settle();
  }
  buffered_set_point_.reset();
  set_point_acknowledged_ = false;
}

void Uc57DriveSim::on_operation_mode_bits(std::uint16_t previous, std::uint16_t controlword) {
  const bool halt = cia402::is_set(controlword, ControlBit::kHalt);
  const bool halt_raised = cia402::rising_edge(previous, controlword, ControlBit::kHalt);
  const bool new_set_point = cia402::rising_edge(previous, controlword, ControlBit::kNewSetPoint);
  const bool set_point_released = cia402::rising_edge(controlword, previous, ControlBit::kNewSetPoint);
  switch (mode()) {
    case static_cast<std::int8_t>(cia402::ModeOfOperation::kProfilePosition):
      if (halt_raised) stop_motion(stop_deceleration(idx::kProfileDeceleration));
      if (new_set_point && !halt) accept_set_point(cia402::is_set(controlword, ControlBit::kChangeSetImmediately));
      if (set_point_released && !buffered_set_point_) set_point_acknowledged_ = false;
      break;
    case static_cast<std::int8_t>(cia402::ModeOfOperation::kProfileVelocity): update_profile_velocity(); break;
    case static_cast<std::int8_t>(cia402::ModeOfOperation::kHoming):
      if (new_set_point && !halt) {
        start_homing();
      } else if (activity_ == Activity::kHoming && (halt_raised || set_point_released)) {
        // Halt or bit 4 1 -> 0 interrupts homing (manual §4.2.6).
        homing_legs_.clear();
        stop_motion(stop_deceleration(idx::kHomingAcceleration));
        finish_homing(false);
      }
      break;
    default: break;
  }
}

std::int8_t Uc57DriveSim::mode() const { return static_cast<std::int8_t>(stored(idx::kModesOfOperationDisplay, 0)); }

std::uint32_t Uc57DriveSim::pulses_per_rev() const {
  return od::pulses_per_revolution(static_cast<std::uint16_t>(stored(idx::kMicrostepping, 0)))
      .value_or(od::kDefaultPulsesPerRevolution);
}

// A trapezoid at `speed` (pulses/s) whose ramps come from two ramp objects; ramps in milliseconds
// span the change from the start speed to `speed` (C-02).
Profile Uc57DriveSim::ramp_profile(double speed, std::uint16_t accel_index, std::uint16_t decel_index,
                                   double start_speed) const {
  const double magnitude = std::abs(speed);
  // A stop from the current speed ramps across that speed.
  const double change =
      std::max(magnitude > 0 ? magnitude - start_speed : std::abs(kinematics_.at(now_).velocity), 0.0);
  const auto rate = [&](std::uint16_t index) {
    const double a = od::ramp_acceleration(options_.ramp_unit, stored(index, 0), change, pulses_per_rev());
    return std::isfinite(a) && a > 0 ? a : kStepAcceleration;
  };
  return {speed, rate(accel_index), rate(decel_index), std::min(start_speed, magnitude)};
}

// The deceleration of a stop with the ramp object `index`. A stop of a running profile whose ramps
// come from that object brakes at the profile's own deceleration: the ramp's setting spans the
// change between the start speed and the commanded speed (§4.2.4), not the change from the present
// speed to rest, so a halt never brakes more gently than the profile would have (a slow move halted
// near its target otherwise ran the whole ramp time from the present speed and passed the target).
// With nothing of that object running, the ramp spans the present speed.
double Uc57DriveSim::stop_deceleration(std::uint16_t index) const {
  if (activity_ != Activity::kIdle && running_.decel_index == index) return running_.profile.deceleration;
  return ramp_profile(0, index, index, 0).deceleration;
}

void Uc57DriveSim::run_profile(const Profile& profile, std::uint16_t decel_index, std::optional<std::int64_t> target) {
  running_ = {profile, decel_index};
  if (target) {
    kinematics_.move_to(now_, *target, profile);
  } else {
    kinematics_.jog(now_, profile);
  }
}

void Uc57DriveSim::begin_motion(std::int64_t target) {
  if (!motion_.active) {
    motion_.active = true;
    motion_.start = now_;
    motion_.start_utime = frame_utime_;
    if (context_.report) context_.report(motionlcm::sim_report_t::MOTION_STARTED, frame_utime_, position(now_), target);
  }
  motion_.target = target;
}

std::int64_t Uc57DriveSim::utime_at(TimePoint t) const {
  return motion_.start_utime + std::chrono::duration_cast<std::chrono::microseconds>(t - motion_.start).count();
}

bool Uc57DriveSim::motion_done() const { return !running(now_); }

// Kinematics reports the end instant itself as moving; the drive has arrived then.
bool Uc57DriveSim::running(TimePoint now) const {
  if (kinematics_.jogging()) return true;
  const TimePoint end = kinematics_.end_time();
  return end == kNever ? kinematics_.at(now).moving : now < end;
}

// Motion-end bookkeeping: PP arrival (target reached, in position, the buffered set-point),
// homing legs, the end of a stop.
void Uc57DriveSim::settle() {
  for (int guard = 0; guard < 8 && activity_ != Activity::kIdle && motion_done(); ++guard) {
    const TimePoint end = kinematics_.end_time() == kNever ? now_ : kinematics_.end_time();
    if (activity_ == Activity::kHoming && !homing_legs_.empty()) {
      start_homing_leg();
      continue;
    }
    if (activity_ == Activity::kHoming) finish_homing(homing_succeeds_);
    const Activity finished = activity_;
    activity_ = Activity::kIdle;
    target_reached_ = true;
    in_position_ = finished == Activity::kProfilePosition && position(now_) == motion_.target;
    if (motion_.active && context_.report) {
      context_.report(motionlcm::sim_report_t::MOTION_FINISHED, utime_at(end), position(now_), motion_.target);
    }
    const std::int64_t next_utime = utime_at(end);
    motion_ = {};
    if (buffered_set_point_ && state_ == State::kOperationEnabled) {
      SetPoint next = *buffered_set_point_;
      buffered_set_point_.reset();
      next.utime = next_utime;
      start_profile_position(next);
      if (!cia402::is_set(controlword_, ControlBit::kNewSetPoint)) set_point_acknowledged_ = false;
    }
  }
}

void Uc57DriveSim::stop_motion(double deceleration) {
  if (activity_ == Activity::kIdle) return;
  // Like the trapezoid's end (§4.2.4), the braking ends at the start speed with a step to rest.
  kinematics_.stop(now_, deceleration, running_.profile.cut_in);
  if (activity_ != Activity::kHoming) activity_ = Activity::kStopping;
  buffered_set_point_.reset();
  settle();
}

// --- profile position (manual §4.2.4, §7 MC_MOVABS/MC_MOVREL) ---

void Uc57DriveSim::accept_set_point(bool change_immediately) {
  SetPoint set_point{stored(idx::kTargetPosition, 0), cia402::is_set(controlword_, ControlBit::kRelative),
                     frame_utime_};
  if (activity_ == Activity::kProfilePosition && !change_immediately) {
    if (buffered_set_point_) return;  // one-deep buffer full: the edge is ignored
    buffered_set_point_ = set_point;
  } else {
    start_profile_position(set_point);
  }
  set_point_acknowledged_ = true;
}

void Uc57DriveSim::start_profile_position(const SetPoint& set_point) {
  frame_utime_ = set_point.utime;
  const std::int64_t target = set_point.relative ? position(now_) + set_point.target : set_point.target;
  const double start_speed =
      od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kStartSpeed, 0)), pulses_per_rev());
  const double speed =
      od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kProfileVelocity, 0)), pulses_per_rev());
  run_profile(ramp_profile(speed, idx::kProfileAcceleration, idx::kProfileDeceleration, start_speed),
              idx::kProfileDeceleration, target);
  activity_ = Activity::kProfilePosition;
  target_reached_ = false;
  in_position_ = false;
  motion_.active = false;  // a replaced set-point reports a new start
  begin_motion(target);
}

// --- profile velocity (manual §4.2.5) ---

void Uc57DriveSim::update_profile_velocity() {
  const bool runs = state_ == State::kOperationEnabled &&
                    mode() == static_cast<std::int8_t>(cia402::ModeOfOperation::kProfileVelocity) &&
                    !cia402::is_set(controlword_, ControlBit::kHalt);
  const double velocity =
      od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kTargetVelocity, 0)), pulses_per_rev());
  if (!runs || velocity == 0) {
    if (activity_ == Activity::kProfileVelocity) { stop_motion(stop_deceleration(idx::kProfileDeceleration)); }
    return;
  }
  if (activity_ != Activity::kIdle && activity_ != Activity::kProfileVelocity && activity_ != Activity::kStopping)
    return;
  const double start_speed =
      od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kStartSpeed, 0)), pulses_per_rev());
  run_profile(ramp_profile(velocity, idx::kProfileAcceleration, idx::kProfileDeceleration, start_speed),
              idx::kProfileDeceleration, std::nullopt);
  activity_ = Activity::kProfileVelocity;
  target_reached_ = false;
  begin_motion(velocity > 0 ? std::numeric_limits<std::int32_t>::max() : std::numeric_limits<std::int32_t>::min());
}

// --- homing (manual §4.2.6) ---

void Uc57DriveSim::start_homing() {
  homed_ = homing_attained_ = homing_finished_ = false;
  homing_legs_.clear();
  const auto* method = od::find_homing_method(static_cast<std::uint8_t>(stored(idx::kHomingMethod, 0)));
  if (method == nullptr) {  // homing error, no motion
    homing_finished_ = true;
    return;
  }
  const auto ppr = pulses_per_rev();
  const double fast = od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kHomingSpeeds, 1)), ppr);
  const double slow = od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kHomingSpeeds, 2)), ppr);
  const double accel = ramp_profile(fast, idx::kHomingAcceleration, idx::kHomingAcceleration, 0).acceleration;
  const auto dir = static_cast<std::int64_t>(method->search_direction);
  const std::int64_t signal = method->home_signal == od::HomeSignal::kOrigin          ? options_.origin_position
                              : method->home_signal == od::HomeSignal::kPositiveLimit ? options_.positive_limit
                                                                                      : options_.negative_limit;
  const std::int64_t limit = dir > 0 ? options_.positive_limit : options_.negative_limit;
  const auto physical = static_cast<std::int64_t>(std::llround(kinematics_.at(now_).position + position_shift_));
  // The switch is met at full speed; the drive then decelerates past it.
  const auto overshoot = static_cast<std::int64_t>(std::ceil(fast * fast / (2 * accel)));
  const bool ahead = (signal - physical) * dir >= 0;
  homing_succeeds_ = true;
  if (!ahead && method->on_limit == od::LimitReaction::kStopFailed) {
    homing_legs_.push_back({limit, fast});
    homing_succeeds_ = false;
  } else if (!ahead) {
    // Limit in the search direction: turn round, pass the switch, come back slowly.
    homing_legs_.push_back({limit, fast});
    homing_legs_.push_back({signal - dir * (overshoot + options_.homing_backoff), fast});
    homing_legs_.push_back({signal, slow});
  } else if (method->backs_off_and_locates_slowly) {
    homing_legs_.push_back({signal + dir * overshoot, fast});
    homing_legs_.push_back({signal - dir * options_.homing_backoff, fast});
    homing_legs_.push_back({signal, slow});
  } else {
    homing_legs_.push_back({signal, fast});  // 41/42: stop at once on the switch
  }
  activity_ = Activity::kHoming;
  target_reached_ = false;
  begin_motion(signal);
  start_homing_leg();
}

void Uc57DriveSim::start_homing_leg() {
  const HomingLeg leg = homing_legs_.front();
  homing_legs_.pop_front();
  const auto target =
      static_cast<std::int64_t>(std::llround(static_cast<double>(leg.physical_target) - position_shift_));
  run_profile(ramp_profile(leg.speed, idx::kHomingAcceleration, idx::kHomingAcceleration, 0), idx::kHomingAcceleration,
              target);
}

void Uc57DriveSim::finish_homing(bool succeeded) {
  homing_finished_ = true;
  homing_attained_ = succeeded;
  homed_ = succeeded;
  if (!succeeded) return;
  // 6064h = -607Ch at the mechanical home (CiA 402 style).
  const std::int64_t home_value = -stored(idx::kHomeOffset, 0);
  position_shift_ += static_cast<double>(position(now_) - home_value);
  kinematics_.set_position(now_, home_value);
  motion_.target = home_value;
}

// --- faults (manual §6, §4.2.1) ---

void Uc57DriveSim::fault(const canopen::Emergency& emergency) {
  if (activity_ != Activity::kIdle) {
    homing_legs_.clear();
    kinematics_.halt(now_);
    settle();
  }
  buffered_set_point_.reset();
  set_point_acknowledged_ = false;
  for (const auto event : {cia402::DriveEvent::kFaultDetected, cia402::DriveEvent::kFaultReactionDone}) {
    if (const auto t = cia402::find_event_transition(state_, event)) state_ = t->to;
  }
  send_emcy(emergency);
}

void Uc57DriveSim::try_fault_reset() {
  std::uint16_t latched = 0;
  for (unsigned code = 1; code <= kAlarms.size(); ++code) {
    if (kAlarms[code - 1].needs_power_cycle) latched = static_cast<std::uint16_t>(latched | (1U << (code - 1)));
  }
  fault_bits_ &= latched;  // auto-reset alarms clear; power-off alarms stay (manual §6; the reset rule is assumed)
  if (fault_bits_ != 0) return;
  stalled_ = false;
  if (state_ == State::kFault) {
    if (const auto t =
            cia402::find_command_transition(State::kFault, 0, cia402::controlword_for(cia402::Command::kFaultReset))) {
      state_ = t->to;
    }
  }
  send_emcy({});  // error reset
}

std::uint8_t Uc57DriveSim::error_register() const {
  std::uint8_t reg = 0;
  for (unsigned code = 1; code <= kAlarms.size(); ++code) {
    if ((fault_bits_ & (1U << (code - 1))) != 0)
      reg = static_cast<std::uint8_t>(reg | kAlarms[code - 1].error_register);
  }
  if (stalled_) reg = static_cast<std::uint8_t>(reg | kStallErrorRegister);
  return reg;
}

// ------------------------------------------------------------------------------------------------
// Status and I/O

std::int64_t Uc57DriveSim::position(TimePoint now) const { return kinematics_.position_counts(now); }
std::int64_t Uc57DriveSim::physical_position(TimePoint now) const {
  return std::llround(kinematics_.at(now).position + position_shift_);
}

std::uint16_t Uc57DriveSim::statusword(TimePoint now) const {
  std::uint16_t bits = 0;
  const auto set = [&bits](StatusBit bit, bool on) {
    if (on) bits = static_cast<std::uint16_t>(bits | cia402::mask(bit));
  };
  auto motion = kinematics_.at(now);
  motion.moving = running(now);
  if (!motion.moving) motion.velocity = 0;
  set(StatusBit::kAlarm, fault_bits_ != 0 || stalled_);
  set(StatusBit::kHomingDone, homed_);
  set(StatusBit::kNewSetPointEcho, cia402::is_set(controlword_, ControlBit::kNewSetPoint));
  set(StatusBit::kMotorEnabled, motor_energised(state_) && state_ != State::kFaultReactionActive);
  set(StatusBit::kMotorRunning, motion.moving);
  if (state_ == State::kOperationEnabled) {
    switch (mode()) {
      case static_cast<std::int8_t>(cia402::ModeOfOperation::kProfilePosition):
        set(StatusBit::kTargetReached, target_reached_ && !motion.moving);
        set(StatusBit::kSetPointAcknowledge, set_point_acknowledged_);
        set(StatusBit::kInPosition, in_position_);
        break;
      case static_cast<std::int8_t>(cia402::ModeOfOperation::kProfileVelocity): {
        const double target =
            od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kTargetVelocity, 0)), pulses_per_rev());
        const bool halted = cia402::is_set(controlword_, ControlBit::kHalt);
        set(StatusBit::kTargetReached, halted ? !motion.moving : std::abs(motion.velocity - target) < 1e-6);
        set(cia402::kSpeedIsZero, !motion.moving);
        break;
      }
      case static_cast<std::int8_t>(cia402::ModeOfOperation::kHoming):
        set(StatusBit::kTargetReached, homing_finished_ && !motion.moving);
        set(cia402::kHomingAttained, homing_attained_);
        break;
      default: break;
    }
  }
  return cia402::compose_statusword(state_ == State::kStart ? State::kNotReadyToSwitchOn : state_, bits);
}

std::uint8_t Uc57DriveSim::input_levels() const {
  const double physical = kinematics_.at(now_).position + position_shift_;
  const bool positive_limit = forced_inputs_[0] || physical >= static_cast<double>(options_.positive_limit);
  const bool origin = forced_inputs_[1] || std::abs(physical - static_cast<double>(options_.origin_position)) <=
                                               static_cast<double>(options_.origin_half_width);
  const bool negative_limit = forced_inputs_[2] || physical <= static_cast<double>(options_.negative_limit);
  return static_cast<std::uint8_t>((positive_limit ? 1 : 0) | (origin ? 2 : 0) | (negative_limit ? 4 : 0));
}

// 60FDh: bit 0 negative limit (X2 = IN3), bit 1 positive limit (X0 = IN1), bit 2 origin (X1 = IN2),
// after the polarity of 2030h:01.
std::uint32_t Uc57DriveSim::digital_inputs() const {
  const auto active = static_cast<std::uint8_t>(input_levels() ^ (stored(idx::kIoConfiguration, 0x01) & 0x07));
  return ((active & 4U) != 0 ? 1U : 0U) | ((active & 1U) != 0 ? 2U : 0U) | ((active & 2U) != 0 ? 4U : 0U);
}

// 2004h: Y0/Y1 per their function (2030h:0D/0E; 0 = the default function: Y0 alarm, Y1 driver
// status) and polarity (2030h:0C).
std::uint16_t Uc57DriveSim::output_states() const {
  const auto output = [this](std::uint8_t function_sub, std::int64_t default_function) {
    std::int64_t function = stored(idx::kIoConfiguration, function_sub);
    if (function == 0) function = default_function;
    switch (function) {
      case 1: return fault_bits_ != 0 || stalled_ || state_ == State::kFault;
      case 2: return motor_energised(state_);
      case 3: return homed_;
      case 4: return in_position_;
      case 5: return true;
      default: return false;
    }
  };
  const auto levels = static_cast<std::uint16_t>((output(0x0D, 1) ? 1 : 0) | (output(0x0E, 2) ? 2 : 0));
  return static_cast<std::uint16_t>(levels ^ (stored(idx::kIoConfiguration, 0x0C) & 0x03));
}

}  // namespace motion::sim
