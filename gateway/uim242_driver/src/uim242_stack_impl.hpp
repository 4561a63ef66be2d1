// Private to Uim242Stack's sources (uim242_stack.cpp: construction, plumbing, bytes in, start-up
// and polling; uim242_stack_commands.cpp: commands): the helpers and the drive, command and move
// types they share. Not installed, not included elsewhere.
#pragma once

#include "motion/uim242_driver/uim242_stack.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <limits>
#include <optional>

#include <fmt/format.h>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/param_t.hpp>

#include "motion/gateway/axis_limits.hpp"
#include "motion/gateway/serial_line.hpp"
#include "motion/lcm/reply_error.hpp"

namespace motion::uim242_driver {

using gateway::Lifecycle;
using motionlcm::event_t;
using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using uim242::Frame;
using uim242::Instruction;
using uim242::Mnemonic;

namespace core_detail {

using namespace std::chrono_literals;

// reply_t error codes: the one list in motion/lcm/reply_error.hpp.
constexpr std::int32_t kMalformed = error_code(ReplyError::kMalformedRequest);
constexpr std::int32_t kUnknownAxis = error_code(ReplyError::kUnknownAxis);
constexpr std::int32_t kOutsideLimits = error_code(ReplyError::kOutsideLimits);
constexpr std::int32_t kAxisDisabled = error_code(ReplyError::kAxisDisabled);
constexpr std::int32_t kAxisOffline = error_code(ReplyError::kAxisOffline);
constexpr std::int32_t kDriveError = error_code(ReplyError::kDriveError);
constexpr std::int32_t kTimeout = error_code(ReplyError::kTimeout);
constexpr std::int32_t kStopped = error_code(ReplyError::kStopped);
constexpr std::int32_t kGroupFault = error_code(ReplyError::kAxisFault);
constexpr std::int32_t kUnsupported = error_code(ReplyError::kUnsupported);

// MCFG (EN/CN §5.4): CM (ramps) + STLIE + STPIE + S3IE..S1IE. Input RTCNs still need a non-zero
// action code in S12CON/S34CON, so enabling them all changes nothing until an input is bound.
constexpr std::int64_t kDefaultMcfg = 0x0400 | 0x0040 | 0x0010 | 0x0007;
constexpr Duration kIdentifyRetry = 1s;
// ICF (UIM242 manual §5.1): ICFG bits 3..0 exist, 15..4 read 0; after a write the controller
// reboots for a time the manual does not give: asked again every kIcfRebootCheck (each ask waits
// its own request timeout), given up after kIcfRebootLimit.
constexpr std::int64_t kIcfgBits = 0x000F;
constexpr Duration kIcfRebootCheck = 100ms;
constexpr Duration kIcfRebootLimit = 5s;
constexpr std::int64_t kSpeedMax = 65535;              // SPD range (#37)
constexpr std::int64_t kAccelerationMax = 65'000'000;  // MAC/MDE value mode (#15)
constexpr std::uint8_t kResetAndEmergencyStop = 0xC;   // sensor action 1100 (EN/CN §8.4)
// S34CON.STALL (bits 15..12): 0000 sends no stall notification whatever STLIE says (EN/CN §8.7,
// §10.2; the stall message id is undocumented); 0001 = no action, notification per STLIE.
constexpr std::uint16_t kStallField = 0xF000;
constexpr std::uint16_t kStallNotifyOnly = 0x1000;
constexpr int kStillPollsBeforeFailure = 2;
// Settling (waiting for rest after a stop or before loading a move): how often `FBK;` asks, and
// how long a motor may take to come to rest.
constexpr Duration kRestCheck = 10ms;
constexpr Duration kRestLimit = 10s;
// The spd0_position_move probe (docs/protocols.md, UIM242 #3): how long after `STP 1;` at speed 0
// the `FBK;` looks for motion. The crawl that starts an axis not known to hold: 1 pps.
constexpr Duration kSpd0ProbeWait = 20ms;
constexpr std::int64_t kCrawlSpeed = 1;

inline Instruction set(Mnemonic m, std::int64_t v) { return Instruction{m, false, v, false}; }
inline Instruction bare(Mnemonic m) { return Instruction{m, false, std::nullopt, false}; }

inline std::int64_t steady_us(TimePoint t) {
  return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
}

inline std::int64_t field(const Frame& f, uim242::Layout layout, std::size_t index) {
  const auto fields = uim242::decode_fields(f.data, layout);
  return fields && index < fields->size() ? (*fields)[index] : 0;
}

inline std::int64_t clamp_rate(double counts_per_s2) {
  return std::clamp<std::int64_t>(std::llround(std::abs(counts_per_s2)), 1, kAccelerationMax);
}

// Duration of a trapezoidal (or, when too short to reach `speed`, triangular) run of `distance`
// counts: a slow short move shows no position change between polls while it still runs.
inline Duration trapezoid_duration(std::int64_t distance, std::int64_t speed, std::int64_t acceleration,
                                   std::int64_t deceleration) {
  const double d = static_cast<double>(std::llabs(distance));
  const double v = static_cast<double>(std::max<std::int64_t>(speed, 1));
  const double a = static_cast<double>(std::max<std::int64_t>(acceleration, 1));
  const double b = static_cast<double>(std::max<std::int64_t>(deceleration, 1));
  const double ramps = v * v / (2 * a) + v * v / (2 * b);
  const double seconds = d >= ramps ? d / v + v / (2 * a) + v / (2 * b) : [&] {
    const double peak = std::sqrt(2 * d * a * b / (a + b));
    return peak / a + peak / b;
  }();
  return std::chrono::duration_cast<Duration>(std::chrono::duration<double>(seconds));
}

}  // namespace core_detail

using namespace core_detail;  // the helpers above, unqualified in the core's sources

struct Uim242Stack::Drive {
  const config::Drive* config = nullptr;
  const config::Axis* axis = nullptr;  // null when no axis uses the drive
  std::string name;
  std::string axis_name;
  int node = 0;
  bool identifying = false;
  bool set_up = false;
  gateway::DriveStatus status;
  std::optional<std::int64_t> last_polled_position;
  int still_polls = 0;
  // Homing by switch: the command waiting for the edge, the register to restore, the offset.
  std::int64_t homing_command = 0;
  uim242::Event homing_edge = uim242::Event::kS1Falling;
  uim242::ScfWrite homing_restore;
  std::int64_t homing_offset = 0;
  // The jog being started (its instructions queued or its rest awaited): a stop ends it, so
  // nothing of it reaches the drive after the stop.
  std::int64_t jog_command = 0;
  // What the controller does with a displacement (STP) loaded at desired speed 0
  // (docs/protocols.md, UIM242 #3): the set-up key spd0_position_move, else found by the probe of
  // the first armed move. Only kHolds is preloaded and started by its speed alone.
  enum class Spd0 { kUnknown, kHolds, kRunsAtLastSpeed, kRefused };
  Spd0 spd0 = Spd0::kUnknown;
};

struct Uim242Stack::Move {
  struct Axis {
    Drive* drive = nullptr;
    std::int64_t target = 0;
    std::int64_t speed = 0;
    std::int64_t acceleration = 0;
    std::int64_t deceleration = 0;
    bool loaded = false;     // armed (or already at the target): its part is Armed
    bool arrived = false;    // its part is Done once the move is Started
    bool preloaded = false;  // `SPD 0; STP n;` loaded (a drive that holds it): its speed starts it
    Duration planned{};      // the trapezoid's duration from where the drive stood at the start
  };
  // The lifecycle is the ledger's (parts Loading -> Armed -> Started -> Done); this only says
  // that the start instructions were handed to the line (fire() must not start it twice).
  std::int64_t command_id = 0;
  std::int64_t trigger_id = 0;
  bool start_sent = false;
  std::vector<Axis> axes;
  std::optional<TimePoint> first_start;
  TimePoint last_start{};
};

}  // namespace motion::uim242_driver
