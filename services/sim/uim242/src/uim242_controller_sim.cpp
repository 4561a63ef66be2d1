#include "uim242_controller_sim.hpp"

#include <algorithm>
#include <cmath>

#include <motionlcm/sim_report_t.hpp>

namespace motion::sim {

using uim242::Frame;
using uim242::Header;
using uim242::Instruction;
using uim242::Mnemonic;

namespace {

// A speed change "at once" (basic motion, CM = 0, or a zero-length period ramp).
constexpr double kInstantRate = 1e12;
// Module byte of MDL (EN/CN #22): internal encoder, closed loop, advanced motion, 3 sensor ports.
constexpr std::uint8_t kModules = 0x73;

std::int64_t steady_us(TimePoint t) {
  return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
}

// Sensor action codes (EN/CN §8.4, §8.6) that the simulator carries out.
enum Action : std::uint8_t {
  kNoRtcn = 0x0,
  kDecelerate = 0x3,
  kEmergencyStop = 0x4,
  kResetPosition = 0x6,
  kResetDecelerate = 0xB,
  kResetEmergencyStop = 0xC,
  kOff = 0xF,
};

}  // namespace

void Uim242GatewaySim::Controller::power_up(TimePoint now) {
  kinematics_.halt(now);
  in_motion_ = false;
  pt_target_.reset();
  desired_speed_ = 0;
  velocity_mode_ = true;
  enabled_ = (icfg_ & kIcfgEna) != 0;  // auto-enable (the ENAtimer delay is not modelled)
  if (const auto& sw = setup_.home_switch) inputs_[sw->port] = sw->level_at(physical_position(now)) ? 1 : 0;
  report(std::int8_t{motionlcm::sim_report_t::POWERED_UP}, now, position(now));
}

std::vector<Frame> Uim242GatewaySim::Controller::execute(const Instruction& in, TimePoint now, bool acknowledge) {
  std::vector<Frame> out;
  const auto reply = [&](std::span<const std::int64_t> fields) {
    if (acknowledge) out.push_back(uim242::make_reply(uim242::reply_form(in, options_.org_reply), node(), fields));
  };
  const auto reply_value = [&](std::int64_t v) { reply(std::span<const std::int64_t>(&v, 1)); };
  const auto reply_desired = [&] {
    if (acknowledge) out.push_back(uim242::make_status_frame(Header::kAck, node(), desired_status()));
  };
  const bool set = in.value.has_value();
  const std::int64_t v = in.value.value_or(0);
  switch (in.mnemonic) {
    case Mnemonic::kNull: reply_desired(); break;
    case Mnemonic::kACR:
      if (set) acr_ = v;
      if (set && v <= 1) {
        reply_desired();
      } else {
        reply_value(acr_);
      }
      break;
    case Mnemonic::kBLC:
      if (set) blc_ = v;
      reply_value(blc_);
      break;
    case Mnemonic::kCUR:
      current_ = v;
      reply_desired();
      break;
    case Mnemonic::kDOU:
      if (set) {
        s34con_ &= static_cast<std::uint16_t>(~kS34P4Bits);
        set_p4(v != 0, out);
      }
      reply_value(p4_ ? 1 : 0);
      break;
    case Mnemonic::kENA:
      if (!set) {
        enabled_ = true;
        resume(now);
        reply_desired();
      } else {
        if (!uim242::is_enable_timer_query(in)) enable_timer_ = v;
        reply_value(enable_timer_);
      }
      break;
    case Mnemonic::kFBK:
      if (acknowledge) out.push_back(uim242::make_status_frame(Header::kStatus, node(), actual_status(now)));
      break;
    case Mnemonic::kICF:
      if (set) icfg_ = static_cast<std::uint16_t>(v & 0x000F);  // bits 15..4 read 0
      reply_value(icfg_);
      if (set) {  // an ICFG write reboots the controller (EN/CN §5.1); the ACK goes first (assumed)
        ++icf_writes_;
        power_up(now);
        awake_at_ = now + setup_.reboot;
      }
      break;
    case Mnemonic::kMAC:
      if (set) acceleration_ = v;
      reply(std::array<std::int64_t, 2>{(mcfg_ & kAm) ? 1 : 0, acceleration_});
      break;
    case Mnemonic::kMDE:
      if (set) deceleration_ = v;
      reply(std::array<std::int64_t, 2>{(mcfg_ & kDm) ? 1 : 0, deceleration_});
      break;
    case Mnemonic::kMCF:
      if (set) mcfg_ = static_cast<std::uint16_t>(v & ~kMcfgReadZero);
      reply_value(mcfg_);
      break;
    case Mnemonic::kMCS:
      micro_steps_ = v;
      reply_desired();
      break;
    case Mnemonic::kMDL:
      reply(std::array<std::int64_t, 5>{0x18, 0x02, setup_.max_current_tenths, kModules, setup_.firmware});
      break;
    case Mnemonic::kMMD:
      if (set) mmd_ = v;
      reply_value(mmd_);
      break;
    case Mnemonic::kMMS:
      if (set) mms_ = v;
      reply_value(mms_);
      break;
    case Mnemonic::kOFF:
      enabled_ = false;
      halt(now);
      reply_desired();
      break;
    case Mnemonic::kORG:
      if (moving(now)) return {uim242::make_error(uim242::ErrorCode::kValueError)};
      set_counter(now, v);
      displacement_origin_ = v;
      reply_value(v);
      break;
    case Mnemonic::kQEC:
      if (set && refuses_target(v - position(now))) return {uim242::make_error(uim242::ErrorCode::kValueError)};
      if (set) {
        reply_value(v);
        set_target(now, v, v - position(now));
      } else {
        reply_value(position(now));
      }
      break;
    case Mnemonic::kQER:
      if (set) encoder_lines_ = v;
      reply_value(encoder_lines_);
      break;
    case Mnemonic::kSQT:
      if (set) stall_tolerance_ = v;
      reply_value(stall_tolerance_);
      break;
    case Mnemonic::kSCF:
      if (set) write_sensor_register(*uim242::scf_write(in));
      reply(std::array<std::int64_t, 3>{(std::int64_t{s34con_} << 16) | s12con_, atconl_, atconh_});
      break;
    case Mnemonic::kSFB: reply(std::array<std::int64_t, 4>{inputs_[0], inputs_[1], inputs_[2], 0}); break;
    case Mnemonic::kSPD:
      if (!set) {
        reply_value(std::llround(kinematics_.at(now).velocity));
        break;
      }
      reply_value(v);
      desired_speed_ = v;
      if (v != 0) desired_positive_ = v > 0;
      if (v != 0) last_speed_ = std::llabs(v);
      resume(now);
      break;
    case Mnemonic::kSTG:
      if (set) {
        const auto stg = *uim242::stg_write(in);
        sampling_[static_cast<std::size_t>(stg.port)] = stg.interval;
      }
      reply(std::array<std::int64_t, 3>{sampling_[0], sampling_[1], sampling_[2]});
      break;
    case Mnemonic::kSTO: reply({}); break;  // parameter groups are stored, not simulated
    case Mnemonic::kSTP:
      if (!set) {
        reply_value(position(now) - displacement_origin_);
        break;
      }
      if (refuses_target(v)) return {uim242::make_error(uim242::ErrorCode::kValueError)};
      reply_value(v);
      if (v == 0) {
        leave_position_mode(now);
      } else {
        set_target(now, position(now) + v, v);
      }
      break;
    case Mnemonic::kADR:
    case Mnemonic::kSET:
    case Mnemonic::kBTR:
    case Mnemonic::kBDR:
    case Mnemonic::kABC:
    case Mnemonic::kREG: break;  // gateway instructions never reach a controller
  }
  return out;
}

std::vector<Frame> Uim242GatewaySim::Controller::process(TimePoint now) {
  std::vector<Frame> out;
  if (const auto& sw = setup_.home_switch; sw && in_motion_) {
    const bool level = sw->level_at(physical_position(now));
    if (level != (inputs_[sw->port] != 0)) out = set_input(static_cast<int>(sw->port) + 1, level, now);
  }
  if (!in_motion_ || moving(now)) return out;
  in_motion_ = false;
  const std::int64_t at = position(now);
  report(std::int8_t{motionlcm::sim_report_t::MOTION_FINISHED}, now, pt_target_.value_or(at));
  if (pt_target_ && at == *pt_target_ && enabled_) {
    pt_target_.reset();
    if (mcfg_ & kStpie) {
      uim242::Notification n{node(), uim242::Event::kDisplacementComplete, std::nullopt, std::nullopt};
      if (options_.cn_completion_format) {
        n.closed_loop = (mcfg_ & (1u << 11)) != 0;
        n.position = static_cast<std::int32_t>(at - displacement_origin_);
      }
      out.push_back(uim242::make_notification(n, options_.stall_message_id));
    }
  }
  return out;
}

std::vector<Frame> Uim242GatewaySim::Controller::set_input(int port, bool level, TimePoint now) {
  std::vector<Frame> out;
  const auto index = static_cast<std::size_t>(port - 1);
  if (inputs_[index] == (level ? 1 : 0)) return out;
  inputs_[index] = level ? 1 : 0;
  const std::uint16_t reg = port == 3 ? s34con_ : s12con_;
  const int shift = (port == 2 ? 8 : 0) + (level ? 4 : 0);
  const auto action = static_cast<std::uint8_t>((reg >> shift) & 0xF);
  if (action == kNoRtcn) return out;
  if (mcfg_ & (1u << (port - 1))) {
    const auto event = static_cast<uim242::Event>(0xA0 + 2 * (port - 1) + (level ? 1 : 0));
    out.push_back(uim242::make_notification({node(), event, std::nullopt, std::nullopt}, options_.stall_message_id));
  }
  sensor_action(action, now);
  return out;
}

std::vector<Frame> Uim242GatewaySim::Controller::stall(TimePoint now) {
  std::vector<Frame> out;
  const auto action = static_cast<std::uint8_t>(s34con_ >> 12);
  halt(now);  // a blocked rotor stops whatever the configured action
  sensor_action(action, now);
  if ((mcfg_ & kStlie) && action != 0) {
    out.push_back(uim242::make_notification({node(), uim242::Event::kStall, std::nullopt, std::nullopt},
                                            options_.stall_message_id));
  }
  return out;
}

uim242::Status Uim242GatewaySim::Controller::desired_status() const {
  return uim242::Status{acr_ != 0,
                        enabled_,
                        desired_positive_,
                        static_cast<std::uint8_t>(micro_steps_),
                        static_cast<std::uint8_t>(current_),
                        static_cast<std::int16_t>(desired_speed_),
                        static_cast<std::int32_t>(desired_displacement_)};
}

uim242::Status Uim242GatewaySim::Controller::actual_status(TimePoint now) const {
  const double velocity = kinematics_.at(now).velocity;
  const bool positive = velocity != 0 ? velocity > 0 : last_positive_;
  return uim242::Status{acr_ != 0,
                        enabled_,
                        positive,
                        static_cast<std::uint8_t>(micro_steps_),
                        static_cast<std::uint8_t>(current_),
                        static_cast<std::int16_t>(std::llround(velocity)),
                        static_cast<std::int32_t>(position(now) - displacement_origin_)};
}

double Uim242GatewaySim::Controller::rate(std::int64_t setting, bool period_mode, double delta) const {
  if (!(mcfg_ & kCm)) return kInstantRate;
  if (!period_mode) return static_cast<double>(std::max<std::int64_t>(setting, 1));
  if (delta <= 0) return kInstantRate;
  return delta / (static_cast<double>(std::max<std::int64_t>(setting, 1)) / 1000.0);
}

Profile Uim242GatewaySim::Controller::profile(TimePoint now, double speed) const {
  const double delta = std::abs(std::abs(speed) - std::abs(kinematics_.at(now).velocity));
  const double cut_in = (mcfg_ & kCm) ? static_cast<double>(mms_) : 0.0;
  return Profile{speed, rate(acceleration_, (mcfg_ & kAm) != 0, delta), rate(deceleration_, (mcfg_ & kDm) != 0, delta),
                 cut_in};
}

void Uim242GatewaySim::Controller::started(TimePoint now, std::int64_t target) {
  if (in_motion_) return;
  in_motion_ = true;
  report(std::int8_t{motionlcm::sim_report_t::MOTION_STARTED}, now, target);
}

void Uim242GatewaySim::Controller::brake(TimePoint now) {
  const Profile p = profile(now, 0);
  kinematics_.stop(now, p.deceleration, p.cut_in);
}

bool Uim242GatewaySim::Controller::refuses_target(std::int64_t displacement) const {
  return setup_.spd0_position_move == Uim242ControllerSetup::Spd0Move::kRefused && displacement != 0 &&
         desired_speed_ == 0;
}

void Uim242GatewaySim::Controller::resume(TimePoint now, bool new_target) {
  if (!enabled_) return;
  if (velocity_mode_) {
    if (desired_speed_ == 0) {
      if (moving(now)) brake(now);
      return;
    }
    last_positive_ = desired_speed_ > 0;
    started(now, position(now));
    kinematics_.jog(now, profile(now, static_cast<double>(desired_speed_)));
    return;
  }
  if (!pt_target_) return;
  std::int64_t speed = std::llabs(desired_speed_);
  if (speed == 0 && new_target && setup_.spd0_position_move == Uim242ControllerSetup::Spd0Move::kRunsAtLastSpeed) {
    speed = last_speed_;
  }
  if (speed == 0) {  // PT with no speed: hold (pre-loaded move) or brake, keep the target
    if (moving(now)) brake(now);
    return;
  }
  last_positive_ = *pt_target_ >= position(now);
  started(now, *pt_target_);
  kinematics_.move_to(now, *pt_target_, profile(now, static_cast<double>(speed)));
}

void Uim242GatewaySim::Controller::set_target(TimePoint now, std::int64_t target, std::int64_t displacement) {
  velocity_mode_ = false;
  displacement_origin_ = position(now);
  desired_displacement_ = displacement;
  desired_positive_ = displacement >= 0;
  pt_target_ = target;
  resume(now, true);
}

void Uim242GatewaySim::Controller::leave_position_mode(TimePoint now) {
  velocity_mode_ = true;
  desired_speed_ = 0;  // CN #44: SPD is reset to 0
  pt_target_.reset();
  if (moving(now)) {
    if (mcfg_ & kCm) {
      brake(now);
    } else {
      kinematics_.halt(now);
    }
  }
}

void Uim242GatewaySim::Controller::set_counter(TimePoint now, std::int64_t counts) {
  physical_base_ += kinematics_.position_counts(now) - counts;
  kinematics_.set_position(now, counts);
}

void Uim242GatewaySim::Controller::halt(TimePoint now) {
  kinematics_.halt(now);
  pt_target_.reset();
}

void Uim242GatewaySim::Controller::write_sensor_register(uim242::ScfWrite w) {
  switch (w.reg) {
    case uim242::SensorRegister::kS12CON: s12con_ = w.value; break;
    case uim242::SensorRegister::kS34CON: s34con_ = w.value; break;
    case uim242::SensorRegister::kATCONL: atconl_ = w.value & 0x0FFF; break;
    case uim242::SensorRegister::kATCONH: atconh_ = w.value & 0x0FFF; break;
  }
}

void Uim242GatewaySim::Controller::sensor_action(std::uint8_t action, TimePoint now) {
  const bool reset = action == kResetPosition || action == kResetDecelerate || action == kResetEmergencyStop;
  switch (action) {
    case kDecelerate:
    case kResetDecelerate:
      desired_speed_ = 0;
      velocity_mode_ = true;
      pt_target_.reset();
      brake(now);
      break;
    case kEmergencyStop:
    case kResetEmergencyStop: halt(now); break;
    case kOff:
      enabled_ = false;
      halt(now);
      break;
    default: break;
  }
  if (reset) {
    // Position (and encoder) counter := 0 where the motor is; a braking motor keeps counting
    // from there (approximation: the ramp is re-based at the reset point).
    const auto state = kinematics_.at(now);
    set_counter(now, 0);
    displacement_origin_ = 0;
    if (state.moving && action == kResetDecelerate) {
      kinematics_.jog(now, Profile{state.velocity, kInstantRate, kInstantRate, 0});
      brake(now);
    }
  }
}

void Uim242GatewaySim::Controller::set_p4(bool level, std::vector<Frame>& out) {
  if (p4_ == level) return;
  p4_ = level;
  if (mcfg_ & kP4ie) {
    const auto event = level ? uim242::Event::kP4LowToHigh : uim242::Event::kP4HighToLow;
    out.push_back(uim242::make_notification({node(), event, std::nullopt, std::nullopt}, options_.stall_message_id));
  }
}

void Uim242GatewaySim::Controller::report(std::int8_t kind, TimePoint now, std::int64_t target) {
  if (!context_.report) return;
  const std::int64_t utime = context_.utime_of ? context_.utime_of(now) : steady_us(now);
  context_.report(setup_.drive, kind, utime, position(now), target);
}

}  // namespace motion::sim
