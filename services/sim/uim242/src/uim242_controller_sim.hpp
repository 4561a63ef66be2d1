// One UIM242 controller behind the simulated UIM2501 (uim242_gateway_sim.hpp): registers,
// counters and motion. Private to motion::sim_uim242; the gateway owns one per drive.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "motion/sim/kinematics.hpp"
#include "motion/sim/uim242_gateway_sim.hpp"
#include "motion/uim242/feedback.hpp"
#include "motion/uim242/instruction.hpp"

namespace motion::sim {

// Returns the frames it sends; reports through the gateway's context.
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

  void power_up(TimePoint now);

  // Executes one instruction addressed to this controller; its reply frames (none when
  // `acknowledge` is false) and any error.
  std::vector<uim242::Frame> execute(const uim242::Instruction& in, TimePoint now, bool acknowledge);

  // Arrival and end-of-motion notifications due at `now`.
  std::vector<uim242::Frame> process(TimePoint now);

  std::vector<uim242::Frame> set_input(int port, bool level, TimePoint now);

  std::vector<uim242::Frame> stall(TimePoint now);

 private:
  // MCFG bits (EN/CN §5.4).
  static constexpr std::uint16_t kMcfgReadZero = 0x1080;  // bits 12 and 7 are unimplemented
  static constexpr std::uint16_t kCm = 1u << 10;
  static constexpr std::uint16_t kAm = 1u << 9;
  static constexpr std::uint16_t kDm = 1u << 8;
  static constexpr std::uint16_t kStlie = 1u << 6;
  static constexpr std::uint16_t kStpie = 1u << 4;
  static constexpr std::uint16_t kP4ie = 1u << 3;
  static constexpr std::uint16_t kIcfgEna = 1u << 0;
  static constexpr std::uint16_t kS34P4Bits = 0x0F00;  // P4LVL and P4EVENT, cleared by DOU (#7)
  // CN §7.8 factory group STO0: acceleration, deceleration, MMS, MMD (EN #43 gives other values).
  static constexpr std::int64_t kFactoryRamp = 250;
  static constexpr std::int64_t kFactoryJump = 1000;
  // The speed a position move loaded at desired speed 0 runs at under runs_at_last_speed when no
  // non-zero SPD was ever set (assumed).
  static constexpr std::int64_t kAssumedLastSpeed = 1000;

  [[nodiscard]] uim242::Status desired_status() const;
  [[nodiscard]] uim242::Status actual_status(TimePoint now) const;

  // Rate in pps/s for a speed change of `delta` pps (AM/DM, EN/CN §5.4, §7.8): value mode as is,
  // period mode from the ramp time (not stated in the manuals: assumed), basic motion at once.
  [[nodiscard]] double rate(std::int64_t setting, bool period_mode, double delta) const;
  [[nodiscard]] Profile profile(TimePoint now, double speed) const;

  void started(TimePoint now, std::int64_t target);

  void brake(TimePoint now);

  // The spd0_position_move variant refuses a displacement loaded at desired speed 0.
  [[nodiscard]] bool refuses_target(std::int64_t displacement) const;

  // Applies the desired speed / pending target to the motor (enable, SPD, STP, QEC);
  // `new_target`: a position instruction just set the target.
  void resume(TimePoint now, bool new_target = false);

  void set_target(TimePoint now, std::int64_t target, std::int64_t displacement);

  void leave_position_mode(TimePoint now);

  // The position counter := `counts` where the shaft stands (ORG, a reset action).
  void set_counter(TimePoint now, std::int64_t counts);

  void halt(TimePoint now);

  void write_sensor_register(uim242::ScfWrite w);

  void sensor_action(std::uint8_t action, TimePoint now);

  void set_p4(bool level, std::vector<uim242::Frame>& out);

  void report(std::int8_t kind, TimePoint now, std::int64_t target);

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

}  // namespace motion::sim
