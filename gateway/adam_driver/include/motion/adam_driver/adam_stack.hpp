// The Modbus RTU master of one RS485 line of ADAM NEMA8–NEMA23 integrated steppers, as a
// PASSIVE core: bytes and `now` in, frames out (through `send`), the next deadline out. No fd, no
// clock, no timer: AdamBusDriver (adam_bus_driver.hpp, a gateway::SerialBusDriver) is the thin
// poll-loop shell around it, and tests drive it with scripted bytes and an explicit `now`.
//
// The line (manual §1, §5, §6; the manual states no timing):
//  * one request at a time; the reply must arrive within the drive's request_timeout_ms
//    (configuration; measured from the end of the request on the wire), else it is retried up to
//    `retries` times; a drive that never answers fails the command with a reason naming the drive,
//    its slave id and the register;
//  * a reply ends at its expected length (known from the request) or after t3.5 of silence;
//    CRC errors and malformed replies are counted, reported as PROTOCOL_ERROR events and retried;
//  * Modbus exception replies (not described in the manual's §6) fail the command at once
//    (the drive refused; repeating would not help) and are reported as ERROR_REPORT events;
//  * broadcasts (unit 0) get no reply (§5): after one the core keeps the line silent for t3.5
//    plus a guard time before the next frame (not stated in the manual: assumed).
//
// Commands (gateway_command_t, drive counts), one terminal reply each (DONE or FAILED; ARM_MOVE
// first ARMED, then STARTED when fired, then DONE/FAILED):
//  * ENABLE/DISABLE: 0x00D4 = 0 / 1 (§8.67). The drive has no "enabled" status bit, so the core
//    remembers what it wrote (initially from 0x0012 bit 4, power-on state, §8.15).
//  * ARM_MOVE: per axis the profile (0x0096/0x0097 start/stop speed = 0 so the ramps are the
//    planned ones, 0x0098/0x0099 ramp times, 0x00D8 speed) and the target as table entry 0
//    (§8.54: size 1, pointer 0, start offset 200 → register 500). fire(): ONE broadcast
//    0x00DD = 0 ("execute own table entry, absolute, pointer + 0", §5, §8.54) starts every
//    drive at once: start_mechanism "broadcast". The broadcast reaches every drive of the line, so
//    it is used only when every other drive is "neutral" (idle, its table entry 0 = its position:
//    executing it moves nothing); otherwise the armed axes are started one by one with 0x00D0
//    (absolute move), start_mechanism "sequential". DONE when every axis is idle, in position
//    (X12) and at its target; FAILED on an alarm, a limit, or a stop short of the target.
//  * STOP/ESTOP: 0x00C8 = 0 (ramped) / 256 (immediate) (§8.65①); DONE when stopped. Motion
//    commands of those axes end FAILED ("stopped by command N").
//  * JOG: 0x00CA jog word (§8.65②): speed in whole rpm (0…511), sign = direction; velocity 0 =
//    ramped jog stop. DONE once the drive acknowledged (a jog runs until stopped).
//  * HOME: the manual's homing (§8.48): 0x009C low byte = the axis's home input (NPN,
//    active high), then 0x00C9 (direction from the velocity sign, speed in rpm, immediate stop on
//    the sensor, no secondary pass). DONE when idle at home (X15); then target_counts, if not 0,
//    is preset as the home position (0x00D2).
//  * FAULT_RESET: 0x00A4 = 0 (§8.52). SET_OUTPUTS: 0x00A0 (on) / 0x00A1 (off) bit masks (§8.51).
//    SET_POSITION: 0x00D2 (§8.66). PARAM_READ/WRITE: param_t space MODBUS_REGISTER, index =
//    register, width 1 or 2 registers (0: from the register map), 32-bit values low word first.
//  * DISARM: the armed ARM_MOVEs of the trigger (or of the named axes) end FAILED ("disarmed").
//
// Polling: at poll_hz per drive, position+status (0x0004, 4 registers) and outputs+alarm (0x00A2,
// 2 registers). A drive that stops answering goes OFFLINE (event), and ONLINE again when it does.
// Commands and set-up are queued before the polls already waiting (never behind a poll round of
// every drive); stops and the broadcast start go first of all.
//
// Thread contract: single-threaded; every method returns at once.
#pragma once

#include "motion/lcm/reply_error.hpp"

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "motion/adam/rtu.hpp"
#include "motion/adam/status.hpp"
#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"
#include "motion/gateway/bus_driver.hpp"
#include "motion/gateway/command_ledger.hpp"
#include "motion/gateway/serial_stack.hpp"
#include "motion/serial/silence_framer.hpp"

namespace motion::adam_driver {

// One drive of the line, from the configuration.
struct DriveSettings {
  std::string drive;      // configuration name, e.g. "c-drive"
  std::string axis;       // the axis it carries ("" when none)
  std::uint8_t unit = 1;  // Modbus slave id 1…64
  Duration request_timeout = std::chrono::milliseconds(100);
  int retries = 1;
  int home_input = 1;  // 1-based digital input of the home switch (axis homing)
  config::HomingMethod homing_method = config::HomingMethod::kNone;
  // Save (0x00DC = 1) after loading a table entry, before it can be executed (setup table_save,
  // default true): the manual's §8.54 sequence saves the table data, whether the drive executes
  // unsaved data is not said (docs/protocols.md).
  bool table_save = true;
  // Start-up writes from the drive's `setup:` map (register, words).
  std::vector<std::pair<std::uint16_t, std::vector<std::uint16_t>>> setup_writes;
};

struct MasterSettings {
  std::string bus;
  std::string transport;  // for bus_stats_t, e.g. "simserial:rs485"
  adam::rtu::SerialFormat format;
  Duration poll_period = std::chrono::milliseconds(100);
  Duration broadcast_guard = std::chrono::milliseconds(5);  // not in the manual: assumed, a few ms after a broadcast
  // From a write to the port to the frame's first character on the line (bus key
  // egress_latency_us): a frame's end, and with it a broadcast start's time, is dated after it.
  Duration egress_latency{};
  std::vector<DriveSettings> drives;
};

// The settings of `bus` from the configuration: its adam-modbus drives, their axes, timeouts,
// retries, poll rate, and the start-up writes of each drive's `setup:` map:
//   pulses_per_revolution → 0x0024 subdivision (pulses/rev, §8.29); otherwise subdivision
//   (micro-steps of a 200-step motor) → 0x0024 = 200 × subdivision; current_a → 0x000D
//   (0.01 A, §8.10); closed_loop false → 0x0017 = 65535 forces open loop (§8.18).
[[nodiscard]] MasterSettings settings_from_config(const config::Config& config, const config::Bus& bus);

// gateway_reply_t.error_code values: motion::ReplyError (motion/lcm/reply_error.hpp).

class AdamStack final : public gateway::SerialStack {
 public:
  using Send = std::function<bool(std::span<const std::uint8_t>)>;
  using WallClock = gateway::WallClock;  // µs since the epoch of a steady time (reply and sample utimes)

  AdamStack(MasterSettings settings, Send send, gateway::GatewayOutput& out, WallClock wall_clock = {});
  ~AdamStack() override;
  AdamStack(const AdamStack&) = delete;
  AdamStack& operator=(const AdamStack&) = delete;

  // Start-up: per drive read 0x0012 (power-on enable state), apply the setup writes, read 0x0024
  // (pulses/rev, for rpm conversions); then polling begins.
  void start(TimePoint now) override;
  void on_bytes(std::span<const std::uint8_t> bytes, TimePoint now) override;
  // Timeouts, replies closed by silence, polls, the next frame. Returns the next deadline.
  TimePoint process(TimePoint now) override;
  void execute(const motionlcm::gateway_command_t& command, TimePoint now) override;
  void fire(std::int64_t trigger_id, TimePoint now) override;
  // No transaction that would still hold the line at `at` (its request, the reply as long as the
  // register count gives it, the drive's assumed latency and t3.5) starts before `at`, nor any
  // from `at` until fire() or kReservationGrace after `at`.
  void reserve_line(TimePoint at, TimePoint now) override;
  // The longest exchange the stack begins on its own: a poll read (position and status, or outputs
  // and alarm) as the reservation judges it. It bounds every exchange: while a move awaits its
  // trigger no longer one begins (a Save, a long write), and a drive that is not online is not
  // polled (next_to_send()).
  [[nodiscard]] Duration start_wait() const override { return start_wait_; }
  [[nodiscard]] std::string exchange_under_way(TimePoint now) const override;
  // A transport failure (hang-up): every command ends FAILED and the line is "closed".
  void line_lost(const std::string& why, TimePoint now) override;

  [[nodiscard]] motionlcm::bus_stats_t statistics() const override;
  [[nodiscard]] gateway::LedgerCounters ledger_counters() const override { return operations_.counters(); }
  [[nodiscard]] bool ready() const override;
  [[nodiscard]] const MasterSettings& settings() const { return settings_; }

 private:
  struct Drive;
  struct Transaction;
  struct Operation;

  // Line.
  void enqueue(Transaction t, bool urgent = false);
  void send_next(TimePoint now);
  // The queued transaction that may begin next (queue_.end(): none). While a move of the line
  // awaits its trigger, no exchange longer than start_wait() begins (a Save and its flash erase,
  // a long write of another command): the line announced that none of its own holds it longer
  // (LINE_TIMING). Such a transaction, and those after it for the same drive, wait for the start
  // or the move's release; other drives' go by it, a broadcast goes by none. Starts and stops
  // (queued urgent) are never held. Reads of drives that are not online are dropped meanwhile.
  [[nodiscard]] std::deque<Transaction>::iterator next_to_send();
  void on_reply_frame(std::vector<std::uint8_t> frame, TimePoint now);
  void on_timeout(TimePoint now);
  void retry_or_fail(const std::string& why, std::int32_t code, TimePoint now);
  void complete_in_flight(const adam::rtu::Response& response, TimePoint now);
  [[nodiscard]] std::optional<std::size_t> expected_reply_size(std::span<const std::uint8_t> pending) const;
  // Bytes of the reply in flight are pending but fewer than its length (expected_reply_size, or
  // the shortest reply while the function byte has not come).
  [[nodiscard]] bool reply_incomplete() const;
  static constexpr std::size_t kShortestReply = 5;  // unit, function | 0x80, exception code, CRC

  // Drives and polling.
  void run_setup(Drive& d);
  void poll(TimePoint now);
  // A move of the line is armed for a trigger that has not come: drives that are not online are
  // not polled meanwhile (a read to a silent drive holds the line until its timeout, far longer
  // than the start wait the line announces).
  [[nodiscard]] bool awaiting_trigger() const;
  // How long a transaction handed over now holds the line, as a reservation judges it: the
  // egress latency and adam::transaction_time.
  [[nodiscard]] Duration line_time(const adam::rtu::Request& request) const;
  // start_wait(), computed once: the line's format and egress latency do not change.
  [[nodiscard]] Duration longest_poll_read() const;
  Duration start_wait_{};
  void on_position_status(Drive& d, std::span<const std::uint16_t> words, TimePoint now);
  // Its power-on marker (adam_stack.cpp): position reminder X19 read back, and written.
  void read_marker(Drive& d);
  void arm_marker(Drive& d);
  // A power-up seen (`why`): its motion ends, its position is lost, it is set up again.
  void powered_up(Drive& d, const std::string& why);
  void on_outputs_alarm(Drive& d, std::span<const std::uint16_t> words, TimePoint now);
  void publish_status(const Drive& d) const;
  void set_online(Drive& d, bool online, const std::string& why);
  void event(const Drive* d, std::int16_t kind, std::int8_t severity, std::int32_t code, const std::string& text) const;
  [[nodiscard]] Drive* drive_of_axis(const std::string& axis);
  [[nodiscard]] std::string describe(const Transaction& t) const;

  // Commands.
  Operation& open_operation(const motionlcm::gateway_command_t& command, std::vector<Drive*> drives);
  void add_write(Operation& op, Drive& d, const adam::rtu::Request& request, std::function<void(TimePoint)> after = {});
  void when_transferred(Operation& op, std::function<void(TimePoint)> next);
  // Ends the command: the ledger's one terminal reply (DONE with `param` when given; FAILED).
  void finish(std::int64_t command_id, std::int8_t status, const std::string& reason = {}, std::int32_t code = 0,
              std::optional<motionlcm::param_t> param = std::nullopt);
  [[nodiscard]] Operation* operation(std::int64_t id);       // nullptr once it ended
  [[nodiscard]] std::size_t index_of(const Drive& d) const;  // the drive's part key
  void fail_motion_of(const Drive& d, const std::string& reason, std::int32_t code);
  // A fresh position/status sample of `sampled` arrived: updates every drive of `op`.
  void check_motion(Operation& op, const Drive& sampled, TimePoint now);
  void arm_move(Operation& op, TimePoint now);
  void start_armed(Operation& op, TimePoint now);
  void param(Operation& op, const motionlcm::param_t& param);
  // Queues the writes that set `d`'s table entry 0 to its position (and a Save with table_save);
  // false when the drive is offline, moving, owned by a command or its position is unknown.
  bool neutralize(Drive& d);
  [[nodiscard]] bool neutral_for(const Drive& d, const Operation& firing) const;
  [[nodiscard]] std::optional<std::string> busy_reason(const std::vector<Drive*>& drives) const;
  [[nodiscard]] double rpm_of(const Drive& d, double counts_per_s) const;

  MasterSettings settings_;
  Send send_;
  gateway::GatewayOutput& out_;
  WallClock wall_clock_;
  adam::rtu::FrameTiming timing_;
  serial::SilenceFramer framer_;

  std::vector<std::unique_ptr<Drive>> drives_;
  std::deque<Transaction> queue_;
  std::unique_ptr<Transaction> in_flight_;
  TimePoint reply_deadline_ = kNever;
  TimePoint line_free_at_{};  // no frame before this (t3.5 after the last traffic)
  TimePoint next_poll_ = kNever;
  TimePoint reserved_at_ = kNever;  // reserve_line: a start frame goes out then
  // Each command's parts (one per drive: Loading -> Armed -> Started -> Done | Failed | Stopped)
  // and, beside them, what the master does for it (Operation).
  gateway::CommandLedger<std::unique_ptr<Operation>> operations_;  // replies to out_ (set in the constructor)
  bool started_ = false;
  bool line_open_ = true;

  // Statistics.
  std::int64_t tx_frames_ = 0, rx_frames_ = 0, tx_bytes_ = 0, rx_bytes_ = 0;
  std::int64_t errors_ = 0, timeouts_ = 0, retries_ = 0;
  Duration busy_time_{};
  TimePoint first_activity_ = kNever;
  TimePoint last_activity_{};
};

}  // namespace motion::adam_driver
