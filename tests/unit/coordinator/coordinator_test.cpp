// The coordinator's request lifecycle against fake gateways: every request ends in exactly one
// terminal reply, with the right cause. The passive core runs on a simulated wire and a manual
// clock (no multicast, no waiting); one test at the end runs CoordinatorService over LCM.
#include "motion/coordinator/coordinator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <memory>
#include <set>

#include <motionlcm/active_moves_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>

#include "motion/coordinator/coordinator_service.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/node.hpp"
#include "motion/security/signed_request.hpp"
#include "motion/testing/lcm_url.hpp"
#include "motion/testing/pump.hpp"

namespace motion::coordinator {
namespace {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using motionlcm::reply_t;
using motionlcm::request_t;
using std::chrono::milliseconds;

const char* kConfig = R"(
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
std::variant<MovePlan, std::string> simple_planner(const std::vector<PlanInput>& in, double, double) {
  MovePlan plan;
  for (const auto& i : in) {
    if (i.target_counts == 777) return std::string("refused: 777 counts");
    plan.axes.push_back({i.axis, i.target_counts, i.max_velocity, i.max_acceleration, i.max_acceleration, 0.1});
  }
  plan.duration_s = 0.1;
  return plan;
}

// A drive model as a gateway publishes it: velocity in 1 count/s, acceleration in 1 count/s^2.
motionlcm::drive_model_t test_model(const std::string& axis, const std::string& bus, const std::string& family) {
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
  const auto start = [&m](std::int8_t kind, double wire_us) {
    m.start_kinds.push_back(kind);
    m.start_addresses.push_back(0);
    m.start_wire_us.push_back(wire_us);
    m.num_starts = static_cast<std::int32_t>(m.start_kinds.size());
  };
  if (family == "uim342") {
    start(M::START_UIM342_GROUP_BG, 70.0);
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
  void call_every(Duration period, Action action) { every(now_ + period, period, std::make_shared<Action>(std::move(action))); }

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

  void every(TimePoint at, Duration period, std::shared_ptr<Action> action) {
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

// Gateways of both buses: heartbeat, axis states, and scripted replies to commands.
struct FakeGateways {
  explicit FakeGateways(SimLoop& sim) : loop_(sim) {
    loop_.call_every(milliseconds(50), [this] { tick(); });
  }

  void tick() {
    for (const std::string bus : {"can0", "rs485"}) {
      if (silent.contains(bus) || !heartbeats) continue;
      motionlcm::health_t h{};
      h.process = "gateway:" + bus;
      h.role = "gateway";
      h.pid = pid_of[bus];
      h.state = motionlcm::health_t::OK;
      h.uptime_s = 10;
      loop_.send_to_cores([h](Coordinator& c, TimePoint now) { c.on_health(h, now); });
    }
    for (const auto& [name, m] : models) {
      if (silent.contains(m.bus) || !publish_models) continue;
      loop_.send_to_cores([m](Coordinator& c, TimePoint now) { c.on_drive_model(m, now); });
    }
    for (auto& [name, s] : states) {
      if (silent.contains(s.bus)) continue;
      s.utime = s.sample_utime = loop_.wall_us();
      loop_.send_to_cores([s](Coordinator& c, TimePoint now) { c.on_axis_state(s, now); });
    }
  }
  // GW_COMMAND_<bus> as a gateway receives it.
  void receive(const gateway_command_t& c) {
    commands.push_back(c);
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
  void add_axis(const std::string& name, const std::string& bus, double scale, const std::string& family) {
    models[name] = test_model(name, bus, family);
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
  bool publish_models = true;
  std::vector<TimePoint> model_requests;  // when the coordinator sent DRIVE_MODEL_REQUEST
  std::map<std::string, std::int32_t> pid_of{{"can0", 100}, {"rs485", 200}};
  std::set<std::string> silent;
  bool heartbeats = true;  // false: axis states only (a coordinator that missed the heartbeats)
  std::vector<gateway_command_t> commands;
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
  void gateway_command(const std::string&, const gateway_command_t& c) override {
    loop_.send([this, c] { gateways_.receive(c); });
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
  void drive_model_request(const motionlcm::drive_model_request_t&) override { gateways_.model_requests.push_back(loop_.now()); }

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
    gateways.add_axis("x", "can0", 100, "uim342");
    gateways.add_axis("y", "can0", 100, "uim342");
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
    request_t r{};
    r.client_id = "test";
    r.request_id = next_id++;
    r.kind = kind;
    r.axes = std::move(axes);
    r.values = std::move(values);
    r.num_axes = static_cast<std::int32_t>(r.axes.size());
    r.timeout_ms = timeout_ms;
    client.publish(r);
    return r.request_id;
  }
  static bool is_terminal(std::int8_t s) { return s == reply_t::DONE || s == reply_t::REJECTED || s == reply_t::ABORTED || s == reply_t::FAILED; }
  // Waits for the terminal reply of `id`, then checks no second terminal reply follows.
  reply_t terminal(std::int64_t id) {
    EXPECT_TRUE(pump_until([&] {
      for (const auto& r : replies[id]) if (is_terminal(r.status)) return true;
      return false;
    })) << "no terminal reply for request " << id;
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
    gateways.on_command = [this, complete](const gateway_command_t& c) {
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
    for (; handled_triggers < gateways.triggers.size(); ++handled_triggers) trigger_handler(gateways.triggers[handled_triggers]);
  }
  reply_t run_to_terminal(std::int64_t id) {
    EXPECT_TRUE(pump_until([&] {
      pump_triggers();
      for (const auto& r : replies[id]) if (is_terminal(r.status)) return true;
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

TEST_F(CoordinatorTest, UnknownAxisIsRejectedWithTheKnownAxes) {
  const auto r = terminal(send(request_t::MOVE_ABSOLUTE, {"q"}, {1.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kUnknownAxis));
  EXPECT_NE(r.reason.find("unknown axis 'q' (axes: x, y, c, r)"), std::string::npos) << r.reason;
}

// The coordinator quantizes from the drive model only: an axis whose gateway has not published
// one is refused by name (code 21), and the coordinator asks for it once a second, no more.
TEST_F(CoordinatorTest, MoveOfAnAxisWithoutADriveModelIsRefusedAndTheModelIsRequested) {
  Coordinator& fresh = add_coordinator();
  gateways.publish_models = false;
  gateways.model_requests.clear();
  pump(milliseconds(2500));
  EXPECT_EQ(fresh.drive_model("x"), nullptr);
  ASSERT_GE(gateways.model_requests.size(), 2u);
  EXPECT_LE(gateways.model_requests.size(), 3u) << "DRIVE_MODEL_REQUEST once a second while models are missing";
  EXPECT_GE(gateways.model_requests[1] - gateways.model_requests[0], milliseconds(1000));
  // The first coordinator has its models (from before); the fresh one refuses, naming the axis.
  std::vector<reply_t> fresh_replies;
  client.on_reply = [&](const reply_t& r) {
    if (r.request_id == 91) fresh_replies.push_back(r);
  };
  request_t move{};
  move.client_id = "test";
  move.request_id = 91;
  move.kind = request_t::MOVE_ABSOLUTE;
  move.axes = {"x"};
  move.values = {1.0};
  move.num_axes = 1;
  loop.send([&fresh, move, this] { loop.deliver_to(fresh, [move](Coordinator& c, TimePoint now) { c.on_request(move, now); }); });
  pump(milliseconds(50));
  ASSERT_FALSE(fresh_replies.empty());
  EXPECT_EQ(fresh_replies.back().status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(fresh_replies.back().error_code, static_cast<int>(ReplyError::kNoDriveModel));
  EXPECT_NE(fresh_replies.back().reason.find("axis x has no drive model yet: the gateway of bus can0 has not published DRIVE_MODEL"),
            std::string::npos)
      << fresh_replies.back().reason;
  // Once the models come, the requests stop and the move is planned.
  gateways.publish_models = true;
  pump(milliseconds(200));
  ASSERT_NE(fresh.drive_model("x"), nullptr);
  const auto requests = gateways.model_requests.size();
  pump(milliseconds(2000));
  EXPECT_EQ(gateways.model_requests.size(), requests);
}

// A model that contradicts the configuration is ignored (PROTOCOL_ERROR event); an unusable one
// makes the axis's moves fail planning with the reason.
TEST_F(CoordinatorTest, DriveModelsContradictingTheConfigurationAreIgnored) {
  std::vector<motionlcm::event_t> events;
  client.on_event = [&](const motionlcm::event_t& e) { events.push_back(e); };
  auto wrong_family = test_model("x", "can0", "uc57");
  loop.send_to_cores([wrong_family](Coordinator& c, TimePoint now) { c.on_drive_model(wrong_family, now); });
  auto wrong_bus = test_model("c", "can0", "adam-modbus");
  loop.send_to_cores([wrong_bus](Coordinator& c, TimePoint now) { c.on_drive_model(wrong_bus, now); });
  pump(milliseconds(10));
  ASSERT_GE(events.size(), 2u);
  EXPECT_NE(events[0].text.find("drive model of axis x ignored: it says family 'uc57', the configuration says 'uim342'"), std::string::npos)
      << events[0].text;
  EXPECT_NE(events[1].text.find("drive model of axis c ignored: it comes from bus 'can0', the axis is on bus 'rs485'"), std::string::npos)
      << events[1].text;
  EXPECT_EQ(coordinator.drive_model("x")->family, "uim342");
}

TEST_F(CoordinatorTest, TargetBeyondLimitIsRejectedNamingTheLimit) {
  const auto r = terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {1.0, 12.5}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kOutsideLimits));
  EXPECT_NE(r.reason.find("target 12.5 mm of axis y is outside its limits [-10, 10]"), std::string::npos) << r.reason;
  // Relative moves are checked against current position + distance.
  gateways.put("x", 900, false);  // 9 mm
  pump(milliseconds(120));
  EXPECT_EQ(terminal(send(request_t::MOVE_RELATIVE, {"x"}, {2.0})).error_code, static_cast<int>(ReplyError::kOutsideLimits));
}

// A jog toward a limit the axis stands at or beyond has nowhere to go: REJECTED naming the limit,
// nothing sent; the other direction runs.
TEST_F(CoordinatorTest, JogTowardALimitTheAxisStandsAtIsRejectedAndTheOtherWayIsNot) {
  gateways.put("x", -1000, false);  // -10 mm: at its minimum
  pump(milliseconds(120));
  const auto r = terminal(send(request_t::JOG, {"x"}, {-1.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kOutsideLimits));
  EXPECT_NE(r.reason.find("jog of axis x toward its limit -10 mm refused: it stands at -10 mm, less than one count from (or beyond)"),
            std::string::npos)
      << r.reason;
  EXPECT_TRUE(gateways.commands.empty()) << "a refused jog sent " << gateways.commands.size() << " commands";
  send(request_t::JOG, {"x"}, {1.0});
  ASSERT_TRUE(pump_until([&] { return !gateways.commands.empty(); })) << "the jog away from the limit was not sent";
  EXPECT_EQ(gateways.commands.front().kind, std::int8_t{gateway_command_t::JOG});
}

// One whole count to go before the limit is room enough for a jog.
TEST_F(CoordinatorTest, JogWithOneWholeCountToItsLimitIsSent) {
  gateways.put("x", -999, false);
  pump(milliseconds(120));
  send(request_t::JOG, {"x"}, {-1.0});
  ASSERT_TRUE(pump_until([&] { return !gateways.commands.empty(); })) << "a jog with one count to go was not sent";
  EXPECT_EQ(gateways.commands.front().kind, std::int8_t{gateway_command_t::JOG});
}

TEST_F(CoordinatorTest, MalformedAndDuplicateRequestsAreRejected) {
  request_t bad{};
  bad.client_id = "test";
  bad.request_id = 500;
  bad.kind = request_t::MOVE_ABSOLUTE;
  bad.num_axes = 1;
  bad.axes = {"x"};
  bad.values = {std::nan("")};
  client.publish(bad);
  const auto r = terminal(500);
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_NE(r.reason.find("not a finite number"), std::string::npos) << r.reason;

  bad.request_id = 501;
  bad.kind = 99;
  client.publish(bad);
  EXPECT_NE(terminal(501).reason.find("unknown request kind 99"), std::string::npos);
}

TEST_F(CoordinatorTest, MalformedRequestWithReadableIdsIsRejectedNamingWhy) {
  request_t r{};
  r.client_id = "test";
  r.request_id = 510;
  r.kind = request_t::MOVE_ABSOLUTE;
  r.axes = {"x", "y"};
  r.values = {1.0, 2.0};
  r.num_axes = 2;
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(r.getEncodedSize()));
  ASSERT_EQ(r.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  bytes.resize(bytes.size() - 10);  // the arrays claim more than the message carries
  client.publish_raw(bytes);
  const auto reply = terminal(510);
  EXPECT_EQ(reply.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(reply.error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_NE(reply.reason.find("malformed request"), std::string::npos) << reply.reason;
  EXPECT_TRUE(gateways.commands.empty());
}

TEST_F(CoordinatorTest, DisabledFaultedAndOfflineAxesAreRejected) {
  gateways.states["x"].enabled = false;
  gateways.states["y"].fault = true;
  gateways.states["y"].fault_text = "stall";
  pump(milliseconds(120));
  EXPECT_EQ(terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0})).error_code, static_cast<int>(ReplyError::kAxisDisabled));
  const auto faulted = terminal(send(request_t::MOVE_ABSOLUTE, {"y"}, {1.0}));
  EXPECT_EQ(faulted.error_code, static_cast<int>(ReplyError::kAxisFaulted));
  EXPECT_NE(faulted.reason.find("stall"), std::string::npos);
  gateways.silent.insert("rs485");
  pump(milliseconds(500));
  EXPECT_EQ(terminal(send(request_t::MOVE_ABSOLUTE, {"c"}, {1.0})).error_code, static_cast<int>(ReplyError::kGatewayOffline));
}

// An axis whose drive lost power (fault_code POSITION_LOST, not faulted): moves and jogs are
// refused with code 22 naming it and why; set-position (how it becomes valid again) is not.
TEST_F(CoordinatorTest, AnAxisThatLostItsPositionIsRefusedMovesAndJogsButNotASetPosition) {
  gateways.states["x"].fault_code = motionlcm::axis_state_t::POSITION_LOST;
  gateways.states["x"].fault_text = "position lost: x-drive answers as freshly powered up; home or set-position";
  pump(milliseconds(120));
  for (const auto kind : {request_t::MOVE_ABSOLUTE, request_t::MOVE_RELATIVE, request_t::JOG}) {
    const auto refused = terminal(send(kind, {"x"}, {1.0}));
    EXPECT_EQ(refused.status, std::int8_t{reply_t::REJECTED}) << refused.reason;
    EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kPositionLost)) << refused.reason;
    EXPECT_NE(refused.reason.find("axis x lost its position (position lost: x-drive answers"), std::string::npos) << refused.reason;
  }
  EXPECT_TRUE(gateways.commands.empty());
  send(request_t::SET_POSITION, {"x"}, {0.0});
  ASSERT_TRUE(pump_until([&] { return !gateways.commands.empty(); })) << "the set-position was not sent";
  EXPECT_EQ(gateways.commands.back().kind, std::int8_t{gateway_command_t::SET_POSITION});
}

TEST_F(CoordinatorTest, SynchronizedMoveAcrossTwoBusesArmsTriggersAndCompletes) {
  auto_execute_moves();
  const auto id = send(request_t::MOVE_ABSOLUTE, {"x", "y", "c"}, {1.0, -2.0, 3.0});
  const auto r = run_to_terminal(id);
  EXPECT_EQ(r.status, std::int8_t{reply_t::DONE}) << r.reason;
  EXPECT_DOUBLE_EQ(r.progress, 1.0);
  ASSERT_EQ(r.positions.size(), 3u);
  EXPECT_DOUBLE_EQ(r.positions[0], 1.0);
  EXPECT_DOUBLE_EQ(r.positions[2], 3.0);
  // Every bus got one ARM_MOVE with the same trigger id; one trigger names both buses.
  ASSERT_EQ(gateways.triggers.size(), 1u);
  EXPECT_EQ(gateways.triggers[0].num_buses, 2);
  const auto& arms = armed[gateways.triggers[0].trigger_id];
  ASSERT_EQ(arms.size(), 2u);
  std::int64_t x_target = 0;
  for (const auto& c : arms) for (const auto& a : c.axes) if (a.axis == "x") x_target = a.target_counts;
  EXPECT_EQ(x_target, 100);
  // Cross-bus trigger is scheduled ahead; the order of replies was ACCEPTED, STARTED, ..., DONE.
  EXPECT_GT(gateways.triggers[0].fire_utime, gateways.triggers[0].utime);
  // The scheduled trigger: each bus hands its start frame over early by its wire time (from the
  // drive models), so both act at act_utime; the old trigger's fire time is the earliest hand-over.
  ASSERT_EQ(gateways.triggers2.size(), 1u);
  const auto& t2 = gateways.triggers2[0];
  EXPECT_EQ(t2.trigger_id, gateways.triggers[0].trigger_id);
  ASSERT_EQ(t2.buses, (std::vector<std::string>{"can0", "rs485"}));
  EXPECT_DOUBLE_EQ(t2.lead_us[0], 70.0);   // x + y: one group BG
  EXPECT_DOUBLE_EQ(t2.lead_us[1], 694.0);  // c: the broadcast
  EXPECT_EQ(t2.send_utime[0], t2.act_utime - 70);
  EXPECT_EQ(t2.send_utime[1], t2.act_utime - 694);
  EXPECT_EQ(t2.send_utime[1], gateways.triggers[0].fire_utime);
  EXPECT_EQ(t2.num_starts, 2);
  EXPECT_DOUBLE_EQ(t2.predicted_spread_us, 0.0);
  const auto& all = replies[id];
  EXPECT_EQ(all.front().status, std::int8_t{reply_t::ACCEPTED});
  EXPECT_TRUE(std::any_of(all.begin(), all.end(), [](const reply_t& x) { return x.status == reply_t::STARTED; }));
}

TEST_F(CoordinatorTest, BusyAxisIsRejectedAndStopPreemptsTheMove) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {5.0, 5.0});
  pump_until([&] { pump_triggers(); return !gateways.triggers.empty(); });
  pump(milliseconds(50));
  EXPECT_EQ(terminal(send(request_t::MOVE_ABSOLUTE, {"y"}, {1.0})).error_code, static_cast<int>(ReplyError::kAxisBusy));
  const auto stop = send(request_t::STOP, {"y"}, {0.0});
  const auto moved = terminal(move);
  EXPECT_EQ(moved.status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(moved.error_code, static_cast<int>(ReplyError::kStopped));
  EXPECT_EQ(terminal(stop).status, std::int8_t{reply_t::DONE});
}

TEST_F(CoordinatorTest, StallOfOneAxisAbortsTheGroupAndStopsTheOthers) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {5.0, 5.0});
  pump_until([&] { pump_triggers(); return !gateways.triggers.empty(); });
  pump(milliseconds(50));
  motionlcm::event_t stall{};
  stall.axis = "y";
  stall.bus = "can0";
  stall.kind = motionlcm::event_t::STALL;
  stall.severity = motionlcm::event_t::ERROR;
  stall.text = "motor stall detected";
  gateways.publish(stall);
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kAxisFault));
  EXPECT_NE(r.reason.find("axis y: motor stall detected"), std::string::npos) << r.reason;
  const bool stopped_both = std::any_of(gateways.commands.begin(), gateways.commands.end(), [](const gateway_command_t& c) {
    return c.kind == gateway_command_t::STOP && c.num_axes == 2;
  });
  EXPECT_TRUE(stopped_both);
}

// A coordinator started after its gateways has missed their last heartbeat: their axis states
// show them alive at once (no heartbeat period of "gateway offline"); when the states stop too,
// the gateway is offline after gateway_timeout_ms as before.
struct CoordinatorWithoutHeartbeats : CoordinatorTest {
  void SetUp() override {
    gateways.heartbeats = false;
    CoordinatorTest::SetUp();
  }
};

TEST_F(CoordinatorWithoutHeartbeats, AxisStatesShowTheGatewayAliveUntilTheyStop) {
  auto_execute_moves();
  const auto moved = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {2.0, 3.0}));
  EXPECT_EQ(moved.status, std::int8_t{reply_t::DONE}) << moved.reason;
  gateways.silent.insert("rs485");
  pump(milliseconds(500));
  const auto refused = terminal(send(request_t::MOVE_ABSOLUTE, {"c"}, {1.0}));
  EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kGatewayOffline)) << refused.reason;
  // Its first heartbeat is not taken for a restart.
  gateways.silent.erase("rs485");
  gateways.heartbeats = true;
  pump(milliseconds(200));
  EXPECT_EQ(run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"c"}, {1.0})).status, std::int8_t{reply_t::DONE});
}

// The desired state of active moves: one row per axis with request, bus, gateway command,
// target (counts and user units) and fire time, republished while the move runs, then an empty
// message once it is done.
// Rows a gateway kept from a coordinator that died: each request that is not this coordinator's
// own ends once, ABORTED with code 20 naming its axes, however often the rows arrive; a request
// this coordinator runs is left alone.
TEST_F(CoordinatorTest, OrphanedMovesOfAPredecessorEndOnceAndOwnRequestsAreLeftAlone) {
  auto_execute_moves(/*complete=*/false);
  const auto own = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0});
  ASSERT_TRUE(pump_until([&] { pump_triggers(); return !replies[own].empty() && replies[own].back().status == reply_t::STARTED; }));
  motionlcm::active_moves_t rows{};
  const auto row = [&rows](const std::string& axis, const std::string& client_id, std::int64_t request) {
    rows.axes.push_back(axis);
    rows.buses.push_back("can0");
    rows.client_ids.push_back(client_id);
    rows.request_ids.push_back(request);
    rows.kinds.push_back(std::int8_t{request_t::MOVE_ABSOLUTE});
    rows.phases.push_back(std::int8_t{motionlcm::active_moves_t::MOVING});
    rows.command_ids.push_back(1);
    rows.target_counts.push_back(0);
    rows.targets.push_back(0.0);
    rows.fire_utime.push_back(1);
    rows.num_axes = static_cast<std::int32_t>(rows.axes.size());
  };
  row("y", "test", 7001);
  row("r", "test", 7001);
  row("x", "test", own);
  for (int i = 0; i < 2; ++i) {
    loop.send_to_cores([rows](Coordinator& c, TimePoint now) { c.on_orphaned_moves(rows, now); });
    pump(milliseconds(50));
  }
  ASSERT_EQ(replies[7001].size(), 1u);
  EXPECT_EQ(replies[7001][0].status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(replies[7001][0].error_code, static_cast<int>(ReplyError::kCoordinatorRestarted));
  EXPECT_NE(replies[7001][0].reason.find("y (can0), r (can0)"), std::string::npos) << replies[7001][0].reason;
  for (const auto& r : replies[own]) EXPECT_FALSE(is_terminal(r.status)) << "its own request was ended: " << r.reason;
}

TEST_F(CoordinatorTest, ActiveMovesAreRepublishedWhileTheyRunAndClearedAtTheEnd) {
  std::vector<motionlcm::active_moves_t> seen;
  client.on_active_moves = [&](const motionlcm::active_moves_t& m) { seen.push_back(m); };
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {5.0, 2.0});
  ASSERT_TRUE(pump_until([&] {
    pump_triggers();
    return std::count_if(seen.begin(), seen.end(), [](const auto& m) { return m.num_axes == 2; }) >= 3;  // fire + 2 periods
  }));
  const auto& m = seen.back();
  ASSERT_EQ(m.num_axes, 2);
  EXPECT_EQ(m.axes, (std::vector<std::string>{"x", "c"}));
  EXPECT_EQ(m.buses, (std::vector<std::string>{"can0", "rs485"}));
  EXPECT_EQ(m.request_ids[0], move);
  EXPECT_EQ(m.client_ids[1], "test");
  EXPECT_EQ(m.phases[0], std::int8_t{motionlcm::active_moves_t::MOVING});
  EXPECT_EQ(m.target_counts, (std::vector<std::int64_t>{500, 20}));  // 100 and 10 counts per unit
  EXPECT_DOUBLE_EQ(m.targets[0], 5.0);
  EXPECT_DOUBLE_EQ(m.targets[1], 2.0);
  EXPECT_NE(m.command_ids[0], 0);
  EXPECT_NE(m.command_ids[0], m.command_ids[1]);  // one ARM_MOVE per bus
  ASSERT_EQ(gateways.triggers.size(), 1u);
  EXPECT_EQ(m.fire_utime[0], gateways.triggers[0].fire_utime);
  // The axes arrive: DONE, and the set is published empty once.
  gateways.put("x", 500, false);
  gateways.put("c", 20, false);
  EXPECT_EQ(terminal(move).status, std::int8_t{reply_t::DONE});
  ASSERT_TRUE(pump_until([&] { return seen.back().num_axes == 0; }));
  const auto count = seen.size();
  pump(milliseconds(1200));
  EXPECT_EQ(seen.size(), count);  // nothing active: nothing more
}

TEST_F(CoordinatorTest, LostGatewayAbortsTheRequestAndStopsTheOtherBus) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {5.0, 5.0});
  pump_until([&] { pump_triggers(); return !gateways.triggers.empty(); });
  gateways.silent.insert("rs485");
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kGatewayLost));
  EXPECT_NE(r.reason.find("bus rs485"), std::string::npos) << r.reason;
  EXPECT_TRUE(std::any_of(gateways.commands.begin(), gateways.commands.end(),
                          [](const gateway_command_t& c) { return c.kind == gateway_command_t::STOP && c.bus == "can0"; }));
}

TEST_F(CoordinatorTest, RestartedGatewayAbortsTheRequest) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0});
  pump_until([&] { pump_triggers(); return !gateways.triggers.empty(); });
  gateways.pid_of["can0"] = 101;  // a new process on the same bus
  const auto r = terminal(move);
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kGatewayLost));
  EXPECT_NE(r.reason.find("restarted"), std::string::npos) << r.reason;
}

TEST_F(CoordinatorTest, SilentGatewayDuringArmingFailsTheRequest) {
  gateways.on_command = [](const gateway_command_t&) {};  // never answers
  const auto r = terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kArmFailed));
}

TEST_F(CoordinatorTest, RequestTimeoutFailsAndStops) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0}, /*timeout_ms=*/300);
  pump_until([&] { pump_triggers(); return !gateways.triggers.empty(); });
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kTimeout));
}

TEST_F(CoordinatorTest, GatewaysOwnErrorCodeReachesTheClient) {
  gateways.on_command = [this](const gateway_command_t& c) {
    gateway_reply_t r{};
    r.command_id = c.command_id;
    r.bus = c.bus;
    r.status = gateway_reply_t::FAILED;
    r.error_code = static_cast<std::int32_t>(ReplyError::kOutsideLimits);
    r.reason = "x-drive (node 5): value 70000 outside the range of SQT";
    gateways.publish(r);
  };
  const auto r = terminal(send(request_t::ENABLE, {"x"}, {0.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kOutsideLimits));
  EXPECT_NE(r.reason.find("bus can0: x-drive (node 5): value 70000"), std::string::npos) << r.reason;
}

TEST_F(CoordinatorTest, GatewayFailureOfASimpleCommandFailsTheRequestWithItsReason) {
  gateways.on_command = [this](const gateway_command_t& c) { gateways.reply(c, gateway_reply_t::FAILED, "node 5 did not answer MO=1"); };
  const auto r = terminal(send(request_t::ENABLE, {"x"}, {0.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kDriveError));
  EXPECT_NE(r.reason.find("bus can0: node 5 did not answer MO=1"), std::string::npos) << r.reason;
}

TEST_F(CoordinatorTest, EnableOnTwoBusesIsDoneWhenBothGatewaysAre) {
  auto_execute_moves();
  const auto r = terminal(send(request_t::ENABLE, {"x", "c"}, {0.0, 0.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::DONE});
  int enables = 0;
  for (const auto& c : gateways.commands) enables += c.kind == gateway_command_t::ENABLE;
  EXPECT_EQ(enables, 2);
}

// ---- ordinary requests outside the demo's path

std::vector<gateway_command_t> commands_of_kind(const std::vector<gateway_command_t>& all, std::int8_t kind) {
  std::vector<gateway_command_t> out;
  for (const auto& c : all) {
    if (c.kind == kind) out.push_back(c);
  }
  return out;
}

TEST_F(CoordinatorTest, AxisAlreadyAtItsTargetIsDoneWithoutACommandWhileItsPartnerMoves) {
  auto_execute_moves();
  const auto r = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {0.0, 1.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::DONE}) << r.reason;
  const auto arms = commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE);
  ASSERT_EQ(arms.size(), 1u);
  ASSERT_EQ(arms[0].num_axes, 1);
  EXPECT_EQ(arms[0].axes[0].axis, "y");
  EXPECT_DOUBLE_EQ(gateways.states["y"].position, 1.0);
}

TEST_F(CoordinatorTest, MoveWithEveryAxisAtItsTargetIsDoneAtOnceWithoutBusTraffic) {
  auto_execute_moves();
  gateways.put("c", 30, false);  // 3.0 units
  pump(milliseconds(100));
  // A relative move below one count rounds to the position it starts from.
  const auto absolute = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {0.0, 3.0}));
  const auto relative = run_to_terminal(send(request_t::MOVE_RELATIVE, {"x"}, {0.004}));
  EXPECT_EQ(absolute.status, std::int8_t{reply_t::DONE}) << absolute.reason;
  EXPECT_EQ(relative.status, std::int8_t{reply_t::DONE}) << relative.reason;
  EXPECT_TRUE(gateways.commands.empty()) << gateways.commands.size() << " gateway commands";
  EXPECT_TRUE(gateways.triggers.empty());
}

TEST_F(CoordinatorTest, PlanningFailureIsRejectedAndSendsNothing) {
  auto_execute_moves();
  const auto refused = terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {7.77, 1.0}));
  EXPECT_EQ(refused.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kPlanningFailed));
  EXPECT_NE(refused.reason.find("777 counts"), std::string::npos) << refused.reason;
  EXPECT_TRUE(gateways.commands.empty()) << "a refused plan sent " << gateways.commands.size() << " commands (a STOP?)";
  // Nothing is left busy: the next move of the same axes runs.
  const auto next = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {1.0, 1.0}));
  EXPECT_EQ(next.status, std::int8_t{reply_t::DONE}) << next.reason;
}

TEST_F(CoordinatorTest, ArmingFailureDisarmsEveryArmedPartBeforeTheTerminalReply) {
  std::size_t replies_when_disarmed = 0;
  std::int64_t move = 0;
  gateways.on_command = [&](const gateway_command_t& c) {
    if (c.kind == gateway_command_t::ARM_MOVE) {
      gateways.reply(c, c.bus == "rs485" ? gateway_reply_t::FAILED : gateway_reply_t::ARMED, "drive refused the profile");
    } else if (c.kind == gateway_command_t::DISARM) {
      replies_when_disarmed = replies[move].size();
      gateways.reply(c, gateway_reply_t::DONE);
    }
  };
  move = send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {1.0, 1.0});
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kArmFailed));
  EXPECT_NE(r.reason.find("bus rs485: drive refused the profile"), std::string::npos) << r.reason;
  const auto disarms = commands_of_kind(gateways.commands, gateway_command_t::DISARM);
  ASSERT_FALSE(disarms.empty());
  const auto arm = commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE).front();
  bool can0_disarmed = false;
  for (const auto& d : disarms) can0_disarmed = can0_disarmed || (d.bus == "can0" && d.trigger_id == arm.trigger_id);
  EXPECT_TRUE(can0_disarmed) << "the armed part on can0 was not released by trigger id";
  EXPECT_EQ(replies_when_disarmed, 1u) << "the terminal reply went out before the DISARM";
  EXPECT_TRUE(commands_of_kind(gateways.commands, gateway_command_t::STOP).empty()) << "nothing moved: no STOP";
  EXPECT_TRUE(gateways.triggers.empty());
}

TEST_F(CoordinatorTest, RelativeStepsCountFromTheCommandedTargetAndRoundOnce) {
  auto_execute_moves();
  std::vector<std::int64_t> targets;
  for (const double step : {4.0, 4.0, 100.0}) {
    const auto r = run_to_terminal(send(request_t::MOVE_RELATIVE, {"r"}, {step}));
    ASSERT_EQ(r.status, std::int8_t{reply_t::DONE}) << r.reason;
    targets.push_back(commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE).back().axes[0].target_counts);
  }
  // 4, 8 and 108 degrees at 8.89 counts per degree, each rounded once from user units.
  EXPECT_EQ(targets, (std::vector<std::int64_t>{36, 71, 960}));
  // Moved by anything else, the axis counts from where it stands.
  gateways.put("r", 100, false);
  pump(milliseconds(100));
  run_to_terminal(send(request_t::MOVE_RELATIVE, {"r"}, {1.0}));
  EXPECT_EQ(commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE).back().axes[0].target_counts, 109);
}

TEST_F(CoordinatorTest, OutOfRangeSetPositionScaleAndTimeoutAreRejectedNamingTheValue) {
  auto_execute_moves();
  const auto position = terminal(send(request_t::SET_POSITION, {"x"}, {100.0}));
  EXPECT_EQ(position.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(position.error_code, static_cast<int>(ReplyError::kOutsideLimits));
  EXPECT_NE(position.reason.find("position 100 "), std::string::npos) << position.reason;
  EXPECT_EQ(terminal(send(request_t::SET_POSITION, {"x"}, {1e12})).error_code, static_cast<int>(ReplyError::kOutsideLimits));

  const auto timeout = terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0}, -5));
  EXPECT_EQ(timeout.error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_NE(timeout.reason.find("timeout_ms -5"), std::string::npos) << timeout.reason;

  request_t slow{};
  slow.client_id = "test";
  slow.request_id = 900;
  slow.kind = request_t::MOVE_ABSOLUTE;
  slow.axes = {"x"};
  slow.values = {1.0};
  slow.num_axes = 1;
  slow.velocity_scale = 1.5;
  client.publish(slow);
  const auto scale = terminal(900);
  EXPECT_EQ(scale.error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_NE(scale.reason.find("velocity_scale 1.5"), std::string::npos) << scale.reason;
  // A plan longer than the request's timeout is refused up front, not failed on the timeout.
  const auto too_long = terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0}, 50));
  EXPECT_EQ(too_long.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(too_long.error_code, static_cast<int>(ReplyError::kPlanningFailed));
  EXPECT_TRUE(gateways.commands.empty());
}

TEST_F(CoordinatorTest, ResetIsDoneOnlyOnceTheAxisStateShowsNoFault) {
  gateways.states["x"].fault = true;
  gateways.states["x"].fault_text = "stall";
  bool clear_after_reset = true;
  gateways.on_command = [&](const gateway_command_t& c) {
    gateways.reply(c, gateway_reply_t::DONE);  // before the drive's state shows it
    if (c.kind == gateway_command_t::FAULT_RESET && clear_after_reset) {
      loop.call_after(milliseconds(200), [this] { gateways.states["x"].fault = false; });
    }
  };
  pump(milliseconds(100));
  const auto reset = send(request_t::FAULT_RESET, {"x"}, {0.0});
  ASSERT_TRUE(pump_until([&] { return !replies[reset].empty() && is_terminal(replies[reset].back().status); }));
  EXPECT_EQ(replies[reset].back().status, std::int8_t{reply_t::DONE}) << replies[reset].back().reason;
  // At once after DONE, the coordinator's own view agrees: a move is not refused as faulted.
  auto_execute_moves();
  const auto move = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0}));
  EXPECT_EQ(move.status, std::int8_t{reply_t::DONE}) << move.reason;

  // A drive that keeps its fault fails the reset, naming it.
  gateways.states["y"].fault = true;
  gateways.states["y"].fault_text = "over-current";
  clear_after_reset = false;
  gateways.on_command = [&](const gateway_command_t& c) { gateways.reply(c, gateway_reply_t::DONE); };
  pump(milliseconds(100));
  const auto stuck = terminal(send(request_t::FAULT_RESET, {"y"}, {0.0}));
  EXPECT_EQ(stuck.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(stuck.error_code, static_cast<int>(ReplyError::kAxisFaulted));
  EXPECT_NE(stuck.reason.find("over-current"), std::string::npos) << stuck.reason;
}

TEST_F(CoordinatorTest, HomeOfAnAxisWithoutHomingIsRejectedOnEveryFamily) {
  auto_execute_moves();
  const auto r = terminal(send(request_t::HOME, {"x", "c"}, {0.0, 0.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kUnsupported));
  EXPECT_NE(r.reason.find("axis x has no homing configured"), std::string::npos) << r.reason;
  EXPECT_TRUE(gateways.commands.empty());
}

TEST_F(CoordinatorTest, AStopSupersededByASecondStopEndsDone) {
  std::vector<gateway_command_t> stops;
  gateways.on_command = [&](const gateway_command_t& c) {
    if (c.kind != gateway_command_t::STOP) return;
    stops.push_back(c);
    if (stops.size() == 2) {
      // The gateway ends the first stop as superseded (code 14), then completes the second.
      gateway_reply_t r{};
      r.command_id = stops[0].command_id;
      r.bus = c.bus;
      r.status = gateway_reply_t::FAILED;
      r.error_code = error_code(ReplyError::kStopped);
      r.reason = "superseded by command " + std::to_string(c.command_id);
      gateways.publish(r);
      gateways.reply(c, gateway_reply_t::DONE);
    }
  };
  const auto first = send(request_t::STOP, {"x"}, {0.0});
  pump_until([&] { return stops.size() == 1; });
  const auto second = send(request_t::STOP, {"x"}, {0.0});
  EXPECT_EQ(terminal(first).status, std::int8_t{reply_t::DONE}) << terminal(first).reason;
  EXPECT_EQ(terminal(second).status, std::int8_t{reply_t::DONE});
}

TEST_F(CoordinatorTest, AMoveSentRightBehindAStopTakesTheAxisAndEndsThePreemptedMove) {
  auto_execute_moves(/*complete=*/false);
  const auto first = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0});
  pump_until([&] { pump_triggers(); return !gateways.triggers.empty(); });
  pump(milliseconds(50));
  // The stop, and without waiting for it, the next move of the same axis.
  const auto stop = send(request_t::STOP, {"x"}, {0.0});
  const auto again = send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0});
  const auto preempted = terminal(first);
  EXPECT_EQ(preempted.status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(preempted.error_code, static_cast<int>(ReplyError::kStopped));
  ASSERT_TRUE(pump_until([&] { return !replies[again].empty(); }));
  EXPECT_EQ(replies[again].front().status, std::int8_t{reply_t::ACCEPTED}) << replies[again].front().reason;
  EXPECT_NE(terminal(stop).status, std::int8_t{reply_t::REJECTED});
}

TEST_F(CoordinatorTest, BeyondMaxActiveRequestsARequestIsRefusedAsBusyButAStopPasses) {
  config.coordinator.max_active_requests = 2;
  gateways.on_command = [](const gateway_command_t&) {};  // nothing ends: requests stay active
  const auto first = send(request_t::ENABLE, {"x"}, {0.0});
  const auto second = send(request_t::ENABLE, {"c"}, {0.0});
  pump_until([&] { return !replies[first].empty() && !replies[second].empty(); });
  const auto refused = terminal(send(request_t::ENABLE, {"y"}, {0.0}));
  EXPECT_EQ(refused.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kBusy));
  EXPECT_NE(refused.reason.find("busy: 2 requests in progress (max_active_requests 2)"), std::string::npos) << refused.reason;
  const auto stop = send(request_t::STOP, {"y"}, {0.0});
  ASSERT_TRUE(pump_until([&] { return !replies[stop].empty(); }));
  EXPECT_EQ(replies[stop].front().status, std::int8_t{reply_t::ACCEPTED});
}

TEST_F(CoordinatorTest, RefusedRequestIsASecurityEventAndAnsweredOnlyWhenItsIdsAreAuthentic) {
  std::vector<motionlcm::event_t> security;
  client.on_event = [&](const motionlcm::event_t& e) {
    if (e.kind == motionlcm::event_t::SECURITY) security.push_back(e);
  };
  auto_execute_moves();
  request_t r{};
  r.client_id = "test";
  r.request_id = 900;
  r.kind = request_t::MOVE_ABSOLUTE;
  r.axes = {"x"};
  r.values = {5.0};
  r.num_axes = 1;
  // Ids that cannot be trusted: the event only, no reply, nothing sent to a gateway.
  loop.send_to_cores([](Coordinator& c, TimePoint now) { c.on_refused_request(std::nullopt, "unsigned request refused: test", now); });
  // Authentic ids, role too low: the event and a REJECTED reply (kUnauthorized).
  loop.send_to_cores([r](Coordinator& c, TimePoint now) { c.on_refused_request(r, "role too low: test", now); });
  ASSERT_TRUE(pump_until([&] { return security.size() == 2; }));
  EXPECT_EQ(security[0].text, "unsigned request refused: test");
  EXPECT_EQ(security[0].source, "coordinator");
  EXPECT_EQ(security[0].severity, std::int8_t{motionlcm::event_t::WARNING});
  const auto refused = terminal(900);
  EXPECT_EQ(refused.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kUnauthorized));
  EXPECT_EQ(refused.reason, "role too low: test");
  EXPECT_EQ(replies.size(), 1u);
  EXPECT_TRUE(armed.empty());
  EXPECT_EQ(coordinator.active_requests(), 0u);
}

// Stops that do not take: the coordinator watches every stop it sends until the axis states show
// standstill, repeats it, then e-stops, and the aborted request says what happened only then.
struct StopsThatDoNotTake : CoordinatorTest {
  // The first `ignored` stops (STOP or ESTOP) for x change nothing; later ones stop it.
  void ignore_stops(int ignored) {
    auto_execute_moves(/*complete=*/false);
    gateways.on_command = [this, ignored, base = gateways.on_command](const gateway_command_t& c) {
      if (c.kind == gateway_command_t::STOP || c.kind == gateway_command_t::ESTOP) {
        stops.push_back(c);
        gateways.reply(c, gateway_reply_t::DONE);  // the gateway sent it; the drive did not take it
        if (static_cast<int>(stops.size()) > ignored) {
          for (const auto& a : c.axes) gateways.states[a.axis].moving = false;
        }
        return;
      }
      base(c);
    };
    client.on_event = [this](const motionlcm::event_t& e) { events.push_back(e); };
  }
  std::int64_t moving_x() {
    const auto id = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0});
    pump_until([&] { pump_triggers(); return !gateways.triggers.empty(); });
    pump(milliseconds(100));
    return id;
  }
  [[nodiscard]] bool event_says(std::int16_t kind, const std::string& text) const {
    return std::any_of(events.begin(), events.end(), [&](const auto& e) { return e.kind == kind && e.text.find(text) != std::string::npos; });
  }
  std::vector<gateway_command_t> stops;
  std::vector<motionlcm::event_t> events;
};

TEST_F(StopsThatDoNotTake, ALostStopIsRepeatedAndTheAbortWaitsForStandstill) {
  ignore_stops(1);
  const auto move = moving_x();
  // A fault of x aborts the move; the first STOP is lost.
  gateways.states["x"].fault = true;
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::ABORTED});
  ASSERT_EQ(stops.size(), 2u) << "the unconfirmed stop was not repeated";
  EXPECT_EQ(stops[1].kind, std::int8_t{gateway_command_t::STOP});
  EXPECT_FALSE(gateways.states["x"].moving);  // ABORTED came after standstill
  EXPECT_EQ(r.reason.find("could not stop"), std::string::npos) << r.reason;
  EXPECT_TRUE(event_says(motionlcm::event_t::STOP_UNCONFIRMED, "axis x still reports moving"));
  EXPECT_TRUE(event_says(motionlcm::event_t::STOP_UNCONFIRMED, "stopping it again"));
}

TEST_F(StopsThatDoNotTake, TwoLostStopsAreFollowedByAnEStopAndAStopRequestSaysSo) {
  ignore_stops(2);
  const auto move = moving_x();
  const auto stop = send(request_t::STOP, {"x"}, {0.0});
  const auto preempted = terminal(move);
  EXPECT_EQ(preempted.status, std::int8_t{reply_t::ABORTED});
  const auto r = terminal(stop);
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_NE(r.reason.find("axis x did not stop on STOP; it was e-stopped"), std::string::npos) << r.reason;
  ASSERT_EQ(stops.size(), 3u);
  EXPECT_EQ(stops[0].kind, std::int8_t{gateway_command_t::STOP});
  EXPECT_EQ(stops[1].kind, std::int8_t{gateway_command_t::STOP});
  EXPECT_EQ(stops[2].kind, std::int8_t{gateway_command_t::ESTOP});
  EXPECT_TRUE(event_says(motionlcm::event_t::STOP_UNCONFIRMED, "e-stopping it"));
}

TEST_F(StopsThatDoNotTake, AnAxisThatNeverStopsIsGivenUpAndTheAbortNamesIt) {
  ignore_stops(100);
  const auto move = moving_x();
  gateways.states["x"].fault = true;
  EXPECT_TRUE(pump_until([&] { return std::any_of(replies[move].begin(), replies[move].end(), [](const reply_t& r) { return is_terminal(r.status); }); },
                         milliseconds(5000)));
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::ABORTED});
  EXPECT_NE(r.reason.find("could not stop x (still moving after an e-stop)"), std::string::npos) << r.reason;
  EXPECT_EQ(stops.size(), 3u);  // STOP, STOP, ESTOP, then given up
  EXPECT_TRUE(event_says(motionlcm::event_t::STOP_UNCONFIRMED, "giving up"));
}

TEST_F(StopsThatDoNotTake, AnAxisMovingWhenANewCoordinatorStartsIsStopped) {
  ignore_stops(0);
  gateways.put("x", 120, true);  // moved by a coordinator that is gone
  pump(milliseconds(100));
  EXPECT_TRUE(stops.empty());  // the running coordinator has heard of x before: not its business
  add_coordinator();  // a second coordinator on the same wire, started now
  ASSERT_TRUE(pump_until([&] { return !stops.empty(); }));
  EXPECT_EQ(stops[0].axes.at(0).axis, "x");
  EXPECT_TRUE(event_says(motionlcm::event_t::UNOWNED_MOTION, "axis x was moving"));
  EXPECT_TRUE(pump_until([&] { return !gateways.states["x"].moving; }));
}


// The shell on the wire: the same core behind the LCM subscriptions and publications, driven by
// one loop timer at the deadlines it returns.
TEST(CoordinatorServiceOverLcm, ARequestTravelsOverLcmToTheGatewayAndBack) {
  const config::Config config = *config::load_string(kConfig).config;
  EventLoop loop;
  const std::string url = testing::unique_lcm_url(21);
  lcm::Node node(loop, {url, "CT_"});
  lcm::Node gateway(loop, {url, "CT_"});
  lcm::Node client(loop, {url, "CT_"});
  ASSERT_TRUE(node.ok() && gateway.ok() && client.ok());
  CoordinatorService service(loop, node, config, simple_planner);

  // The gateway of can0 with axis x: heartbeat and state every 50 ms; ARM_MOVE armed, the trigger
  // started and the axis at its target at once.
  motionlcm::axis_state_t x{};
  x.axis = "x";
  x.bus = "can0";
  x.online = x.enabled = x.in_position = true;
  const auto tick = loop.call_every(milliseconds(50), [&] {
    motionlcm::health_t h{};
    h.process = "gateway:can0";
    h.role = "gateway";
    h.pid = 100;
    h.state = motionlcm::health_t::OK;
    h.uptime_s = 10;
    gateway.publish(lcm::channels::kHealth, h);
    x.utime = x.sample_utime = wall_time_us();
    gateway.publish(lcm::channels::kAxisState, x);
  });
  // The gateway answers the coordinator's DRIVE_MODEL_REQUEST with the model of x.
  int model_requests = 0;
  gateway.subscribe<motionlcm::drive_model_request_t>(lcm::channels::kDriveModelRequest,
                                                      [&](const motionlcm::drive_model_request_t& r, const std::string&) {
                                                        EXPECT_EQ(r.requester, "coordinator");
                                                        ++model_requests;
                                                        gateway.publish(lcm::channels::kDriveModel, test_model("x", "can0", "uim342"));
                                                      });
  std::vector<gateway_command_t> commands;
  const auto answer = [&](const gateway_command_t& c, std::int8_t status) {
    gateway_reply_t r{};
    r.command_id = c.command_id;
    r.bus = c.bus;
    r.status = status;
    r.trigger_utime = wall_time_us();
    gateway.publish(lcm::channels::kGatewayReply, r);
  };
  gateway.subscribe_raw("CT_GW_COMMAND_.*", [&](const void* data, int size, const std::string&) {
    gateway_command_t c{};
    if (c.decode(data, 0, size) != size) return;
    commands.push_back(c);
    answer(c, c.kind == gateway_command_t::ARM_MOVE ? gateway_reply_t::ARMED : gateway_reply_t::DONE);
  });
  std::vector<motionlcm::sync_trigger_t> triggers;
  gateway.subscribe<motionlcm::sync_trigger_t>(lcm::channels::kSyncTrigger, [&](const motionlcm::sync_trigger_t& t, const std::string&) {
    triggers.push_back(t);
    for (const auto& c : commands) {
      if (c.kind != gateway_command_t::ARM_MOVE || c.trigger_id != t.trigger_id) continue;
      answer(c, gateway_reply_t::STARTED);
      x.position_counts = c.axes.at(0).target_counts;
      x.position = static_cast<double>(x.position_counts) / 100.0;
    }
  });
  std::map<std::int64_t, std::vector<reply_t>> replies;
  client.subscribe<reply_t>(lcm::channels::kReply, [&](const reply_t& r, const std::string&) { replies[r.request_id].push_back(r); });
  std::vector<motionlcm::active_moves_t> active;
  client.subscribe<motionlcm::active_moves_t>(lcm::channels::kActiveMoves,
                                              [&](const motionlcm::active_moves_t& m, const std::string&) { active.push_back(m); });
  const auto ended = [&](std::int64_t id) {
    return !replies[id].empty() && replies[id].back().status != reply_t::ACCEPTED && replies[id].back().status != reply_t::STARTED &&
           replies[id].back().status != reply_t::PROGRESS;
  };

  ASSERT_TRUE(testing::pump_until(loop, [&] { return service.buses_without_gateway() == std::vector<std::string>{"rs485"}; }, milliseconds(3000)));
  ASSERT_TRUE(testing::pump_until(loop, [&] { return model_requests > 0; }, milliseconds(3000))) << "no DRIVE_MODEL_REQUEST";
  testing::pump_until(loop, [] { return false; }, milliseconds(100));  // the model reaches the coordinator
  request_t move{};
  move.client_id = "test";
  move.request_id = 1;
  move.kind = request_t::MOVE_ABSOLUTE;
  move.axes = {"x"};
  move.values = {1.0};
  move.num_axes = 1;
  client.publish(lcm::channels::kRequest, move);
  ASSERT_TRUE(testing::pump_until(loop, [&] { return ended(1); }, milliseconds(3000)));
  EXPECT_EQ(replies[1].front().status, std::int8_t{reply_t::ACCEPTED});
  EXPECT_EQ(replies[1].back().status, std::int8_t{reply_t::DONE}) << replies[1].back().reason;
  ASSERT_FALSE(commands.empty());
  EXPECT_EQ(commands.front().kind, std::int8_t{gateway_command_t::ARM_MOVE});
  EXPECT_EQ(commands.front().axes.at(0).target_counts, 100);
  ASSERT_EQ(triggers.size(), 1u);
  EXPECT_EQ(triggers[0].buses, std::vector<std::string>{"can0"});
  ASSERT_TRUE(testing::pump_until(loop, [&] { return !active.empty() && active.back().num_axes == 0; }, milliseconds(3000)));
  EXPECT_TRUE(std::any_of(active.begin(), active.end(), [](const auto& m) { return m.num_axes == 1 && m.axes[0] == "x"; }));

  // A request that does not decode is answered when its ids are readable.
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(move.getEncodedSize()));
  move.request_id = 2;
  ASSERT_EQ(move.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  bytes.resize(bytes.size() - 10);
  client.publish_raw(client.channel(lcm::channels::kRequest), bytes);
  ASSERT_TRUE(testing::pump_until(loop, [&] { return ended(2); }, milliseconds(3000)));
  EXPECT_EQ(replies[2].back().error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_EQ(service.active_requests(), 0u);
  loop.cancel(tick);
}

}  // namespace
}  // namespace motion::coordinator

namespace motion::coordinator {
namespace {

// The shell with security enforced: what reaches the core from REQUEST and SREQUEST.
TEST(CoordinatorServiceOverLcm, EnforcedSecurityRefusesPlainMalformedAndUnauthorizedRequests) {
  config::Config config = *config::load_string(kConfig).config;
  config.security.mode = config::SecuritySettings::Mode::kEnforce;
  const security::KeyPair watch = security::KeyPair::generate("watch");
  auto keys = std::get<security::AuthorizedKeys>(security::AuthorizedKeys::parse(watch.authorized_line("observe") + "\n", "keys"));
  EventLoop loop;
  const std::string url = testing::unique_lcm_url(22);
  lcm::Node node(loop, {url, "CS_"});
  lcm::Node client(loop, {url, "CS_"});
  ASSERT_TRUE(node.ok() && client.ok());
  CoordinatorService::Security gate;
  gate.verifier.emplace(std::move(keys), "CS_", milliseconds(2000), wall_time_us() - 1000);
  CoordinatorService service(loop, node, config, simple_planner, std::move(gate));
  std::vector<reply_t> replies;
  std::vector<motionlcm::event_t> security_events;
  client.subscribe<reply_t>(lcm::channels::kReply, [&](const reply_t& r, const std::string&) { replies.push_back(r); });
  client.subscribe<motionlcm::event_t>(lcm::channels::kEvent, [&](const motionlcm::event_t& e, const std::string&) {
    if (e.kind == motionlcm::event_t::SECURITY) security_events.push_back(e);
  });

  request_t plain{};
  plain.client_id = "plain";
  plain.request_id = 1;
  plain.kind = request_t::MOVE_ABSOLUTE;
  plain.axes = {"x"};
  plain.values = {1.0};
  plain.num_axes = 1;
  client.publish(lcm::channels::kRequest, plain);
  ASSERT_TRUE(testing::pump_until(loop, [&] { return security_events.size() == 1; }, milliseconds(3000)));
  EXPECT_EQ(security_events[0].text.rfind("unsigned request refused: security is enforced (move request 1 of client 'plain'", 0), 0u)
      << security_events[0].text;

  client.publish_raw(node.channel(lcm::channels::kSignedRequest), {1, 2, 3});
  ASSERT_TRUE(testing::pump_until(loop, [&] { return security_events.size() == 2; }, milliseconds(3000)));
  EXPECT_EQ(security_events[1].text.rfind("malformed signed request refused: ", 0), 0u) << security_events[1].text;

  security::RequestSigner signer(watch, "CS_");
  request_t move = plain;
  move.client_id = "watch/ctl";
  move.request_id = 2;
  client.publish(lcm::channels::kSignedRequest, signer.sign(move, wall_time_us()));
  ASSERT_TRUE(testing::pump_until(loop, [&] { return !replies.empty(); }, milliseconds(3000)));
  EXPECT_EQ(replies[0].client_id, "watch/ctl");
  EXPECT_EQ(replies[0].request_id, 2);
  EXPECT_EQ(replies[0].status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(replies[0].error_code, static_cast<int>(ReplyError::kUnauthorized));
  ASSERT_EQ(security_events.size(), 3u);
  EXPECT_EQ(replies[0].reason.rfind("signed request refused: role too low: key 'watch'", 0), 0u) << replies[0].reason;
  EXPECT_EQ(security_events[2].text, replies[0].reason);
  // The plain request and the malformed envelope got no reply.
  EXPECT_EQ(replies.size(), 1u);
  EXPECT_EQ(service.active_requests(), 0u);
}

}  // namespace
}  // namespace motion::coordinator
