// The plug-in interface between the gateway process and the drives of one bus.
//
// A BusDriver owns one bus (CAN: UIM342 and CANopen stacks on one transport; RS485: Modbus RTU;
// RS232: the UIM242 gateway). It works in drive counts; the Gateway converts to user units and
// speaks LCM. Thread contract: everything runs on the gateway's EventLoop thread; no method
// blocks (drivers use the loop's fds and timers).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <motionlcm/bus_stats_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>

#include "motion/core/clock.hpp"
#include "motion/gateway/command_ledger.hpp"

namespace motion::gateway {

// One axis's drive state, in drive counts.
struct DriveStatus {
  std::int64_t sample_utime = 0;  // when the drive reported it (wall clock, us)
  std::int64_t position_counts = 0;
  // position_counts was read from the drive (false: not yet, e.g. just identified): what the
  // gateway's position record is compared with and kept from (position_record.hpp).
  bool position_read = false;
  double velocity_counts = 0;  // counts/s
  std::int64_t target_counts = 0;
  bool online = false;
  bool enabled = false;
  bool moving = false;
  bool in_position = false;
  bool homed = false;
  bool fault = false;
  std::int32_t fault_code = 0;
  std::string fault_text;
  std::int32_t inputs = 0;  // bit n = input n+1
  std::int32_t outputs = 0;
};

struct DriveEvent {
  std::int16_t kind = 0;     // motionlcm::event_t kinds
  std::int8_t severity = 0;  // motionlcm::event_t severities
  std::int32_t code = 0;     // family-specific
  std::string text;
};

// What a driver read from a drive at set-up that decides how it executes motion (the drive model,
// lcmtypes/drive_model_t.lcm). Unset fields: not read (the configuration's value stands).
struct DriveFacts {
  std::optional<std::uint32_t> counts_per_revolution;  // e.g. UC57 2006h read back (manual §5.1)
  std::optional<double> start_speed_rpm;               // e.g. UC57 200Eh (manual §5.1)
  std::string firmware;
  // false: the drive cannot join the family's one-frame start (e.g. a UC57 that applies RPDOs on
  // reception): its axis starts by its own frame (START_SINGLE). nullopt: as the family does.
  std::optional<bool> one_frame_start = std::nullopt;
  // true: the drive's armed moves start with a crawl before the family's start (a UIM242 that does
  // not hold a displacement loaded at speed 0, docs/protocols.md UIM242 #3): START_UIM242_CRAWL.
  bool crawl_start = false;
  // true: the homed flag of its status is the drive's own (e.g. UC57 status word bit 8), kept by
  // the drive until it is powered up or reset, so a gateway that starts can trust it (and read a
  // cleared one as a power-on marker, position_record.hpp). false: the driver's own bookkeeping.
  bool drive_keeps_homed = false;
};

// Implemented by the Gateway; drivers report through it.
class GatewayOutput {
 public:
  virtual ~GatewayOutput() = default;
  virtual void axis_status(const std::string& axis, const DriveStatus& status) = 0;
  // axis empty: an event of the bus itself (bus-off, CRC errors, ...).
  virtual void axis_event(const std::string& axis, const DriveEvent& event) = 0;
  // Progress/outcome of a command (bus, utime filled in by the Gateway).
  virtual void command_reply(motionlcm::gateway_reply_t reply) = 0;
  // What the driver read from the drive of `axis` once it is set up, reported before the axis's
  // first online status (and again after every new set-up). Drivers of families that read
  // nothing never call it. Default: ignored.
  virtual void drive_facts(const std::string& /*axis*/, const DriveFacts& /*facts*/) {}
  // The drive of `axis` lost power (a power cycle the driver detected, `why` says how): the
  // position it reports is no longer the machine's. The Gateway latches "position lost" until a
  // HOME or SET_POSITION of the axis is DONE (README "Safety and faults"). Default: ignored.
  virtual void position_lost(const std::string& /*axis*/, const std::string& /*why*/) {}
};

class BusDriver {
 public:
  virtual ~BusDriver() = default;

  // Opens the bus, identifies and sets up the drives (asynchronously; progress as events).
  virtual void start() = 0;
  // Carries out a command for axes of this bus (already checked to belong to it). Must end in a
  // reply with status DONE or FAILED (ARM_MOVE: ARMED, then STARTED when fired, or FAILED).
  virtual void execute(const motionlcm::gateway_command_t& command) = 0;
  // Starts every move armed with this trigger id, now, with the bus's one-frame mechanism where
  // the family has one.
  virtual void fire(std::int64_t trigger_id) = 0;
  // The same, with the start frames of several commands (one start mechanism each) handed to the
  // wire back to back in `command_order` (SYNC_TRIGGER2's wire order; ids of other buses and
  // unknown ids are ignored). Default: the driver's own order.
  // A fire is scheduled at `at` (steady clock): keep the bus free for its start frames then
  // (serial lines: no poll transaction that would still run). Default: nothing to do.
  virtual void prepare_fire(TimePoint /*at*/) {}
  // How long before `at` prepare_fire() must come for the bus to be free of the driver's own
  // traffic at `at` (LINE_TIMING): the longest exchange a serial line may have under way, the
  // answer horizon of a CAN bus's polls or its SYNC's quiet time. Default 0.
  [[nodiscard]] virtual Duration start_wait() const { return Duration::zero(); }
  // Over [from, until) (steady clock; until: this bus's fire) start no traffic of the driver's own
  // (polls, a periodic SYNC, retries), so that the host's CPUs are free when the gateways of a
  // start wake to hand their frames over: what arrives meanwhile is still read, and what is due is
  // done at `until`. A command executed, or the fire, ends the hold. Default: nothing (a serial
  // line already begins no exchange that would run into its start, and its polls cost the host
  // little).
  virtual void hold_traffic(TimePoint /*from*/, TimePoint /*until*/) {}
  // How long after its send time the start frame of the moves armed with `trigger_id` is to be
  // handed over: a frame shorter than the one the coordinator's schedule counted waits the
  // difference, so that it ends when that one would. Fired then, it goes out at once, with no
  // second wake-up of the loop in between. Default 0.
  [[nodiscard]] virtual Duration start_delay(std::int64_t /*trigger_id*/) const { return Duration::zero(); }
  virtual void fire_ordered(std::int64_t trigger_id, const std::vector<std::int64_t>& /*command_order*/) {
    fire(trigger_id);
  }
  // Health: statistics per bus, and whether all drives are online and set up.
  [[nodiscard]] virtual std::vector<motionlcm::bus_stats_t> statistics() const = 0;
  [[nodiscard]] virtual bool ready() const = 0;
  // The counters of the bus's command ledgers, summed over its stacks (LEDGER_STATS). Default: none.
  [[nodiscard]] virtual LedgerCounters ledger_counters() const { return {}; }
};

}  // namespace motion::gateway
