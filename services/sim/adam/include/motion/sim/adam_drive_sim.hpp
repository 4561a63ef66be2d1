// One simulated ADAM NEMA8–NEMA23 integrated stepper: the register bank a Modbus RTU slave
// (motion::adam::serve) reads and writes, with the drive's behaviour behind the command
// registers (manual §8.48, §8.51–§8.54, §8.64–§8.67; the motion model itself is not stated in the
// manual):
//  * motion by motion::sim::Kinematics (exact trapezoid): speed 0x00D8 (0.01 rpm, kept in step
//    with 0x009A rpm), start speed 0x0096 as the cut-in speed, ramps as TIMES 0x0098/0x0099 from
//    the start speed to the target speed, pulses of the subdivision 0x0024;
//  * 0x00C8 velocity run/stop/e-stop, 0x00CA jog, 0x00CE/0x00D0 (standstill only, otherwise
//    echoed and ignored: assumed from §8.65④/⑥ "in stop state"), 0x00DE/0x00E8 (pre-empting),
//    0x00D2 preset, 0x00D4 enable/release/restart, 0x00DD table entry execute, 0x00C9 homing,
//    0x00A0/0x00A1 outputs, 0x00A4 alarm clear;
//  * status 0x0006 from the motion (bits 9–8 phase, X12 in position, X15 home) and inputs;
//  * homing (assumed, §8.48 does not say): the home switch is where the drive powered up (counter 0
//    at power-up), or the configured home input going active; homing travels to it, stops, zeroes
//    the position, X15.
//  * 0x00CC timed run (§8.65) is stored but not acted on (no test or driver uses it).
// Motion commands are ignored while released (0x00D4 = 1) or while an alarm is active.
//
// Thread contract: single-threaded; every call takes the current time via set_now()/`now`.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "motion/adam/registers.hpp"
#include "motion/adam/slave.hpp"
#include "motion/adam/status.hpp"
#include "motion/core/clock.hpp"
#include "motion/sim/kinematics.hpp"

namespace motion::sim {

// What the manual leaves open about a table start (simulation.variants, docs/protocols.md):
// which register's speed an executed table entry runs at (§8.44 0x009A "working speed", §8.64
// 0x00D8 "target speed", §8.65 ties the velocity commands to 0x009A; `shared`: one setpoint
// behind both, as the simulator assumed before), and whether table data written by Modbus is used
// only after a Save (§8.54 step 2 "after sending, it is necessary to send a save command"). A
// Save (0x00DC = 1) erases flash for save_time (§8.69: 0.1 s); the drive answers after it.
struct AdamTableVariants {
  enum class Speed { kWorking009a, kTarget00d8, kShared };
  Speed speed = Speed::kWorking009a;
  bool needs_save = true;
  Duration save_time = std::chrono::milliseconds(100);
};

class AdamDriveSim final : public adam::RegisterBank {
 public:
  explicit AdamDriveSim(AdamTableVariants variants = {});

  // The time of the frame being served (the bank interface has no time argument).
  void set_now(TimePoint now) { now_ = now; }

  std::optional<adam::rtu::ExceptionCode> read(std::uint16_t start, std::span<std::uint16_t> out) override;
  std::optional<adam::rtu::ExceptionCode> write(std::uint16_t start, std::span<const std::uint16_t> values) override;

  // Reports for motion-sim: a motion command started motion (cleared by reading it).
  [[nodiscard]] bool take_motion_started() { return std::exchange(motion_started_, false); }
  // When the current motion ends (kNever when jogging or at rest).
  [[nodiscard]] TimePoint motion_end() const { return kinematics_.end_time(); }
  // Called at/after motion_end(): homing completion, "finished" bookkeeping. True when a motion
  // finished since the last call.
  bool settle(TimePoint now);

  [[nodiscard]] std::int64_t position(TimePoint now) const { return kinematics_.position_counts(now); }
  [[nodiscard]] std::int64_t target() const { return target_; }
  // Saves (0x00DC = 1) taken, and until when the last one keeps the drive busy (no answer).
  [[nodiscard]] int saves() const { return saves_; }
  [[nodiscard]] TimePoint busy_until() const { return busy_until_; }
  [[nodiscard]] const AdamTableVariants& variants() const { return variants_; }
  [[nodiscard]] adam::DriveStatus status(TimePoint now) const;

  // Fault injection and inputs (sim_control_t).
  void inject_alarm(adam::AlarmCode code, TimePoint now);
  void set_input(unsigned index, bool level, TimePoint now);  // index 0…7 = X0…X7
  void power_cycle(TimePoint now);

 private:
  [[nodiscard]] std::uint16_t reg(adam::Reg r) const { return regs_[adam::address(r)]; }
  [[nodiscard]] std::int32_t reg32(adam::Reg r) const;
  void refresh(TimePoint now);
  void act(std::uint16_t address, TimePoint now);
  [[nodiscard]] bool may_move() const;
  [[nodiscard]] double pps_of_rpm(double rpm) const;
  [[nodiscard]] Profile profile(double speed_rpm) const;
  void move_to(std::int64_t target, TimePoint now, double speed_rpm);
  void execute_table_entry(TimePoint now);

  std::vector<std::uint16_t> regs_;
  AdamTableVariants variants_;
  std::vector<std::uint16_t> saved_;  // flash: what the last Save wrote (kept over power cycles)
  int saves_ = 0;
  TimePoint busy_until_{};
  Kinematics kinematics_;
  TimePoint now_{};
  std::int64_t target_ = 0;
  bool enabled_ = true;
  bool homing_ = false;
  bool at_home_ = true;  // assumed: powered up on the home switch
  std::uint8_t inputs_ = 0;
  adam::AlarmState alarm_{};
  bool motion_started_ = false;
  bool was_moving_ = false;
};

}  // namespace motion::sim
