// A simulated UIROBOT UIM342 drive (SimpleCAN 3.0) for motion-sim: it answers the host's
// instructions byte for byte as the manual describes and moves with the shared trapezoid
// kinematics.
//
// Manual sections (UIM342C/S/XS User Manual V1.0):
//  §1.1 / §2.5  acceptance: node ID, group ID (PP[8], here `group_id` of the configuration) and
//               global ID 0; replies carry the drive's node ID as producer, addressed to the
//               instruction's producer (the host, 4)
//  §2.1 / §2.3  ACK only with CW bit 7; rejected instructions are answered by an error report
//               (CW 0x0F: 0x32 syntax, 0x33 data, 0x34 sub-index, 0x3C SD<DC, 0x3D running,
//               0x3E BG with driver off, 0x3F BG during an emergency stop, 0x41 OG running),
//               also without bit 7; a get without bit 7 is not answered
//  §2.4 / §5.29 real-time notifications: alarms (always), input edges (IE[0..2]), PTP finished
//               (IE[8])
//  §3.2 / §3.3  JOG and PTP, cut-in speed SS, AC/DC as rates or ramp times (IC[4]), SD stops
//  §3.7 / §5.24 MS[0] / MS[1] status words; §4.2-§4.4 / §5.26-§5.27 input logic and triggers
//  §5.1-§5.28   every instruction, including MF parameter groups and the "#50" SP ordering rule
// Where the manual is silent the simulator follows an assumed reading; the comments say so
// where it matters.
//
// Passive core: frames and `now` in, frames out through SimDriveContext::send, next deadline
// out of process(). No clock, no I/O. Thread contract: the host loop's thread only.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>

#include "motion/config/config.hpp"
#include "motion/sim/can_drive.hpp"
#include "motion/sim/home_switch.hpp"
#include "motion/sim/kinematics.hpp"
#include "motion/uim342/instructions.hpp"
#include "motion/uim342/notifications.hpp"

namespace motion::sim {

// What the ML and SN queries report and the bit rate PP[5] reads back: not in the drive set-up
// of the configuration, so the factory derives them (uim342_identity) and tests choose them.
struct Uim342Identity {
  std::array<std::uint8_t, 4> model_bytes{0x22, 0x28, 0x13, 0x00};  // 342C04 (§5.4)
  std::uint16_t firmware = 0x0100;
  std::uint32_t serial = 0;
  std::uint16_t manufacturer = 0;
  std::uint16_t vendor = 0;
  std::uint8_t bit_rate_code = 0;  // PP[5]: 0 = 1000 kbit/s
};

// The smallest UIM342C model whose peak current covers the configured `current_a`, a serial
// number derived from the node ID, and the bus's bit-rate code.
[[nodiscard]] Uim342Identity uim342_identity(const config::Drive& drive, int bus_bitrate);

// A home switch of the simulated machine (motion/sim/home_switch.hpp). The drive samples it every
// millisecond while it moves (§1: control loops within 1 ms), so input logic (§4.3, §5.26) acts on
// the edge during motion.
using Uim342HomeSwitch = HomeSwitch;

// The switch of `drive` from the configuration: its axis's `homing` (method switch: input, edge,
// direction) and `simulation.home_switches` (edge position, or none). nullopt: no switch.
[[nodiscard]] std::optional<Uim342HomeSwitch> uim342_home_switch(const config::Config& config,
                                                                 const config::Drive& drive);

// When a written MT[0] micro-step resolution moves the motor (simulation.variants key
// `micro_steps_apply`, docs/protocols.md). The manual (§5.9, §5.7) says the drive must be
// powered off and restarted for it to take effect: after_restart (the default) applies the
// resolution stored in EEPROM at each (re)boot only, so a value written while the driver is on
// (RAM only) reads back but never moves the motor; immediately applies any written value at once.
enum class MicroStepsApply { kAfterRestart, kImmediately };

class Uim342Drive final : public CanDriveSim {
 public:
  Uim342Drive(const config::Drive& drive, SimDriveContext context, Uim342Identity identity = {},
              std::optional<Uim342HomeSwitch> home_switch = std::nullopt,
              MicroStepsApply micro_steps_apply = MicroStepsApply::kAfterRestart);

  void power_up(TimePoint now) override;
  void on_frame(const can::Frame& frame, TimePoint now) override;
  TimePoint process(TimePoint now) override;
  bool control(const motionlcm::sim_control_t& control, TimePoint now) override;

  // Observers for tests and logs (the wire gives the same through PA / MS).
  [[nodiscard]] std::int64_t position(TimePoint now) const;
  [[nodiscard]] bool moving(TimePoint now) const { return motion_state(now).moving; }
  [[nodiscard]] bool driver_on() const { return driver_on_; }
  [[nodiscard]] std::uint8_t node_id() const { return node_id_; }
  // Ground truth of the shaft: where it stands in full steps (1/200 rev) since power-up, whatever
  // resolution the counts were made at; kept over a reboot (the counter restarts at 0, the shaft
  // does not move). And the resolution the motor runs at (micro-steps per full step).
  [[nodiscard]] double shaft_full_steps(TimePoint now) const;
  [[nodiscard]] std::uint16_t applied_micro_steps() const { return applied_micro_steps_; }

  // Parameters the drive keeps over a reboot (SY[1]); see store() for which sets persist.
  struct MotionGroup {                  // MF §5.13: 0 = normal, 2..7 = input edges
    std::uint32_t acceleration = 1000;  // AC
    std::uint32_t deceleration = 1000;  // DC
    std::int32_t speed = 0;             // SP (group 0: DV[2], shared with JV)
    std::int32_t relative = 0;          // PR (group 0: DV[3])
    std::int32_t absolute = 0;          // PA (group 0: DV[4])
  };
  struct Parameters {
    std::uint8_t bit_rate_code = 0;  // PP[5], PP[7], PP[8]: active after a reboot
    std::uint8_t node_id = 5;
    std::uint8_t group_id = 0;                                            // 0: no group (the configuration gave none)
    std::array<std::uint16_t, 8> initial_config{0, 1, 0, 0, 0, 0, 0, 0};  // IC; IC[1] = 1 factory (§3.1)
    std::array<std::uint16_t, 9> information_enable{};                    // IE[0..2], IE[8]
    std::array<std::uint16_t, 5> encoder{1000, 100, 17, 1, 3200};         // QE
    std::array<std::uint16_t, 4> driver{16, 28, 50, 0};                   // MT
    std::uint32_t cut_in_speed = 1000;                                    // SS (the manual's example value)
    std::uint32_t stop_deceleration = 1'600'000;                          // SD
    std::uint32_t backlash = 0;                                           // BL
    std::array<uim342::InputActions, 3> input_logic{};                    // IL[0..2]
    std::uint16_t stall_behaviour = 0;                                    // IL[16] (alias IL[3])
    std::array<std::uint16_t, 3> trigger{};                               // TG[0..2]
    std::array<MotionGroup, 8> groups{};
  };

 private:
  struct Motion {
    bool active = false;
    bool ptp = false;
    bool aborted = false;             // stopped before its target: no in-position
    std::int64_t target = 0;          // PTP target, reported coordinates
    std::int64_t ended_by_utime = 0;  // timestamp of the frame that stopped it (0: none)
  };
  struct PendingInput {  // TG low-pass filter: a level waiting to be stable
    bool level = false;
    TimePoint due = kNever;
    std::int64_t utime = 0;
  };
  using Instruction = uim342::Instruction;

  void reboot(TimePoint now);
  void handle(const Instruction& instruction, std::uint8_t host, std::uint8_t received_cw, const can::Frame& frame,
              TimePoint now);
  // The error a state check raises (empty when the instruction may run); `group` = MF selection.
  [[nodiscard]] std::error_code state_error(const Instruction& instruction, std::uint8_t group, TimePoint now) const;
  // Gets and sets by instruction family; each returns the ACK (the caller sends it if asked).
  [[nodiscard]] uim342::Reply configuration(const Instruction& instruction, TimePoint now);
  [[nodiscard]] uim342::Reply motion_parameter(const Instruction& instruction, std::uint8_t group, TimePoint now);
  [[nodiscard]] uim342::Reply motion_command(const Instruction& instruction, const can::Frame& frame, TimePoint now);
  [[nodiscard]] uim342::Reply status(const Instruction& instruction, TimePoint now);
  void store(const Instruction& instruction, Parameters& target, std::uint8_t group) const;
  [[nodiscard]] bool persists(const Instruction& instruction, std::uint8_t group) const;

  void send(const uim342::Reply& reply, std::uint8_t host);
  void notify(const uim342::Notification& notification);
  void reject(uim342::DriveErrc error, std::uint8_t received_cw, std::uint8_t sub_index, std::uint8_t host);

  // Motion (reported coordinates = kinematics counts - origin offset).
  [[nodiscard]] Profile profile(const MotionGroup& group, double velocity) const;
  [[nodiscard]] double ramp_rate(std::uint32_t wire_value, double velocity) const;
  // `utime`: timestamp of the frame (or control message) that caused it, for the ground truth.
  void begin(TimePoint now, std::int64_t utime);
  void start_ptp(TimePoint now, std::int64_t target, const MotionGroup& group, std::int64_t utime);
  void start_jog(TimePoint now, double velocity, const MotionGroup& group, std::int64_t utime);
  // Ramps down at `rate` (pulse/s^2); `emergency`: an SD stop, during which BG is refused.
  void stop_with(TimePoint now, double rate, bool emergency, std::int64_t utime);
  void halt(TimePoint now, std::int64_t utime);
  void set_origin(TimePoint now);
  void finish_if_done(TimePoint now);
  void stall(TimePoint now, std::int64_t utime);
  void raise_alarm(uim342::AlarmCode alarm, TimePoint now, std::int64_t utime);

  // Inputs and input logic (§4).
  void set_input(std::size_t port, bool level, TimePoint now, std::int64_t utime);
  void accept_input(std::size_t port, bool level, TimePoint now, std::int64_t utime);
  void run_input_action(std::size_t port, uim342::Edge edge, uim342::InputAction action, TimePoint now,
                        std::int64_t utime);
  void input_emergency_stop(TimePoint now, std::int64_t utime);

  // The kinematics' state, at rest from the motion's end time on (the kinematics still report the
  // last segment at exactly that instant; the drive has arrived there).
  [[nodiscard]] Kinematics::State motion_state(TimePoint now) const;
  [[nodiscard]] std::uint8_t io_status() const;
  [[nodiscard]] std::uint8_t status_flags(TimePoint now) const;
  [[nodiscard]] std::int32_t speed(TimePoint now) const;
  [[nodiscard]] std::int64_t relative_position(TimePoint now) const { return position(now) - relative_origin_; }
  [[nodiscard]] uim342::AccelerationUnit acceleration_unit() const;
  [[nodiscard]] bool notification_enabled(uim342::InformationEnable which) const;
  void record_error(const uim342::ErrorRecord& record);

  SimDriveContext context_;
  Uim342Identity identity_;
  Parameters factory_;    // from the configuration's set-up: what a power cycle restores
  Parameters persisted_;  // EEPROM/FLASH: what SY[1] reloads
  Parameters active_;     // RAM

  std::uint8_t node_id_ = 5;  // active IDs (PP changes them at the next reboot)
  std::uint8_t group_id_ = 0;
  bool driver_on_ = false;
  TimePoint auto_enable_at_ = kNever;
  uim342::MotionMode mode_ = uim342::MotionMode::kJog;  // DV[0]
  bool ptp_relative_ = false;                           // the last of PR/PA written decides what BG does
  std::uint8_t selected_group_ = 0;                     // MF: for the next AC/DC/SP/PR/PA only
  bool in_position_ = false;
  bool stalled_ = false;
  bool locked_ = false;
  bool error_ = false;
  bool emergency_stopping_ = false;  // an SD stop runs: BG is refused (0x3F)
  Kinematics kinematics_;
  Motion motion_;
  std::int64_t origin_offset_ = 0;         // kinematics counts at the origin
  std::int64_t relative_origin_ = 0;       // reported position where the relative counter is 0
  std::array<bool, 3> inputs_{};           // pin levels
  std::array<bool, 3> accepted_inputs_{};  // after the TG filter
  std::array<PendingInput, 3> pending_inputs_{};
  bool output_ = false;  // OP1
  std::optional<Uim342HomeSwitch> home_switch_;
  MicroStepsApply micro_steps_apply_ = MicroStepsApply::kAfterRestart;
  std::uint16_t applied_micro_steps_ = 16;  // the resolution the motor runs at
  double shaft_base_full_steps_ = 0;        // shaft position at counts_base_
  std::int64_t counts_base_ = 0;            // kinematics counts when applied_micro_steps_ last changed
  void apply_micro_steps(std::uint16_t micro_steps, TimePoint now);
  void sample_home_switch(TimePoint now);
  std::array<uim342::ErrorRecord, 9> error_history_{};  // ER[10..18], [0] = latest
};

// The motion-sim registration: family uim342 -> this simulator (identity from the configuration).
[[nodiscard]] CanDriveFactory uim342_factory(const config::Config& config);

}  // namespace motion::sim
