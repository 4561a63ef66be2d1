// The coordinator's tests against fake gateways: the passive core runs on a simulated wire and a
// manual clock (no multicast, no waiting). Shared by the coordinator_*_test.cpp files: the lab's
// configuration, the simulated loop and wire, fake gateways and client, and the test fixture.
// Thread contract: everything runs on the test's thread.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <set>

#include <motionlcm/active_moves_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>
#include <motionlcm/trigger_heard_t.hpp>

#include "motion/coordinator/coordinator.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/wire_bounds.hpp"

namespace motion::coordinator::test_fixture {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using motionlcm::reply_t;
using motionlcm::request_t;
using std::chrono::milliseconds;

inline const char* const kConfig = R"(
buses:
  - {name: can0, transport: simcan:can0}
  - {name: rs485, transport: simserial:rs485}
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5, group_id: 20}
  - {name: yd, family: uim342, bus: can0, node_id: 6, group_id: 20}
  - {name: cd, family: adam-modbus, bus: rs485, node_id: 1}
  - {name: rd, family: uim342, bus: can0, node_id: 7}
axes:
  - {name: x, drive: xd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 5, acceleration: 50}}
  - {name: y, drive: yd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 5, acceleration: 50}}
  - {name: c, drive: cd, steps_per_unit: 10, limits: {min: -10, max: 10, velocity: 5, acceleration: 50}}
  - {name: r, drive: rd, steps_per_unit: 8.888888888888889, limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}}
coordinator: {gateway_timeout_ms: 400, arm_timeout_ms: 500, progress_period_ms: 50}
)";

// Plans every axis with its own limits: enough for lifecycle tests (the planner has its own).
inline std::variant<MovePlan, std::string> simple_planner(const std::vector<PlanInput>& in, double, double) {
  MovePlan plan;
  for (const auto& i : in) {
    if (i.target_counts == 777) return std::string("refused: 777 counts");
    // Natives as on the test models' 1 count/s and 1 count/s^2 grids.
    const std::int64_t v = std::llround(i.max_velocity);
    const std::int64_t a = std::llround(i.max_acceleration);
    plan.axes.push_back({i.axis,
                         i.target_counts,
                         i.max_velocity,
                         i.max_acceleration,
                         i.max_acceleration,
                         0.1,
                         {v, a, a},
                         i.model_utime});
  }
  plan.duration_s = 0.1;
  return plan;
}

// A request of client "test": `kind` of `axes` with `values` (one per axis).
inline request_t test_request(std::int64_t id, std::int8_t kind, std::vector<std::string> axes,
                              std::vector<double> values) {
  request_t r{};
  r.client_id = "test";
  r.request_id = id;
  r.kind = kind;
  r.axes = std::move(axes);
  r.values = std::move(values);
  r.num_axes = static_cast<std::int32_t>(r.axes.size());
  return r;
}

// A drive model as a gateway publishes it: velocity in 1 count/s, acceleration in 1 count/s^2; a
// UIM342 in a group (group_id != 0) offers BG to its group id, each drive a start of its own.
inline motionlcm::drive_model_t test_model(const std::string& axis, const std::string& bus, const std::string& family,
                                           std::int32_t group_id = 0) {
  motionlcm::drive_model_t m{};
  m.bus = bus;
  m.axis = axis;
  m.family = family;
  m.grid = "test pps+pps/s";
  m.velocity_step = 1.0;
  m.velocity_min = 1;
  m.velocity_max = 1'000'000;
  m.acceleration_kind = motionlcm::drive_model_t::ACCEL_RATE;
  m.acceleration_step = 1.0;
  m.acceleration_min = 1;
  m.acceleration_max = 10'000'000;
  // Start mechanisms with made-up wire times (a 29-bit BG; an ADAM broadcast at 115200 baud).
  using M = motionlcm::drive_model_t;
  const auto start = [&m](std::int8_t kind, double wire_us, std::int32_t address = 0) {
    m.start_kinds.push_back(kind);
    m.start_addresses.push_back(address);
    m.start_wire_us.push_back(wire_us);
    m.num_starts = static_cast<std::int32_t>(m.start_kinds.size());
  };
  if (family == "uim342") {
    if (group_id != 0) start(M::START_UIM342_GROUP_BG, 70.0, group_id);
    start(M::START_SINGLE, 72.0);
  } else if (family == "adam-modbus") {
    start(M::START_ADAM_BROADCAST, 694.0);
  }
  return m;
}

// Simulated time and wire. A message sent is delivered after everything sent before it, at the
// time it was sent; every core handed a message runs process() right after it, as
// CoordinatorService does. Time moves only to the next thing due: a core's deadline, a scheduled
// action (gateway ticks, test actions) or the end of the run.
class SimLoop {
 public:
  using Action = std::function<void()>;
  using Input = std::function<void(Coordinator&, TimePoint)>;

  [[nodiscard]] TimePoint now() const { return now_; }
  // The wall clock of the simulation: microseconds since the epoch, moving with now().
  [[nodiscard]] std::int64_t wall_us() const {
    return kWallStartUs + std::chrono::duration_cast<std::chrono::microseconds>(now_ - kStart).count();
  }

  void attach(Coordinator& core) { cores_.push_back({&core, core.process(now_)}); }
  // Puts a message on the wire: `delivery` runs once everything sent before it has arrived.
  void send(Action delivery) { wire_.push_back(std::move(delivery)); }
  // A message to every coordinator.
  void send_to_cores(Input input) {
    send([this, input = std::move(input)] { deliver(input); });
  }
  // Hands `input` to every coordinator now, each running what is due after it.
  void deliver(const Input& input) {
    for (auto& c : cores_) {
      input(*c.core, now_);
      c.deadline = c.core->process(now_);
    }
  }
  // Hands `input` to one of the coordinators only.
  void deliver_to(Coordinator& core, const Input& input) {
    for (auto& c : cores_) {
      if (c.core != &core) continue;
      input(core, now_);
      c.deadline = core.process(now_);
    }
  }
  void call_after(Duration delay, Action action) { scheduled_.emplace(now_ + delay, std::move(action)); }
  void call_every(Duration period, Action action) {
    every(now_ + period, period, std::make_shared<Action>(std::move(action)));
  }

  // Runs until `done()` (checked whenever nothing is due) or `end`; false when `end` came first.
  bool run_until(TimePoint end, const std::function<bool()>& done) {
    for (;;) {
      if (!settle()) return false;
      if (done && done()) return true;
      if (!wire_.empty()) continue;  // `done` sent something
      if (now_ >= end) return false;
      TimePoint next = end;
      if (!scheduled_.empty()) next = std::min(next, scheduled_.begin()->first);
      for (const auto& c : cores_) next = std::min(next, c.deadline);
      now_ = std::max(now_, next);
    }
  }

 private:
  // Far from TimePoint{} (which the core reads as "never heard").
  static constexpr TimePoint kStart = TimePoint{} + std::chrono::hours(1000);
  static constexpr std::int64_t kWallStartUs = 1'700'000'000'000'000;
  struct Attached {
    Coordinator* core;
    TimePoint deadline;
  };

  void every(TimePoint at, Duration period, const std::shared_ptr<Action>& action) {
    scheduled_.emplace(at, [this, at, period, action] {
      (*action)();
      every(at + period, period, action);
    });
  }
  // Everything due at now_: messages, scheduled actions, the cores' deadlines. False, for good,
  // when a core keeps returning a deadline that is already due (the loop it runs in would spin).
  bool settle() {
    for (int round = 0; !stuck_; ++round) {
      if (round == 100000) {
        ADD_FAILURE() << "a core keeps returning a deadline that is already due";
        stuck_ = true;
        break;
      }
      bool busy = false;
      while (!wire_.empty()) {
        Action delivery = std::move(wire_.front());
        wire_.pop_front();
        delivery();
        busy = true;
      }
      while (!scheduled_.empty() && scheduled_.begin()->first <= now_) {
        Action action = std::move(scheduled_.begin()->second);
        scheduled_.erase(scheduled_.begin());
        action();
        busy = true;
      }
      for (auto& c : cores_) {
        if (c.deadline > now_) continue;
        c.deadline = c.core->process(now_);
        busy = true;
      }
      if (!busy) return true;
    }
    return false;
  }

  TimePoint now_ = kStart;
  std::deque<Action> wire_;
  std::multimap<TimePoint, Action> scheduled_;
  std::vector<Attached> cores_;
  bool stuck_ = false;
};

// The heartbeat of a fake gateway of `bus`, as every fake gateway here sends it.
inline motionlcm::health_t gateway_heartbeat(const std::string& bus, std::int32_t pid = 100) {
  motionlcm::health_t h{};
  h.process = "gateway:" + bus;
  h.role = "gateway";
  h.host = "testhost";
  h.pid = pid;
  h.state = motionlcm::health_t::OK;
  h.uptime_s = 10;
  return h;
}

// The fake gateway of the tests of CoordinatorService on real multicast: every 50 ms its heartbeat
// (to `heartbeat`: published plain, or signed too) and the state of its axis stamped now (to
// `publish_state`). `state` must outlive the timer.
template <typename Heartbeat, typename PublishState>
EventLoop::TimerId start_gateway_ticks(EventLoop& loop, motionlcm::axis_state_t& state, Heartbeat heartbeat,
                                       PublishState publish_state) {
  return loop.call_every(milliseconds(50), [&state, heartbeat, publish_state] {
    heartbeat(gateway_heartbeat(state.bus));
    state.utime = state.sample_utime = wall_time_us();
    publish_state(state);
  });
}

// Gateways of both buses: heartbeat, axis states, and scripted replies to commands.
struct FakeGateways {
  explicit FakeGateways(SimLoop& sim) : loop_(sim) {
    loop_.call_every(milliseconds(50), [this] { tick(); });
  }

  void tick() {
    for (const std::string bus : {"can0", "rs485"}) {
      if (silent.contains(bus) || !heartbeats) continue;
      const motionlcm::health_t h = gateway_heartbeat(bus, pid_of[bus]);
      loop_.send_to_cores([h](Coordinator& c, TimePoint now) { c.on_health(h, now); });
    }
    for (const auto& [name, m] : models) {
      if (silent.contains(m.bus) || !publish_models) continue;
      loop_.send_to_cores([model = m](Coordinator& c, TimePoint now) { c.on_drive_model(model, now); });
    }
    for (const auto& [name, t] : armings) {
      if (silent.contains(t.bus)) continue;
      loop_.send_to_cores([timing = t](Coordinator& c, TimePoint now) { c.on_arm_timing(timing, now); });
    }
    for (const auto& [bus, t] : lines) {
      if (silent.contains(bus)) continue;
      loop_.send_to_cores([timing = t](Coordinator& c, TimePoint now) { c.on_line_timing(timing, now); });
    }
    for (auto& [name, s] : states) {
      if (silent.contains(s.bus)) continue;
      s.utime = s.sample_utime = loop_.wall_us();
      loop_.send_to_cores([state = s](Coordinator& c, TimePoint now) { c.on_axis_state(state, now); });
    }
  }
  // GW_COMMAND_<bus> as a gateway receives it.
  // `c2` is what goes on the wire (GW_COMMAND2_<bus>), `c` the same in counts/s.
  void receive(const gateway_command_t& c, const motionlcm::gateway_command2_t& c2) {
    commands.push_back(c);
    commands2.push_back(c2);
    if (on_command) on_command(c);
  }
  void publish(const gateway_reply_t& r) {
    loop_.send_to_cores([r](Coordinator& c, TimePoint now) { c.on_gateway_reply(r, now); });
  }
  void publish(const motionlcm::event_t& e) {
    loop_.send_to_cores([e](Coordinator& c, TimePoint now) { c.on_event(e, now); });
  }
  void reply(const gateway_command_t& c, std::int8_t status, const std::string& reason = {}) {
    gateway_reply_t r{};
    r.command_id = c.command_id;
    r.bus = c.bus;
    r.status = status;
    r.reason = reason;
    r.trigger_utime = loop_.wall_us();
    publish(r);
  }
  void add_axis(const std::string& name, const std::string& bus, double scale, const std::string& family,
                std::int32_t group_id = 0) {
    models[name] = test_model(name, bus, family, group_id);
    armings[name].bus = bus;
    armings[name].axis = name;
    motionlcm::axis_state_t s{};
    s.axis = name;
    s.bus = bus;
    s.online = true;
    s.enabled = true;
    s.in_position = true;
    scales[name] = scale;
    states[name] = s;
  }
  void put(const std::string& name, std::int64_t counts, bool moving) {
    auto& s = states[name];
    s.position_counts = counts;
    s.position = static_cast<double>(counts) / scales[name];
    s.moving = moving;
  }

  SimLoop& loop_;
  std::map<std::string, motionlcm::axis_state_t> states;
  std::map<std::string, double> scales;
  std::map<std::string, motionlcm::drive_model_t> models;  // DRIVE_MODEL, every tick
  std::map<std::string, motionlcm::arm_timing_t> armings;  // ARM_TIMING (zero unless a test sets it), every tick
  std::map<std::string, motionlcm::line_timing_t>
      lines;  // LINE_TIMING per bus (none unless a test sets it), every tick
  bool publish_models = true;
  std::vector<TimePoint> model_requests;  // when the coordinator sent DRIVE_MODEL_REQUEST
  std::map<std::string, std::int32_t> pid_of{{"can0", 100}, {"rs485", 200}};
  std::set<std::string> silent;
  bool heartbeats = true;  // false: axis states only (a coordinator that missed the heartbeats)
  std::vector<gateway_command_t> commands;
  std::vector<motionlcm::gateway_command2_t> commands2;  // the same, as sent (grid integers)
  std::vector<motionlcm::sync_trigger_t> triggers;
  std::vector<motionlcm::sync_trigger2_t> triggers2;
  std::function<void(const gateway_command_t&)> on_command;
};

// A client: requests in, and what it hears of REPLY, ACTIVE_MOVES and EVENT.
struct FakeClient {
  explicit FakeClient(SimLoop& sim) : loop_(sim) {}
  void publish(const request_t& r) {
    loop_.send_to_cores([r](Coordinator& c, TimePoint now) { c.on_request(r, now); });
  }
  // REQUEST bytes as they arrive, decoded as an LCM node decodes them.
  void publish_raw(const std::vector<std::uint8_t>& bytes) {
    request_t r{};
    const std::string why = lcm::wire::decode_bounded(bytes.data(), bytes.size(), r);
    if (why.empty()) return publish(r);
    loop_.send_to_cores([bytes, why](Coordinator& c, TimePoint now) { c.on_malformed_request(bytes, why, now); });
  }

  SimLoop& loop_;
  std::function<void(const reply_t&)> on_reply;
  std::function<void(const motionlcm::active_moves_t&)> on_active_moves;
  std::function<void(const motionlcm::event_t&)> on_event;
};

// What the coordinators send, on the simulated wire to the gateways and the client; their own
// events reach every coordinator too (they hear EVENT).
struct Wire final : CoordinatorOutput {
  Wire(SimLoop& sim, FakeGateways& gws, FakeClient& cl) : loop_(sim), gateways_(gws), client_(cl) {}
  void reply(const reply_t& r) override {
    loop_.send([this, r] {
      if (client_.on_reply) client_.on_reply(r);
    });
  }
  void gateway_command(const std::string&, const motionlcm::gateway_command2_t& c2,
                       const gateway_command_t& c) override {
    loop_.send([this, c, c2] { gateways_.receive(c, c2); });
  }
  void sync_trigger(const motionlcm::sync_trigger_t& t) override {
    loop_.send([this, t] { gateways_.triggers.push_back(t); });
  }
  void sync_trigger2(const motionlcm::sync_trigger2_t& t) override {
    loop_.send([this, t] { gateways_.triggers2.push_back(t); });
  }
  void active_moves(const motionlcm::active_moves_t& m) override {
    loop_.send([this, m] {
      if (client_.on_active_moves) client_.on_active_moves(m);
    });
  }
  void event(const motionlcm::event_t& e) override {
    loop_.send([this, e] {
      if (client_.on_event) client_.on_event(e);
      loop_.deliver([e](Coordinator& c, TimePoint now) { c.on_event(e, now); });
    });
  }
  void drive_model_request(const motionlcm::drive_model_request_t&) override {
    gateways_.model_requests.push_back(loop_.now());
  }

  SimLoop& loop_;
  FakeGateways& gateways_;
  FakeClient& client_;
};

struct CoordinatorTest : ::testing::Test {
  CoordinatorTest()
      : config(*config::load_string(kConfig).config),
        gateways(loop),
        client(loop),
        wire(loop, gateways, client),
        coordinator(config, simple_planner, wire, wall_clock()) {
    loop.attach(coordinator);
    gateways.add_axis("x", "can0", 100, "uim342", 20);
    gateways.add_axis("y", "can0", 100, "uim342", 20);
    gateways.add_axis("c", "rs485", 10, "adam-modbus");
    gateways.add_axis("r", "can0", 8.888888888888889, "uim342");
    client.on_reply = [this](const reply_t& r) { replies[r.request_id].push_back(r); };
  }
  void SetUp() override { pump(milliseconds(200)); }  // heartbeats and states reach the coordinator
  WallClock wall_clock() {
    return [this] { return loop.wall_us(); };
  }
  // One more coordinator on the same wire, from now on.
  Coordinator& add_coordinator() {
    more.push_back(std::make_unique<Coordinator>(config, simple_planner, wire, wall_clock()));
    loop.attach(*more.back());
    return *more.back();
  }
  void pump(milliseconds d) { loop.run_until(loop.now() + d, nullptr); }
  bool pump_until(const std::function<bool()>& done, milliseconds limit = milliseconds(3000)) {
    return loop.run_until(loop.now() + limit, done);
  }
  std::int64_t send(std::int8_t kind, std::vector<std::string> axes, std::vector<double> values, int timeout_ms = 0) {
    request_t r = test_request(next_id++, kind, std::move(axes), std::move(values));
    r.timeout_ms = timeout_ms;
    client.publish(r);
    return r.request_id;
  }
  static bool is_terminal(std::int8_t s) {
    return s == reply_t::DONE || s == reply_t::REJECTED || s == reply_t::ABORTED || s == reply_t::FAILED;
  }
  // Waits for the terminal reply of `id`, then checks no second terminal reply follows.
  reply_t terminal(std::int64_t id) {
    EXPECT_TRUE(pump_until([&] {
      for (const auto& r : replies[id])
        if (is_terminal(r.status)) return true;
      return false;
    })) << "no terminal reply for request "
        << id;
    pump(milliseconds(100));
    int count = 0;
    reply_t last{};
    for (const auto& r : replies[id]) {
      if (is_terminal(r.status)) {
        ++count;
        last = r;
      }
    }
    EXPECT_EQ(count, 1) << "request " << id << " got " << count << " terminal replies";
    return last;
  }
  // Answers ARM_MOVE with ARMED, and the trigger with STARTED; moves the fake axes to target.
  void auto_execute_moves(bool complete = true) {
    gateways.on_command = [this](const gateway_command_t& c) {
      if (c.kind == gateway_command_t::ARM_MOVE) {
        gateways.reply(c, gateway_reply_t::ARMED);
        armed[c.trigger_id].push_back(c);
      } else if (c.kind == gateway_command_t::STOP || c.kind == gateway_command_t::ESTOP) {
        for (const auto& a : c.axes) gateways.states[a.axis].moving = false;
        gateways.reply(c, gateway_reply_t::DONE);
      } else {
        gateways.reply(c, gateway_reply_t::DONE);
      }
    };
    trigger_handler = [this, complete](const motionlcm::sync_trigger_t& t) {
      for (const auto& c : armed[t.trigger_id]) {
        gateways.reply(c, gateway_reply_t::STARTED);
        for (const auto& a : c.axes) gateways.put(a.axis, complete ? a.target_counts : 0, !complete);
      }
    };
  }
  void pump_triggers() {
    for (; handled_triggers < gateways.triggers.size(); ++handled_triggers)
      trigger_handler(gateways.triggers[handled_triggers]);
  }
  reply_t run_to_terminal(std::int64_t id) {
    EXPECT_TRUE(pump_until([&] {
      pump_triggers();
      for (const auto& r : replies[id])
        if (is_terminal(r.status)) return true;
      return false;
    }));
    return terminal(id);
  }

  config::Config config;
  SimLoop loop;
  FakeGateways gateways;
  FakeClient client;
  Wire wire;
  Coordinator coordinator;
  std::vector<std::unique_ptr<Coordinator>> more;
  std::map<std::int64_t, std::vector<reply_t>> replies;
  std::map<std::int64_t, std::vector<gateway_command_t>> armed;
  std::function<void(const motionlcm::sync_trigger_t&)> trigger_handler;
  std::size_t handled_triggers = 0;
  std::int64_t next_id = 1;
};

}  // namespace motion::coordinator::test_fixture
