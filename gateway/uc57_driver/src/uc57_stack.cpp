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

namespace {


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

std::string hex(std::uint32_t value, int digits) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%0*" PRIX32, digits, value);
  return text;
}

std::string object_text(ObjectAddress object) {
  return hex(object.index, 4) + ":" + hex(object.subindex, 2).substr(2);
}

template <typename T>
std::vector<std::uint8_t> le(T value) {
  return canopen::encode_value<T>(value);
}

// Little-endian unsigned reading of up to 8 bytes (SDO uploads may come with any length 1..4).
std::uint64_t read_unsigned(std::span<const std::uint8_t> data) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < data.size() && i < 8; ++i) value |= std::uint64_t{data[i]} << (8 * i);
  return value;
}

std::int64_t read_signed(std::span<const std::uint8_t> data) {
  return canopen::sign_extend(read_unsigned(data), static_cast<unsigned>(std::min<std::size_t>(data.size(), 8) * 8));
}

// 603Fh bit field (manual §5.2) as text.
std::string fault_bits_text(std::uint16_t bits) {
  static constexpr std::string_view kNames[] = {"overcurrent", "overvoltage", "operational amplifier failure",
                                                "phase loss", "EEPROM read/write error", "undervoltage"};
  std::string text;
  for (std::size_t bit = 0; bit < std::size(kNames); ++bit) {
    if ((bits & (1U << bit)) == 0) continue;
    text += (text.empty() ? "" : ", ") + std::string(kNames[bit]);
  }
  return text.empty() ? "no alarm bit set" : text;
}

bool is_fault_state(std::optional<State> state) {
  return state == State::kFault || state == State::kFaultReactionActive;
}

}  // namespace

// What a node is busy with on behalf of a command (at most one per node).
enum class Uc57Stack::TaskKind : std::uint8_t {
  kNone,
  kSdoOnly,     // parameters, outputs, set position: ends in its SDO callback
  kPower,       // PowerController towards a target state
  kQuickStop,   // waiting to leave Operation enabled
  kHalt,        // waiting for standstill
  kArming,      // SDO set-up, then bit 4 = 0 and bit 12 = 0 in the drive
  kArmed,       // waiting for fire()
  kTriggered,   // bit 4 = 1 applied by the SYNC, waiting for bit 12 = 1
  kReleasing,   // bit 4 = 0 again, waiting for bit 12 = 0
  kMoving,      // waiting for bit 10 / bit 15
  kJog,         // PV settings in, waiting for them to show
  kHoming,      // edge applied, waiting for the homing result
};

struct Uc57Stack::Node {
  enum class Phase : std::uint8_t { kConfigError, kOffline, kConfiguring, kStarting, kOperational };

  NodeSettings settings;
  Phase phase = Phase::kOffline;
  unsigned session = 0;          // bumped by every (re)configuration: stale callbacks are dropped
  TimePoint retry_at = kNever;
  Duration backoff{};
  TimePoint starting_deadline = kNever;
  bool offline_reported = false;  // an offline event went out since the node was last online
  std::string offline_reason;

  RpdoLayout layout = RpdoLayout::kControlwordTarget;
  bool remap_refused = false;    // remembered across re-configurations
  bool tpdo2_active = true;
  std::uint32_t pulses_per_rev = cia402::uc57::kDefaultPulsesPerRevolution;
  double start_speed = 0;        // 200Eh, pulses/s

  RpdoImage image;                   // as last sent, or as read from the drive
  std::deque<RpdoImage> rpdo_queue;  // one image per SYNC cycle
  std::uint64_t image_sync = 0;      // the SYNC (sent count) that applies the last sent image
  cia402::PowerController power;
  std::uint8_t power_transition = 0;  // the transition last awaited (named in timeouts)

  std::optional<std::uint16_t> statusword;
  std::int8_t mode_display = 0;
  // Synchronous TPDOs: this SYNC's TPDO1, held until its TPDO2 so that both count as one sample.
  std::optional<Tpdo1> held_tpdo1;
  gateway::DriveStatus status;
  bool fault_seen = false;       // a fault edge was handled (event, 603Fh read)
  TimePoint next_position_poll = kNever;
  bool position_poll_in_flight = false;

  // The running task.
  TaskKind task = TaskKind::kNone;
  std::int64_t task_command = 0;
  TimePoint task_deadline = kNever;
  bool task_watching = false;    // SDO part done, the statusword now decides
};

struct Uc57Stack::Job {
  enum class Part : std::uint8_t { kRunning, kArmed, kStarted, kDone };
  Command command;
  std::vector<std::size_t> nodes;
  std::vector<Part> parts;
  bool started = false;
  // A stop's unreachable (offline) nodes: the others are still stopped, then the reply fails.
  std::int32_t unreached_code = 0;
  std::string unreached;

  [[nodiscard]] std::size_t slot(std::size_t n) const {
    return static_cast<std::size_t>(std::find(nodes.begin(), nodes.end(), n) - nodes.begin());
  }
  [[nodiscard]] bool all(Part state) const {
    return std::all_of(parts.begin(), parts.end(), [state](Part p) { return p == state; });
  }
};

struct Uc57Stack::ConfigOp {
  std::function<void(Continue)> run;
};

// ---------------------------------------------------------------------------------------------
// Construction
// ---------------------------------------------------------------------------------------------

Uc57Stack::Uc57Stack(const config::Config& config, const config::Bus& bus, gateway::CanStackContext context)
    : Uc57Stack(config, bus, std::move(context), Options{}) {}

Uc57Stack::Uc57Stack(const config::Config& config, const config::Bus& bus, gateway::CanStackContext context,
                     Options options)
    : context_(std::move(context)),
      options_(std::move(options)),
      bus_(bus.name),
      sync_period_(std::chrono::duration_cast<Duration>(std::chrono::duration<double>(1.0 / std::max(bus.poll_hz, 0.1)))),
      master_([this](const can::Frame& frame) {
        if (!context_.send || !context_.send(frame)) ++counters_.protocol_errors;
      }) {
  if (!options_.wall_clock_us) options_.wall_clock_us = [](TimePoint) { return wall_time_us(); };
  for (const auto& drive : config.drives) {
    if (drive.family != config::Family::kUc57 || drive.bus != bus.name) continue;
    auto node = std::make_unique<Node>();
    node->settings = make_node_settings(config, bus, drive, options_.default_heartbeat_ms);
    node->power = cia402::PowerController({options_.state_switch_timeout});
    node_index_[node->settings.node] = nodes_.size();
    // Retries are ours (sdo_read/sdo_write) so that they can be counted.
    master_.sdo().configure_node(node->settings.node, {node->settings.sdo_timeout, 0, 64 * 1024});
    nodes_.push_back(std::move(node));
  }
  master_.nmt().on_event([this](const canopen::NodeEvent& e) { on_node_event(e); });
  master_.emcy().on_event([this](const canopen::EmcyEvent& e) { on_emcy(e); });
  master_.configure_sync({sync_period_, 0, canopen::kSyncCobId});
}

Uc57Stack::~Uc57Stack() = default;

std::vector<std::string> Uc57Stack::axes() const {
  std::vector<std::string> out;
  for (const auto& node : nodes_) {
    if (!node->settings.axis.empty()) out.push_back(node->settings.axis);
  }
  return out;
}

std::optional<RpdoLayout> Uc57Stack::rpdo_layout(std::string_view drive) const {
  for (const auto& node : nodes_) {
    if (node->settings.drive == drive && node->phase == Node::Phase::kOperational) return node->layout;
  }
  return std::nullopt;
}

bool Uc57Stack::ready() const {
  return std::all_of(nodes_.begin(), nodes_.end(), [](const auto& node) { return node->phase == Node::Phase::kOperational; });
}

void Uc57Stack::add_statistics(motionlcm::bus_stats_t& stats) const {
  stats.timeouts += counters_.sdo_timeouts;
  stats.retries += counters_.sdo_retries;
  // bus_stats_t has no protocol-level fields: drive-reported errors count as bus errors.
  stats.errors += counters_.sdo_aborts + counters_.emcy + counters_.protocol_errors;
  stats.drives_total += static_cast<std::int32_t>(nodes_.size());
  stats.drives_online += static_cast<std::int32_t>(
      std::count_if(nodes_.begin(), nodes_.end(), [](const auto& node) { return node->status.online; }));
}

std::string Uc57Stack::offline_text(std::size_t n) const {
  const Node& node = *nodes_[n];
  return node.settings.label() + " is offline" + (node.offline_reason.empty() ? "" : ": " + node.offline_reason);
}

void Uc57Stack::event(std::size_t n, std::int16_t kind, std::int8_t severity, std::int32_t code, const std::string& text) {
  if (context_.out == nullptr) return;
  gateway::DriveEvent e;
  e.kind = kind;
  e.severity = severity;
  e.code = code;
  e.text = text;
  context_.out->axis_event(nodes_[n]->settings.axis, e);
}

// ---------------------------------------------------------------------------------------------
// Start-up: probe, configure, start
// ---------------------------------------------------------------------------------------------

void Uc57Stack::start(TimePoint now) {
  now_ = now;
  started_ = true;
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    for (const auto& warning : node.settings.warnings) {
      event(n, Event::CONFIG_MISMATCH, Event::WARNING, 0, node.settings.label() + ": " + warning);
    }
    if (!node.settings.errors.empty()) {
      std::string text;
      for (const auto& error : node.settings.errors) text += (text.empty() ? "" : "; ") + error;
      node.phase = Node::Phase::kConfigError;
      node.offline_reason = text;
      event(n, Event::CONFIG_MISMATCH, Event::ERROR, 0, node.settings.label() + ": cannot be set up: " + text);
      continue;
    }
    begin_probe(n, now);
  }
  // SYNC is harmless in pre-operational and doubles as the cycle of the RPDO queue.
  master_.sync()->start(now);
}

void Uc57Stack::begin_probe(std::size_t n, TimePoint /*now*/) {
  Node& node = *nodes_[n];
  node.retry_at = kNever;
  node.phase = Node::Phase::kConfiguring;
  ++node.session;
  master_.sdo().cancel(node.settings.node);
  node.rpdo_queue.clear();
  node.held_tpdo1.reset();
  auto ops = std::make_shared<std::vector<ConfigOp>>(configuration_ops(n));
  run_config(n, node.session, std::move(ops), 0);
}

void Uc57Stack::run_config(std::size_t n, unsigned session, std::shared_ptr<std::vector<ConfigOp>> ops, std::size_t step) {
  if (nodes_[n]->session != session || nodes_[n]->phase != Node::Phase::kConfiguring) return;
  if (step == ops->size()) {
    enter_starting(n);
    return;
  }
  const auto run = (*ops)[step].run;
  run([this, n, session, ops, step](std::optional<std::string> failure) {
    if (nodes_[n]->session != session) return;
    if (failure) {
      configuration_failed(n, *failure, true);
      return;
    }
    run_config(n, session, ops, step + 1);
  });
}

std::vector<Uc57Stack::ConfigOp> Uc57Stack::configuration_ops(std::size_t n) {
  Node& node = *nodes_[n];
  const NodeSettings& s = node.settings;
  std::vector<ConfigOp> ops;

  const auto read = [this, n](ObjectAddress object, std::function<std::optional<std::string>(std::span<const std::uint8_t>)> use) {
    return ConfigOp{[this, n, object, use](Continue next) {
      sdo_read(n, object, [this, n, object, use, next](std::error_code ec, std::span<const std::uint8_t> data) {
        if (ec) return next(sdo_failure(n, false, object, ec));
        next(use(data));
      });
    }};
  };
  const auto write = [this, n](ObjectAddress object, std::vector<std::uint8_t> data) {
    return ConfigOp{[this, n, object, data](Continue next) {
      sdo_write(n, object, data, [this, n, object, next](std::error_code ec, std::span<const std::uint8_t>) {
        next(ec ? std::optional{sdo_failure(n, true, object, ec)} : std::nullopt);
      });
    }};
  };
  const auto expect = [label = s.label()](ObjectAddress object, std::uint64_t wanted) {
    return [label, object, wanted](std::span<const std::uint8_t> data) -> std::optional<std::string> {
      if (read_unsigned(data) == wanted) return std::nullopt;
      return label + ": " + object_text(object) + " reads back " + std::to_string(read_unsigned(data)) + ", " +
             std::to_string(wanted) + " was written";
    };
  };

  // 1. Identify: a CiA 402 device (1000h low word 402), from ADAMPOWER (1018h:01; warning only).
  ops.push_back(read({od::kDeviceType, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    const auto type = static_cast<std::uint32_t>(read_unsigned(data));
    if ((type & 0xFFFF) == kCia402Profile) return std::nullopt;
    const std::string text = nodes_[n]->settings.label() + ": device type (1000h) " + hex(type, 8) +
                             " is not a CiA 402 drive (UC57: 0x00040192)";
    event(n, Event::CONFIG_MISMATCH, Event::ERROR, static_cast<std::int32_t>(type), text);
    return text;
  }));
  ops.push_back(read({0x1018, 1}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    const auto vendor = static_cast<std::uint32_t>(read_unsigned(data));
    if (vendor != kAdampowerVendorId) {
      event(n, Event::CONFIG_MISMATCH, Event::WARNING, static_cast<std::int32_t>(vendor),
            nodes_[n]->settings.label() + ": vendor ID (1018h:01) " + hex(vendor, 8) + ", not ADAMPOWER's 0x00000322");
    }
    return std::nullopt;
  }));
  // 2. Pre-operational: PDOs stop while their parameters change (CiA 301 remap procedure).
  ops.push_back({[this, n](Continue next) {
    master_.nmt().send(canopen::NmtCommand::kEnterPreOperational, nodes_[n]->settings.node);
    next(std::nullopt);
  }});
  // 3. Setup keys, written and read back (RW/S objects, not saved to EEPROM: 200Ch default 1).
  if (s.subdivision_code) {
    ops.push_back(write({od::kMicrostepping, 0}, le<std::uint16_t>(*s.subdivision_code)));
  }
  ops.push_back(read({od::kMicrostepping, 0}, [this, n, expect, code = s.subdivision_code](std::span<const std::uint8_t> data)
                         -> std::optional<std::string> {
    if (code) {
      if (auto mismatch = expect({od::kMicrostepping, 0}, *code)(data)) return mismatch;
    }
    const auto ppr = cia402::uc57::pulses_per_revolution(static_cast<std::uint16_t>(read_unsigned(data)));
    if (!ppr) return nodes_[n]->settings.label() + ": 2006h holds an unknown subdivision code " + std::to_string(read_unsigned(data));
    nodes_[n]->pulses_per_rev = *ppr;
    return std::nullopt;
  }));
  if (s.run_current) {
    ops.push_back(write({od::kRunCurrent, 0}, le<std::uint16_t>(*s.run_current)));
    ops.push_back(read({od::kRunCurrent, 0}, expect({od::kRunCurrent, 0}, *s.run_current)));
  }
  ops.push_back(read({od::kStartSpeed, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    Node& nd = *nodes_[n];
    nd.start_speed = cia402::uc57::rpm_to_pulses_per_second(static_cast<double>(read_unsigned(data)), nd.pulses_per_rev);
    return std::nullopt;
  }));
  // 4. Error control: heartbeat (the UC57 has no node guarding objects).
  ops.push_back(write({od::kProducerHeartbeatTime, 0}, le<std::uint16_t>(s.heartbeat_ms)));
  ops.push_back(read({od::kEmcyCobId, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    const auto cob = static_cast<std::uint32_t>(read_unsigned(data)) & 0x7FF;
    // The manual prints the default as "0x80" (C-11): a drive really using 080h would share SYNC's id.
    if (cob != canopen::emcy_cob_id(nodes_[n]->settings.node) && cob != canopen::kSyncCobId) {
      master_.emcy().set_cob_id(nodes_[n]->settings.node, cob);
      relocated_emcy_ids_.insert(cob);
    }
    return std::nullopt;
  }));
  // 5. RPDO1: remap to controlword + target (synchronous); fall back to the manual's default.
  ops.push_back({[this, n](Continue next) {
    Node& nd = *nodes_[n];
    if (nd.remap_refused) {
      nd.layout = RpdoLayout::kManualDefault;
      return next(std::nullopt);
    }
    const unsigned session = nd.session;
    canopen::configure_pdo(master_.sdo(), nd.settings.node, rpdo1_remap(nd.settings.node),
                           [this, n, session, next](const canopen::SdoSequenceResult& result) {
                             Node& remapped = *nodes_[n];
                             if (remapped.session != session) return;
                             if (!result.error) {
                               remapped.layout = RpdoLayout::kControlwordTarget;
                               return next(std::nullopt);
                             }
                             count_sdo_result(result.error);
                             // Only an abort is the drive's answer. Without one (a timeout, a late reply
                             // to an earlier request) the step may have been applied, the first one
                             // too (1400h:01 invalid: RPDO1 off): reset, configure again, try the remap again.
                             const bool refused = result.error.category() == canopen::sdo_category() &&
                                                  result.error != canopen::SdoAbortCode::kTimeout;
                             if (!refused) {
                               master_.nmt().send(canopen::NmtCommand::kResetNode, remapped.settings.node);
                               return next(remapped.settings.label() + ": RPDO1 remap step " + std::to_string(result.failed_step + 1) +
                                           " got no usable answer (" + result.error.message() + "); node reset to restore its stored PDO mapping");
                             }
                             remapped.remap_refused = true;
                             remapped.layout = RpdoLayout::kManualDefault;
                             const std::string why = remapped.settings.label() + ": RPDO1 remap refused at step " +
                                                     std::to_string(result.failed_step + 1) + " (" + result.error.message() + ")";
                             if (result.failed_step == 0) {
                               // Nothing changed in the drive: go on with its default mapping.
                               event(n, Event::CONFIG_MISMATCH, Event::INFO, 0, why + "; using the manual's default RPDO1");
                               return next(std::nullopt);
                             }
                             // Half-applied: a node reset restores the stored mapping; configure again.
                             master_.nmt().send(canopen::NmtCommand::kResetNode, remapped.settings.node);
                             next(why + "; node reset to restore its stored PDO mapping");
                           });
  }});
  ops.push_back({[this, n, write](Continue next) {
    if (nodes_[n]->layout != RpdoLayout::kManualDefault) return next(std::nullopt);
    write({canopen::pdo_communication_index(canopen::PdoDirection::kReceive, 1), canopen::kPdoTransmissionTypeSub},
          le<std::uint8_t>(kTransmissionSyncEveryCycle))
        .run(std::move(next));
  }});
  // 6. TPDO1 / TPDO2 transmission type (1800h/1801h:02, RW/S) and whether TPDO2 is mapped (C-09).
  for (std::uint16_t tpdo = 1; tpdo <= 2; ++tpdo) {
    ops.push_back(write({canopen::pdo_communication_index(canopen::PdoDirection::kTransmit, tpdo), canopen::kPdoTransmissionTypeSub},
                        le<std::uint8_t>(s.tpdo_transmission_type())));
  }
  ops.push_back(read({canopen::pdo_mapping_index(canopen::PdoDirection::kTransmit, 2), 0},
                     [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
                       Node& nd = *nodes_[n];
                       nd.tpdo2_active = read_unsigned(data) == tpdo2_mapping().size();
                       if (!nd.tpdo2_active) {
                         event(n, Event::CONFIG_MISMATCH, Event::WARNING, 0,
                               nd.settings.label() + ": TPDO2 (1A01h) is not mapped; position is polled by SDO (6064h)");
                       }
                       return std::nullopt;
                     }));
  // 7. The drive's current process image, so the first RPDO changes nothing by accident.
  ops.push_back(read({od::kControlword, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    nodes_[n]->image.controlword = static_cast<std::uint16_t>(read_unsigned(data));
    nodes_[n]->power.note_controlword_sent(nodes_[n]->image.controlword);
    return std::nullopt;
  }));
  ops.push_back(read({od::kModesOfOperation, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    nodes_[n]->image.mode = static_cast<std::int8_t>(read_signed(data));
    return std::nullopt;
  }));
  ops.push_back(read({od::kTargetVelocity, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    nodes_[n]->image.target_velocity = static_cast<std::int32_t>(read_signed(data));
    return std::nullopt;
  }));
  ops.push_back(read({od::kTargetPosition, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    nodes_[n]->image.target_position = static_cast<std::int32_t>(read_signed(data));
    return std::nullopt;
  }));
  ops.push_back(read({od::kPositionActual, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    nodes_[n]->status.position_counts = read_signed(data);
    return std::nullopt;
  }));
  ops.push_back(read({od::kStatusword, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    nodes_[n]->statusword = static_cast<std::uint16_t>(read_unsigned(data));
    return std::nullopt;
  }));
  // 8. Operational.
  ops.push_back({[this, n](Continue next) {
    Node& nd = *nodes_[n];
    const auto consumer = std::chrono::milliseconds(nd.settings.heartbeat_ms) * options_.heartbeat_loss_factor;
    master_.nmt().monitor(nd.settings.node, consumer);
    master_.nmt().mark_configured(nd.settings.node);
    master_.nmt().send(canopen::NmtCommand::kStart, nd.settings.node);
    next(std::nullopt);
  }});
  return ops;
}

void Uc57Stack::enter_starting(std::size_t n) {
  Node& node = *nodes_[n];
  if (node.settings.heartbeat_ms == 0) {
    enter_operational(n);
    return;
  }
  // The next heartbeat must say Operational (on_node_event); give it a few producer periods.
  node.phase = Node::Phase::kStarting;
  node.starting_deadline = now_ + std::chrono::milliseconds(node.settings.heartbeat_ms) * options_.heartbeat_loss_factor;
  if (master_.nmt().state(node.settings.node) == canopen::NmtState::kOperational) enter_operational(n);
}

void Uc57Stack::enter_operational(std::size_t n) {
  Node& node = *nodes_[n];
  node.phase = Node::Phase::kOperational;
  node.starting_deadline = kNever;
  node.backoff = Duration{};
  node.offline_reported = false;
  node.fault_seen = false;
  node.status.online = true;
  node.next_position_poll = node.tpdo2_active ? kNever : TimePoint{};
  event(n, Event::ONLINE, Event::INFO, node.settings.node,
        node.settings.label() + ": configured and operational (RPDO1 " +
            (node.layout == RpdoLayout::kControlwordTarget ? "controlword + target position" : "manual default mapping") +
            ", synchronous; TPDOs " + (node.settings.tpdo_mode == TpdoMode::kSync ? "every SYNC" : "event-driven") + ")");
  publish_status(n);
}

void Uc57Stack::configuration_failed(std::size_t n, const std::string& reason, bool retry) {
  Node& node = *nodes_[n];
  master_.sdo().cancel(node.settings.node);
  node.phase = retry ? Node::Phase::kOffline : Node::Phase::kConfigError;
  node.starting_deadline = kNever;
  node.offline_reason = reason;
  node.status.online = false;
  node.backoff = node.backoff == Duration{} ? options_.retry_initial : std::min(node.backoff * 2, options_.retry_max);
  node.retry_at = now_ + node.backoff;
  if (!node.offline_reported) {
    node.offline_reported = true;
    event(n, Event::OFFLINE, Event::ERROR, node.settings.node, reason + " (retrying with back-off)");
    publish_status(n);
  }
}

void Uc57Stack::go_offline(std::size_t n, std::int16_t event_kind, const std::string& reason, TimePoint now) {
  Node& node = *nodes_[n];
  end_task(n, error_code(ReplyError::kAxisOffline), reason);
  master_.sdo().cancel(node.settings.node);
  ++node.session;
  node.phase = Node::Phase::kOffline;
  node.starting_deadline = kNever;
  node.rpdo_queue.clear();
  node.held_tpdo1.reset();
  node.statusword.reset();
  node.status.online = false;
  node.offline_reason = reason;
  node.offline_reported = true;
  node.backoff = options_.retry_initial;
  node.retry_at = now + node.backoff;
  event(n, event_kind, Event::ERROR, node.settings.node, reason);
  publish_status(n);
}

void Uc57Stack::on_node_event(const canopen::NodeEvent& e) {
  const auto it = node_index_.find(e.node);
  if (it == node_index_.end()) return;
  const std::size_t n = it->second;
  Node& node = *nodes_[n];
  const std::string label = node.settings.label();
  switch (e.kind) {
    case canopen::NodeEventKind::kBootUp:
    case canopen::NodeEventKind::kRebooted:
      if (node.phase == Node::Phase::kConfigError) return;
      if (node.phase == Node::Phase::kOperational || node.phase == Node::Phase::kStarting) {
        // It lost its PDO configuration and its CiA 402 state: everything starts again.
        go_offline(n, Event::REBOOT, label + ": rebooted (boot-up message); configuring it again", e.at);
      }
      if (started_) begin_probe(n, e.at);
      return;
    case canopen::NodeEventKind::kHeartbeatLost:
      if (node.phase == Node::Phase::kOperational || node.phase == Node::Phase::kStarting) {
        go_offline(n, Event::HEARTBEAT_LOST,
                   label + ": heartbeat lost (none for " + std::to_string(node.settings.heartbeat_ms * options_.heartbeat_loss_factor) + " ms)",
                   e.at);
      }
      return;
    case canopen::NodeEventKind::kHeartbeatRecovered:
    case canopen::NodeEventKind::kStateChanged:
      if (node.phase == Node::Phase::kStarting && e.state == canopen::NmtState::kOperational) {
        enter_operational(n);
      } else if (node.phase == Node::Phase::kOperational && e.state && e.state != canopen::NmtState::kOperational) {
        // Someone else's NMT command (or a node-side error): PDOs stopped; put it back.
        event(n, Event::PROTOCOL_ERROR, Event::WARNING, static_cast<std::int32_t>(*e.state),
              label + ": left Operational (NMT state " + std::string(canopen::to_string(*e.state)) + "); sending NMT start");
        master_.nmt().send(canopen::NmtCommand::kStart, node.settings.node);
      } else if (node.phase == Node::Phase::kOffline && e.kind == canopen::NodeEventKind::kHeartbeatRecovered) {
        begin_probe(n, e.at);
      }
      return;
  }
}

void Uc57Stack::on_emcy(const canopen::EmcyEvent& e) {
  const auto it = node_index_.find(e.node);
  if (it == node_index_.end()) return;
  ++counters_.emcy;
  const std::size_t n = it->second;
  Node& node = *nodes_[n];
  const std::uint16_t code = e.emergency.error_code;
  if (e.is_reset()) {
    event(n, Event::EMCY, Event::INFO, 0, node.settings.label() + ": EMCY error reset (no error)");
    return;
  }
  std::string manufacturer;
  for (const auto byte : e.emergency.manufacturer) manufacturer += " " + hex(byte, 2).substr(2);
  const std::string text = node.settings.label() + ": EMCY " + hex(code, 4) + " (" +
                           std::string(canopen::to_string(e.error_class)) + "), error register " +
                           hex(e.emergency.error_register, 2) + ", manufacturer bytes" + manufacturer;
  node.status.fault_code = code;
  node.status.fault_text = text;
  event(n, Event::EMCY, Event::ERROR, code, text);
  end_task(n, error_code(ReplyError::kAxisFaulted), text);
  publish_status(n);
}

// ---------------------------------------------------------------------------------------------
// SDO
// ---------------------------------------------------------------------------------------------

void Uc57Stack::count_sdo_result(std::error_code error) {
  if (!error || error.category() != canopen::sdo_category()) return;
  if (error == canopen::SdoAbortCode::kTimeout) {
    ++counters_.sdo_timeouts;
  } else {
    ++counters_.sdo_aborts;
  }
}

std::string Uc57Stack::sdo_failure(std::size_t n, bool write, ObjectAddress object, std::error_code error) const {
  const NodeSettings& s = nodes_[n]->settings;
  std::string text = s.label() + ": SDO " + (write ? "write " : "read ") + object_text(object);
  if (error == canopen::SdoAbortCode::kTimeout) {
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(s.sdo_timeout).count();
    return text + " timed out (no answer within " + std::to_string(ms) + " ms, " + std::to_string(s.sdo_retries + 1) +
           " attempts)";
  }
  if (error.category() == canopen::sdo_category()) {
    const auto code = static_cast<std::uint32_t>(error.value());
    std::string why(canopen::description(static_cast<canopen::SdoAbortCode>(code)));
    if (why.empty()) why = "manufacturer-specific abort";
    why[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(why[0])));
    return text + " aborted: " + why + " (" + hex(code, 8) + ")";
  }
  return text + " failed: " + error.message();
}

void Uc57Stack::sdo_read(std::size_t n, ObjectAddress object, SdoDone done, unsigned attempt) {
  const unsigned session = nodes_[n]->session;
  master_.sdo().upload(nodes_[n]->settings.node, object,
                       [this, n, object, done = std::move(done), attempt, session](std::error_code ec, std::span<const std::uint8_t> data) {
                         if (ec == canopen::SdoAbortCode::kTimeout && attempt < nodes_[n]->settings.sdo_retries &&
                             nodes_[n]->session == session) {
                           ++counters_.sdo_retries;
                           sdo_read(n, object, done, attempt + 1);
                           return;
                         }
                         count_sdo_result(ec);
                         done(ec, data);
                       });
}

void Uc57Stack::sdo_write(std::size_t n, ObjectAddress object, std::vector<std::uint8_t> data, SdoDone done, unsigned attempt) {
  const unsigned session = nodes_[n]->session;
  master_.sdo().download(nodes_[n]->settings.node, object, data,
                         [this, n, object, data, done = std::move(done), attempt, session](std::error_code ec,
                                                                                            std::span<const std::uint8_t> reply) {
                           if (ec == canopen::SdoAbortCode::kTimeout && attempt < nodes_[n]->settings.sdo_retries &&
                               nodes_[n]->session == session) {
                             ++counters_.sdo_retries;
                             sdo_write(n, object, data, done, attempt + 1);
                             return;
                           }
                           count_sdo_result(ec);
                           done(ec, reply);
                         });
}

void Uc57Stack::sdo_write_all(std::size_t n, std::vector<std::pair<ObjectAddress, std::vector<std::uint8_t>>> writes, Continue done) {
  if (writes.empty()) return done(std::nullopt);
  auto first = writes.front();
  writes.erase(writes.begin());
  sdo_write(n, first.first, first.second,
            [this, n, object = first.first, rest = std::move(writes), done = std::move(done)](std::error_code ec,
                                                                                             std::span<const std::uint8_t>) mutable {
              if (ec) return done(sdo_failure(n, true, object, ec));
              sdo_write_all(n, std::move(rest), std::move(done));
            });
}

// ---------------------------------------------------------------------------------------------
// Frames in, deadlines
// ---------------------------------------------------------------------------------------------

bool Uc57Stack::on_frame(const can::Frame& frame, TimePoint now) {
  now_ = now;
  // 29-bit frames belong to the UIM342 stack; RTR frames are nothing this master consumes.
  if (frame.extended || frame.rtr) return false;
  const auto info = canopen::classify_cob_id(frame.id);
  std::optional<std::size_t> n;
  if (info) {
    const auto it = node_index_.find(info->node);
    if (it != node_index_.end()) n = it->second;
  }
  if (!n) {
    // A relocated EMCY COB-ID (1014h) of one of our nodes; anything else belongs to someone else.
    if (relocated_emcy_ids_.count(frame.id) == 0) return false;
    master_.emcy().on_frame(frame, now);
    return true;
  }
  switch (info->kind) {
    case canopen::MessageKind::kSdoResponse:
    case canopen::MessageKind::kHeartbeat:
    case canopen::MessageKind::kEmcy:
      master_.on_frame(frame, now);
      return true;
    case canopen::MessageKind::kTpdo:
      on_pdo(*n, frame, now);
      return true;
    default:
      // Requests and RPDOs *to* our nodes come from another master: not ours.
      return false;
  }
}

TimePoint Uc57Stack::process(TimePoint now) {
  now_ = now;
  if (!started_) return kNever;
  TimePoint next = kNever;
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    if (node.phase == Node::Phase::kOffline && now >= node.retry_at) begin_probe(n, now);
    if (node.phase == Node::Phase::kStarting && now >= node.starting_deadline) {
      node.starting_deadline = kNever;
      configuration_failed(n, node.settings.label() + ": no Operational heartbeat after NMT start", true);
    }
    if (node.phase == Node::Phase::kOperational && !node.tpdo2_active && now >= node.next_position_poll &&
        !node.position_poll_in_flight) {
      node.position_poll_in_flight = true;
      node.next_position_poll = now + cycle();
      sdo_read(n, {od::kPositionActual, 0}, [this, n](std::error_code ec, std::span<const std::uint8_t> data) {
        nodes_[n]->position_poll_in_flight = false;
        if (ec) return;
        nodes_[n]->status.position_counts = read_signed(data);
        publish_status(n);
      });
    }
  }
  check_task_timeouts(now);
  auto* sync = master_.sync();
  if (sync->next_deadline() <= now) run_sync_cycle(now);
  next = std::min(next, master_.process(now));
  for (const auto& node : nodes_) {
    next = std::min({next, node->retry_at, node->starting_deadline, node->task_deadline, node->power.deadline()});
    if (node->phase == Node::Phase::kOperational && !node->tpdo2_active) next = std::min(next, node->next_position_poll);
  }
  return std::max(next, now);
}

// One SYNC cycle: each node's next queued image goes out, then the SYNC that applies them all.
void Uc57Stack::run_sync_cycle(TimePoint now) {
  const std::uint64_t applying_sync = master_.sync()->sent() + 1;
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    if (node.phase != Node::Phase::kOperational || node.rpdo_queue.empty()) continue;
    send_image(n, node.rpdo_queue.front());
    node.rpdo_queue.pop_front();
    node.image_sync = applying_sync;
  }
  master_.sync()->process(now);
}

void Uc57Stack::send_image(std::size_t n, const RpdoImage& image) {
  Node& node = *nodes_[n];
  node.image = image;
  const can::Frame frame = encode_rpdo1(node.settings.node, node.layout, image);
  if (!context_.send || !context_.send(frame)) ++counters_.protocol_errors;
}

RpdoImage Uc57Stack::latest_image(std::size_t n) const {
  const Node& node = *nodes_[n];
  return node.rpdo_queue.empty() ? node.image : node.rpdo_queue.back();
}

void Uc57Stack::queue_image(std::size_t n, const RpdoImage& image) {
  Node& node = *nodes_[n];
  node.rpdo_queue.push_back(image);
  node.power.note_controlword_sent(image.controlword);
}

bool Uc57Stack::image_applied(std::size_t n) {
  // The SYNC that applied the image has gone, and one more: a TPDO now shows its effect whatever
  // order the drive uses between applying RPDOs and sampling TPDOs at one SYNC.
  const Node& node = *nodes_[n];
  return node.rpdo_queue.empty() && master_.sync()->sent() > node.image_sync;
}

std::optional<State> Uc57Stack::drive_state(std::size_t n) const {
  const auto& sw = nodes_[n]->statusword;
  return sw ? cia402::decode_state(*sw) : std::nullopt;
}

void Uc57Stack::on_pdo(std::size_t n, const can::Frame& frame, TimePoint now) {
  Node& node = *nodes_[n];
  if (node.phase != Node::Phase::kOperational) return;  // late TPDOs of a node being (re)configured
  const auto info = canopen::classify_cob_id(frame.id);
  if (info->pdo_number == 1) {
    const auto tpdo = decode_tpdo1(frame.payload());
    if (!tpdo) {
      ++counters_.protocol_errors;
      return;
    }
    if (node.settings.tpdo_mode == TpdoMode::kSync && node.tpdo2_active) {
      // Both TPDOs sample one SYNC instant: the statusword waits for its position (TPDO2, next on
      // the bus), or a "homed" / "stopped" would go out next to the previous SYNC's position.
      if (node.held_tpdo1) take_tpdo1(n, *std::exchange(node.held_tpdo1, std::nullopt), now);  // its TPDO2 was lost
      node.held_tpdo1 = *tpdo;
      return;
    }
    // TPDO2 (position) publishes every sample; TPDO1 only when what it reports changed, so a
    // state change shows at once also with event-driven TPDOs, where TPDO2 may stay silent.
    node.status.sample_utime = frame.timestamp_us;
    if (take_tpdo1(n, *tpdo, now) || !node.tpdo2_active) publish_status(n);
  } else if (info->pdo_number == 2 && node.tpdo2_active) {
    const auto tpdo = decode_tpdo2(frame.payload());
    if (!tpdo) {
      ++counters_.protocol_errors;
      return;
    }
    node.status.position_counts = tpdo->position;
    node.status.velocity_counts = cia402::uc57::rpm_to_pulses_per_second(tpdo->velocity_rpm, node.pulses_per_rev);
    node.status.sample_utime = frame.timestamp_us;
    // The task sees the statusword with this position (a DONE is followed by the state it reached).
    if (node.held_tpdo1) take_tpdo1(n, *std::exchange(node.held_tpdo1, std::nullopt), now);
    publish_status(n);
  }
}

bool Uc57Stack::take_tpdo1(std::size_t n, const Tpdo1& tpdo, TimePoint now) {
  Node& node = *nodes_[n];
  const std::int32_t inputs = inputs_from_60fd(tpdo.digital_inputs);
  const bool changed = node.statusword != tpdo.statusword || node.status.inputs != inputs;
  node.statusword = tpdo.statusword;
  node.mode_display = tpdo.mode_display;
  node.status.inputs = inputs;
  on_statusword(n, now);
  return changed;
}

void Uc57Stack::publish_status(std::size_t n) {
  Node& node = *nodes_[n];
  if (context_.out == nullptr || node.settings.axis.empty()) return;
  if (node.statusword) {
    const std::uint16_t sw = *node.statusword;
    const auto state = cia402::decode_state(sw);
    node.status.enabled = state == State::kOperationEnabled;
    node.status.moving = cia402::is_set(sw, StatusBit::kMotorRunning);
    node.status.in_position = cia402::is_set(sw, StatusBit::kInPosition);
    node.status.homed = cia402::is_set(sw, StatusBit::kHomingDone);
    node.status.fault = is_fault_state(state) || cia402::is_set(sw, StatusBit::kAlarm);
  }
  node.status.target_counts = node.image.target_position;
  context_.out->axis_status(node.settings.axis, node.status);
}

// Every statusword: faults first, then whatever the running task waits for.
void Uc57Stack::on_statusword(std::size_t n, TimePoint now) {
  Node& node = *nodes_[n];
  const std::uint16_t sw = *node.statusword;
  const auto state = cia402::decode_state(sw);
  const bool fault = is_fault_state(state) || cia402::is_set(sw, StatusBit::kAlarm);
  if (fault && !node.fault_seen) {
    node.fault_seen = true;
    const std::string text = node.settings.label() + ": drive fault (statusword " + hex(sw, 4) + ", " +
                             (state ? std::string(cia402::to_string(*state)) : "unknown state") + ")";
    if (node.status.fault_text.empty()) node.status.fault_text = text;
    event(n, Event::ALARM, Event::ERROR, sw, text);
    if (!(node.task == TaskKind::kPower && node.power.target() == State::kSwitchOnDisabled)) end_task(n, error_code(ReplyError::kAxisFaulted), text);
    // 603Fh names the alarm (manual §5.2 bit field).
    sdo_read(n, {od::kFaultBits, 0}, [this, n](std::error_code ec, std::span<const std::uint8_t> data) {
      if (ec) return;
      Node& nd = *nodes_[n];
      const auto bits = static_cast<std::uint16_t>(read_unsigned(data));
      nd.status.fault_code = bits;
      nd.status.fault_text = nd.settings.label() + ": alarm " + fault_bits_text(bits) + " (603Fh = " + hex(bits, 4) + ")";
      event(n, Event::ALARM, Event::ERROR, bits, nd.status.fault_text);
      publish_status(n);
    });
  } else if (!fault && node.fault_seen) {
    node.fault_seen = false;
    node.status.fault_code = 0;
    node.status.fault_text.clear();
  }

  const bool acknowledged = cia402::is_set(sw, StatusBit::kSetPointAcknowledge);
  switch (node.task) {
    case TaskKind::kPower:
      apply_power_action(n, node.power.on_statusword(sw, now));
      break;
    case TaskKind::kQuickStop:
      if (image_applied(n) && state != State::kOperationEnabled) part_done(node.task_command, n);
      break;
    case TaskKind::kHalt:
      if (image_applied(n) && !cia402::is_set(sw, StatusBit::kMotorRunning)) part_done(node.task_command, n);
      break;
    case TaskKind::kArming:
      if (node.task_watching && image_applied(n) && !acknowledged && node.mode_display == kModeProfilePosition) {
        part_armed(node.task_command, n, now);
      }
      break;
    case TaskKind::kTriggered:
      if (acknowledged) {
        // Set-point taken: clear bit 4 so the next set-point can have its edge (manual §7 step 8).
        RpdoImage image = latest_image(n);
        image.controlword = cia402::profile_position_controlword({}, false, false);
        queue_image(n, image);
        node.task = TaskKind::kReleasing;
        node.task_deadline = now + options_.set_point_timeout + 2 * cycle();
      }
      break;
    case TaskKind::kReleasing:
    case TaskKind::kMoving:
      if (!image_applied(n) || acknowledged) break;
      node.task = TaskKind::kMoving;
      node.task_deadline = kNever;  // a move's duration is the coordinator's to supervise
      if (cia402::is_set(sw, StatusBit::kTargetReached) || cia402::is_set(sw, StatusBit::kInPosition)) {
        part_done(node.task_command, n);
      }
      break;
    case TaskKind::kJog:
      if (node.task_watching && image_applied(n) && node.mode_display == kModeProfileVelocity) part_done(node.task_command, n);
      break;
    case TaskKind::kHoming:
      if (!node.task_watching || !image_applied(n)) break;
      switch (cia402::uc57::homing_result(sw)) {
        case cia402::uc57::HomingResult::kInProgress: break;
        case cia402::uc57::HomingResult::kSucceeded: {
          RpdoImage image = latest_image(n);
          image.controlword = cia402::with(image.controlword, ControlBit::kNewSetPoint, false);
          queue_image(n, image);
          part_done(node.task_command, n);
          break;
        }
        case cia402::uc57::HomingResult::kStoppedWithoutHome:
          part_failed(node.task_command, n, error_code(ReplyError::kDriveError),
                      node.settings.label() + ": homing stopped without finding home (statusword " + hex(sw, 4) + ")");
          break;
      }
      break;
    case TaskKind::kNone:
    case TaskKind::kSdoOnly:
    case TaskKind::kArmed:
      break;
  }
}

// ---------------------------------------------------------------------------------------------
// Commands: bookkeeping
// ---------------------------------------------------------------------------------------------

void Uc57Stack::fail_command(const Command& command, std::int32_t code, const std::string& reason) {
  if (context_.out == nullptr) return;
  Reply r{};
  r.command_id = command.command_id;
  r.status = Reply::FAILED;
  r.error_code = code;
  r.reason = reason;
  context_.out->command_reply(r);
}

void Uc57Stack::reply(const Job& job, std::int8_t status, std::int32_t code, const std::string& reason) {
  if (context_.out == nullptr) return;
  Reply r{};
  r.command_id = job.command.command_id;
  r.status = status;
  r.error_code = code;
  r.reason = reason;
  r.param = job.command.param;
  context_.out->command_reply(r);
}

void Uc57Stack::start_task(std::size_t n, TaskKind kind, std::int64_t command_id, TimePoint deadline) {
  Node& node = *nodes_[n];
  node.task = kind;
  node.task_command = command_id;
  node.task_deadline = deadline;
  node.task_watching = false;
}

void Uc57Stack::end_task(std::size_t n, std::int32_t code, const std::string& reason) {
  Node& node = *nodes_[n];
  if (node.task == TaskKind::kNone) return;
  part_failed(node.task_command, n, code, reason);
}

void Uc57Stack::part_done(std::int64_t command_id, std::size_t n) {
  Node& node = *nodes_[n];
  if (node.task_command == command_id) {
    node.task = TaskKind::kNone;
    node.task_deadline = kNever;
  }
  const auto it = jobs_.find(command_id);
  if (it == jobs_.end()) return;
  Job& job = it->second;
  job.parts[job.slot(n)] = Job::Part::kDone;
  if (!job.all(Job::Part::kDone)) return;
  // The state the command left its axes in goes out first: whoever acts on the reply (the
  // coordinator checking "enabled" for the next move, a client reading "homed") has it by then.
  for (const std::size_t done : job.nodes) publish_status(done);
  if (job.unreached.empty()) {
    reply(job, Reply::DONE);
  } else {
    reply(job, Reply::FAILED, job.unreached_code, job.unreached);
  }
  jobs_.erase(it);
}

void Uc57Stack::part_failed(std::int64_t command_id, std::size_t n, std::int32_t code, const std::string& reason) {
  if (nodes_[n]->task_command == command_id) {
    nodes_[n]->task = TaskKind::kNone;
    nodes_[n]->task_deadline = kNever;
  }
  const auto it = jobs_.find(command_id);
  if (it == jobs_.end()) return;
  const Job job = std::move(it->second);
  jobs_.erase(it);
  // The command is over: the other axes' tasks for it end silently (one terminal reply).
  for (const std::size_t other : job.nodes) {
    Node& node = *nodes_[other];
    if (node.task_command != command_id || node.task == TaskKind::kNone) continue;
    if (node.task == TaskKind::kPower) node.power.cancel();
    node.task = TaskKind::kNone;
    node.task_deadline = kNever;
  }
  reply(job, Reply::FAILED, code, reason);
}

void Uc57Stack::part_armed(std::int64_t command_id, std::size_t n, TimePoint now) {
  Node& node = *nodes_[n];
  node.task = TaskKind::kArmed;
  node.task_deadline = kNever;
  const auto it = jobs_.find(command_id);
  if (it == jobs_.end()) return;
  Job& job = it->second;
  job.parts[job.slot(n)] = Job::Part::kArmed;
  if (!job.all(Job::Part::kArmed)) return;
  reply(job, Reply::ARMED);
  if (job.command.trigger_id == 0) fire_jobs({command_id}, now);  // "0 = at once"
}

void Uc57Stack::check_task_timeouts(TimePoint now) {
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    if (node.task == TaskKind::kPower && node.power.deadline() <= now) apply_power_action(n, node.power.on_timer(now));
    if (node.task == TaskKind::kNone || now < node.task_deadline) continue;
    const std::string label = node.settings.label();
    const auto ms = [](Duration d) { return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d).count()); };
    switch (node.task) {
      case TaskKind::kArming:
        part_failed(node.task_command, n, error_code(ReplyError::kArmFailed),
                    label + ": not ready for a set-point (statusword bit 12 still set or 6061h != 1) within " +
                        ms(options_.set_point_timeout) + " ms");
        break;
      case TaskKind::kTriggered:
      case TaskKind::kReleasing:
        part_failed(node.task_command, n, error_code(ReplyError::kTimeout),
                    label + ": set-point handshake timed out (statusword bit 12 " +
                        (node.task == TaskKind::kTriggered ? "never acknowledged" : "never released") + ")");
        break;
      case TaskKind::kHalt:
      case TaskKind::kQuickStop:
        part_failed(node.task_command, n, error_code(ReplyError::kTimeout), label + ": motor still running " + ms(options_.stop_timeout) + " ms after the stop");
        break;
      default:
        part_failed(node.task_command, n, error_code(ReplyError::kTimeout), label + ": no answer from the drive in time");
        break;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Commands: execution
// ---------------------------------------------------------------------------------------------

void Uc57Stack::execute(const Command& command, TimePoint now) {
  now_ = now;
  Job job;
  job.command = command;
  for (const auto& axis : command.axes) {
    const auto it = std::find_if(nodes_.begin(), nodes_.end(), [&](const auto& node) { return node->settings.axis == axis.axis; });
    if (it == nodes_.end()) return fail_command(command, error_code(ReplyError::kUnknownAxis), "axis '" + axis.axis + "' is not driven by a UC57 on bus " + bus_);
    job.nodes.push_back(static_cast<std::size_t>(it - nodes_.begin()));
  }
  if (job.nodes.empty()) return fail_command(command, error_code(ReplyError::kMalformedRequest), "command names no axis");
  job.parts.assign(job.nodes.size(), Job::Part::kRunning);

  const std::int8_t kind = command.kind;
  const bool stops = kind == Command::STOP || kind == Command::ESTOP;
  const bool preempts = stops || kind == Command::DISABLE || kind == Command::FAULT_RESET;
  // Parameter and output commands are plain SDO transfers: they may run next to a motion.
  const bool needs_slot = kind != Command::DISARM && kind != Command::PARAM_READ && kind != Command::PARAM_WRITE &&
                          kind != Command::SET_OUTPUTS;
  // Checks first, so that a refused command starts nothing on the wire.
  for (std::size_t i = 0; i < job.nodes.size(); ++i) {
    const std::size_t n = job.nodes[i];
    const Node& node = *nodes_[n];
    // A stop naming an offline node must still stop the others (a group aborted because one of
    // its nodes fell silent): that node only makes the reply fail, below.
    if (node.phase != Node::Phase::kOperational && !stops) {
      return fail_command(command, error_code(ReplyError::kAxisOffline), offline_text(n));
    }
    if (needs_slot && !preempts && node.task != TaskKind::kNone) {
      return fail_command(command, error_code(ReplyError::kAxisBusy),
                          node.settings.label() + " is busy with command " + std::to_string(node.task_command));
    }
    const auto state = drive_state(n);
    const bool motion = kind == Command::ARM_MOVE || kind == Command::JOG || kind == Command::HOME;
    if (motion && is_fault_state(state)) {
      return fail_command(command, error_code(ReplyError::kAxisFaulted), node.settings.label() + " is faulted: " + node.status.fault_text);
    }
    if (motion && state != State::kOperationEnabled) {
      return fail_command(command, error_code(ReplyError::kAxisDisabled),
                          node.settings.label() + " is not enabled (" + (state ? std::string(cia402::to_string(*state)) : "no statusword") + ")");
    }
    // What this drive cannot do for this axis refuses the whole command here: found while the
    // parts start, an earlier axis would already have been changed (random lab seed 1: a HOME
    // that failed for its second axis had zeroed the first one's position).
    if (auto refusal = refuse(n, command, command.axes[i])) {
      return fail_command(command, refusal->first, refusal->second);
    }
  }
  if ((kind == Command::PARAM_READ || kind == Command::PARAM_WRITE) && job.nodes.size() != 1) {
    return fail_command(command, error_code(ReplyError::kMalformedRequest), "a parameter command names exactly one axis");
  }
  // Which nodes had nothing running before this command preempted it (a STOP there is DONE at once).
  std::vector<bool> idle(job.nodes.size());
  for (std::size_t i = 0; i < job.nodes.size(); ++i) idle[i] = at_rest(job.nodes[i]);
  if (preempts) {
    const std::string why = std::string(kind == Command::ESTOP ? "e-stopped" : kind == Command::STOP ? "stopped" : "superseded") +
                            " by command " + std::to_string(command.command_id);
    for (const std::size_t n : job.nodes) end_task(n, error_code(ReplyError::kStopped), nodes_[n]->settings.label() + ": " + why);
  }

  const std::int64_t id = command.command_id;
  auto [it, inserted] = jobs_.emplace(id, std::move(job));
  if (!inserted) return fail_command(command, error_code(ReplyError::kMalformedRequest), "command id " + std::to_string(id) + " is already running");
  Job& live = it->second;
  const std::vector<std::size_t> targets = live.nodes;
  for (std::size_t i = 0; i < targets.size(); ++i) {
    if (jobs_.find(id) == jobs_.end()) return;  // an earlier part already ended the command
    const std::size_t n = targets[i];
    const auto& axis = command.axes[i];
    if (stops && nodes_[n]->phase != Node::Phase::kOperational) {
      live.unreached += (live.unreached.empty() ? "" : "; ") + offline_text(n);
      live.unreached_code = error_code(ReplyError::kAxisOffline);
      part_done(id, n);
      continue;
    }
    switch (kind) {
      case Command::ENABLE: start_power(n, live, State::kOperationEnabled, now); break;
      case Command::DISABLE:
        if (is_fault_state(drive_state(n))) {
          part_done(id, n);  // the motor is already released in Fault
        } else {
          start_power(n, live, State::kReadyToSwitchOn, now);
        }
        break;
      case Command::FAULT_RESET:
        if (!is_fault_state(drive_state(n)) && !cia402::is_set(nodes_[n]->statusword.value_or(0), StatusBit::kAlarm)) {
          part_done(id, n);
        } else {
          start_power(n, live, State::kSwitchOnDisabled, now);
        }
        break;
      case Command::ESTOP: start_quick_stop(n, live, now); break;
      case Command::STOP: start_halt(n, live, idle[i], now); break;
      case Command::ARM_MOVE: start_arm(n, live, axis, now); break;
      case Command::JOG: start_jog(n, live, axis, now); break;
      case Command::HOME: start_home(n, live, axis, now); break;
      case Command::SET_OUTPUTS: start_outputs(n, live, axis); break;
      case Command::SET_POSITION: start_set_position(n, live, axis); break;
      case Command::PARAM_READ:
      case Command::PARAM_WRITE: start_param(n, live); break;
      case Command::DISARM:
        disarm(live);
        part_done(id, n);
        break;
      default:
        part_failed(id, n, error_code(ReplyError::kMalformedRequest), "unknown gateway command kind " + std::to_string(kind));
        return;
    }
  }
}

void Uc57Stack::start_power(std::size_t n, Job& job, State target, TimePoint now) {
  Node& node = *nodes_[n];
  start_task(n, TaskKind::kPower, job.command.command_id, kNever);
  node.power.note_controlword_sent(latest_image(n).controlword);
  node.power.request(target, now);
  if (node.statusword) apply_power_action(n, node.power.on_statusword(*node.statusword, now));
}

void Uc57Stack::apply_power_action(std::size_t n, const cia402::PowerController::Action& action) {
  Node& node = *nodes_[n];
  const std::int64_t id = node.task_command;
  for (const std::uint16_t device_control : action.controlwords()) {
    // Only the device-control bits come from the controller; bit 4 is cleared so that enabling
    // never starts a set-point, the mode bits (halt, abs/rel) stay.
    RpdoImage image = latest_image(n);
    const auto mode_bits = static_cast<std::uint16_t>(image.controlword & ~cia402::kDeviceControlBits & ~cia402::mask(ControlBit::kNewSetPoint));
    image.controlword = static_cast<std::uint16_t>(mode_bits | (device_control & cia402::kDeviceControlBits));
    queue_image(n, image);
  }
  if (action.outcome == cia402::PowerController::Outcome::kInProgress) node.power_transition = action.transition;
  const std::string label = node.settings.label();
  const auto target = node.power.target();
  switch (action.outcome) {
    case cia402::PowerController::Outcome::kReached: part_done(id, n); break;
    case cia402::PowerController::Outcome::kTimedOut:
      part_failed(id, n, error_code(ReplyError::kTimeout),
                  label + ": CiA 402 transition " + std::to_string(node.power_transition) + " not confirmed by the statusword within " +
                      std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(options_.state_switch_timeout).count()) +
                      " ms (state " + (action.observed ? std::string(cia402::to_string(*action.observed)) : "unknown") + ")");
      break;
    case cia402::PowerController::Outcome::kUnreachable:
      part_failed(id, n, is_fault_state(action.observed) ? error_code(ReplyError::kAxisFaulted) : error_code(ReplyError::kDriveError),
                  label + ": cannot reach " + (target ? std::string(cia402::to_string(*target)) : "the requested state") +
                      " from " + (action.observed ? std::string(cia402::to_string(*action.observed)) : "an unknown state") +
                      (is_fault_state(action.observed) ? " (FAULT_RESET first)" : ""));
      break;
    case cia402::PowerController::Outcome::kIdle:
    case cia402::PowerController::Outcome::kInProgress: break;
  }
}

void Uc57Stack::start_quick_stop(std::size_t n, Job& job, TimePoint now) {
  if (drive_state(n) != State::kOperationEnabled) return part_done(job.command.command_id, n);  // nothing runs
  start_task(n, TaskKind::kQuickStop, job.command.command_id, now + options_.stop_timeout);
  RpdoImage image = latest_image(n);
  image.controlword = cia402::with(cia402::apply_command(image.controlword, cia402::Command::kQuickStop), ControlBit::kNewSetPoint, false);
  // A jog's speed must not survive the e-stop: enabled again, a drive in profile velocity mode
  // would run on at 60FFh. Zeroed in the process data and in the object (written by SDO for jogs).
  image.target_velocity = 0;
  queue_image(n, image);
  sdo_write(n, {od::kTargetVelocity, 0}, le<std::int32_t>(0), [](std::error_code, std::span<const std::uint8_t>) {});
}

void Uc57Stack::start_halt(std::size_t n, Job& job, bool idle, TimePoint now) {
  if (drive_state(n) != State::kOperationEnabled) return part_done(job.command.command_id, n);
  RpdoImage image = latest_image(n);
  image.controlword = cia402::with(cia402::with(image.controlword, ControlBit::kHalt, true), ControlBit::kNewSetPoint, false);
  image.target_velocity = 0;  // manual §7 MC_STOP: bit 8 = 1 and 60FFh = 0 (in the RPDO of the default layout)
  if (idle) {
    // Nothing runs: the halt still goes out with the next SYNC, but the STOP does not hold the
    // node for the two SYNC cycles that would confirm it. The coordinator's abort of a failed
    // request is such a STOP, and the request after it found the node "busy" (random lab seed 1).
    queue_image(n, image);
    return part_done(job.command.command_id, n);
  }
  start_task(n, TaskKind::kHalt, job.command.command_id, now + options_.stop_timeout);
  queue_image(n, image);
}

// At rest for certain: no task, every queued image applied and seen, the motor not running in
// the statusword, and the applied image is no jog (a jog's task ends when it runs; its first
// statusword may still be one from before the ramp).
bool Uc57Stack::at_rest(std::size_t n) {
  const Node& node = *nodes_[n];
  if (node.task != TaskKind::kNone || !image_applied(n) || !node.statusword) return false;
  if (cia402::is_set(*node.statusword, StatusBit::kMotorRunning)) return false;
  const bool halted = cia402::is_set(node.image.controlword, ControlBit::kHalt);
  return halted || node.image.mode != kModeProfileVelocity || node.image.target_velocity == 0;
}

// Why `command` cannot run on node n whatever its state: (reply code, reason), checked before any
// part starts.
std::optional<std::pair<std::int32_t, std::string>> Uc57Stack::refuse(std::size_t n, const Command& command,
                                                                       const motionlcm::axis_command_t& axis) const {
  const Node& node = *nodes_[n];
  const std::string label = node.settings.label();
  switch (command.kind) {
    case Command::HOME: {
      const config::Homing& homing = node.settings.homing;
      if (homing.method == config::HomingMethod::kCurrentPosition) {
        if (axis.target_counts == 0) return std::nullopt;
        return std::pair{error_code(ReplyError::kUnsupported), label + ": the UC57 can only zero its position (2012h); offset " +
                                                                   std::to_string(axis.target_counts) + " counts is not supported"};
      }
      if (homing.method != config::HomingMethod::kSwitch) {
        return std::pair{error_code(ReplyError::kUnsupported), label + ": no homing method configured for axis " + node.settings.axis};
      }
      if (homing.input < 1 || homing.input > 3) {
        return std::pair{error_code(ReplyError::kUnsupported), label + ": homing on input " + std::to_string(homing.input) +
                                                                   " is not possible (UC57: IN1 positive limit, IN2 origin, IN3 negative limit)"};
      }
      return std::nullopt;
    }
    case Command::SET_POSITION:
      if (axis.target_counts == 0) return std::nullopt;
      return std::pair{error_code(ReplyError::kUnsupported), label + ": the UC57 can only set its position to zero (2012h); " +
                                                                 std::to_string(axis.target_counts) + " counts is not possible"};
    case Command::SET_OUTPUTS:
      if ((axis.output_mask & ~((1 << kOutputCount) - 1)) == 0) return std::nullopt;
      return std::pair{error_code(ReplyError::kOutsideLimits), label + ": output mask " + hex(static_cast<std::uint32_t>(axis.output_mask), 2) +
                                                                   " names outputs the UC57 does not have (OUT1, OUT2)"};
    default: return std::nullopt;
  }
}

void Uc57Stack::set_mode(std::size_t n, std::int8_t mode, Continue done) {
  sdo_write(n, {od::kModesOfOperation, 0}, le<std::int8_t>(mode),
            [this, n, mode, done = std::move(done)](std::error_code ec, std::span<const std::uint8_t>) {
              if (ec) return done(sdo_failure(n, true, {od::kModesOfOperation, 0}, ec));
              Node& node = *nodes_[n];
              node.image.mode = mode;
              for (auto& queued : node.rpdo_queue) queued.mode = mode;
              done(std::nullopt);
            });
}

void Uc57Stack::start_arm(std::size_t n, Job& job, const motionlcm::axis_command_t& axis, TimePoint /*now*/) {
  Node& node = *nodes_[n];
  const std::int64_t id = job.command.command_id;
  const std::string label = node.settings.label();
  const auto* target_entry = cia402::uc57::find_entry(od::kTargetPosition, 0);
  const auto target = cia402::uc57::quantize_position(*target_entry, static_cast<double>(axis.target_counts));
  if (target.clamped) {
    return part_failed(id, n, error_code(ReplyError::kOutsideLimits),
                       label + ": target " + std::to_string(axis.target_counts) + " counts is outside 607Ah's range " +
                           std::to_string(target_entry->min) + ".." + std::to_string(target_entry->max));
  }
  if (axis.velocity <= 0 || axis.acceleration <= 0 || axis.deceleration <= 0) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest), label + ": ARM_MOVE needs a positive velocity, acceleration and deceleration");
  }
  const auto speed = cia402::uc57::quantize_speed(*cia402::uc57::find_entry(od::kProfileVelocity, 0), axis.velocity, node.pulses_per_rev);
  const double speed_change = std::max(0.0, speed.realized - node.start_speed);
  const auto accel = cia402::uc57::quantize_ramp(*cia402::uc57::find_entry(od::kProfileAcceleration, 0), axis.acceleration,
                                                 speed_change, node.pulses_per_rev);
  const auto decel = cia402::uc57::quantize_ramp(*cia402::uc57::find_entry(od::kProfileDeceleration, 0), axis.deceleration,
                                                 speed_change, node.pulses_per_rev);
  std::vector<std::pair<ObjectAddress, std::vector<std::uint8_t>>> writes = {
      {{od::kProfileVelocity, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(speed.native))},
      {{od::kProfileAcceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(accel.native))},
      {{od::kProfileDeceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(decel.native))},
  };
  const auto target_counts = static_cast<std::int32_t>(target.native);
  if (node.layout == RpdoLayout::kManualDefault) {
    // No room for 607Ah in the default RPDO1: it goes by SDO now, the edge alone at the SYNC.
    writes.push_back({{od::kTargetPosition, 0}, le<std::int32_t>(target_counts)});
  }
  start_task(n, TaskKind::kArming, id, kNever);
  const unsigned session = node.session;
  set_mode(n, kModeProfilePosition, [this, n, id, session, target_counts, writes = std::move(writes)](std::optional<std::string> failure) mutable {
    if (failure) return part_failed(id, n, error_code(ReplyError::kArmFailed), *failure);
    sdo_write_all(n, std::move(writes), [this, n, id, session, target_counts](std::optional<std::string> write_failure) {
      Node& nd = *nodes_[n];
      if (write_failure) return part_failed(id, n, error_code(ReplyError::kArmFailed), *write_failure);
      if (nd.session != session || nd.task_command != id || nd.task != TaskKind::kArming) return;
      RpdoImage image = latest_image(n);
      image.controlword = cia402::profile_position_controlword({}, false, false);  // 0x0F: bit 4 = 0, halt off
      image.target_position = target_counts;
      image.target_velocity = 0;  // PP frames of the default RPDO1 (manual §5 comm. table) carry 60FFh = 0
      image.mode = kModeProfilePosition;
      queue_image(n, image);
      nd.task_watching = true;
      // A TPDO after the image's SYNC decides; set_point_timeout covers a drive stuck with bit 12.
      nd.task_deadline = now_ + options_.set_point_timeout + 3 * cycle();
    });
  });
}

void Uc57Stack::start_jog(std::size_t n, Job& job, const motionlcm::axis_command_t& axis, TimePoint now) {
  Node& node = *nodes_[n];
  const std::int64_t id = job.command.command_id;
  const auto speed = cia402::uc57::quantize_speed(*cia402::uc57::find_entry(od::kTargetVelocity, 0), axis.velocity, node.pulses_per_rev);
  const double speed_change = std::max(0.0, std::abs(speed.realized) - node.start_speed);
  const auto accel = cia402::uc57::quantize_ramp(*cia402::uc57::find_entry(od::kProfileAcceleration, 0),
                                                 std::max(axis.acceleration, 1.0), speed_change, node.pulses_per_rev);
  const auto decel = cia402::uc57::quantize_ramp(*cia402::uc57::find_entry(od::kProfileDeceleration, 0),
                                                 std::max(axis.deceleration, 1.0), speed_change, node.pulses_per_rev);
  const auto rpm = static_cast<std::int32_t>(speed.native);
  start_task(n, TaskKind::kJog, id, now + options_.state_switch_timeout + 3 * cycle());
  // Manual §7 MC_JOG: ramps, 60FFh = 0 before the mode switch (no jump), mode 3, then the speed.
  sdo_write_all(n,
                {{{od::kProfileAcceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(accel.native))},
                 {{od::kProfileDeceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(decel.native))},
                 {{od::kTargetVelocity, 0}, le<std::int32_t>(0)}},
                [this, n, id, rpm](std::optional<std::string> failure) {
                  // Superseded (a STOP while the ramps went out): neither the mode nor the speed
                  // follows, or the drive would hold the jog's 60FFh behind the halt.
                  if (nodes_[n]->task_command != id || nodes_[n]->task != TaskKind::kJog) return;
                  if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
                  set_mode(n, kModeProfileVelocity, [this, n, id, rpm](std::optional<std::string> mode_failure) {
                    if (nodes_[n]->task_command != id || nodes_[n]->task != TaskKind::kJog) return;
                    if (mode_failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *mode_failure);
                    sdo_write_all(n, {{{od::kTargetVelocity, 0}, le<std::int32_t>(rpm)}}, [this, n, id, rpm](std::optional<std::string> speed_failure) {
                      Node& nd = *nodes_[n];
                      if (speed_failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *speed_failure);
                      if (nd.task_command != id || nd.task != TaskKind::kJog) return;
                      RpdoImage image = latest_image(n);
                      image.controlword = cia402::profile_position_controlword({}, false, false);  // 0x0F = PV start, halt off
                      image.target_velocity = rpm;
                      image.mode = kModeProfileVelocity;
                      queue_image(n, image);
                      nd.task_watching = true;
                    });
                  });
                });
}

void Uc57Stack::start_home(std::size_t n, Job& job, const motionlcm::axis_command_t& axis, TimePoint /*now*/) {
  Node& node = *nodes_[n];
  const std::int64_t id = job.command.command_id;
  const std::string label = node.settings.label();
  const config::Homing& homing = node.settings.homing;
  if (homing.method == config::HomingMethod::kCurrentPosition) {
    if (axis.target_counts != 0) {
      return part_failed(id, n, error_code(ReplyError::kUnsupported), label + ": the UC57 can only zero its position (2012h); offset " +
                                                  std::to_string(axis.target_counts) + " counts is not supported");
    }
    start_task(n, TaskKind::kSdoOnly, id, kNever);
    return sdo_write_all(n, {{{od::kZeroPosition, 0}, le<std::uint16_t>(kZeroPositionCommand)}}, [this, n, id](std::optional<std::string> failure) {
      if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
      part_done(id, n);
    });
  }
  if (homing.method != config::HomingMethod::kSwitch) {
    return part_failed(id, n, error_code(ReplyError::kUnsupported), label + ": no homing method configured for axis " + node.settings.axis);
  }
  // The manual's default input functions (§3.1): IN1 positive limit, IN2 origin, IN3 negative limit.
  const double direction = axis.velocity != 0 ? axis.velocity : homing.velocity;
  cia402::uc57::HomingMethod method{};
  switch (homing.input) {
    case 1: method = cia402::uc57::HomingMethod::kPositiveLimit; break;
    case 2:
      method = direction >= 0 ? cia402::uc57::HomingMethod::kHomeSwitchPositive : cia402::uc57::HomingMethod::kHomeSwitchNegative;
      break;
    case 3: method = cia402::uc57::HomingMethod::kNegativeLimit; break;
    default:
      return part_failed(id, n, error_code(ReplyError::kUnsupported), label + ": homing on input " + std::to_string(homing.input) +
                                                  " is not possible (UC57: IN1 positive limit, IN2 origin, IN3 negative limit)");
  }
  cia402::uc57::HomingRequest request;
  request.method = method;
  request.search_speed = std::max(std::abs(axis.velocity), 1.0);
  request.locate_speed = request.search_speed / 4;  // the slow approach decides the accuracy (§4.2.6)
  request.acceleration = std::max(axis.acceleration, 1.0);
  request.offset = static_cast<double>(axis.target_counts);
  const auto settings = cia402::uc57::quantize_homing(request, node.pulses_per_rev);
  if (settings.offset.clamped) {
    return part_failed(id, n, error_code(ReplyError::kOutsideLimits), label + ": homing offset " + std::to_string(axis.target_counts) + " counts exceeds 607Ch's range");
  }
  start_task(n, TaskKind::kHoming, id, kNever);
  sdo_write_all(n,
                {{{od::kHomingMethod, 0}, le<std::uint8_t>(settings.method)},
                 {{od::kHomingSpeeds, 1}, le<std::uint32_t>(static_cast<std::uint32_t>(settings.search_speed.native))},
                 {{od::kHomingSpeeds, 2}, le<std::uint32_t>(static_cast<std::uint32_t>(settings.locate_speed.native))},
                 {{od::kHomingAcceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(settings.acceleration.native))},
                 {{od::kHomeOffset, 0}, le<std::int32_t>(static_cast<std::int32_t>(settings.offset.native))}},
                [this, n, id](std::optional<std::string> failure) {
                  if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
                  set_mode(n, kModeHoming, [this, n, id](std::optional<std::string> mode_failure) {
                    Node& nd = *nodes_[n];
                    if (mode_failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *mode_failure);
                    if (nd.task_command != id || nd.task != TaskKind::kHoming) return;
                    // Two SYNC cycles: bit 4 = 0, then 1 -> the rising edge starts homing (0x0F -> 0x1F).
                    RpdoImage image = latest_image(n);
                    image.mode = kModeHoming;
                    image.controlword = cia402::profile_position_controlword({}, false, false);
                    queue_image(n, image);
                    image.controlword = cia402::profile_position_controlword({}, true, false);
                    queue_image(n, image);
                    nd.task_watching = true;
                  });
                });
}

void Uc57Stack::start_outputs(std::size_t n, Job& job, const motionlcm::axis_command_t& axis) {
  const std::int64_t id = job.command.command_id;
  const std::string label = nodes_[n]->settings.label();
  if ((axis.output_mask & ~((1 << kOutputCount) - 1)) != 0) {
    return part_failed(id, n, error_code(ReplyError::kOutsideLimits), label + ": output mask " + hex(static_cast<std::uint32_t>(axis.output_mask), 2) +
                                                  " names outputs the UC57 does not have (OUT1, OUT2)");
  }
  // The outputs are driven by their function selection (2030h:0D/0E): 5 = high, 6 = low. RW/S,
  // not stored: the configured function returns after a power cycle.
  std::vector<std::pair<ObjectAddress, std::vector<std::uint8_t>>> writes;
  for (int output = 0; output < kOutputCount; ++output) {
    if ((axis.output_mask & (1 << output)) == 0) continue;
    const bool high = (axis.output_value & (1 << output)) != 0;
    writes.push_back({{od::kIoConfiguration, static_cast<std::uint8_t>(kFirstOutputFunctionSub + output)},
                      le<std::uint16_t>(high ? kOutputForcedHigh : kOutputForcedLow)});
  }
  sdo_write_all(n, std::move(writes), [this, n, id, mask = axis.output_mask, value = axis.output_value](std::optional<std::string> failure) {
    if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
    auto& outputs = nodes_[n]->status.outputs;
    outputs = (outputs & ~mask) | (value & mask);
    publish_status(n);
    part_done(id, n);
  });
}

void Uc57Stack::start_set_position(std::size_t n, Job& job, const motionlcm::axis_command_t& axis) {
  const std::int64_t id = job.command.command_id;
  if (axis.target_counts != 0) {
    return part_failed(id, n, error_code(ReplyError::kUnsupported),
                       nodes_[n]->settings.label() + ": the UC57 can only set its position to zero (2012h); " +
                           std::to_string(axis.target_counts) + " counts is not possible");
  }
  start_task(n, TaskKind::kSdoOnly, id, kNever);
  sdo_write_all(n, {{{od::kZeroPosition, 0}, le<std::uint16_t>(kZeroPositionCommand)}}, [this, n, id](std::optional<std::string> failure) {
    if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
    nodes_[n]->status.position_counts = 0;
    part_done(id, n);
  });
}

void Uc57Stack::start_param(std::size_t n, Job& job) {
  const std::int64_t id = job.command.command_id;
  const motionlcm::param_t& param = job.command.param;
  const std::string label = nodes_[n]->settings.label();
  if (param.space != motionlcm::param_t::CANOPEN_OBJECT) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest), label + ": UC57 parameters are CANopen objects (param_t space CANOPEN_OBJECT)");
  }
  if (param.index < 0 || param.index > 0xFFFF || param.subindex < -1 || param.subindex > 0xFF) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest), label + ": object " + std::to_string(param.index) + ":" + std::to_string(param.subindex) +
                                              " is not a CANopen index (0..FFFFh) and sub-index (0..FFh)");
  }
  const ObjectAddress object{static_cast<std::uint16_t>(param.index), static_cast<std::uint8_t>(std::max(param.subindex, 0))};
  const auto* entry = cia402::uc57::find_entry(object.index, object.subindex);
  std::size_t width = static_cast<std::size_t>(std::max<std::int8_t>(param.width, 0));
  bool is_signed = param.is_signed;
  if (width == 0 && entry != nullptr) {
    width = cia402::uc57::size_bytes(entry->type);
    is_signed = cia402::uc57::is_signed(entry->type);
  }
  if (width != 0 && width != 1 && width != 2 && width != 4) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest), label + ": width " + std::to_string(width) + " (CANopen objects: 1, 2 or 4 bytes)");
  }
  if (job.command.kind == Command::PARAM_READ) {
    return sdo_read(n, object, [this, n, id, object, is_signed](std::error_code ec, std::span<const std::uint8_t> data) {
      if (ec) return part_failed(id, n, error_code(ReplyError::kDriveError), sdo_failure(n, false, object, ec));
      const auto it = jobs_.find(id);
      if (it != jobs_.end()) it->second.command.param.value = is_signed ? read_signed(data) : static_cast<std::int64_t>(read_unsigned(data));
      part_done(id, n);
    });
  }
  if (width == 0) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest), label + ": object " + object_text(object) + " is not in the UC57 dictionary: give the width");
  }
  std::vector<std::uint8_t> data(width);
  for (std::size_t i = 0; i < width; ++i) data[i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(param.value) >> (8 * i));
  sdo_write(n, object, std::move(data), [this, n, id, object](std::error_code ec, std::span<const std::uint8_t>) {
    if (ec) return part_failed(id, n, error_code(ReplyError::kDriveError), sdo_failure(n, true, object, ec));
    part_done(id, n);
  });
}

void Uc57Stack::disarm(const Job& disarm_job) {
  std::vector<std::int64_t> victims;
  for (const auto& [id, job] : jobs_) {
    if (job.command.kind != Command::ARM_MOVE || job.started) continue;
    if (disarm_job.command.trigger_id != 0 && job.command.trigger_id != disarm_job.command.trigger_id) continue;
    const bool shares_axis = std::any_of(job.nodes.begin(), job.nodes.end(), [&](std::size_t n) {
      return std::find(disarm_job.nodes.begin(), disarm_job.nodes.end(), n) != disarm_job.nodes.end();
    });
    if (shares_axis) victims.push_back(id);
  }
  // Bit 4 is still 0 in every armed drive: forgetting the job is all it takes.
  for (const auto id : victims) {
    const Job& job = jobs_.at(id);
    part_failed(id, job.nodes.front(), error_code(ReplyError::kStopped), "disarmed by command " + std::to_string(disarm_job.command.command_id));
  }
}

void Uc57Stack::fire(std::int64_t trigger_id, TimePoint now) {
  now_ = now;
  std::vector<std::int64_t> ready_jobs;
  std::vector<std::int64_t> early_jobs;
  for (const auto& [id, job] : jobs_) {
    if (job.command.kind != Command::ARM_MOVE || job.started || job.command.trigger_id != trigger_id || trigger_id == 0) continue;
    (job.all(Job::Part::kArmed) ? ready_jobs : early_jobs).push_back(id);
  }
  for (const auto id : early_jobs) {
    const Job& job = jobs_.at(id);
    part_failed(id, job.nodes.front(), error_code(ReplyError::kArmFailed),
                "trigger " + std::to_string(trigger_id) + " arrived before every axis of command " + std::to_string(id) + " was armed");
  }
  if (!ready_jobs.empty()) fire_jobs(ready_jobs, now);
}

// The synchronized start: every armed node's RPDO1 with bit 4 = 1, then ONE SYNC applies them all.
void Uc57Stack::fire_jobs(const std::vector<std::int64_t>& command_ids, TimePoint now) {
  std::vector<bool> armed(nodes_.size(), false);
  for (const auto id : command_ids) {
    for (const std::size_t n : jobs_.at(id).nodes) armed[n] = true;
  }
  const std::uint64_t applying_sync = master_.sync()->sent() + 1;
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    if (node.phase != Node::Phase::kOperational) continue;
    if (armed[n]) {
      RpdoImage image = latest_image(n);
      image.controlword = cia402::profile_position_controlword({}, true, false);  // 0x1F: absolute, new set-point
      node.rpdo_queue.clear();
      node.power.note_controlword_sent(image.controlword);
      send_image(n, image);
      node.task = TaskKind::kTriggered;
      node.task_deadline = now + options_.set_point_timeout + 2 * cycle();
    } else if (!node.rpdo_queue.empty()) {
      // This SYNC applies whatever else is pending, as a periodic one would.
      send_image(n, node.rpdo_queue.front());
      node.rpdo_queue.pop_front();
    } else {
      continue;
    }
    node.image_sync = applying_sync;
  }
  master_.sync()->trigger_now(now);
  const std::int64_t trigger_utime = options_.wall_clock_us(now);  // the driver replaces it by the SYNC's echo
  can::Frame sync_frame{};
  sync_frame.id = master_.sync()->config().cob_id & 0x7FF;
  for (const auto id : command_ids) {
    if (context_.start_frame) context_.start_frame(id, sync_frame);
    Job& job = jobs_.at(id);
    job.started = true;
    std::fill(job.parts.begin(), job.parts.end(), Job::Part::kStarted);
    Reply r{};
    r.command_id = id;
    r.status = Reply::STARTED;
    r.trigger_utime = trigger_utime;
    r.start_mechanism = "sync";
    r.predicted_skew_us = 0;  // one frame starts every axis; the nodes' SYNC latency is undocumented
    if (context_.out != nullptr) context_.out->command_reply(r);
  }
}

}  // namespace motion::uc57_driver
