// The gateway-side protocol stack of the UIROBOT UIM342 (SimpleCAN 3.0, 29-bit CAN): turns
// gateway commands into instructions, matches the drives' ACKs, error reports and real-time
// notifications, polls status, and reports through GatewayOutput.
//
// Passive core: frames and `now` in (on_frame, process, execute, fire), frames out through
// CanStackContext::send, replies/status/events through CanStackContext::out; process() returns the
// next deadline. No sockets, no threads, no clock reads except the optional wall clock that dates
// STARTED replies and status samples (injected, see Uim342Stack::WallClock).
// Thread contract: single-threaded (the gateway's event-loop thread); no method blocks.
//
// Manual sections implemented (UIM342C/S/XS user manual V1.0):
//   §2.1 ACK bit and replies, one outstanding request per node; §2.3 error reports (request fails,
//   ERROR_REPORT event); §2.4/§5.29 notifications (alarms -> ALARM/STALL/LIMIT events and fault,
//   input edges -> INPUT_EDGE, PTP finished -> in position); §2.5 identifiers (codec);
//   §5.1 PP[8] group id (written, then SY[1] reboot: PP values act only after a reboot);
//   §5.2 IC, §5.3 IE[0..2,8] (input and in-position notifications), §5.4 ML identification,
//   §5.7 QE, §5.9 MT (micro-steps, current), §5.10 MO, §5.11 BG (to the group id for a one-frame
//   start; a move of part of a group holds the group's other drives, at rest, with §5.20 PR=0
//   until that BG, docs/protocols.md UIM342 row 8), §5.12 ST (stops at SD: the manual's only host stop, used for STOP and ESTOP),
//   §5.14-5.17 AC/DC/SS/SD, §5.18 JV, §5.19 SP (after PA: "#50" ordering rule), §5.21 PA,
//   §5.22 OG (SET_POSITION, and HOME with `homing.method: none | current-position`: the origin
//   is set where the axis stands, no switch search, and the DONE reason says so; SET_POSITION and
//   the homing offset are kept as a gateway offset: the manual has no "set position" instruction),
//   §4.3/§5.26 IL[i] and §5.13 MF (HOME with `homing.method: switch`: IL[i] of the switch input
//   read (kept), the edge's parameter group DC set, IL[i] armed with action 0x06 "set origin, then
//   decelerate to stop" on the configured edge (FG = 1: only on a real edge), then a jog (JV, AC,
//   DC, BG, §5.18) toward the switch; when the drive has stopped on the switch (IN edge
//   notification and MS[0] polls) IL[i] is restored, the axis goes back to the switch edge
//   (PA = 0, SP, BG) and the homing offset applies; DONE only then. Starting on the switch, the
//   search goes the other way and the origin is the edge leaving it. A search that does not find
//   the switch within travel range / speed + ramps + 2 s is stopped (ST) and FAILS naming the input.
//   A HOME needs the driver on: IL written while it is off would go to EEPROM (§5.26 note)),
//   §5.23 BL, §5.24 MS[0]/MS[1] polling (fills the idle bus, one poll frame handed to the transport at a
//   time, commands first) and MS[0]=0 (FAULT_RESET),
//   §5.28 DI (OP1 output). A request's timeout starts when it is handed to the transport, plus
//   the wire time of the requests ahead of it, so a busy bus is not taken for a silent drive.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"
#include "motion/gateway/can_bus_driver.hpp"
#include "motion/gateway/command_ledger.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/uim342/uim342.hpp"

namespace motion::gateway {

// gateway_reply_t.error_code values: motion::ReplyError (motion/lcm/reply_error.hpp).

struct Uim342NodeConfig {
  std::string drive;  // configuration name, used in every reason ("x-drive (node 5) ...")
  std::string axis;   // the axis commands name; empty when no axis uses the drive
  std::uint8_t node_id = uim342::kMinNodeId;
  std::uint8_t group_id = 0;  // 0: none
  std::chrono::milliseconds request_timeout{50};
  int retries = 2;  // extra attempts after a timeout
  config::SetupMap setup;
  config::Homing homing;           // of the axis (HOME)
  std::int64_t travel_counts = 0;  // (max - min) x steps per unit: bounds a switch search
};

struct Uim342StackConfig {
  std::string bus;
  std::uint32_t bitrate = 500'000;
  std::chrono::milliseconds poll_period{50};
  std::vector<Uim342NodeConfig> nodes;
  std::chrono::milliseconds offline_retry_first{500};  // back-off of a silent node, doubling
  std::chrono::milliseconds offline_retry_max{10'000};
  std::chrono::milliseconds reboot_wait{1'000};  // after SY[1] (group id change)

  // The uim342 drives of `bus` with their axes, timeouts, retries and poll rate.
  [[nodiscard]] static Uim342StackConfig from(const config::Config& config, std::string_view bus);
};

class Uim342Stack final : public CanStack {
 public:
  // Wall time (us since the epoch) of a steady `now`: trigger_utime and sample_utime. The
  // gateway's one clock shape (command_ledger.hpp); default system_wall_clock, tests inject one.
  using WallClock = ::motion::gateway::WallClock;

  Uim342Stack(Uim342StackConfig config, CanStackContext context, WallClock wall_clock = {});
  // What the gateway does: Uim342Stack(config, bus_name, can_driver.context()).
  Uim342Stack(const config::Config& config, std::string_view bus, CanStackContext context, WallClock wall_clock = {});
  ~Uim342Stack() override;

  [[nodiscard]] std::string family() const override { return "uim342"; }
  [[nodiscard]] std::vector<std::string> axes() const override;
  void start(TimePoint now) override;
  bool on_frame(const can::Frame& frame, TimePoint now) override;
  void on_transmitted(const can::Frame& frame, TimePoint now) override;
  TimePoint process(TimePoint now) override;
  void execute(const motionlcm::gateway_command_t& command, TimePoint now) override;
  void fire(std::int64_t trigger_id, TimePoint now) override;
  // A start frame goes out at `at`: no poll is handed over whose answer could still be on the wire
  // then (the requests ahead of it and a few exchanges more), until fire() or 10 ms after `at`. The
  // armed drives are not polled anyway; this keeps the bus's other drives' polls off the start.
  void prepare_fire(TimePoint at, TimePoint now) override;
  // A poll handed over just before the trigger was heard: its exchange, the polls in flight ahead
  // of it and the answer slack (8 exchanges of the longest poll: 1.8 ms at 1 Mbit/s).
  [[nodiscard]] Duration start_wait() const override;
  [[nodiscard]] bool ready() const override;
  void add_statistics(motionlcm::bus_stats_t& stats) const override;
  [[nodiscard]] LedgerCounters ledger_counters() const override;

  struct Counters {
    std::int64_t timeouts = 0;       // requests that got no answer after the last retry
    std::int64_t retries = 0;        // re-sent requests
    std::int64_t malformed = 0;      // frames from our nodes the codec refused
    std::int64_t unexpected = 0;     // well-formed replies nobody waited for
    std::int64_t error_reports = 0;  // CW 0x0F frames that were not ER ACKs
    std::int64_t notifications = 0;  // CW 0x5A frames
    std::int64_t foreign = 0;        // extended frames not from a configured node (left to others)
  };
  [[nodiscard]] const Counters& counters() const { return counters_; }
  // The period each drive is polled at: the configured one, or, when polling every drive at that
  // rate needs more than the bus carries, the time one poll of every drive takes on an otherwise
  // idle bus (an estimate; a CONFIG_MISMATCH warning says so at start).
  [[nodiscard]] Duration poll_period() const;
  [[nodiscard]] std::optional<DriveStatus> status(std::string_view axis) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  Counters counters_;
};

}  // namespace motion::gateway
