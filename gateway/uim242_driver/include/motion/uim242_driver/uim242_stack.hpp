// The gateway-side protocol core of one RS232 bus: a UIM2501/2502 RS232-CAN gateway with UIM242
// controllers behind it (manuals EN / CN Ver.1301/1302). Implements the
// command semantics of motion::gateway::BusDriver in drive counts (pulses).
//
// Passive, fd-free: bytes and `now` in (on_bytes), bytes out (context.send), replies/status/events
// out (context.out), next deadline out (process). A gateway::SerialStack: Uim242BusDriver
// (uim242_bus_driver.hpp) wraps it in the serial poll-loop shell, which on the fd readable calls
// on_bytes(), on the timer process(), execute()/fire() as they come, and after EVERY call
// process(now), re-arming its timer at the result.
// Thread contract: one thread (the gateway's loop).
//
// Behaviour:
// * start(): per drive `MDL η;` (identify; a model other than 18 02 is a CONFIG_MISMATCH event),
//   then the set-up: `SCF;` and, when S34CON.STALL is 0000 (which silences the stall
//   notification), S34CON.STALL := 0001 (notify, no action); `MCS`, `CUR` (setup micro_steps,
//   current_a), `MCF` (setup mcfg, default CM + STPIE + STLIE: ramps, A8 arrival and stall
//   notifications), `QER`, `SQT`, `MMS 0;` `MMD 0;` — all after `ICF` when `icfg` is configured
//   (read first; written only when different, then the reboot is waited out and the value read
//   back, §5.1),
//   (exact trapezoids), `STP 0;` (velocity mode, at rest). An unanswered drive is offline and
//   identified again every second.
// * Polling at poll_hz, one request at a time: `FBK;` (enabled, speed) and `QEC;` (position).
// * ARM_MOVE: `MAC a; MDE d; SPD 0;` (brakes whatever still runs), then at rest (below) `STP
//   (target - position);` — the move is loaded with zero speed and does not run (PT mode, EN/CN
//   §6.1). STP is relative to the position at its receipt (EN/CN #44), so the position it is
//   computed from is read with the motor at rest: a `QEC;` of a decelerating motor would leave the
//   move off by the counts run meanwhile. ARMED when every axis is loaded.
//   That a displacement loaded at speed 0 holds still is an inference (docs/protocols.md, UIM242
//   #3): only a drive known to hold (set-up spd0_position_move: holds, or found by the probe of
//   its first armed move: at rest `STP 1;`, `FBK;` 20 ms later, `STP 0;` — an EE 66 is
//   "refused", motion "runs_at_last_speed") is preloaded. Any other axis is loaded with nothing
//   and started by a crawl: `SPD ±1; STP n;` (PT at 1 pps, a fraction of a count before the
//   start) and then its speed.
// * "At rest" (settle): `FBK;` until the actual speed is 0 (re-asked every 10 ms, given up after
//   10 s naming the drive and its speed), then `QEC;`: the real position goes out in the axis
//   state, not moving, before whatever waited for it goes on.
// * fire(trigger): when the armed axes are every controller of the bus and share one speed, one
//   `gSPD v;` starts them all ("broadcast", skew 0); otherwise `SPD v_i;` axis by axis
//   ("sequential", skew = the serial time of the other axes' starts). trigger 0 = at once.
//   With a crawling axis the crawl instructions of every such axis go first ("crawl_broadcast" /
//   "crawl_sequential"; STARTED's time is the first crawl instruction, its skew runs to the last
//   start instruction).
//   DONE when every axis reported A8 or was polled at its target at rest.
// * JOG `STP 0; MAC; MDE; SPD 0;`, then at rest (settle) `STP n; SPD |v|;` (`SPD ±1;` first
//   unless the drive is known to hold a displacement at speed 0): a position move
//   (PT mode, EN/CN §6.1) to the last whole count inside the axis limit in the jog's direction, at
//   the jog's speed. The drive itself decelerates onto the limit, so a stop that reaches it late
//   over the serial line (the gateway's jog watch) cannot let it pass. Less than one whole count
//   from the limit: FAILED, outside limits. STOP `STP 0;` (ramped stop, leaves PT), DONE at rest with the
//   position re-read (settle): a move planned right after it starts from where the axis really
//   stopped. ESTOP `OFF;` (the only
//   immediate stop the manual offers; `gOFF;` when every drive of the bus is named).
//   ENABLE `ENA;`, DISABLE `OFF;`, SET_POSITION `ORG η;`, SET_OUTPUTS `DOU η;` (output 1 = P4),
//   FAULT_RESET clears the latched stall and checks the drive answers (`FBK;`).
// * HOME (offset = the command's target_counts, speed = its velocity): method none / current
//   position -> `ORG offset;`; switch on input n -> S12CON/S34CON action 1100 (reset position +
//   emergency stop) on the falling edge of Sn with its RTCN enabled, `STP 0; SPD v;`, wait for
//   the edge RTCN, restore the registers, `SPD 0; ORG offset;`. Homed and at the offset in the
//   axis state before DONE (as every command's state: ENABLE, DISABLE, SET_POSITION, outputs).
// * PARAM_READ/WRITE: param_t UIM242_INSTRUCTION, mnemonic = the instruction (first three letters,
//   "MCFG" = MCF), subindex = SCF register 0..3 / STG port 0..2 (a 16-bit value), else -1. CUR
//   and MCS are read from the basic ACK of `;`. Values outside the instruction's range fail.
// * line_lost(): the port hung up: every command ends FAILED ("serial line of bus B lost: why"),
//   queued requests are dropped, the drives go offline; the next start() identifies them again.
// * Every command ends in exactly one DONE or FAILED; a failure names drive, node and instruction.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

#include <motionlcm/bus_stats_t.hpp>
#include <motionlcm/gateway_command_t.hpp>

#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"
#include "motion/gateway/bus_driver.hpp"
#include "motion/gateway/command_ledger.hpp"
#include "motion/gateway/serial_stack.hpp"
#include "motion/uim242/feedback.hpp"
#include "motion/uim242_driver/request_channel.hpp"

namespace motion::uim242_driver {

struct CoreContext {
  std::function<void(std::span<const std::uint8_t>)> send;  // bytes to the RS232 line
  gateway::GatewayOutput* out = nullptr;
  // Wall-clock utime of a core time point (trigger_utime, sample_utime); default: steady microseconds.
  gateway::WallClock utime_of;
};

class Uim242Stack final : public gateway::SerialStack {
 public:
  Uim242Stack(const config::Config& config, const std::string& bus, CoreContext context);
  ~Uim242Stack() override;
  Uim242Stack(const Uim242Stack&) = delete;
  Uim242Stack& operator=(const Uim242Stack&) = delete;

  void start(TimePoint now) override;
  void on_bytes(std::span<const std::uint8_t> bytes, TimePoint now) override;
  TimePoint process(TimePoint now) override;
  void execute(const motionlcm::gateway_command_t& command, TimePoint now) override;
  void fire(std::int64_t trigger_id, TimePoint now) override;
  void reserve_line(TimePoint at, TimePoint now) override;
  // The longest exchange the stack begins on its own between moves, a poll (`FBK;`, `QEC;`, with
  // a selection first when the line has several controllers), as the reservation judges it
  // (RequestChannel::exchange_time). It bounds every exchange while a move awaits its trigger
  // (awaiting_trigger()): no longer one begins but starts and stops (RequestChannel::limit), and
  // an offline controller's identification, which would hold the line until its timeout, is not
  // tried.
  [[nodiscard]] Duration start_wait() const override { return start_wait_; }
  // A move started by one global `SPD` shorter than the longest form the coordinator's schedule
  // counted (`gSPD 65535;`): the characters it lacks, at the line's character time.
  [[nodiscard]] Duration start_delay(std::int64_t trigger_id) const override;
  [[nodiscard]] std::string exchange_under_way(TimePoint now) const override { return channel_.under_way(now); }
  void line_lost(const std::string& why, TimePoint now) override;

  [[nodiscard]] bool ready() const override;
  [[nodiscard]] motionlcm::bus_stats_t statistics() const override;
  [[nodiscard]] gateway::LedgerCounters ledger_counters() const override { return commands_.counters(); }
  [[nodiscard]] std::vector<std::string> axes() const;
  // ICF writes sent and acknowledged since construction (each is an EEPROM write and a reboot).
  [[nodiscard]] std::int64_t icf_writes() const noexcept { return icf_writes_; }
  // What `drive` does with a displacement loaded at desired speed 0, as configured or found:
  // "holds", "runs_at_last_speed", "refused", or "" while unknown.
  [[nodiscard]] std::string spd0_position_move(std::string_view drive) const;

 private:
  struct Drive;
  // A command's parts (one per drive it names) live in the gateway's CommandLedger; beside them
  // the instruction sequences still running for it (DONE when none is left).
  struct CommandData {
    std::size_t outstanding = 0;
    std::string unreached;  // a stop's drives that do not answer: the command fails naming them
  };
  using Command = gateway::CommandLedger<CommandData>::Entry;
  struct Move;

  // ---- plumbing
  void submit(Drive& d, uim242::Instruction in, std::int64_t group,
              std::function<void(const uim242::Frame&, TimePoint)> on_reply, bool front = false);
  void run_sequence(Command& c, Drive& d, std::vector<uim242::Instruction> steps,
                    const std::function<void(TimePoint)>& done);
  void on_frame(const uim242::Frame& frame, TimePoint now);
  void on_notification(const uim242::Notification& n, TimePoint now);
  void finish(std::int64_t command_id, bool ok, const std::string& reason = {}, std::int32_t error_code = 0,
              std::optional<motionlcm::param_t> param = std::nullopt);
  void part_done(std::int64_t command_id);
  void event(const Drive& d, std::int16_t kind, std::int8_t severity, std::int32_t code, const std::string& text);
  void publish(Drive& d, TimePoint now);
  // The drive model's facts of `d` (DriveFacts::crawl_start once its move start is known).
  void report_facts(const Drive& d);

  // ---- start-up and polling
  void identify(Drive& d, TimePoint now);
  // FBK first: a drive found moving is stopped (STP 0) and seen at rest before set_up().
  void stop_then_set_up(Drive& d);
  void set_up_at_rest(Drive& d, TimePoint give_up);
  void set_up(Drive& d);
  void set_up_steps(Drive& d);  // everything after ICFG (see set_up)
  void verify_icfg(Drive& d, std::int64_t wanted, TimePoint give_up, TimePoint now);
  void after(TimePoint due, std::function<void(TimePoint)> then);
  void poll(TimePoint now);
  // A move of the line is armed for a trigger that has not come: the drives that do not answer
  // are not tried meanwhile (an exchange with a silent controller holds the line until its
  // timeout, far longer than the start wait the line announces).
  [[nodiscard]] bool awaiting_trigger() const;
  void mark_offline(Drive& d, const std::string& reason, TimePoint now);

  // ---- commands
  Drive* drive_of_axis(const std::string& axis);
  [[nodiscard]] std::size_t index_of(const Drive& d) const;  // the drive's part key
  // Runs `f` for each axis's drive; false (the command failed) for an axis of no drive of this
  // bus or, unless `stops`, of a drive offline. With `stops` an offline drive gets its stop all
  // the same (stop_unanswering) and the command ends FAILED naming it.
  bool for_each_axis(const motionlcm::gateway_command_t& command,
                     const std::function<void(Drive&, const motionlcm::axis_command_t&)>& f, bool stops = false);
  void stop_unanswering(Drive& d, bool estop, std::int64_t command_id);
  void arm(const motionlcm::gateway_command_t& command, TimePoint now);
  // `scheduled`: when the start was reserved for (reserve_line), the time of the fire without a
  // reservation; a global speed shorter than the longest form goes no sooner than
  // global_start_shortfall() after it.
  void start_move(Move& m, TimePoint scheduled);
  // What the global speed starting the move's axes not at their target yet lacks to the longest
  // form's wire time (zero when the move starts drive by drive or crawls).
  [[nodiscard]] Duration global_start_shortfall(const Move& m) const;
  TimePoint reserved_at_ = kNever;  // reserve_line: the start time, until fire()
  // The first armed move of a drive whose spd0_position_move is unknown: at rest `STP 1;`, after
  // kSpd0ProbeWait `FBK;` (moving: runs_at_last_speed; EE 66 to the STP: refused; else holds),
  // `STP 0;`; then `then` (the drive may have moved one count: settle again).
  void probe_spd0(Drive& d, std::int64_t group, const std::function<void(TimePoint)>& then);
  // The instructions that run `d` by `displacement` at `speed` from rest: `STP n; SPD v;`, with a
  // `SPD ±1;` crawl first unless `d` holds a displacement loaded at speed 0.
  [[nodiscard]] std::vector<uim242::Instruction> position_run(const Drive& d, std::int64_t displacement,
                                                              std::int64_t speed) const;
  void move_axis_arrived(Drive& d, TimePoint now);
  void fail_moves_of(const Drive& d, const std::string& reason, std::int32_t code);
  // Waits (for command `group`) until `d` is at rest, re-reads and publishes its position, then
  // calls `then`; the command FAILS when it still moves at `give_up`.
  void settle(Drive& d, std::int64_t group, TimePoint give_up, std::function<void(TimePoint)> then);
  void home(Command& c, Drive& d, const config::Axis& axis, const motionlcm::axis_command_t& a);
  void jog(Command& c, Drive& d, const motionlcm::axis_command_t& a);
  void homed(Drive& d, std::int64_t offset, TimePoint now);
  void param(const motionlcm::gateway_command_t& command, Drive& d, bool write);

  std::string bus_;
  std::string transport_;
  CoreContext context_;
  Duration poll_period_;
  // start_wait(), computed once the drives and the channel are set up (neither changes after).
  [[nodiscard]] Duration longest_poll_exchange() const;
  Duration start_wait_{};
  RequestChannel channel_;
  uim242::FeedbackFramer framer_;
  std::vector<std::unique_ptr<Drive>> drives_;
  gateway::CommandLedger<CommandData> commands_{[this](motionlcm::gateway_reply_t reply) {
    if (context_.out) context_.out->command_reply(std::move(reply));
  }};
  std::vector<std::unique_ptr<Move>> moves_;
  struct RestCheck {
    TimePoint due;
    Drive* drive = nullptr;
    std::int64_t group = 0;
    TimePoint give_up;
    std::function<void(TimePoint)> then;
  };
  std::vector<RestCheck> rest_checks_;  // settles waiting for their next `FBK;`
  struct Timer {
    TimePoint due;
    std::function<void(TimePoint)> then;
  };
  std::vector<Timer> timers_;  // one-shot waits (an ICF reboot)
  std::int64_t icf_writes_ = 0;
  TimePoint next_poll_{};
  TimePoint next_identify_{};
  std::int64_t protocol_errors_ = 0;
  int polls_outstanding_ = 0;  // poll requests queued or in flight (a new round waits for them)
  bool started_ = false;
};

}  // namespace motion::uim242_driver
