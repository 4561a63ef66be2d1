#include "motion/sim/uim242_gateway_sim.hpp"

#include "motion/config/sim_variants.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <motionlcm/sim_report_t.hpp>

#include "motion/sim/kinematics.hpp"

namespace motion::sim {

using uim242::Frame;
using uim242::Header;
using uim242::Instruction;
using uim242::Mnemonic;

namespace {

// MCFG bits (EN/CN §5.4).
constexpr std::uint16_t kMcfgReadZero = 0x1080;  // bits 12 and 7 are unimplemented
constexpr std::uint16_t kCm = 1u << 10;
constexpr std::uint16_t kAm = 1u << 9;
constexpr std::uint16_t kDm = 1u << 8;
constexpr std::uint16_t kStlie = 1u << 6;
constexpr std::uint16_t kStpie = 1u << 4;
constexpr std::uint16_t kP4ie = 1u << 3;
constexpr std::uint16_t kIcfgEna = 1u << 0;
constexpr std::uint16_t kS34P4Bits = 0x0F00;  // P4LVL and P4EVENT, cleared by DOU (#7)

// A speed change "at once" (basic motion, CM = 0, or a zero-length period ramp).
constexpr double kInstantRate = 1e12;
// Module byte of MDL (EN/CN #22): internal encoder, closed loop, advanced motion, 3 sensor ports.
constexpr std::uint8_t kModules = 0x73;
// CN §7.8 factory group STO0: acceleration, deceleration, MMS, MMD (EN #43 gives other values).
constexpr std::int64_t kFactoryRamp = 250;
constexpr std::int64_t kFactoryJump = 1000;
// The speed a position move loaded at desired speed 0 runs at under runs_at_last_speed when no
// non-zero SPD was ever set (assumed).
constexpr std::int64_t kAssumedLastSpeed = 1000;

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

// One UIM242: registers, counters and motion. Returns the frames it sends; reports through the
// gateway's context.
class Uim242GatewaySim::Controller {
 public:
  Controller(Uim242ControllerSetup setup, const Uim242SimOptions& options, const Uim242SimContext& context)
      : setup_(std::move(setup)), options_(options), context_(context) {}

  [[nodiscard]] const std::string& drive() const { return setup_.drive; }
  [[nodiscard]] std::uint8_t node() const { return setup_.node_id; }
  [[nodiscard]] bool silent() const { return silent_; }
  // Its frames reach the UIM2501 (SILENCE: it neither hears nor answers; CRC_ERRORS: it executes
  // what it hears, but every frame it sends fails the CAN CRC at the UIM2501 and is discarded,
  // ISO 11898-1 CRC error and fault confinement, as a node whose frames keep failing ends bus-off).
  [[nodiscard]] bool heard() const { return !silent_ && !corrupt_; }
  void set_corrupt(bool corrupt) { corrupt_ = corrupt; }
  // Silent, or still rebooting after an ICF write.
  [[nodiscard]] bool asleep(TimePoint now) const { return silent_ || now < awake_at_; }
  [[nodiscard]] int icf_writes() const { return icf_writes_; }
  [[nodiscard]] bool enabled() const { return enabled_; }
  [[nodiscard]] std::int64_t position(TimePoint now) const { return kinematics_.position_counts(now); }
  [[nodiscard]] std::int64_t physical_position(TimePoint now) const { return position(now) + physical_base_; }
  // A home switch is sampled every millisecond while the motor moves.
  [[nodiscard]] bool sampling() const { return in_motion_ && setup_.home_switch.has_value(); }
  // Kinematics counts the instant of arrival as moving; the controller has stopped by then.
  [[nodiscard]] bool moving(TimePoint now) const { return kinematics_.moving(now) && kinematics_.end_time() > now; }
  // The end of the current motion; "now" (the epoch) when it ended without a planned end (OFF, halt).
  [[nodiscard]] TimePoint deadline() const {
    if (!in_motion_) return kNever;
    const TimePoint end = kinematics_.end_time();
    return end == kNever && !kinematics_.jogging() ? TimePoint{} : end;
  }
  void set_silent(bool silent) { silent_ = silent; }
  void set_node(std::uint8_t node) { setup_.node_id = node; }

  void power_up(TimePoint now) {
    kinematics_.halt(now);
    in_motion_ = false;
    pt_target_.reset();
    desired_speed_ = 0;
    velocity_mode_ = true;
    enabled_ = (icfg_ & kIcfgEna) != 0;  // auto-enable (the ENAtimer delay is not modelled)
    if (const auto& sw = setup_.home_switch) inputs_[sw->port] = sw->level_at(physical_position(now)) ? 1 : 0;
    report(std::int8_t{motionlcm::sim_report_t::POWERED_UP}, now, position(now));
  }

  // Executes one instruction addressed to this controller; its reply frames (none when
  // `acknowledge` is false) and any error.
  std::vector<Frame> execute(const Instruction& in, TimePoint now, bool acknowledge) {
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

  // Arrival and end-of-motion notifications due at `now`.
  std::vector<Frame> process(TimePoint now) {
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

  std::vector<Frame> set_input(int port, bool level, TimePoint now) {
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

  std::vector<Frame> stall(TimePoint now) {
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

 private:
  [[nodiscard]] uim242::Status desired_status() const {
    return uim242::Status{acr_ != 0,
                          enabled_,
                          desired_positive_,
                          static_cast<std::uint8_t>(micro_steps_),
                          static_cast<std::uint8_t>(current_),
                          static_cast<std::int16_t>(desired_speed_),
                          static_cast<std::int32_t>(desired_displacement_)};
  }
  [[nodiscard]] uim242::Status actual_status(TimePoint now) const {
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

  // Rate in pps/s for a speed change of `delta` pps (AM/DM, EN/CN §5.4, §7.8): value mode as is,
  // period mode from the ramp time (not stated in the manuals: assumed), basic motion at once.
  [[nodiscard]] double rate(std::int64_t setting, bool period_mode, double delta) const {
    if (!(mcfg_ & kCm)) return kInstantRate;
    if (!period_mode) return static_cast<double>(std::max<std::int64_t>(setting, 1));
    if (delta <= 0) return kInstantRate;
    return delta / (static_cast<double>(std::max<std::int64_t>(setting, 1)) / 1000.0);
  }
  [[nodiscard]] Profile profile(TimePoint now, double speed) const {
    const double delta = std::abs(std::abs(speed) - std::abs(kinematics_.at(now).velocity));
    const double cut_in = (mcfg_ & kCm) ? static_cast<double>(mms_) : 0.0;
    return Profile{speed, rate(acceleration_, (mcfg_ & kAm) != 0, delta),
                   rate(deceleration_, (mcfg_ & kDm) != 0, delta), cut_in};
  }

  void started(TimePoint now, std::int64_t target) {
    if (in_motion_) return;
    in_motion_ = true;
    report(std::int8_t{motionlcm::sim_report_t::MOTION_STARTED}, now, target);
  }

  void brake(TimePoint now) {
    const Profile p = profile(now, 0);
    kinematics_.stop(now, p.deceleration, p.cut_in);
  }

  // The spd0_position_move variant refuses a displacement loaded at desired speed 0.
  [[nodiscard]] bool refuses_target(std::int64_t displacement) const {
    return setup_.spd0_position_move == Uim242ControllerSetup::Spd0Move::kRefused && displacement != 0 &&
           desired_speed_ == 0;
  }

  // Applies the desired speed / pending target to the motor (enable, SPD, STP, QEC);
  // `new_target`: a position instruction just set the target.
  void resume(TimePoint now, bool new_target = false) {
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

  void set_target(TimePoint now, std::int64_t target, std::int64_t displacement) {
    velocity_mode_ = false;
    displacement_origin_ = position(now);
    desired_displacement_ = displacement;
    desired_positive_ = displacement >= 0;
    pt_target_ = target;
    resume(now, true);
  }

  void leave_position_mode(TimePoint now) {
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

  // The position counter := `counts` where the shaft stands (ORG, a reset action).
  void set_counter(TimePoint now, std::int64_t counts) {
    physical_base_ += kinematics_.position_counts(now) - counts;
    kinematics_.set_position(now, counts);
  }

  void halt(TimePoint now) {
    kinematics_.halt(now);
    pt_target_.reset();
  }

  void write_sensor_register(uim242::ScfWrite w) {
    switch (w.reg) {
      case uim242::SensorRegister::kS12CON: s12con_ = w.value; break;
      case uim242::SensorRegister::kS34CON: s34con_ = w.value; break;
      case uim242::SensorRegister::kATCONL: atconl_ = w.value & 0x0FFF; break;
      case uim242::SensorRegister::kATCONH: atconh_ = w.value & 0x0FFF; break;
    }
  }

  void sensor_action(std::uint8_t action, TimePoint now) {
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

  void set_p4(bool level, std::vector<Frame>& out) {
    if (p4_ == level) return;
    p4_ = level;
    if (mcfg_ & kP4ie) {
      const auto event = level ? uim242::Event::kP4LowToHigh : uim242::Event::kP4HighToLow;
      out.push_back(uim242::make_notification({node(), event, std::nullopt, std::nullopt}, options_.stall_message_id));
    }
  }

  void report(std::int8_t kind, TimePoint now, std::int64_t target) {
    if (!context_.report) return;
    const std::int64_t utime = context_.utime_of ? context_.utime_of(now) : steady_us(now);
    context_.report(setup_.drive, kind, utime, position(now), target);
  }

  Uim242ControllerSetup setup_;
  const Uim242SimOptions& options_;
  const Uim242SimContext& context_;
  bool silent_ = false;
  bool corrupt_ = false;
  TimePoint awake_at_{};  // end of an ICF reboot
  int icf_writes_ = 0;

  // Registers and settings (EEPROM-backed ones survive power_up).
  std::uint16_t mcfg_ = kCm;  // advanced motion on: closed-loop -IE units ship with the module
  std::uint16_t icfg_ = 0;
  std::uint16_t s12con_ = 0, s34con_ = 0, atconl_ = 0, atconh_ = 0;
  std::array<std::int64_t, 3> sampling_{};
  std::int64_t acr_ = 0, blc_ = 0, current_ = 10, micro_steps_ = 16, enable_timer_ = 0;
  std::int64_t acceleration_ = kFactoryRamp, deceleration_ = kFactoryRamp, mms_ = kFactoryJump, mmd_ = kFactoryJump;
  std::int64_t encoder_lines_ = 0, stall_tolerance_ = 0;
  std::array<std::int64_t, 3> inputs_{1, 1, 1};  // idle switches read 5 V (EN §8.10: a hit outputs 0 V)
  bool p4_ = false;

  // Motion.
  bool enabled_ = false;
  bool velocity_mode_ = true;
  std::int64_t desired_speed_ = 0;
  std::int64_t last_speed_ = kAssumedLastSpeed;  // the last non-zero |SPD| (runs_at_last_speed)
  std::int64_t desired_displacement_ = 0;
  bool desired_positive_ = true;
  bool last_positive_ = true;
  std::optional<std::int64_t> pt_target_;
  std::int64_t displacement_origin_ = 0;
  bool in_motion_ = false;          // MOTION_STARTED reported, MOTION_FINISHED pending
  std::int64_t physical_base_ = 0;  // shaft counts from power-up = counter + this
  Kinematics kinematics_;
};

// ---- Gateway ---------------------------------------------------------------------------------

Uim242GatewaySim::Uim242GatewaySim(std::vector<Uim242ControllerSetup> controllers, Uim242SimContext context,
                                   Uim242SimOptions options)
    : context_(std::move(context)), options_(options) {
  for (auto& c : controllers) controllers_.push_back(std::make_unique<Controller>(std::move(c), options_, context_));
}

Uim242GatewaySim::~Uim242GatewaySim() = default;

std::vector<Uim242ControllerSetup> Uim242GatewaySim::controllers_of(const config::Config& config,
                                                                    const std::string& bus) {
  std::vector<Uim242ControllerSetup> out;
  for (const auto& d : config.drives) {
    if (d.bus != bus || d.family != config::Family::kUim242) continue;
    Uim242ControllerSetup setup;
    setup.drive = d.name;
    setup.node_id = static_cast<std::uint8_t>(d.node_id);
    setup.reboot = std::chrono::milliseconds(config::sim_variant_int(config, d, "reboot_ms"));
    const auto spd0 = config::sim_variant(config, d, "spd0_position_move");
    setup.spd0_position_move = spd0 == "refused"              ? Uim242ControllerSetup::Spd0Move::kRefused
                               : spd0 == "runs_at_last_speed" ? Uim242ControllerSetup::Spd0Move::kRunsAtLastSpeed
                                                              : Uim242ControllerSetup::Spd0Move::kHolds;
    setup.home_switch = home_switch(config, d);
    out.push_back(setup);
  }
  return out;
}

SerialDeviceFactory uim242_line_factory() {
  return [](const config::Config& config, const config::Bus& bus,
            SerialDeviceContext line) -> std::unique_ptr<SerialDeviceSim> {
    const Duration latency = std::chrono::microseconds(config.simulation.reply_latency_us);
    Uim242SimContext context;
    context.bus = bus.name;
    context.send = [send = line.send, latency](std::span<const std::uint8_t> bytes) { send(bytes, latency); };
    context.report = line.report;
    context.utime_of = line.utime_of;
    return std::make_unique<Uim242GatewaySim>(Uim242GatewaySim::controllers_of(config, bus.name), std::move(context));
  };
}

int Uim242GatewaySim::icf_writes(const std::string& drive) const {
  const auto* c = find_drive(drive);
  return c ? c->icf_writes() : 0;
}

void Uim242GatewaySim::power_up(TimePoint now) {
  selected_ = 5;
  splitter_.reset();
  if (options_.greet_on_power_up) send(uim242::make_greeting(options_.version));
  for (auto& c : controllers_) c->power_up(now);
}

TimePoint Uim242GatewaySim::receive(std::span<const std::uint8_t> bytes, TimePoint now) {
  process(now);  // arrivals before these bytes come first
  for (const auto& chunk : splitter_.push(bytes)) execute(chunk, now);
  return process(now);
}

TimePoint Uim242GatewaySim::process(TimePoint now) {
  TimePoint next = kNever;
  for (auto& c : controllers_) {
    for (const auto& f : c->process(now)) {
      if (c->heard()) send(f);
    }
    next = std::min(next, c->deadline());
    if (c->sampling()) next = std::min(next, now + std::chrono::milliseconds(1));
  }
  return next;
}

bool Uim242GatewaySim::control(const motionlcm::sim_control_t& control, TimePoint now) {
  process(now);  // arrivals before the fault come first
  Controller* c = find_drive(control.drive);
  if (!c) return false;
  std::vector<Frame> out;
  switch (control.action) {
    case motionlcm::sim_control_t::STALL: out = c->stall(now); break;
    case motionlcm::sim_control_t::SET_INPUT:
      if (control.value < 1 || control.value > 3) return false;
      out = c->set_input(control.value, control.level != 0, now);
      break;
    case motionlcm::sim_control_t::SILENCE: c->set_silent(control.value != 0); return true;
    case motionlcm::sim_control_t::POWER_CYCLE: c->power_up(now); return true;
    case motionlcm::sim_control_t::CRC_ERRORS: c->set_corrupt(control.value != 0); return true;
    default: return false;
  }
  if (c->heard()) {
    for (const auto& f : out) send(f);
  }
  return true;
}

std::int64_t Uim242GatewaySim::position(const std::string& drive, TimePoint now) const {
  const Controller* c = find_drive(drive);
  return c ? c->position(now) : 0;
}
std::int64_t Uim242GatewaySim::physical_position(const std::string& drive, TimePoint now) const {
  const Controller* c = find_drive(drive);
  return c ? c->physical_position(now) : 0;
}
bool Uim242GatewaySim::moving(const std::string& drive, TimePoint now) const {
  const Controller* c = find_drive(drive);
  return c && c->moving(now);
}
bool Uim242GatewaySim::enabled(const std::string& drive) const {
  const Controller* c = find_drive(drive);
  return c && c->enabled();
}

Uim242GatewaySim::Controller* Uim242GatewaySim::find_node(int node) const {
  for (const auto& c : controllers_) {
    if (c->node() == node) return c.get();
  }
  return nullptr;
}

Uim242GatewaySim::Controller* Uim242GatewaySim::find_drive(const std::string& drive) const {
  for (const auto& c : controllers_) {
    if (c->drive() == drive) return c.get();
  }
  return nullptr;
}

void Uim242GatewaySim::send(const Frame& frame) {
  if (!context_.send) return;
  const auto bytes = uim242::serialize(frame);
  context_.send(bytes);
}

void Uim242GatewaySim::execute(const uim242::InstructionChunk& chunk, TimePoint now) {
  // Errors are never silent, not even inside a macro (EN/CN §2.3 do not say: assumed).
  if (chunk.oversize) {
    send(uim242::make_error(uim242::ErrorCode::kSyntaxError));
    return;
  }
  const auto parsed = uim242::parse_instruction(chunk.text);
  if (!parsed) {
    send(uim242::make_error(static_cast<uim242::ErrorCode>(parsed.error().value())));
    return;
  }
  const Instruction& in = *parsed;
  if (in.global || uim242::spec(in.mnemonic).target == uim242::Target::kGateway) {
    execute_gateway(in, now);
    return;
  }
  // MDL names its controller in the value (#22); everything else goes to the selected target.
  const int node = in.mnemonic == Mnemonic::kMDL && in.value ? static_cast<int>(*in.value) : selected_;
  Controller* c = find_node(node);
  if (!c || c->asleep(now)) return;  // nobody answers: the host times out
  for (const auto& f : c->execute(in, now, !chunk.silent)) {
    if ((f.header == Header::kError || !chunk.silent) && c->heard()) send(f);
  }
}

void Uim242GatewaySim::execute_gateway(const Instruction& in, TimePoint now) {
  const auto quantity = static_cast<std::uint8_t>(
      std::count_if(controllers_.begin(), controllers_.end(), [](const auto& c) { return !c->silent(); }));
  const auto form = uim242::reply_form(in, options_.org_reply);
  if (in.global) {
    if (in.mnemonic == Mnemonic::kREG) {
      std::array<std::int64_t, 8> ids{};
      std::size_t n = 0;
      for (const auto& c : controllers_) {
        if (!c->silent() && n < ids.size()) ids[n++] = c->node();
      }
      send(uim242::make_reply(form, quantity, ids));
      return;
    }
    Instruction local = in;
    local.global = false;
    for (auto& c : controllers_) {
      if (!c->silent()) (void)c->execute(local, now, false);
    }
    send(uim242::make_reply(form, quantity, {}));
    return;
  }
  switch (in.mnemonic) {
    case Mnemonic::kADR:
      selected_ = static_cast<int>(*in.value);
      send(uim242::make_reply(form, static_cast<std::uint8_t>(selected_), {}));
      return;
    case Mnemonic::kSET:
      // Only with a single controller wired (EN/CN §3.1); otherwise nobody answers.
      if (controllers_.size() != 1) return;
      controllers_.front()->set_node(static_cast<std::uint8_t>(*in.value));
      send(uim242::make_reply(form, controllers_.front()->node(), {}));
      return;
    case Mnemonic::kBTR: send(uim242::make_reply(form, static_cast<std::uint8_t>(in.value.value_or(0)), {})); return;
    case Mnemonic::kBDR: send(uim242::make_reply(form, 0, {})); return;
    case Mnemonic::kABC: send(uim242::make_greeting(options_.version)); return;
    default: return;
  }
}

}  // namespace motion::sim
