// The system configuration (YAML), loaded and validated before any program does anything else.
//
// Validation is complete, not fail-fast: every problem is reported as
// "<file>:<line>:<column>: <key path>: <reason>" so a user fixes a file in one pass. Checked:
// YAML syntax, unknown keys, wrong types, ranges (node ids per family, group ids), duplicates
// (bus/drive/axis names, node ids in one bus's address space, group ids colliding with node ids),
// references (drive on an undeclared bus, axis on an undeclared drive, family on a bus of the wrong
// kind), non-positive scales and limits, per-family drive set-up keys and ranges.
//
// Thread contract: the loaded Config is an immutable value; load functions are reentrant.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "motion/core/file_access.hpp"

namespace motion::config {

enum class Family { kUim342, kUim242, kUc57, kAdamModbus };
[[nodiscard]] std::string_view to_string(Family family);
[[nodiscard]] std::optional<Family> parse_family(std::string_view text);

struct IdRange {
  int min;
  int max;
};
// Valid node ids: UIM342 5..126 (SimpleCAN §5.1), UIM242 5..125, UC57 CANopen 1..127 (§4.1.2),
// ADAM Modbus 1..64 (manual §1: at most 64 nodes).
[[nodiscard]] IdRange node_id_range(Family family);

struct Location {
  std::string file;
  int line = 0;    // 1-based
  int column = 0;  // 1-based
};

// Where each key of an item was written (for errors found after reading, e.g. references).
struct KeyLocations {
  Location item;
  std::map<std::string, Location, std::less<>> keys;
  [[nodiscard]] const Location& of(std::string_view key) const {
    auto it = keys.find(key);
    return it == keys.end() ? item : it->second;
  }
};

struct ConfigError {
  Location where;
  std::string key;  // dotted path, e.g. "drives[2].node_id"
  std::string reason;
  [[nodiscard]] std::string message() const;
};

struct LcmSettings {
  std::string url;  // empty: LCM_DEFAULT_URL or LCM's default
  std::string channel_prefix = "MOTION_";
};

enum class TransportKind {
  kSimCan,     // simcan:<bus>      simulated CAN bus hosted by motion-sim
  kSocketCan,  // socketcan:<if>    Linux SocketCAN interface
  kSerial,     // serial:<device>   a serial port (RS485 Modbus RTU, RS232 UIM2501/2502 gateway)
  kSimSerial,  // simserial:<name>  a pseudo-terminal created by motion-sim
  kUiMessage,  // uimessage:<device> UIROBOT UIM2513 (RS232) / UIM2533 (USB) gateway: SimpleCAN
               //                    29-bit frames as 16-byte UIMessages over a serial port
};
// CAN buses carry can::Frames (protocol stacks, motionctl dump/send): simcan, socketcan and
// uimessage (which takes SimpleCAN 3.0 frames only).
[[nodiscard]] bool is_can(TransportKind kind);

// Which bytes the UIMessage CRC covers (UIM342 manual §2.6 / Appendix-1 say SM..d8; UIROBOT's
// gateway software computes it over ID..d8): what a uimessage: bus sends. kDetect (the default):
// the transport starts with SM..d8 and follows the coverage of the gateway's replies.
enum class UiMessageCrc { kDetect, kStartToAux, kIdToAux };

// The longest egress latency a bus may state (Bus::egress_latency_us), microseconds.
inline constexpr int kMaxEgressLatencyUs = 20000;
// bus cpu_latency_us: the most a wake-up from idle may take, when limited at all.
inline constexpr int kMaxCpuLatencyUs = 10000;
// bus sched_slice_us: the slices the kernel takes (it clamps sched_attr::sched_runtime to these).
inline constexpr int kMinSchedSliceUs = 100;
inline constexpr int kMaxSchedSliceUs = 100000;

struct Bus {
  std::string name;
  std::string transport;  // as written, e.g. "simcan:lab"
  TransportKind kind = TransportKind::kSimCan;
  std::string target;      // the part after the scheme
  int bitrate = 500000;    // CAN
  bool bus_timing = true;  // simulated CAN: bit-timing model on
  int baud = 115200;       // serial
  char parity = 'N';       // 'N', 'E', 'O'
  int stop_bits = 1;
  UiMessageCrc uimessage_crc = UiMessageCrc::kDetect;  // uimessage: the CRC coverage sent
  bool uimessage_crc_strict = false;                   // uimessage: receive only that coverage (default: either)
  int request_timeout_ms = 50;
  int retries = 2;
  double poll_hz = 20.0;      // status polling rate per drive
  int realtime_priority = 0;  // the gateway's loop thread under SCHED_FIFO at this priority (1..99); 0: not
  int timer_spin_us = 0;      // the gateway's precise deadlines: woken this early, the rest waited busy (0..500)
  // Under normal scheduling, the slice the gateway's loop thread asks of the kernel (EEVDF, Linux
  // 6.12+): a woken loop preempts a thread with a longer one at once. 0, the default: the kernel's.
  int sched_slice_us = 0;  // 0 or kMinSchedSliceUs..kMaxSchedSliceUs
  // While the gateway runs, no CPU of the host takes longer than this to wake from idle (the
  // kernel's PM QoS CPU latency request; 0: idle CPUs poll); -1, the default: the host's own setting.
  int cpu_latency_us = -1;
  // From the gateway's hand-over of a frame (write, send) to its first bit on the wire: a USB
  // adapter's transfer, a driver's queue (0..20000 us, below coordinator.trigger_lead_min_ms; 0: none
  // known). Start frames are handed over this much before a trigger's send time, and a serial line
  // dates its frames by it.
  int egress_latency_us = 0;  // 0..kMaxEgressLatencyUs
  bool kernel_sync = true;    // socketcan: the periodic CANopen SYNC sent by the kernel (CAN_BCM), not the loop
  KeyLocations where;
};

// A scalar drive set-up value, typed by the family's schema.
using SetupValue = std::variant<bool, long long, double, std::string>;
using SetupMap = std::map<std::string, SetupValue>;

// Typed reads of a set-up key (the family's schema has checked the types): nullopt when the key
// is not set. A number also reads integers and flags (0/1); an integer reads a whole-valued
// number; a flag reads an integer (non-zero).
[[nodiscard]] std::optional<double> setup_number(const SetupMap& setup, std::string_view key);
[[nodiscard]] std::optional<long long> setup_integer(const SetupMap& setup, std::string_view key);
[[nodiscard]] std::optional<bool> setup_flag(const SetupMap& setup, std::string_view key);
[[nodiscard]] std::optional<std::string> setup_text(const SetupMap& setup, std::string_view key);

struct Drive {
  std::string name;
  Family family = Family::kUim342;
  std::string bus;
  int node_id = 0;
  int group_id = 0;                       // UIM342 only; 0 = none
  std::optional<int> request_timeout_ms;  // overrides the bus's
  std::optional<int> retries;
  SetupMap setup;  // applied by the gateway at start-up
  KeyLocations where;

  [[nodiscard]] std::optional<double> setup_number(std::string_view key) const {
    return config::setup_number(setup, key);
  }
  [[nodiscard]] std::optional<long long> setup_integer(std::string_view key) const {
    return config::setup_integer(setup, key);
  }
  [[nodiscard]] std::optional<bool> setup_flag(std::string_view key) const { return config::setup_flag(setup, key); }
  [[nodiscard]] std::optional<std::string> setup_text(std::string_view key) const {
    return config::setup_text(setup, key);
  }
};

struct Limits {
  double min_position = 0;
  double max_position = 0;
  double max_velocity = 0;      // user units/s
  double max_acceleration = 0;  // user units/s^2
};

enum class HomingMethod { kNone, kSwitch, kCurrentPosition };
// The input edge that means "the switch is reached" (UIM342 IL[i] edge, manual §5.26).
enum class HomingEdge { kFalling, kRising };
struct Homing {
  HomingMethod method = HomingMethod::kNone;
  int input = 1;                           // digital input of the home switch (1-based)
  HomingEdge edge = HomingEdge::kFalling;  // `edge: falling|rising`; default falling (§5.26 example)
  double velocity = 0;                     // user units/s, sign = direction; 0 = 10 % of max velocity towards min
  double offset = 0;                       // position assigned at the switch, user units
  std::string method_name;                 // as written (validated per family at load: homing_methods())
  KeyLocations where;                      // of the homing keys
};

// The homing methods (configuration names) and inputs a family's gateway implements; load refuses
// others naming the key, e.g. "axes[0].homing.method: 'index' is not a homing method of family
// uim342 (none, switch, current-position)".
struct HomingSupport {
  std::vector<std::string_view> methods;
  int max_input = 8;        // inputs 1..max_input
  std::string_view inputs;  // how the family names them, for the error text
};
[[nodiscard]] HomingSupport homing_support(Family family);

struct Axis {
  std::string name;
  std::string drive;
  std::string unit = "mm";
  double steps_per_unit = 0;  // drive counts per user unit
  bool invert = false;
  Limits limits;
  Homing homing;
  KeyLocations where;
};

struct CoordinatorSettings {
  int default_timeout_ms = 60000;  // per request, when the client gives none
  int progress_period_ms = 200;
  // A trigger of several buses schedules the start this far ahead at most (and until enough
  // TRIGGER_HEARD samples exist); it adapts down to what the gateways take to hear triggers, not
  // below trigger_lead_min_ms (README "Scheduled starts"). Equal: a fixed lead.
  int trigger_lead_ms = 30;
  int trigger_lead_min_ms = 5;
  int gateway_timeout_ms = 1500;  // heartbeat silence after which a gateway is lost
  int arm_timeout_ms = 2000;
  // How long a gateway keeps a move armed that no trigger starts before it releases the move itself
  // (README "Safety and faults"); 0: arm_timeout_ms + trigger_lead_ms + gateway_timeout_ms + the
  // longest arming line time of any bus. Set: must exceed arm_timeout_ms + trigger_lead_ms.
  int arm_expiry_ms = 0;
  // Requests in progress at once (stops and e-stops always pass): beyond it a request is
  // REJECTED with kBusy ("retry later") instead of queueing without bound.
  int max_active_requests = 256;
  double position_tolerance = 0.0;  // user units; 0 = one drive count
};

// Who may command the coordinator (README "Security"). The files are read by the programs that
// use them (motion::security), not by the loader; relative paths are taken from the
// configuration file's folder.
struct SecuritySettings {
  enum class Mode { kOff, kEnforce };
  // kOff: plain request_t on REQUEST is executed; signed requests on SREQUEST too (verified when
  // authorized_keys is set, else unwrapped); likewise gateway commands, plain or signed.
  // kEnforce: only signed requests that verify and whose key's role allows them; a plain request
  // moves nothing (a SECURITY event, no reply); gateways execute only commands signed with the
  // coordinator's key (key, coordinator_public_key: both required); gateways publish what they
  // publish signed with gateway_key (required) and the coordinator acts only on what verifies
  // against the `gateway` keys of authorized_keys.
  Mode mode = Mode::kOff;
  std::string authorized_keys;  // "<base64 public key> <name> <role>" per line; required by kEnforce
  std::string key;              // the coordinator's private key: it signs its gateway commands with it
  std::string
      coordinator_public_key;  // the coordinator's public key (its .pub file): gateways verify its commands, triggers and ACTIVE_MOVES with it, clients its replies
  // A gateway's private key (role gateway in authorized_keys): it signs AXIS_STATE, GW_REPLY,
  // DRIVE_MODEL, ORPHANED_MOVES and its events with it. "{bus}" in the path is replaced by the gateway's bus,
  // for one key per bus.
  std::string gateway_key;
  // The gateways' public keys for clients that cannot read authorized_keys (motionctl, motion-web):
  // a file in authorized_keys' format of which only the lines of role gateway are used; it holds
  // no secret (world-readable is fine). Empty: those clients read authorized_keys.
  std::string gateway_public_keys;
  // Where a client finds the gateway keys it verifies axis states with: gateway_public_keys when
  // set, else authorized_keys; and the name of that setting ("security.gateway_public_keys").
  [[nodiscard]] const std::string& gateway_keys_file() const {
    return gateway_public_keys.empty() ? authorized_keys : gateway_public_keys;
  }
  [[nodiscard]] const char* gateway_keys_setting() const {
    return gateway_public_keys.empty() ? "security.authorized_keys" : "security.gateway_public_keys";
  }
  int window_ms = 2000;  // a signed request's utime must be within this of the coordinator's clock
  KeyLocations where;
};
[[nodiscard]] const char* to_string(SecuritySettings::Mode mode);

struct SimulationSettings {
  std::string runtime_dir;  // where simulated buses/ptys appear; empty: $MOTION_SIM_DIR or /tmp/motion-sim
  // Who besides motion-sim's user may open its bus sockets and ptys (and so inject frames): a group
  // name (mode 0660), or empty: nobody (0600).
  std::string group;
  int reply_latency_us = 200;
  // What a simserial: line is at <runtime_dir>/<bus>.tty (`serial_link: pty | socket`): a pty
  // (default; the gateway's termios code runs, any serial tool can open it) or a Unix socket whose
  // kernel send stamps date the gateway's bytes (no pty hop: motion/serial/sim_link.hpp).
  enum class SerialLink : std::uint8_t { kPty, kSocket };
  SerialLink serial_link = SerialLink::kPty;
  // Simulated home switches (`home_switches: {DRIVE: COUNTS | none}`): where the switch edge of a
  // drive whose axis homes on a switch is, in drive counts from the power-up position; `none`: no
  // switch. Drives not named get one half way from the power-up position to the travel limit in
  // the homing direction.
  std::map<std::string, std::optional<long long>, std::less<>> home_switches;
  // Behaviours where a manual is silent (`variants: {DRIVE: {KEY: VALUE}}`), per drive; the keys
  // and defaults per family are in motion/config/sim_variants.hpp (docs/protocols.md).
  std::map<std::string, std::map<std::string, std::string, std::less<>>, std::less<>> variants;
};

struct Config {
  std::string file;
  LcmSettings lcm;
  std::vector<Bus> buses;
  std::vector<Drive> drives;
  std::vector<Axis> axes;
  CoordinatorSettings coordinator;
  SecuritySettings security;
  SimulationSettings simulation;

  [[nodiscard]] const Bus* find_bus(std::string_view name) const;
  [[nodiscard]] const Drive* find_drive(std::string_view name) const;
  [[nodiscard]] const Axis* find_axis(std::string_view name) const;
  [[nodiscard]] const Drive* drive_of(const Axis& axis) const { return find_drive(axis.drive); }
  [[nodiscard]] std::vector<const Axis*> axes_on_bus(std::string_view bus) const;
};

struct LoadResult {
  std::optional<Config> config;  // set only when errors is empty
  std::vector<ConfigError> errors;
  [[nodiscard]] bool ok() const { return config.has_value(); }
  [[nodiscard]] std::string error_text() const;  // one line per error
};

LoadResult load_file(const std::string& path);
LoadResult load_string(std::string_view yaml_text, const std::string& file_name = "<string>");

// Where simulated buses (sockets) and serial lines (pty links) of this configuration live:
// simulation.runtime_dir, else $MOTION_SIM_DIR, else /tmp/motion-sim-<uid>. Gateways and
// motion-sim agree on it, so a test that sets MOTION_SIM_DIR gets a private lab.
[[nodiscard]] std::string sim_runtime_dir(const Config& config);

// The access of the simulated buses' sockets and ptys (simulation.group, see FileAccess); nullopt
// and `why` when the configured group does not exist on this machine.
[[nodiscard]] std::optional<FileAccess> sim_file_access(const Config& config, std::string* why);

// The simulated lab that ships as the embedded default (config/sim-lab.yaml is its file form):
// $MOTION_CONFIG, else <prefix>/share/motionbus/config/sim-lab.yaml beside an installed program,
// else the source tree's config/sim-lab.yaml.
[[nodiscard]] std::string default_config_path();

}  // namespace motion::config
