#include "motion/sim/adam_drive_sim.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "motion/adam/commands.hpp"
#include "motion/adam/table.hpp"
#include "motion/adam/units.hpp"

namespace motion::sim {

using adam::Reg;
namespace rtu = adam::rtu;

namespace {
constexpr std::size_t kAddressSpace = 0x10000;
// A ramp time of 0 ms means "at once"; the kinematics wants a finite rate.
constexpr double kInstantRate = 1e12;
// Version registers as the manual prints them (§8.1/§8.2): "170" and "105" (decoding assumed: low
// word first).
constexpr std::uint16_t kHardwareVersion[] = {0x3731, 0x0030};
constexpr std::uint16_t kFirmwareVersion[] = {0x3031, 0x0035};
}  // namespace

AdamDriveSim::AdamDriveSim(AdamTableVariants variants)
    : regs_(kAddressSpace, 0), variants_(variants), saved_(kAddressSpace, 0) {
  power_cycle(TimePoint{});
}

void AdamDriveSim::power_cycle(TimePoint now) {
  std::fill(regs_.begin(), regs_.end(), std::uint16_t{0});
  for (const adam::RegisterInfo& r : adam::register_map()) {
    if (!r.default_value) continue;
    const auto words = adam::encode_value(r, *r.default_value);
    if (!words) continue;
    for (std::uint16_t i = 0; i < r.count(); ++i) regs_[r.first() + i] = words.value()[i];
  }
  regs_[0x0000] = kHardwareVersion[0];
  regs_[0x0001] = kHardwareVersion[1];
  regs_[0x0002] = kFirmwareVersion[0];
  regs_[0x0003] = kFirmwareVersion[1];
  regs_[adam::address(Reg::kRatedCurrent)] = 100;           // 1.00 A (the §8.10 example)
  regs_[adam::address(Reg::kCurrentPercentages)] = 0x1919;  // §8.11 example
  regs_[adam::address(Reg::kFilterFrequency)] = 425;        // §7 default "425K" does not fit 16 bits
  kinematics_ = Kinematics{};
  kinematics_.set_position(now, 0);
  target_ = 0;
  enabled_ = (reg(Reg::kProtectionBits) & static_cast<std::uint16_t>(adam::ProtectionBit::kDisabledAtPowerOn)) == 0;
  homing_ = false;
  at_home_ = true;
  alarm_ = {};
  was_moving_ = false;
}

std::int32_t AdamDriveSim::reg32(Reg r) const {
  return adam::decode32_signed(regs_[adam::address(r)], regs_[adam::address(r) + 1U]);
}

adam::DriveStatus AdamDriveSim::status(TimePoint now) const {
  adam::DriveStatus s;
  const auto state = kinematics_.at(now);
  s.inputs = inputs_;
  if (state.moving) {
    // Phase from the speed's trend over the next millisecond (§8.4 bits 9…8, assumed: 01 up, 11
    // cruise, 10 down).
    const double later = std::abs(kinematics_.at(now + std::chrono::milliseconds(1)).velocity);
    const double speed = std::abs(state.velocity);
    s.phase = later > speed + 1e-9   ? adam::MotionPhase::kAccelerating
              : later < speed - 1e-9 ? adam::MotionPhase::kDecelerating
                                     : adam::MotionPhase::kCruising;
  }
  s.in_position = !state.moving;
  s.at_home = at_home_ && !state.moving;
  return s;
}

void AdamDriveSim::refresh(TimePoint now) {
  const auto pos = adam::encode32(static_cast<std::int32_t>(kinematics_.position_counts(now)));
  regs_[adam::address(Reg::kPosition)] = pos[0];
  regs_[adam::address(Reg::kPosition) + 1U] = pos[1];
  const std::uint32_t raw = adam::encode_status(status(now));
  regs_[adam::address(Reg::kStatus)] = static_cast<std::uint16_t>(raw & 0xFFFFU);
  regs_[adam::address(Reg::kStatus) + 1U] = static_cast<std::uint16_t>(raw >> 16);
  const double pps = kinematics_.at(now).velocity;
  const double rpm =
      adam::pps_to_rpm(pps, std::max<std::uint32_t>(1, static_cast<std::uint32_t>(reg32(Reg::kSubdivision))));
  regs_[adam::address(Reg::kSpeedRpm)] = adam::encode16(static_cast<std::int16_t>(std::lround(rpm)));
  const auto centi = adam::encode32(static_cast<std::int32_t>(std::lround(rpm * 100)));
  regs_[adam::address(Reg::kSpeedCentiRpm)] = centi[0];
  regs_[adam::address(Reg::kSpeedCentiRpm) + 1U] = centi[1];
  regs_[adam::address(Reg::kAlarm)] = adam::encode_alarms(alarm_);
}

std::optional<rtu::ExceptionCode> AdamDriveSim::read(std::uint16_t start, std::span<std::uint16_t> out) {
  settle(now_);
  refresh(now_);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = regs_[(start + i) % kAddressSpace];
  return std::nullopt;
}

std::optional<rtu::ExceptionCode> AdamDriveSim::write(std::uint16_t start, std::span<const std::uint16_t> values) {
  settle(now_);
  for (std::size_t i = 0; i < values.size(); ++i) regs_[(start + i) % kAddressSpace] = values[i];
  // Act once per written entry, on its first register (32-bit commands need both halves, which
  // the access rules guarantee).
  for (std::size_t i = 0; i < values.size(); ++i) {
    const auto address = static_cast<std::uint16_t>(start + i);
    if (adam::find_register(address) != nullptr) act(address, now_);
  }
  return std::nullopt;
}

bool AdamDriveSim::may_move() const { return enabled_ && !alarm_.active(); }

double AdamDriveSim::pps_of_rpm(double rpm) const {
  return adam::rpm_to_pps(rpm, static_cast<std::uint32_t>(std::max(reg32(Reg::kSubdivision), 1)));
}

Profile AdamDriveSim::profile(double speed_rpm) const {
  // Ramps are TIMES from the start speed to the target speed (§8.42/§8.43), so the rates follow
  // from the speeds; if the target is below the start speed the drive runs at the start speed.
  const double start_rpm = reg(Reg::kStartSpeed);
  const double target_rpm = std::max(speed_rpm, start_rpm);
  const double rise = std::max(target_rpm - start_rpm, 0.0);
  const double accel_ms = reg(Reg::kAccelerationTime);
  const double decel_ms = reg(Reg::kDecelerationTime);
  Profile p;
  p.velocity = pps_of_rpm(target_rpm);
  p.cut_in = pps_of_rpm(start_rpm);
  p.acceleration = accel_ms > 0 && rise > 0 ? pps_of_rpm(rise) / (accel_ms / 1000.0) : kInstantRate;
  p.deceleration = decel_ms > 0 && rise > 0 ? pps_of_rpm(rise) / (decel_ms / 1000.0) : kInstantRate;
  return p;
}

void AdamDriveSim::move_to(std::int64_t target, TimePoint now, double speed_rpm) {
  target_ = target;
  if (kinematics_.position_counts(now) == target && !kinematics_.moving(now)) return;
  kinematics_.move_to(now, target, profile(speed_rpm));
  at_home_ = false;
  motion_started_ = true;
  was_moving_ = true;
}

void AdamDriveSim::execute_table_entry(TimePoint now) {
  const auto command = adam::decode_table_execute(reg(Reg::kTableExecute));
  if (!command) return;
  const std::uint16_t pointer = reg(Reg::kTablePointer);
  const std::uint32_t at = adam::table_entry_address(reg(Reg::kTableStart), pointer);
  if (at + 1 >= kAddressSpace) return;
  // Table data from flash when the drive uses only saved data (variant table_needs_save).
  const auto& data = variants_.needs_save ? saved_ : regs_;
  const std::int32_t value = adam::decode32_signed(data[at], data[at + 1]);
  // The speed from the register motion reads (variant table_speed_register).
  const double speed = variants_.speed == AdamTableVariants::Speed::kTarget00d8
                           ? reg32(Reg::kTargetSpeed) / 100.0
                           : static_cast<double>(reg(Reg::kWorkingSpeed));
  const std::int64_t here = kinematics_.position_counts(now);
  move_to(command->kind == adam::TableEntryKind::kAbsolute ? value : here + value, now, std::abs(speed));
  const int step = command->arithmetic == adam::PointerArithmetic::kAdd ? command->step : -int{command->step};
  regs_[adam::address(Reg::kTablePointer)] =
      static_cast<std::uint16_t>(std::clamp(pointer + step, 0, int{adam::kMaxTablePointer}));
}

void AdamDriveSim::act(std::uint16_t address, TimePoint now) {
  const bool idle = !kinematics_.moving(now);
  const double speed_rpm = std::abs(reg32(Reg::kTargetSpeed)) / 100.0;
  const auto stop = [&](bool immediate) {
    homing_ = false;
    if (immediate)
      kinematics_.halt(now);
    else
      kinematics_.stop(now, profile(speed_rpm).deceleration, profile(speed_rpm).cut_in);
  };
  switch (static_cast<Reg>(address)) {
    case Reg::kWorkingSpeed:  // variant `shared` (§8.44, §8.64 do not say): 0x009A and 0x00D8 are one setpoint
    {
      if (variants_.speed != AdamTableVariants::Speed::kShared) break;
      const auto centi = adam::encode32(static_cast<std::int32_t>(reg(Reg::kWorkingSpeed)) * 100);
      regs_[adam::address(Reg::kTargetSpeed)] = centi[0];
      regs_[adam::address(Reg::kTargetSpeed) + 1U] = centi[1];
      break;
    }
    case Reg::kTargetSpeed:
      if (variants_.speed != AdamTableVariants::Speed::kShared) break;
      regs_[adam::address(Reg::kWorkingSpeed)] =
          static_cast<std::uint16_t>(std::min<long>(std::lround(speed_rpm), 0xFFFF));
      break;
    case Reg::kVelocityCommand: {
      const auto word = reg(Reg::kVelocityCommand);
      if (word == static_cast<std::uint16_t>(adam::VelocityCommand::kRampedStop))
        stop(false);
      else if (word == static_cast<std::uint16_t>(adam::VelocityCommand::kEmergencyStop))
        stop(true);
      else if (may_move()) {
        Profile p = profile(reg(Reg::kWorkingSpeed));
        if (word == static_cast<std::uint16_t>(adam::VelocityCommand::kRunReverse)) p.velocity = -p.velocity;
        kinematics_.jog(now, p);
        at_home_ = false;
        motion_started_ = true;
        was_moving_ = true;
      }
      break;
    }
    case Reg::kJogCommand: {
      const adam::JogCommand jog = adam::decode_jog(reg(Reg::kJogCommand));
      if (!jog.run) {
        stop(jog.stop == adam::StopMethod::kImmediate);
      } else if (may_move()) {
        Profile p = profile(jog.speed_rpm);
        if (jog.direction == adam::Rotation::kCcw) p.velocity = -p.velocity;
        kinematics_.jog(now, p);
        at_home_ = false;
        motion_started_ = true;
        was_moving_ = true;
      }
      break;
    }
    case Reg::kHomingCommand: {
      if (!may_move() || !idle) break;
      const adam::HomingCommand home = adam::decode_homing(reg(Reg::kHomingCommand));
      homing_ = true;
      move_to(0, now, home.speed_rpm);  // assumed: the switch is where the drive powered up
      if (!was_moving_) {               // already on the switch
        homing_ = false;
        at_home_ = true;
      }
      break;
    }
    case Reg::kRelativeMove:
      if (idle && may_move()) move_to(kinematics_.position_counts(now) + reg32(Reg::kRelativeMove), now, speed_rpm);
      break;
    case Reg::kAbsoluteMove:
      if (idle && may_move()) move_to(reg32(Reg::kAbsoluteMove), now, speed_rpm);
      break;
    case Reg::kRelativeMovePreempt:
      if (may_move()) move_to(kinematics_.position_counts(now) + reg32(Reg::kRelativeMovePreempt), now, speed_rpm);
      break;
    case Reg::kAbsoluteMovePreempt:
      if (may_move()) move_to(reg32(Reg::kAbsoluteMovePreempt), now, speed_rpm);
      break;
    case Reg::kTableExecute:
      if (idle && may_move()) execute_table_entry(now);
      break;
    case Reg::kPresetPosition:
      if (idle) {
        kinematics_.set_position(now, reg32(Reg::kPresetPosition));
        target_ = reg32(Reg::kPresetPosition);
      }
      break;
    case Reg::kEnableCommand: {
      const auto word = reg(Reg::kEnableCommand);
      if (word == static_cast<std::uint16_t>(adam::EnableCommand::kRestart)) {
        power_cycle(now);
      } else {
        enabled_ = word == static_cast<std::uint16_t>(adam::EnableCommand::kEnable);
        if (!enabled_) kinematics_.halt(now);  // released: the motor is free
      }
      break;
    }
    case Reg::kOutputsOn:
      regs_[adam::address(Reg::kOutputState)] |= static_cast<std::uint16_t>(reg(Reg::kOutputsOn) & 0xFF);
      break;
    case Reg::kOutputsOff:
      regs_[adam::address(Reg::kOutputState)] &= static_cast<std::uint16_t>(~reg(Reg::kOutputsOff) & 0xFF);
      break;
    case Reg::kClearAlarm:
      if (alarm_.active()) {  // the current alarm moves into the history (§8.52 fields; the shift is assumed)
        alarm_.history = {alarm_.current, alarm_.history[0], alarm_.history[1]};
        alarm_.current = adam::AlarmCode::kNone;
      }
      break;
    case Reg::kSaveCommand:
      if (reg(Reg::kSaveCommand) == static_cast<std::uint16_t>(adam::SaveCommand::kRestoreFactory)) power_cycle(now);
      if (reg(Reg::kSaveCommand) ==
          static_cast<std::uint16_t>(adam::SaveCommand::kSave)) {  // §8.69: a flash erase, 0.1 s
        saved_ = regs_;
        ++saves_;
        busy_until_ = now + variants_.save_time;
      }
      break;
    default: break;
  }
}

bool AdamDriveSim::settle(TimePoint now) {
  if (!was_moving_ || kinematics_.moving(now) || kinematics_.jogging()) return false;
  was_moving_ = false;
  if (homing_) {
    homing_ = false;
    kinematics_.set_position(now, 0);  // not stated in §8.48 (assumed): position 0 at home, X15 = 1
    target_ = 0;
    at_home_ = true;
  }
  return true;
}

void AdamDriveSim::inject_alarm(adam::AlarmCode code, TimePoint now) {
  alarm_.current = code;
  homing_ = false;
  kinematics_.halt(now);  // assumed (the manual does not say): the drive stops on an alarm
}

void AdamDriveSim::set_input(unsigned index, bool level, TimePoint now) {
  if (index >= 8) return;
  const auto bit = static_cast<std::uint8_t>(1U << index);
  inputs_ = level ? static_cast<std::uint8_t>(inputs_ | bit) : static_cast<std::uint8_t>(inputs_ & ~bit);
  // The configured home input going active during homing is the switch (0x009C low byte).
  const adam::InputPair assignment = adam::decode_input_pair(reg(Reg::kEnableHomeInputs));
  if (homing_ && level && assignment.low.enabled && assignment.low.input == index) {
    kinematics_.halt(now);
    settle(now);
  }
}

}  // namespace motion::sim
