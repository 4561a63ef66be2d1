// Private to the UC57 stack's sources (uc57_stack.cpp: construction, process data; uc57_stack_boot.cpp:
// probe, configuration, SDO; uc57_stack_commands.cpp: commands; uc57_stack_rpdo.cpp: the RPDO1
// acceptance test and start facts): the helpers and the node, job
// and task types they share. Not installed, not included elsewhere.
#pragma once
#include "motion/uc57_driver/uc57_stack.hpp"

#include "motion/lcm/reply_error.hpp"

#include <algorithm>
#include <cctype>
#include <cinttypes>
#include <cstdio>
#include <utility>

#include <motionlcm/event_t.hpp>
#include <motionlcm/param_t.hpp>

#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/errors.hpp"
#include "motion/canopen/pdo_config.hpp"
#include "motion/cia402/modes.hpp"
#include "motion/cia402/state_machine.hpp"
#include "motion/cia402/uc57_homing.hpp"
#include "motion/cia402/uc57_od.hpp"
#include "motion/cia402/uc57_units.hpp"
#include "motion/cia402/words.hpp"

namespace motion::uc57_driver {

namespace od = cia402::uc57::index;
using canopen::ObjectAddress;
using cia402::ControlBit;
using cia402::State;
using cia402::StatusBit;
using Reply = motionlcm::gateway_reply_t;
using Command = motionlcm::gateway_command_t;
using Event = motionlcm::event_t;
using gateway::Lifecycle;

namespace stack_detail {

// CiA 402 mode values (conflict C-01: 1/3/6).
constexpr auto kModeProfilePosition = static_cast<std::int8_t>(cia402::ModeOfOperation::kProfilePosition);
constexpr auto kModeProfileVelocity = static_cast<std::int8_t>(cia402::ModeOfOperation::kProfileVelocity);
constexpr auto kModeHoming = static_cast<std::int8_t>(cia402::ModeOfOperation::kHoming);

// 1000h low word: the device profile number; 1018h:01: ADAMPOWER's vendor ID (manual §5 comm. table).
constexpr std::uint32_t kCia402Profile = 402;
constexpr std::uint32_t kAdampowerVendorId = 0x322;
// 2030h output function codes (manual §5.1): 5 = output high level, 6 = output low level.
constexpr std::uint16_t kOutputForcedHigh = 5;
constexpr std::uint16_t kOutputForcedLow = 6;
constexpr std::uint8_t kFirstOutputFunctionSub = 0x0D;  // Y0 = OUT1; 0x0E = Y1 = OUT2
constexpr int kOutputCount = 2;
// 2012h := 1 sets the current position to zero (manual §5.1); 2012h has no other value.
constexpr std::uint16_t kZeroPositionCommand = 1;

inline std::string hex(std::uint32_t value, int digits) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%0*" PRIX32, digits, value);
  return text;
}

inline std::string object_text(ObjectAddress object) {
  return hex(object.index, 4) + ":" + hex(object.subindex, 2).substr(2);
}

template <typename T>
inline std::vector<std::uint8_t> le(T value) {
  return canopen::encode_value<T>(value);
}

// Little-endian unsigned reading of up to 8 bytes (SDO uploads may come with any length 1..4).
inline std::uint64_t read_unsigned(std::span<const std::uint8_t> data) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < data.size() && i < 8; ++i) value |= std::uint64_t{data[i]} << (8 * i);
  return value;
}

inline std::int64_t read_signed(std::span<const std::uint8_t> data) {
  return canopen::sign_extend(read_unsigned(data), static_cast<unsigned>(std::min<std::size_t>(data.size(), 8) * 8));
}

// 603Fh bit field (manual §5.2) as text.
inline std::string fault_bits_text(std::uint16_t bits) {
  static constexpr std::string_view kNames[] = {
      "overcurrent", "overvoltage", "operational amplifier failure", "phase loss", "EEPROM read/write error",
      "undervoltage"};
  std::string text;
  for (std::size_t bit = 0; bit < std::size(kNames); ++bit) {
    if ((bits & (1U << bit)) == 0) continue;
    text += (text.empty() ? "" : ", ") + std::string(kNames[bit]);
  }
  return text.empty() ? "no alarm bit set" : text;
}

inline bool is_fault_state(std::optional<State> state) {
  return state == State::kFault || state == State::kFaultReactionActive;
}

}  // namespace stack_detail

using namespace stack_detail;  // the helpers above, unqualified in the stack's sources

// What a node is busy with on behalf of a command (at most one per node).
enum class Uc57Stack::TaskKind : std::uint8_t {
  kNone,
  kSdoOnly,    // parameters, outputs, set position: ends in its SDO callback
  kPower,      // PowerController towards a target state
  kQuickStop,  // waiting to leave Operation enabled
  kHalt,       // waiting for standstill
  kArming,     // SDO set-up, then bit 4 = 0 and bit 12 = 0 in the drive
  kArmed,      // waiting for fire()
  kTriggered,  // bit 4 = 1 applied by the SYNC, waiting for bit 12 = 1
  kReleasing,  // bit 4 = 0 again, waiting for bit 12 = 0
  kMoving,     // waiting for bit 10 / bit 15
  kJog,        // PV settings in, waiting for them to show
  kHoming,     // edge applied, waiting for the homing result
};

struct Uc57Stack::Node {
  enum class Phase : std::uint8_t { kConfigError, kOffline, kConfiguring, kStarting, kOperational };

  NodeSettings settings;
  Phase phase = Phase::kOffline;
  unsigned session = 0;  // bumped by every (re)configuration: stale callbacks are dropped
  TimePoint retry_at = kNever;
  bool awaiting_slot = false;  // offline, to be configured once the window has room (begin_probe)
  Duration backoff{};
  TimePoint starting_deadline = kNever;
  bool offline_reported = false;  // an offline event went out since the node was last online
  bool ever_operational = false;  // its position has meant something: a later boot-up loses it
  std::string offline_reason;

  RpdoLayout layout = RpdoLayout::kControlwordTarget;
  bool remap_refused = false;  // remembered across re-configurations
  // RPDO1 transmission type 1 aborted by the drive (remembered): RPDO1 runs asynchronous (FFh).
  bool sync_refused = false;
  // How RPDO1 applies, found at set-up (rpdo_acceptance_op): at the SYNC (the one-frame start
  // and preloading work) or on reception (moves start node by node, never preloaded).
  bool rpdo_at_sync = true;
  std::string rpdo_finding;  // "honoured (detected)", "refused", ...: events and the drive model
  Duration rpdo_end{};       // wire_sent_ after this node's last RPDO1 (start skew)
  can::Frame last_rpdo{};    // that RPDO1
  bool tpdo2_active = true;
  std::uint32_t pulses_per_rev = cia402::uc57::kDefaultPulsesPerRevolution;
  double start_speed = 0;  // 200Eh, pulses/s

  RpdoImage image;                   // as last sent, or as read from the drive
  bool preloaded = false;            // the start image (bit 4 = 1) waits in the drive for a SYNC
  std::deque<RpdoImage> rpdo_queue;  // one image per SYNC cycle
  std::uint64_t image_sync = 0;      // the SYNC (sent count) that applies the last sent image
  cia402::PowerController power;
  std::uint8_t power_transition = 0;  // the transition last awaited (named in timeouts)

  std::optional<std::uint16_t> statusword;
  std::int8_t mode_display = 0;
  // Synchronous TPDOs: this SYNC's TPDO1, held until its TPDO2 so that both count as one sample
  // (staggered: the TPDO2 of the next SYNC, its slot follows TPDO1's).
  std::optional<Tpdo1> held_tpdo1;
  std::uint64_t held_sample = 0;  // the SYNC index held_tpdo1 answered
  std::uint64_t sample_sync = 0;  // the SYNC index of the last statusword taken

  // Staggered TPDOs (uc57_stack_stagger.cpp): the node's place among the staggered nodes (-1: not
  // staggered), its planned slots, the slots of TPDO1/TPDO2 as planned, then as observed (set
  // once the TPDO's count is armed), and whether a slot other than planned was reported.
  int stagger_index = -1;
  bool stagger_refused = false;  // transmission type G aborted: type 1 (remembered)
  std::array<std::optional<unsigned>, 2> slot;
  std::array<std::optional<unsigned>, 2> slot_candidate;  // another slot seen once
  bool slot_reported = false;
  gateway::DriveStatus status;
  bool fault_seen = false;  // a fault edge was handled (event, 603Fh read)
  TimePoint next_position_poll = kNever;
  bool position_poll_in_flight = false;

  // The running task.
  TaskKind task = TaskKind::kNone;
  std::int64_t task_command = 0;
  TimePoint task_deadline = kNever;
  bool task_watching = false;  // SDO part done, the statusword now decides
};

struct Uc57Stack::ConfigOp {
  std::function<void(Continue)> run;
};

}  // namespace motion::uc57_driver
