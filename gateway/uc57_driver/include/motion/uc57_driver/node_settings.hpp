// What the gateway applies to one ADAMPOWER UC57 node, derived from the configuration: the
// drive's `setup:` keys turned into UC57 object values (manual §5.1 manufacturer objects), the
// SDO timing of its bus/drive, and the homing settings of its axis.
//
// setup key          -> UC57 object (manual)
//   micro_steps      -> 2006h subdivision code for 200 full steps x micro_steps (§5.1 table)
//   pulses_per_revolution -> 2006h code for that many pulses/rev (wins over micro_steps)
//                       (both: cia402::uc57::setup_subdivision, the rule the coordinator plans with)
//   current_a        -> 2005h run current, 0.1 A RMS, 1..25 (§5.1; conflict C-19 in uc57_units.hpp)
//   tpdo_mode        -> 1800h:02 / 1801h:02 transmission type: sync = 1 (every SYNC), event = 255,
//                       staggered = G (every G-th SYNC, each TPDO in a slot of its own; Uc57Stack)
//   heartbeat_ms     -> 1017h producer heartbeat (§5 comm. table; no node guarding: 100Ch/100Dh absent)
//   rpdo_sync        -> none: how RPDO1 applies (docs/protocols.md). detect (default): set-up tests it
//                       (Uc57Stack); honoured / on_reception: the answer where the test cannot run
//   closed_loop      -> none: the manual documents no closed-loop object (a warning when true)
//
// Pure: no I/O. Thread contract: values only.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "motion/canopen/types.hpp"
#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"

namespace motion::uc57_driver {

enum class TpdoMode : std::uint8_t { kSync, kEvent, kStaggered };
// The configured answer to "does the drive apply a synchronous RPDO at the SYNC?" (setup rpdo_sync).
enum class RpdoSyncAnswer : std::uint8_t { kDetect, kHonoured, kOnReception };

// CiA 301 transmission types used for the UC57's PDOs (CiA 301 §7.5.2.35/37; manual §5 comm. table).
inline constexpr std::uint8_t kTransmissionSyncEveryCycle = 1;
inline constexpr std::uint8_t kTransmissionEventDriven = 255;

struct NodeSettings {
  std::string drive;  // configuration name, e.g. "a-drive"
  std::string axis;   // the axis driven by this drive; empty when no axis uses it
  canopen::NodeId node = 0;

  std::optional<std::uint16_t> subdivision_code;  // 2006h value to write
  std::optional<std::uint16_t> run_current;       // 2005h value to write (0.1 A)
  TpdoMode tpdo_mode = TpdoMode::kSync;
  std::uint16_t heartbeat_ms = 0;  // 1017h; 0 = heartbeat off (no loss detection)
  RpdoSyncAnswer rpdo_sync = RpdoSyncAnswer::kDetect;

  Duration sdo_timeout = std::chrono::milliseconds(50);
  unsigned sdo_retries = 2;

  config::Homing homing;

  // Problems that make the node impossible to configure (reported, never retried) and remarks.
  std::vector<std::string> errors;
  std::vector<std::string> warnings;

  // 1 or 255; a staggered node's G is the stack's (Uc57Stack::stagger_cycle()).
  [[nodiscard]] std::uint8_t tpdo_transmission_type() const {
    return tpdo_mode == TpdoMode::kEvent ? kTransmissionEventDriven : kTransmissionSyncEveryCycle;
  }
  // "a-drive (node 1)": the prefix of every reason and event text about this node.
  [[nodiscard]] std::string label() const;
};

[[nodiscard]] NodeSettings make_node_settings(const config::Config& config, const config::Bus& bus,
                                              const config::Drive& drive, std::uint16_t default_heartbeat_ms);

}  // namespace motion::uc57_driver
