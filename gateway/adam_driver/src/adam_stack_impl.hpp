// Private to AdamStack's sources (adam_stack.cpp: settings, the line, drives and polling;
// adam_stack_commands.cpp: commands): the helpers and the drive, transaction and operation
// types they share. Not installed, not included elsewhere.
#pragma once

#include "motion/adam_driver/adam_stack.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include <fmt/format.h>

#include <motionlcm/event_t.hpp>

#include "motion/adam/commands.hpp"
#include "motion/adam/registers.hpp"
#include "motion/adam/table.hpp"
#include "motion/adam/units.hpp"
#include "motion/gateway/power_up_watch.hpp"

namespace motion::adam_driver {

using adam::Reg;
namespace rtu = adam::rtu;
using Reply = motionlcm::gateway_reply_t;
using Event = motionlcm::event_t;

namespace core_detail {

// Status polling reads position and status in one frame (0x0004…0x0007, §8.3, §8.4) and outputs +
// alarm in another.
constexpr std::uint16_t kPositionStatusWords = 4;
constexpr std::uint16_t kOutputsAlarmWords = 2;
inline rtu::Request position_status_read(std::uint8_t unit) {
  return {unit, rtu::ReadRegisters{adam::address(Reg::kPosition), kPositionStatusWords}};
}
inline rtu::Request outputs_alarm_read(std::uint8_t unit) {
  return {unit, rtu::ReadRegisters{adam::address(Reg::kOutputState), kOutputsAlarmWords}};
}
// Where the driver keeps each drive's one-entry table: register 300 + 200 = 500, clear of a stored
// program at 300…499 (the manual's own §8.54 layout).
constexpr std::uint16_t kTableStartOffset = 200;
// A drive seen idle (and not where it should be) this many polls after a start has stopped short.
constexpr int kIdlePollsBeforeShortStop = 3;
// An offline drive is polled this many times less often, without retries, so that it does not
// take the line from the drives that answer.
constexpr int kOfflinePollDivider = 10;
// Default homing speed when the command gives none (assumed: §8.48 gives no default).
constexpr std::uint16_t kDefaultHomingRpm = 60;
constexpr std::uint8_t kMaxOutputs = 8;  // Y0…Y7 (§8.51)
// 0x0017 above any real encoder's lines forces open loop (§8.18).
constexpr std::uint16_t kForceOpenLoopLines = 0xFFFF;
// 0x009A working speed, whole rpm 0…1000 (§8.44): a table entry's speed is written here as well as
// to 0x00D8 (§8.64, 0.01 rpm), so planned speeds are whole rpm (the drive model's grid).
constexpr long kMaxWorkingSpeedRpm = 1000;
// A line reserved for a scheduled start frame (reserve_line) is released this long after the
// start time when its fire never came.
constexpr auto kReservationGrace = std::chrono::milliseconds(5);

inline std::string hex16(std::uint32_t value) { return fmt::format("0x{:04X}", value); }

inline std::string register_name(std::uint16_t address) {
  const auto* info = adam::register_containing(address);
  return info ? " (" + std::string(info->name) + ")" : std::string{};
}

inline std::int64_t setup_int(const config::SetupValue& v) {
  if (const auto* i = std::get_if<long long>(&v)) return *i;
  if (const auto* d = std::get_if<double>(&v)) return std::llround(*d);
  if (const auto* b = std::get_if<bool>(&v)) return *b ? 1 : 0;
  return 0;
}
inline double setup_number(const config::SetupValue& v) {
  if (const auto* d = std::get_if<double>(&v)) return *d;
  return static_cast<double>(setup_int(v));
}

}  // namespace core_detail

using namespace core_detail;  // the helpers above, unqualified in the core's sources

// ---- State --------------------------------------------------------------------------------------

struct AdamStack::Drive {
  DriveSettings cfg;
  bool online = false;
  bool ever_answered = false;
  bool set_up = false;
  bool setup_running = false;
  bool enabled = true;  // until 0x0012 bit 4 is read
  bool homed = false;
  std::uint32_t pulses_per_rev = adam::kDefaultSubdivision;
  std::optional<std::int32_t> position;
  std::optional<adam::DriveStatus> status;
  adam::AlarmState alarm{};
  std::uint16_t outputs = 0;
  double velocity = 0;
  TimePoint position_time{};
  std::int64_t sample_utime = 0;
  std::int64_t target = 0;
  std::optional<std::int32_t> table_entry;  // what this driver loaded as table entry 0
  bool poll_queued = false;
  int poll_skips = 0;
  std::int64_t motion_owner = 0;  // command holding the axis (armed or moving), 0 = none
  gateway::PowerUpWatch power;    // its position samples (on_position_status)
  // Its power-on marker (read_marker()): X19 as written to it by this stack (nullopt: none), as
  // last read, whether a Save went out since it was written (its flash holds it then), whether a
  // read or write of it is queued, and when it was last read.
  std::optional<std::uint32_t> marker;
  std::optional<std::uint32_t> marker_seen;
  bool marker_saved = false;
  bool marker_busy = false;
  TimePoint marker_checked{};
};

struct AdamStack::Transaction {
  Transaction(rtu::Request r, Drive* d, std::int64_t id = 0) : request(std::move(r)), drive(d), command_id(id) {}
  rtu::Request request;
  Drive* drive = nullptr;       // nullptr: broadcast
  std::int64_t command_id = 0;  // 0: polling / start-up
  std::function<void(const rtu::Response&, TimePoint now, TimePoint frame_end)> on_reply;
  std::function<void(const std::string& reason, std::int32_t code)> on_fail;
  int attempts = 0;
  int max_retries = 0;
  bool is_poll = false;
  bool urgent = false;  // a start or a stop: ahead of the queue, never held for a start (next_to_send)
  TimePoint frame_end{};
};

struct AdamStack::Operation {
  motionlcm::gateway_command_t command;
  std::vector<Drive*> drives;  // aligned with command.axes
  std::size_t outstanding = 0;
  std::function<void(TimePoint)> on_transferred;
  // Its drives' samples are checked against `goal` (check_motion): set once its writes are on
  // the drives (a stop, a jog) or its start went out (a move). Armed/started are the ledger's.
  bool watching = false;
  enum class Goal { kNone, kReachTarget, kReachHome, kStandStill } goal = Goal::kNone;
  std::set<Drive*> arrived;
  std::map<Drive*, int> idle_polls;
  std::set<Drive*> seen_moving;
  std::int64_t trigger_utime = 0;
  std::string failure_note;  // added to the reason when one of its writes is never answered
};

}  // namespace motion::adam_driver
