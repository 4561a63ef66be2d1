// Simulated UIM2501/2502 RS232-CAN gateway with the UIM242 controllers of one RS232 bus behind it,
// byte for byte per the UIM242 manuals (EN, CN Ver.1301/1302).
//
// Passive core: host bytes and `now` in (receive), gateway bytes out (context.send), next deadline
// out (process). No fds, no clocks: the host (motion-sim's SerialLineHost over the bus's pty, with
// uim242_line_factory()) owns the serial line, its byte timing and the reply latency
// (simulation.reply_latency_us). Thread contract: one thread (the host's loop).
//
// Gateway (EXT-2501 §2-§3; EN/CN §3.1, Summary): sticky target selected by `ADR η;` (initially 5,
// the factory id); instructions for a target that is not on the bus get no reply. Global `g...`
// instructions act on every controller and are answered once, `AA QTY AD FF`
// (gORG: `CC QTY AD FF`); `gREG;` lists the ids; `ABC;` and power-up send the greeting.
// `MDL η;` is routed to controller η.
//
// Controllers (EN/CN §6-§10): every instruction of the manual with its reply (§12.3), EE 65 / EE 66
// for bad input even inside macros. Motion (EN/CN §6.1, §7.1-§7.5) by motion::sim::Kinematics:
// * MCFG.CM = 1: trapezoid with MAC/MDE (pps/s in value mode; period mode converts the ms to a
//   rate for the speed change at hand), MMS as the cut-in speed of start and stop (Kinematics has
//   one cut-in speed; the driver sets MMS = MMD). CM = 0: speed changes at once.
// * VT: `SPD η;` while enabled jogs at η; `SPD 0;` decelerates to rest.
// * PT: `STP η;` (relative) / `QEC η;` (absolute) set the target from the position at receipt and
//   start when enabled with a non-zero desired speed; the position error gives the direction.
//   `SPD 0;` then a target pre-loads a move that a later `SPD η;` / `gSPD η;` starts — the
//   gateway-wide synchronized start the driver uses (or, per Uim242ControllerSetup::
//   spd0_position_move, runs at once or is refused). `SPD 0;` during a PT move brakes and keeps
//   the target. `STP 0;` leaves PT: decelerate, no A8 (EN/CN §6.1; ramp and no A8 assumed).
// * Arrival: A8 RTCN if MCFG.STPIE, CN 10-byte form by default (CN §4.1; EN: 4 bytes).
// * `ORG[ η];` sets position and encoder counter at rest (EE 66 while moving: assumed, the manuals
//   do not say).
// * A home switch (Uim242ControllerSetup::home_switch) drives its input from the shaft position.
// * Inputs (sim_control_t SET_INPUT 1..3): edge RTCNs A0..A5 per SxIE and a non-zero action code,
//   actions 0011 decelerate, 0100 e-stop, 0110 reset position, 1011/1100 reset + stop, 1111 OFF;
//   the motion-starting actions, analog inputs, sampling modes, P4 events, parameter groups, Elock
//   and user programs are accepted and stored but not simulated.
// * Stall (sim_control_t STALL): the motor halts; `CC id [stall id] FF` if MCFG.STLIE and
//   S34CON.STALL != 0 (the stall message id is undocumented, EN/CN §5.4, §8.7).
// * SILENCE, POWER_CYCLE and CRC_ERRORS are per controller here (one serial line serves them
//   all); with CRC_ERRORS a controller executes what it hears but none of its frames gets through.
// Reports (sim_report_t kinds) per drive: POWERED_UP at power_up, MOTION_STARTED with the time of
// the `;` that started the move, MOTION_FINISHED when it ends (arrival, stop, OFF, stall).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <motionlcm/sim_control_t.hpp>

#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"
#include "motion/sim/home_switch.hpp"
#include "motion/sim/serial_device_sim.hpp"
#include "motion/uim242/feedback.hpp"

namespace motion::sim {

struct Uim242ControllerSetup {
  std::string drive;  // drive name (reports, sim_control_t)
  std::uint8_t node_id = 5;
  std::uint8_t max_current_tenths = 40;  // MDL: UIM24204
  std::uint16_t firmware = 1302;
  // How long the controller is silent after an ICF write (manual §5.1: "will auto reboot", no
  // time given): simulation.variants key reboot_ms.
  Duration reboot = std::chrono::milliseconds(300);
  // A position move (STP/QEC) loaded while the desired speed is 0 (§6.1, #37, #44: no example
  // shows it; simulation.variants key spd0_position_move): held until a later `SPD η;` starts it
  // (holds), run at once at the last non-zero desired speed (runs_at_last_speed; 1000 pps when
  // none was set, assumed), or answered EE 66 and not loaded (refused).
  enum class Spd0Move { kHolds, kRunsAtLastSpeed, kRefused };
  Spd0Move spd0_position_move = Spd0Move::kHolds;
  // The machine's home switch on one of S1..S3 (sampled every millisecond while the motor moves),
  // from the axis's homing and simulation.home_switches; none: inputs change by SET_INPUT only.
  std::optional<HomeSwitch> home_switch = std::nullopt;
};

struct Uim242SimOptions {
  uim242::OrgReplyStyle org_reply = uim242::OrgReplyStyle::kCn;
  bool cn_completion_format = true;  // A8 with closed-loop flag + position (CN) or 4 bytes (EN)
  std::uint8_t stall_message_id = uim242::message::kDefaultStall;
  uim242::Greeting version{1, 0};
  bool greet_on_power_up = true;
};

struct Uim242SimContext {
  std::string bus;
  // Bytes the gateway writes to RS232 (one call per frame).
  std::function<void(std::span<const std::uint8_t>)> send;
  // Ground truth, shaped like SimDriveContext::report plus the drive (one gateway, many drives).
  std::function<void(const std::string& drive, std::int8_t kind, std::int64_t frame_utime, std::int64_t position,
                     std::int64_t target)>
      report;
  // The wall-clock utime of a core time point (frame_utime of reports); default: steady microseconds.
  std::function<std::int64_t(TimePoint)> utime_of;
};

class Uim242GatewaySim final : public SerialDeviceSim {
 public:
  Uim242GatewaySim(std::vector<Uim242ControllerSetup> controllers, Uim242SimContext context,
                   Uim242SimOptions options = {});
  ~Uim242GatewaySim() override;
  Uim242GatewaySim(const Uim242GatewaySim&) = delete;
  Uim242GatewaySim& operator=(const Uim242GatewaySim&) = delete;

  // The UIM242 drives of `bus` in the configuration.
  static std::vector<Uim242ControllerSetup> controllers_of(const config::Config& config, const std::string& bus);

  void power_up(TimePoint now) override;
  // Bytes from the host, in any pieces; `now` = when the last of them arrived. Returns the next
  // deadline (as process()).
  TimePoint receive(std::span<const std::uint8_t> bytes, TimePoint now) override;
  // Advances to `now` (arrivals, notifications); returns the next deadline or kNever.
  TimePoint process(TimePoint now) override;
  // STALL, SET_INPUT, SILENCE, POWER_CYCLE for `control.drive`; false when unsupported/unknown.
  // Call process(now) afterwards for the next deadline.
  bool control(const motionlcm::sim_control_t& control, TimePoint now) override;
  // RS232 to the UIM2501/2502 (EN §2, string messages over RS232): a transmit and a receive line,
  // so an instruction written while an RTCN (EN §1.1) or a reply comes back goes out at once.
  [[nodiscard]] bool full_duplex() const override { return true; }

  // Introspection for tests.
  [[nodiscard]] std::int64_t position(const std::string& drive, TimePoint now) const;
  // Where the shaft is in counts from power-up (ORG and position resets do not move it).
  [[nodiscard]] std::int64_t physical_position(const std::string& drive, TimePoint now) const;
  [[nodiscard]] bool moving(const std::string& drive, TimePoint now) const;
  [[nodiscard]] bool enabled(const std::string& drive) const;
  [[nodiscard]] int selected_node() const noexcept { return selected_; }
  // ICF writes the controller took (each an EEPROM write and a reboot).
  [[nodiscard]] int icf_writes(const std::string& drive) const;

 private:
  class Controller;
  Controller* find_node(int node) const;
  Controller* find_drive(const std::string& drive) const;
  void execute(const uim242::InstructionChunk& chunk, TimePoint now);
  void execute_gateway(const uim242::Instruction& in, TimePoint now);
  void send(const uim242::Frame& frame);

  std::vector<std::unique_ptr<Controller>> controllers_;
  Uim242SimContext context_;
  Uim242SimOptions options_;
  uim242::InstructionSplitter splitter_;
  int selected_ = 5;
};

// The factory motion-sim registers for uim242 lines: the bus's UIM242 drives behind one simulated
// UIM2501, every frame it sends delayed by simulation.reply_latency_us, reports as SIM_REPORT.
[[nodiscard]] SerialDeviceFactory uim242_line_factory();

}  // namespace motion::sim
