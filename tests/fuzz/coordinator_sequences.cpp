// The coordinator's command handling (coordinator.hpp, the passive core) fed message sequences on
// a manual clock: client requests of every kind with edge values (zero, sub-count, at and beyond
// the limits, NaN, unknown axes, repeats of earlier requests), gateway replies to the commands it
// sent and to made-up ones, axis states, heartbeats, drive models (good and broken), events,
// orphaned moves, trigger hearings, silent gateways and time passing, in any order. Gateways may also be switched to
// answering like a working gateway, so that sequences reach triggered moves, progress and stops.
//
// Checked while it runs: a request's terminal replies (a repeat of the request is answered again)
// never disagree; the core never returns a deadline it keeps being due at. Checked at the end,
// with every gateway silent and time run out: every request that got a reply has its terminal
// reply and none is still active. A violation aborts (a libFuzzer crash).
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "fuzz_targets.hpp"
#include "motion/config/config.hpp"
#include "motion/coordinator/coordinator.hpp"
#include "motion/coordinator/move_planner.hpp"
#include "motion/core/log.hpp"

namespace motion::fuzz {
namespace {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using motionlcm::reply_t;
using motionlcm::request_t;
using std::chrono::milliseconds;

// Four families' start mechanisms on two buses: x, y in UIM342 group 20, z a UC57 (SYNC), c an
// ADAM drive (broadcast).
constexpr const char* kLab = R"(
buses:
  - {name: can0, transport: simcan:can0}
  - {name: rs485, transport: simserial:rs485}
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5, group_id: 20}
  - {name: yd, family: uim342, bus: can0, node_id: 6, group_id: 20}
  - {name: zd, family: uc57, bus: can0, node_id: 10}
  - {name: cd, family: adam-modbus, bus: rs485, node_id: 1}
axes:
  - {name: x, drive: xd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 5, acceleration: 50}}
  - {name: y, drive: yd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 5, acceleration: 50}}
  - {name: z, drive: zd, steps_per_unit: 3200, limits: {min: -5, max: 5, velocity: 2, acceleration: 20}}
  - {name: c, drive: cd, steps_per_unit: 10, limits: {min: -100, max: 100, velocity: 50, acceleration: 500}}
coordinator: {gateway_timeout_ms: 400, arm_timeout_ms: 500, progress_period_ms: 50}
)";

struct AxisInfo {
  const char* name;
  const char* bus;
  const char* family;
  std::int32_t node;
  std::int32_t group;
  double steps_per_unit;
};
constexpr std::array<AxisInfo, 4> kAxes{{{"x", "can0", "uim342", 5, 20, 100},
                                         {"y", "can0", "uim342", 6, 20, 100},
                                         {"z", "can0", "uc57", 10, 0, 3200},
                                         {"c", "rs485", "adam-modbus", 1, 0, 10}}};
constexpr std::array<const char*, 2> kBuses{"can0", "rs485"};

const config::Config& lab() {
  // The core logs each request's outcome: quiet unless FUZZ_VERBOSE is set.
  static const bool logging = motion::log::init("coordinator_sequences", std::getenv("FUZZ_VERBOSE") ? "info" : "off");
  (void)logging;
  static const config::Config config = *config::load_string(kLab, "coordinator_sequences").config;
  return config;
}

// FUZZ_VERBOSE=1: the replies on stderr (for reading what a seed does).
bool verbose() {
  static const bool on = std::getenv("FUZZ_VERBOSE") != nullptr;
  return on;
}

[[noreturn]] void violated(const std::string& what) {
  std::fprintf(stderr, "coordinator_sequences: %s\n", what.c_str());
  std::abort();
}

bool is_terminal(std::int8_t status) {
  return status == reply_t::DONE || status == reply_t::REJECTED || status == reply_t::ABORTED ||
         status == reply_t::FAILED;
}

// A drive model as the family's gateway would publish it (grids in the family's style).
motionlcm::drive_model_t model_of(const AxisInfo& a) {
  using M = motionlcm::drive_model_t;
  M m{};
  m.bus = a.bus;
  m.axis = a.name;
  m.drive = std::string(a.name) + "d";
  m.family = a.family;
  m.node_id = a.node;
  m.group_id = a.group;
  m.counts_per_unit = a.steps_per_unit;
  m.grid = "fuzz";
  m.velocity_step = 1.0;
  m.velocity_min = 1;
  m.velocity_max = 1'000'000;
  m.acceleration_kind = M::ACCEL_RATE;
  m.acceleration_step = 1.0;
  m.acceleration_min = 1;
  m.acceleration_max = 10'000'000;
  m.position_min = -(std::int64_t{1} << 31);
  m.position_max = (std::int64_t{1} << 31) - 1;
  const auto start = [&m](std::int8_t kind, double wire_us, std::int32_t address) {
    m.start_kinds.push_back(kind);
    m.start_addresses.push_back(address);
    m.start_wire_us.push_back(wire_us);
  };
  const std::string family = a.family;
  if (family == "uim342") {
    start(M::START_UIM342_GROUP_BG, 70.0, a.group);
  } else if (family == "uc57") {
    m.velocity_step = 3200.0 / 60.0;  // 1 rpm at 3200 counts per revolution
    m.velocity_max = 3000;
    m.acceleration_kind = M::ACCEL_RAMP_TIME;
    m.acceleration_step = 0.001;  // ms
    m.acceleration_max = 65535;
    start(M::START_CANOPEN_SYNC, 60.0, 0x80);
  } else {
    start(M::START_ADAM_BROADCAST, 694.0, 0);
  }
  start(M::START_SINGLE, 72.0, a.node);
  m.num_starts = static_cast<std::int32_t>(m.start_kinds.size());
  return m;
}

// User-unit values that matter: zero, sub-count, tiny, at and beyond the limits, non-finite.
double edge_value(Input& in) {
  static constexpr std::array<double, 16> kValues{0.0,  0.001, 0.004, 0.01, 1.0,  -1.0,   5.0, -5.0,
                                                  10.0, -10.0, 10.01, 100,  1e12, 1e-300, 0.5, 2.5};
  const std::uint8_t b = in.byte();
  if (b < 200) return kValues[b % kValues.size()];
  if (b < 240) return (static_cast<double>(in.u16()) - 32768.0) / 1000.0;
  switch (b % 4) {
    case 0: return std::numeric_limits<double>::quiet_NaN();
    case 1: return std::numeric_limits<double>::infinity();
    case 2: return -std::numeric_limits<double>::infinity();
    default: return std::numeric_limits<double>::denorm_min();
  }
}

class Run final : public coordinator::CoordinatorOutput {
 public:
  Run() : core_(lab(), coordinator::make_move_planner(), *this, [this] { return wall_us(); }) {
    for (const auto& a : kAxes) {
      State s{};
      s.state.axis = a.name;
      s.state.bus = a.bus;
      s.state.family = a.family;
      s.state.node_id = a.node;
      s.state.group_id = a.group;
      s.state.online = s.state.enabled = true;
      states_.push_back(s);
    }
    // The lab comes up: heartbeats, models and states reach the core.
    for (int i = 0; i < 6; ++i) {
      heartbeats();
      for (const auto& a : kAxes) deliver([&](auto& c, auto now) { c.on_drive_model(model_of(a), now); });
      advance(milliseconds(50));
    }
  }

  void step(Input& in) {
    const std::uint8_t op = in.byte();
    if (verbose())
      std::fprintf(stderr, " t=%lld ms op %d\n", static_cast<long long>((wall_us() - kWallStartUs) / 1000), op % 12);
    switch (op % 13) {
      case 0:
      case 1: request(in); break;
      case 2: resend(in); break;
      case 3: gateway_reply(in); break;
      case 4: axis_state(in); break;
      case 5: heartbeats(); break;
      case 6: drive_model(in); break;
      case 7: event(in); break;
      case 8: orphaned(in); break;
      case 9: working_ = (in.byte() & 1) != 0; break;
      case 10: silent_[in.byte() % kBuses.size()] ^= true; break;
      case 12: trigger_heard(in); break;
      default: {
        static constexpr std::array<int, 8> kSteps{0, 1, 10, 50, 100, 500, 2000, 30000};
        const int ms = kSteps[in.byte() % kSteps.size()];
        for (int t = 0; t < ms; t += 50) {
          heartbeats();
          advance(milliseconds(std::min(50, ms - t)));
        }
        break;
      }
    }
    answer();
  }

  // Every gateway falls silent; time runs until nothing is scheduled. Then every request that
  // was answered has ended.
  void finish() {
    silent_.fill(true);
    pending_.clear();
    const TimePoint end = now_ + std::chrono::hours(48);
    for (int i = 0; i < 100000 && now_ < end; ++i) {
      const TimePoint next = core_.process(now_);
      if (next == kNever) break;
      now_ = std::max(next, now_ + std::chrono::microseconds(1));
    }
    for (const auto& [key, replies] : replies_) {
      if (!replies.terminal) violated("request " + key.first + "/" + std::to_string(key.second) + " never ended");
    }
    if (core_.active_requests() != 0) violated(std::to_string(core_.active_requests()) + " requests still active");
  }

  // ---- CoordinatorOutput
  void reply(const reply_t& r) override {
    if (verbose()) {
      std::fprintf(stderr, "  reply %s/%lld status %d code %d: %s\n", r.client_id.c_str(),
                   static_cast<long long>(r.request_id), r.status, r.error_code, r.reason.c_str());
    }
    Replies& seen = replies_[{r.client_id, r.request_id}];
    if (!is_terminal(r.status)) return;
    if (seen.terminal && (seen.status != r.status || seen.code != r.error_code)) {
      violated("request " + r.client_id + "/" + std::to_string(r.request_id) + " ended twice: status " +
               std::to_string(seen.status) + " then " + std::to_string(r.status) + " (" + r.reason + ")");
    }
    seen = {true, r.status, r.error_code};
  }
  void gateway_command(const std::string& bus, const motionlcm::gateway_command2_t& /*grid*/,
                       const gateway_command_t& command) override {
    if (commands_.size() < kMaxCommands) commands_.push_back({bus, command});
    if (working_ && !silent_[bus_index(bus)]) pending_.push_back({bus, command});
  }
  void sync_trigger(const motionlcm::sync_trigger_t& trigger) override {
    if (!working_) return;
    // A working gateway starts what it armed for the trigger and its axes reach their targets.
    for (const auto& [bus, c] : armed_) {
      if (c.trigger_id != trigger.trigger_id || silent_[bus_index(bus)]) continue;
      started_.push_back({bus, c});
    }
  }
  void active_moves(const motionlcm::active_moves_t&) override {}
  void event(const motionlcm::event_t&) override {}

 private:
  static constexpr std::size_t kMaxCommands = 256;
  static constexpr TimePoint kStart = TimePoint{} + std::chrono::hours(1000);
  static constexpr std::int64_t kWallStartUs = 1'700'000'000'000'000;
  struct State {
    motionlcm::axis_state_t state;
  };
  struct Replies {
    bool terminal = false;
    std::int8_t status = 0;
    std::int32_t code = 0;
  };
  using Sent = std::pair<std::string, gateway_command_t>;

  static std::size_t bus_index(const std::string& bus) { return bus == kBuses[0] ? 0 : 1; }
  [[nodiscard]] std::int64_t wall_us() const {
    return kWallStartUs + std::chrono::duration_cast<std::chrono::microseconds>(now_ - kStart).count();
  }

  template <typename F>
  void deliver(F&& f) {
    f(core_, now_);
    settle();
  }
  // Runs what is due at now_; a core that stays due without end would spin its loop.
  void settle() {
    for (int i = 0;; ++i) {
      const TimePoint next = core_.process(now_);
      if (next > now_) return;
      if (i == 10000) violated("the core keeps returning a deadline that is already due");
    }
  }
  void advance(Duration d) {
    const TimePoint end = now_ + d;
    while (now_ < end) {
      const TimePoint next = core_.process(now_);
      now_ = std::min(end, std::max(next, now_ + std::chrono::microseconds(1)));
    }
    settle();
  }

  void request(Input& in) {
    request_t r{};
    r.utime = wall_us();
    r.client_id = (in.byte() & 1) != 0 ? "fuzz-a" : "fuzz-b";
    r.request_id = ++next_request_;
    r.kind = static_cast<std::int8_t>(in.byte() % 16);
    const std::uint8_t mask = in.byte();
    for (std::size_t i = 0; i < kAxes.size() + 1; ++i) {
      if ((mask & (1U << i)) == 0) continue;
      r.axes.emplace_back(i < kAxes.size() ? kAxes[i].name : "nope");
      r.values.push_back(edge_value(in));
    }
    if ((mask & 0x80U) != 0 && !r.axes.empty()) r.axes.push_back(r.axes.front());  // a duplicate axis
    if ((mask & 0x40U) != 0) r.values.resize(r.axes.size());
    r.num_axes = static_cast<std::int32_t>(std::min(r.axes.size(), r.values.size()));
    r.axes.resize(static_cast<std::size_t>(r.num_axes));
    r.values.resize(static_cast<std::size_t>(r.num_axes));
    r.velocity_scale = (in.byte() & 3) == 0 ? edge_value(in) : 0.0;
    r.acceleration_scale = (in.byte() & 3) == 0 ? edge_value(in) : 0.0;
    r.timeout_ms = (in.byte() & 7) == 0 ? static_cast<std::int32_t>(in.u32()) : 0;
    r.output_mask = in.byte();
    r.output_value = in.byte();
    r.param.index = in.u16();
    r.param.subindex = in.byte();
    if (sent_.size() < 64) sent_.push_back(r);
    replies_[{r.client_id, r.request_id}];  // every request is answered
    deliver([&](auto& c, auto now) { c.on_request(r, now); });
  }
  // A client that heard nothing sends an earlier request again (its send time aside, unchanged).
  void resend(Input& in) {
    if (sent_.empty()) return;
    request_t r = sent_[in.byte() % sent_.size()];
    r.utime = wall_us();
    deliver([&](auto& c, auto now) { c.on_request(r, now); });
  }
  void gateway_reply(Input& in) {
    gateway_reply_t g{};
    g.utime = wall_us();
    const std::uint8_t pick = in.byte();
    if (!commands_.empty() && pick < 240) {
      const Sent& s = commands_[pick % commands_.size()];
      g.bus = s.first;
      g.command_id = s.second.command_id;
    } else {
      g.bus = kBuses[pick % kBuses.size()];
      g.command_id = static_cast<std::int64_t>(in.u32()) - 1000;
    }
    g.status = static_cast<std::int8_t>(in.byte() % 7);
    g.error_code = in.byte() % 24;
    g.trigger_utime = (in.byte() & 1) != 0 ? wall_us() : 0;
    g.start_mechanism = "group-bg";
    g.reason = "fuzz";
    deliver([&](auto& c, auto now) { c.on_gateway_reply(g, now); });
  }
  void axis_state(Input& in) {
    State& s = states_[in.byte() % states_.size()];
    const std::uint8_t flags = in.byte();
    s.state.online = (flags & 1) != 0;
    s.state.enabled = (flags & 2) != 0;
    s.state.moving = (flags & 4) != 0;
    s.state.in_position = (flags & 8) != 0;
    s.state.fault = (flags & 16) != 0;
    s.state.homed = (flags & 32) != 0;
    s.state.fault_code = (flags & 64) != 0 ? motionlcm::axis_state_t::POSITION_LOST : 0;
    s.state.position_counts = static_cast<std::int64_t>(static_cast<std::int16_t>(in.u16()));
    publish(s);
  }
  void publish(State& s) {
    s.state.utime = s.state.sample_utime = wall_us();
    s.state.position = static_cast<double>(s.state.position_counts) / kAxes[index_of(s)].steps_per_unit;
    if (silent_[bus_index(s.state.bus)]) return;
    deliver([&](auto& c, auto now) { c.on_axis_state(s.state, now); });
  }
  std::size_t index_of(const State& s) const { return static_cast<std::size_t>(&s - states_.data()); }
  void heartbeats() {
    for (std::size_t b = 0; b < kBuses.size(); ++b) {
      if (silent_[b]) continue;
      motionlcm::health_t h{};
      h.utime = wall_us();
      h.process = std::string("gateway:") + kBuses[b];
      h.role = "gateway";
      h.host = "fuzzhost";
      h.pid = 100 + static_cast<std::int32_t>(b);
      h.state = motionlcm::health_t::OK;
      deliver([&](auto& c, auto now) { c.on_health(h, now); });
    }
    for (auto& s : states_) publish(s);
  }
  void drive_model(Input& in) {
    motionlcm::drive_model_t m = model_of(kAxes[in.byte() % kAxes.size()]);
    switch (in.byte() % 6) {
      case 0: m.velocity_step = edge_value(in); break;
      case 1: m.acceleration_step = edge_value(in); break;
      case 2: m.velocity_max = 0; break;
      case 3: m.family = "uim242"; break;
      case 4: m.num_starts = 0, m.start_kinds.clear(), m.start_addresses.clear(), m.start_wire_us.clear(); break;
      default: break;
    }
    m.utime = wall_us();
    deliver([&](auto& c, auto now) { c.on_drive_model(m, now); });
  }
  void event(Input& in) {
    motionlcm::event_t e{};
    e.utime = wall_us();
    const AxisInfo& a = kAxes[in.byte() % kAxes.size()];
    e.axis = a.name;
    e.bus = a.bus;
    e.source = std::string("gateway:") + a.bus;
    e.kind = static_cast<std::int16_t>(in.byte() % 20);
    e.severity = static_cast<std::int8_t>(in.byte() % 3);
    deliver([&](auto& c, auto now) { c.on_event(e, now); });
  }
  void orphaned(Input& in) {
    motionlcm::active_moves_t m{};
    m.utime = wall_us();
    const AxisInfo& a = kAxes[in.byte() % kAxes.size()];
    m.axes = {a.name};
    m.buses = {a.bus};
    // Requests of the coordinator that stopped: their clients' ids are not this run's.
    m.client_ids = {(in.byte() & 1) != 0 ? "before-a" : "before-b"};
    m.request_ids = {static_cast<std::int64_t>(in.byte() % 8)};
    m.kinds = {static_cast<std::int8_t>(in.byte() % 14)};
    m.phases = {static_cast<std::int8_t>(1 + in.byte() % 2)};
    m.command_ids = {0};
    m.target_counts = {0};
    m.targets = {0.0};
    m.fire_utime = {0};
    m.num_axes = 1;
    deliver([&](auto& c, auto now) { c.on_orphaned_moves(m, now); });
  }

  // A gateway says when it heard a trigger (TRIGGER_HEARD): on time, late, or for a trigger
  // that was never sent.
  void trigger_heard(Input& in) {
    motionlcm::trigger_heard_t h{};
    h.bus = kBuses[in.byte() % kBuses.size()];
    h.trigger_id = in.byte() % 8;
    h.trigger_utime = wall_us() - static_cast<std::int64_t>(in.u16()) * 10;
    h.utime = wall_us();
    h.send_utime = h.trigger_utime + static_cast<std::int64_t>(in.u16()) * 10;
    deliver([&](auto& c, auto now) { c.on_trigger_heard(h, now); });
  }

  // A working gateway's answers: ARM_MOVE is ARMED (started by its trigger), a stop stops its
  // axes, everything else is DONE; a started move's axes are at their targets.
  void answer() {
    while (!pending_.empty() || !started_.empty()) {
      std::vector<Sent> pending;
      pending.swap(pending_);
      for (const auto& [bus, c] : pending) {
        gateway_reply_t g{};
        g.utime = wall_us();
        g.bus = bus;
        g.command_id = c.command_id;
        g.status = c.kind == gateway_command_t::ARM_MOVE ? gateway_reply_t::ARMED : gateway_reply_t::DONE;
        if (c.kind == gateway_command_t::ARM_MOVE && armed_.size() < kMaxCommands) armed_.push_back({bus, c});
        if (c.kind == gateway_command_t::STOP || c.kind == gateway_command_t::ESTOP) {
          for (const auto& a : c.axes) set_moving(a.axis, false, std::nullopt);
        }
        deliver([&](auto& core, auto now) { core.on_gateway_reply(g, now); });
      }
      std::vector<Sent> started;
      started.swap(started_);
      for (const auto& [bus, c] : started) {
        gateway_reply_t g{};
        g.utime = g.trigger_utime = wall_us();
        g.bus = bus;
        g.command_id = c.command_id;
        g.status = gateway_reply_t::STARTED;
        g.start_mechanism = "group-bg";
        deliver([&](auto& core, auto now) { core.on_gateway_reply(g, now); });
        for (const auto& a : c.axes) set_moving(a.axis, false, a.target_counts);
      }
    }
  }
  void set_moving(const std::string& axis, bool moving, std::optional<std::int64_t> position) {
    for (auto& s : states_) {
      if (s.state.axis != axis) continue;
      s.state.moving = moving;
      if (position) s.state.position_counts = *position;
      publish(s);
    }
  }

  TimePoint now_ = kStart;
  coordinator::Coordinator core_;
  std::vector<State> states_;
  std::map<std::pair<std::string, std::int64_t>, Replies> replies_;
  std::vector<Sent> commands_;
  std::vector<Sent> pending_;
  std::vector<Sent> armed_;
  std::vector<Sent> started_;
  std::vector<request_t> sent_;
  std::array<bool, kBuses.size()> silent_{};
  bool working_ = false;
  std::int64_t next_request_ = 0;
};

}  // namespace

int coordinator_sequences(const std::uint8_t* data, std::size_t size) {
  Input in(data, size);
  Run run;
  for (int steps = 0; !in.empty() && steps < 400; ++steps) run.step(in);
  run.finish();
  return 0;
}

}  // namespace motion::fuzz
