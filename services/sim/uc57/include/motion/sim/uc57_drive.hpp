// Simulated ADAMPOWER UC57 CANopen integrated stepper (CiA 301 + CiA 402) for motion-sim.
//
// Behaviour follows the UC57 manual and CiA 301/402 and, where they are silent, assumptions
// that the comments name:
//  - CiA 301: boot-up on power-up and NMT resets (UC57 manual §4.1.2; CiA 301 §7.2.8.3.2), NMT
//    states with the services each allows (CiA 301 §7.3.2), SDO server over the UC57 object
//    dictionary of motion::cia402 (CiA 301 §7.2.4; abort policy assumed, codes per §7.2.4.3.17),
//    producer heartbeat from 1017h, EMCY on 81h + n (1014h) with assumed codes (the manual gives
//    none), 4 RPDOs / 4 TPDOs configurable by SDO (CiA 301 §7.5.2.35-38; the RO markings of the
//    manual's §5 comm. table are lifted by `pdo_configuration_writable`), synchronous RPDOs
//    buffered and applied at SYNC (CiA 301 §7.2.2, §7.2.5) in ascending RPDO number (assumed),
//    TPDOs at SYNC (types 0..240) or on change / event timer (254/255).
//  - CiA 402: power state machine from the controlword (manual §4.2.1/§4.2.2, table in
//    motion::cia402), statusword bits of §4.2.2 composed as assumed where the manual is silent,
//    profile position with the set-point handshake (bits 4/5/6, acks 12, target reached 10, in
//    position 15; manual §4.2.4), profile velocity (§4.2.5), homing methods 17, 18, 24, 29, 41,
//    42 against simulated switches (§4.2.6), halt, quick stop, faults and fault reset (§6).
// Motion is exact (motion::sim::Kinematics): a PP move ends at the time the trapezoid says.
//
// Ground truth: MOTION_STARTED carries the end-of-frame time of the frame that started the motion
// (the SYNC for synchronous RPDOs, else the RPDO or SDO frame); MOTION_FINISHED that time plus
// the motion's exact duration; POWERED_UP has no triggering frame (frame_utime 0).
//
// Thread contract: a passive core on the host's loop thread; frames and `now` in, frames out via
// SimDriveContext::send, next deadline out. No clock reads.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "motion/canopen/emcy.hpp"
#include "motion/canopen/nmt.hpp"
#include "motion/canopen/pdo.hpp"
#include "motion/canopen/sdo_server.hpp"
#include "motion/cia402/state_machine.hpp"
#include "motion/cia402/uc57_od.hpp"
#include "motion/cia402/uc57_units.hpp"
#include "motion/sim/can_drive.hpp"
#include "motion/sim/kinematics.hpp"

namespace motion::sim {

// What the drive does with RPDO transmission type 1 (synchronous, CiA 301 §7.2.2). The UC57
// manual's §4.1.2 ("SYNC ... assuming that the devices in the network support synchronous PDO
// function") and §5 comm. table (1400h:02 Transmission, RW/S, default FFh) do not say that a
// UC57 supports it: simulation.variants `rpdo_sync` (docs/protocols.md).
enum class RpdoSync : std::uint8_t {
  kHonoured,     // type 1 accepted; the mapped values apply at the next SYNC (the default)
  kOnReception,  // type 1 accepted (reads back 1) but every RPDO applies when it arrives
  kRefused,      // writing 1..240 to 1400h+n:02 is aborted (0609 0030h value range); 254/255 accepted
};
[[nodiscard]] std::optional<RpdoSync> parse_rpdo_sync(std::string_view text);

// Switches for the points the manual leaves open. Positions are physical pulses: where
// the axis is at power-up is 0; homing shifts the reported position, not the switches.
struct Uc57SimOptions {
  bool pdo_configuration_writable = true;  // CiA 301 remap (14xxh/18xxh:01, 16xxh/1Axxh:00)
  bool check_range = true;
  RpdoSync rpdo_sync = RpdoSync::kHonoured;
  cia402::uc57::RampUnit ramp_unit = cia402::uc57::RampUnit::kMilliseconds;  // (C-02)
  std::int64_t origin_position = 2000;                                       // IN2 active within +-origin_half_width
  std::int64_t origin_half_width = 100;
  std::int64_t positive_limit = 200000;   // IN1 active at and beyond
  std::int64_t negative_limit = -200000;  // IN3 active at and beyond
  std::int64_t homing_backoff = 500;      // back-off distance before the slow approach
  // A drive that takes TPDO transmission type 1 only (2..240 aborted), and one that starts its
  // TPDOs' SYNC count `tpdo_sync_skew` SYNCs later than at NMT start / a type write (a drive
  // counting differently: staggered TPDOs then answer another slot).
  bool tpdo_every_sync_only = false;
  unsigned tpdo_sync_skew = 0;
};

class Uc57DriveSim final : public CanDriveSim {
 public:
  Uc57DriveSim(canopen::NodeId node, SimDriveContext context, Uc57SimOptions options = {});

  void power_up(TimePoint now) override;
  void on_frame(const can::Frame& frame, TimePoint now) override;
  TimePoint process(TimePoint now) override;
  // STALL -> fault (EMCY 8611h, statusword fault + alarm); ALARM value 1..6 -> the UC57 alarm
  // Err1..Err6 (603Fh bit, EMCY with assumed codes, fault); SET_INPUT value 1..3 (IN1..IN3), level 0/1.
  bool control(const motionlcm::sim_control_t& control, TimePoint now) override;

  // Observers for tests.
  [[nodiscard]] canopen::NmtState nmt_state() const { return nmt_; }
  [[nodiscard]] cia402::State drive_state() const { return state_; }
  [[nodiscard]] std::uint16_t statusword(TimePoint now) const;
  [[nodiscard]] std::int64_t position(TimePoint now) const;
  // Where the shaft is in pulses from power-up (homing shifts the reported position, not this).
  [[nodiscard]] std::int64_t physical_position(TimePoint now) const;

 private:
  enum class Activity : std::uint8_t { kIdle, kProfilePosition, kProfileVelocity, kHoming, kStopping };
  struct SetPoint {
    std::int64_t target = 0;
    bool relative = false;
    std::int64_t utime = 0;
  };
  struct HomingLeg {
    std::int64_t physical_target = 0;
    double speed = 0;  // pulses/s
  };
  struct Motion {
    bool active = false;
    std::int64_t target = 0;
    std::int64_t start_utime = 0;
    TimePoint start{};
  };
  struct TpdoRuntime {
    std::optional<std::vector<std::uint8_t>> last_sent;
    long sync_count = 0;  // SYNCs counted towards the next synchronous send (negative: skew)
    TimePoint inhibit_until{};
    TimePoint next_event = kNever;
  };

  // --- object dictionary ---
  void reset_objects(bool communication_only);
  [[nodiscard]] std::int64_t stored(std::uint16_t index, std::uint8_t sub) const;
  void store(std::uint16_t index, std::uint8_t sub, std::int64_t value);
  [[nodiscard]] std::int64_t current_value(const cia402::uc57::OdEntry& entry, TimePoint now) const;
  canopen::SdoReadResult sdo_read(canopen::ObjectAddress object);
  std::optional<canopen::SdoAbortCode> sdo_write(const canopen::SdoWrite& write);
  [[nodiscard]] std::optional<canopen::SdoAbortCode> check_pdo_parameter(const cia402::uc57::OdEntry& entry,
                                                                         std::int64_t value) const;
  // Stores a value and runs its side effects (controlword, mode, target velocity, commands).
  void apply_write(const cia402::uc57::OdEntry& entry, std::int64_t value);

  // --- CiA 301 services ---
  void boot(TimePoint now, bool communication_only);
  void on_nmt(const can::Frame& frame);
  void on_sync();
  void on_rpdo(unsigned number, std::span<const std::uint8_t> payload);
  void apply_rpdo(unsigned number, std::span<const std::uint8_t> payload);
  [[nodiscard]] canopen::PdoMapping pdo_mapping(canopen::PdoDirection direction, unsigned number) const;
  [[nodiscard]] std::optional<std::vector<std::uint8_t>> tpdo_payload(unsigned number) const;
  void send_tpdo(unsigned number, std::vector<std::uint8_t> payload);
  void service_event_tpdos();
  void send_emcy(const canopen::Emergency& emergency);
  void restart_heartbeat();
  void send(const can::Frame& frame) const;

  // --- CiA 402 ---
  void on_controlword(std::uint16_t controlword);
  void enter_state(cia402::State next);
  void on_operation_mode_bits(std::uint16_t previous, std::uint16_t controlword);
  void accept_set_point(bool change_immediately);
  void start_profile_position(const SetPoint& set_point);
  void update_profile_velocity();
  void start_homing();
  void start_homing_leg();
  void finish_homing(bool succeeded);
  void stop_motion(double deceleration);
  void fault(const canopen::Emergency& emergency);
  void try_fault_reset();
  void settle();  // motion end bookkeeping at now_
  void begin_motion(std::int64_t target);
  [[nodiscard]] bool motion_done() const;
  [[nodiscard]] bool running(TimePoint now) const;
  [[nodiscard]] std::int8_t mode() const;
  [[nodiscard]] std::uint32_t pulses_per_rev() const;
  [[nodiscard]] Profile ramp_profile(double speed, std::uint16_t accel_index, std::uint16_t decel_index,
                                     double start_speed) const;
  [[nodiscard]] double stop_deceleration(std::uint16_t index) const;
  // Starts `profile` (to `target`, or a jog without one) with its deceleration from `decel_index`.
  void run_profile(const Profile& profile, std::uint16_t decel_index, std::optional<std::int64_t> target);
  [[nodiscard]] std::uint8_t input_levels() const;  // bit0..2 = X0..X2 physical
  [[nodiscard]] std::uint32_t digital_inputs() const;
  [[nodiscard]] std::uint16_t output_states() const;
  [[nodiscard]] std::uint8_t error_register() const;
  [[nodiscard]] std::int64_t utime_at(TimePoint t) const;

  canopen::NodeId node_;
  SimDriveContext context_;
  Uc57SimOptions options_;
  cia402::uc57::WritePolicy policy_;
  std::unique_ptr<canopen::SdoServer> sdo_;

  // Time of the frame or call being handled.
  TimePoint now_{};
  std::int64_t frame_utime_ = 0;
  TimePoint powered_at_{};

  std::map<std::uint32_t, std::int64_t> objects_;
  canopen::NmtState nmt_ = canopen::NmtState::kPreOperational;
  TimePoint next_heartbeat_ = kNever;
  std::array<std::optional<std::vector<std::uint8_t>>, 4> rpdo_buffer_{};
  std::array<TpdoRuntime, 4> tpdo_{};
  std::vector<std::uint32_t> error_history_;  // 1003h, newest first

  cia402::State state_ = cia402::State::kStart;
  std::uint16_t controlword_ = 0;
  std::uint16_t fault_bits_ = 0;  // 603Fh
  bool stalled_ = false;
  std::array<bool, 3> forced_inputs_{};

  Kinematics kinematics_;
  struct RunningProfile {
    Profile profile;
    std::uint16_t decel_index = 0;
  } running_;                  // the profile last started (meaningful while activity_ is not kIdle)
  double position_shift_ = 0;  // physical = reported + shift
  Activity activity_ = Activity::kIdle;
  Motion motion_;
  std::optional<SetPoint> buffered_set_point_;
  bool set_point_acknowledged_ = false;
  bool target_reached_ = true;
  bool in_position_ = false;
  std::deque<HomingLeg> homing_legs_;
  bool homing_succeeds_ = false;
  bool homed_ = false;
  bool homing_attained_ = false;
  bool homing_finished_ = false;
};

// The motion-sim factory for family uc57 (node-ID from the configuration).
[[nodiscard]] CanDriveFactory uc57_drive_factory(Uc57SimOptions options = {});
// The same with each drive's `simulation.variants` of `config` (rpdo_sync) over `options`.
[[nodiscard]] CanDriveFactory uc57_drive_factory(const config::Config& config, Uc57SimOptions options = {});

}  // namespace motion::sim
