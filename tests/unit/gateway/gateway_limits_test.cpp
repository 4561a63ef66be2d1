// The gateway's own limit checks, whoever sends the command (issue "Nothing lost, nothing runs
// away"): motion values of every command against the configured axis limits in counts, and the
// watch that stops a jogging axis before it crosses its limit. A fake BusDriver records what
// reaches the drives.
#include <gtest/gtest.h>

#include <cmath>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/drive_model_request_t.hpp>
#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/event_t.hpp>

#include "motion/gateway/axis_limits.hpp"
#include "motion/gateway/gateway.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/testing/lcm_url.hpp"

namespace motion::gateway {
namespace {

using motionlcm::event_t;
using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using std::chrono::milliseconds;

std::int8_t k(std::int8_t v) { return v; }

// j: counts [-1000, 1000], 200 counts/s, 400 counts/s^2. n: inverted, [-10, 30] mm -> counts
// [-3000, 1000].
const char* kConfig = R"(
buses:
  - {name: can0, transport: simcan:can0, poll_hz: 10}
drives:
  - {name: jd, family: uim342, bus: can0, node_id: 5}
  - {name: nd, family: uim342, bus: can0, node_id: 6}
axes:
  - {name: j, drive: jd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 2, acceleration: 4}}
  - {name: n, drive: nd, steps_per_unit: 100, invert: true, limits: {min: -10, max: 30, velocity: 2, acceleration: 4}}
)";

class FakeDriver : public BusDriver {
 public:
  explicit FakeDriver(GatewayOutput& out) : out_(out) {}
  void start() override {}
  void execute(const gateway_command_t& command) override {
    commands.push_back(command);
    gateway_reply_t r{};
    r.command_id = command.command_id;
    r.status = command.kind == gateway_command_t::ARM_MOVE ? gateway_reply_t::ARMED : gateway_reply_t::DONE;
    if (command.kind == fail_kind) r.status = gateway_reply_t::FAILED;
    out_.command_reply(r);
  }
  void fire(std::int64_t) override {}
  std::vector<motionlcm::bus_stats_t> statistics() const override { return {}; }
  bool ready() const override { return true; }

  std::vector<gateway_command_t> commands;
  std::int8_t fail_kind = 0;  // commands of this kind fail at the "drive"

 private:
  GatewayOutput& out_;
};

struct Limits : ::testing::Test {
  Limits()
      : config(*config::load_string(kConfig).config),
        node(loop, {testing::unique_lcm_url(23), "GL_"}),
        health(loop, node, "gateway:can0", "gateway"),
        gateway(loop, node, health, config, "can0") {
    auto d = std::make_unique<FakeDriver>(gateway);
    driver = d.get();
    gateway.attach(std::move(d));
    node.subscribe<gateway_reply_t>(lcm::channels::kGatewayReply,
                                    [this](const gateway_reply_t& r, const std::string&) { replies.push_back(r); });
    node.subscribe<event_t>(lcm::channels::kEvent,
                            [this](const event_t& e, const std::string&) { events.push_back(e); });
  }
  void pump_until(const std::function<bool()>& done) {
    const auto deadline = loop.now() + milliseconds(3000);
    while (!done() && loop.now() < deadline) loop.run_once(milliseconds(5));
  }
  void pump_for(milliseconds period) {
    const auto deadline = loop.now() + period;
    while (loop.now() < deadline) loop.run_once(milliseconds(5));
  }
  // Publishes a one-axis command and waits for its (first) reply.
  gateway_reply_t send(std::int8_t kind, const std::string& axis, std::int64_t target, double velocity,
                       double acceleration = 0, double deceleration = 0) {
    gateway_command_t c{};
    c.bus = "can0";
    c.command_id = next_id++;
    c.kind = kind;
    motionlcm::axis_command_t a{};
    a.axis = axis;
    a.target_counts = target;
    a.velocity = velocity;
    a.acceleration = acceleration;
    a.deceleration = deceleration;
    c.axes = {a};
    c.num_axes = 1;
    node.publish(lcm::channels::gateway_command("can0"), c);
    return await_reply(c.command_id);
  }
  // The same as a gateway_command2_t: grid integers of the axis's model of `model_utime`.
  gateway_reply_t send2(const motionlcm::gateway_command2_t& c) {
    node.publish(lcm::channels::gateway_command2("can0"), c);
    return await_reply(c.command_id);
  }
  motionlcm::gateway_command2_t command2(std::int8_t kind, const std::string& axis, std::int64_t target,
                                         std::int64_t velocity, std::int64_t acceleration, std::int64_t deceleration,
                                         std::int64_t model_utime) {
    motionlcm::gateway_command2_t c{};
    c.bus = "can0";
    c.command_id = next_id++;
    c.kind = kind;
    motionlcm::axis_command2_t a{};
    a.axis = axis;
    a.model_utime = model_utime;
    a.target_counts = target;
    a.velocity = velocity;
    a.acceleration = acceleration;
    a.deceleration = deceleration;
    c.axes = {a};
    c.num_axes = 1;
    return c;
  }
  // The latest reply to command `id` (waits for the first).
  gateway_reply_t await_reply(std::int64_t id) {
    const gateway_reply_t* reply = nullptr;
    pump_until([&] {
      for (const auto& r : replies) {
        if (r.command_id == id) reply = &r;
      }
      return reply != nullptr;
    });
    EXPECT_NE(reply, nullptr) << "no reply to command " << id;
    return reply != nullptr ? *reply : gateway_reply_t{};
  }
  void status(const std::string& axis, std::int64_t position, double velocity, bool moving = true) {
    DriveStatus s;
    s.online = s.enabled = true;
    s.position_counts = position;
    s.velocity_counts = velocity;
    s.moving = moving;
    gateway.axis_status(axis, s);
  }
  [[nodiscard]] std::size_t own_stops() const {
    std::size_t n = 0;
    for (const auto& c : driver->commands) n += c.kind == gateway_command_t::STOP && c.command_id < 0 ? 1 : 0;
    return n;
  }
  const event_t* event_of(std::int16_t kind) const {
    for (const auto& e : events) {
      if (e.kind == kind) return &e;
    }
    return nullptr;
  }

  config::Config config;
  EventLoop loop;
  lcm::Node node;
  lcm::HealthPublisher health;
  Gateway gateway;
  FakeDriver* driver = nullptr;
  std::int64_t next_id = 100;
  std::vector<gateway_reply_t> replies;
  std::vector<event_t> events;
};

void expect_outside(const gateway_reply_t& r, const std::string& text) {
  EXPECT_EQ(r.status, k(gateway_reply_t::FAILED));
  EXPECT_EQ(r.error_code, error_code(ReplyError::kOutsideLimits));
  EXPECT_NE(r.reason.find(text), std::string::npos) << r.reason;
}

TEST_F(Limits, MoveBeyondThePositionLimitIsRefusedWithCodeThreeAndAnEvent) {
  const auto r = send(gateway_command_t::ARM_MOVE, "j", 1200, 100, 100, 100);
  expect_outside(r, "axis j: move target 12 mm (1200 counts) is outside the limits [-10, 10] mm");
  EXPECT_TRUE(driver->commands.empty());
  pump_until([&] { return event_of(event_t::PROTOCOL_ERROR) != nullptr; });
  const auto* e = event_of(event_t::PROTOCOL_ERROR);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->axis, "j");
  EXPECT_EQ(e->severity, k(event_t::WARNING));
  EXPECT_EQ(e->code, 3);
  EXPECT_NE(e->text.find("outside the limits"), std::string::npos) << e->text;
}

TEST_F(Limits, MoveWithinEveryLimitReachesTheDriverIncludingRounding) {
  EXPECT_EQ(send(gateway_command_t::ARM_MOVE, "j", 1000, 200.9, 400.5, 400).status, k(gateway_reply_t::ARMED));
  EXPECT_EQ(send(gateway_command_t::ARM_MOVE, "j", -1000, -200, 1, 1).status, k(gateway_reply_t::ARMED));
  EXPECT_EQ(driver->commands.size(), 2u);
}

TEST_F(Limits, MoveTooFastOrRampsTooSteepAreRefused) {
  expect_outside(send(gateway_command_t::ARM_MOVE, "j", 500, 202, 100, 100),
                 "velocity 2.02 mm/s (202 counts/s) exceeds the limit 2 mm/s");
  expect_outside(send(gateway_command_t::ARM_MOVE, "j", 500, 100, 402, 100),
                 "acceleration 4.02 mm/s^2 (402 counts/s^2) exceeds the limit 4");
  expect_outside(send(gateway_command_t::ARM_MOVE, "j", 500, 100, 100, 402), "deceleration 4.02 mm/s^2");
  EXPECT_TRUE(driver->commands.empty());
}

TEST_F(Limits, InvertedAxisLimitsAreOrderedByCount) {
  // n: user [-10, 30] -> counts [-3000, 1000].
  EXPECT_EQ(send(gateway_command_t::ARM_MOVE, "n", -2500, 100, 100, 100).status, k(gateway_reply_t::ARMED));
  EXPECT_EQ(send(gateway_command_t::ARM_MOVE, "n", 1000, 100, 100, 100).status, k(gateway_reply_t::ARMED));
  expect_outside(send(gateway_command_t::ARM_MOVE, "n", 1100, 100, 100, 100), "target -11 mm (1100 counts)");
  expect_outside(send(gateway_command_t::ARM_MOVE, "n", -3100, 100, 100, 100), "target 31 mm (-3100 counts)");
  EXPECT_EQ(driver->commands.size(), 2u);
}

TEST_F(Limits, JogHomeAndSetPositionAreChecked) {
  expect_outside(send(gateway_command_t::JOG, "j", 0, -250, 400, 400), "jog velocity 2.5 mm/s");
  EXPECT_EQ(send(gateway_command_t::JOG, "j", 0, -200, 0, 0).status, k(gateway_reply_t::DONE));  // 0: the drive's ramps
  expect_outside(send(gateway_command_t::HOME, "j", 0, 300), "homing velocity 3 mm/s");
  expect_outside(send(gateway_command_t::SET_POSITION, "j", 1001, 0), "set position target 10.01 mm (1001 counts)");
  EXPECT_EQ(send(gateway_command_t::SET_POSITION, "j", 1000, 0).status, k(gateway_reply_t::DONE));
  const auto nan = send(gateway_command_t::JOG, "j", 0, std::nan(""));
  EXPECT_EQ(nan.status, k(gateway_reply_t::FAILED));
  EXPECT_EQ(nan.error_code, error_code(ReplyError::kMalformedRequest));
  EXPECT_EQ(driver->commands.size(), 2u);
}

TEST_F(Limits, JogStartingAtOrBeyondItsLimitIsRefusedButMayLeave) {
  status("j", 1000, 0, false);
  expect_outside(
      send(gateway_command_t::JOG, "j", 0, 100, 400, 400),
      "jog toward 10 mm refused: position 10 mm (1000 counts) is less than one count from (or beyond) that limit");
  EXPECT_EQ(send(gateway_command_t::JOG, "j", 0, -100, 400, 400).status, k(gateway_reply_t::DONE));
  // Inverted: counts down is user units up, toward 30 mm (-3000 counts).
  status("n", -3000, 0, false);
  expect_outside(send(gateway_command_t::JOG, "n", 0, -100, 400, 400), "jog toward 30 mm refused");
}

// The whole counts a jog may run: the last one lies inside the limit; less than one whole count
// (a limit between two counts, the axis on the inner one) is no room at all. Seed 7167: a UIM242
// at 22933 counts under a limit of 22933.33 jogged toward it and ended at 22935.
TEST(JogRoom, IsTheWholeCountsInsideTheLimitInTheJogsDirection) {
  config::Axis axis;
  axis.steps_per_unit = 533.33333333333337;
  axis.limits.min_position = -4;
  axis.limits.max_position = 43;  // 22933.33 counts
  const auto l = CountLimits::of(axis);
  EXPECT_EQ(jog_room(l, +1, 22933), std::nullopt);
  EXPECT_EQ(jog_room(l, +1, 22932), std::optional<std::int64_t>{1});
  EXPECT_EQ(jog_room(l, +1, 0), std::optional<std::int64_t>{22933});
  EXPECT_EQ(jog_room(l, -1, 22933), std::optional<std::int64_t>{-25066});  // down to -2133.33: -2133
  EXPECT_EQ(jog_room(l, -1, -2133), std::nullopt);
  EXPECT_EQ(jog_room(l, -1, -2132), std::optional<std::int64_t>{-1});
  EXPECT_EQ(jog_room(l, +1, 30000), std::nullopt);  // beyond
  EXPECT_EQ(jog_room(l, 0, 0), std::nullopt);       // no direction
  axis.invert = true;                               // counts [-22933.33, 2133.33]: a jog up in counts heads for 2133.33
  const auto inv = CountLimits::of(axis);
  EXPECT_EQ(jog_room(inv, +1, 2133), std::nullopt);
  EXPECT_EQ(jog_room(inv, -1, -22933), std::nullopt);
  EXPECT_EQ(jog_room(inv, -1, -22932), std::optional<std::int64_t>{-1});
}

TEST_F(Limits, JogIsStoppedBeforeItsLimitWithALimitEvent) {
  status("j", 0, 0, false);
  ASSERT_EQ(send(gateway_command_t::JOG, "j", 0, 200, 400, 400).status, k(gateway_reply_t::DONE));
  // Margin: 200^2/(2*400) = 50 braking + 2*200/10 = 40 of two status periods + 1 = 91 counts.
  status("j", 500, 200);
  status("j", 908, 200);
  EXPECT_EQ(own_stops(), 0u);
  status("j", 909, 200);
  ASSERT_EQ(own_stops(), 1u);
  const auto& stop = driver->commands.back();
  EXPECT_EQ(stop.kind, k(gateway_command_t::STOP));
  EXPECT_LT(stop.command_id, 0);
  ASSERT_EQ(stop.axes.size(), 1u);
  EXPECT_EQ(stop.axes[0].axis, "j");
  pump_until([&] { return event_of(event_t::LIMIT) != nullptr; });
  const auto* e = event_of(event_t::LIMIT);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->axis, "j");
  EXPECT_EQ(e->severity, k(event_t::WARNING));
  EXPECT_NE(e->text.find("axis j jogging toward its limit 10 mm (1000 counts): stopped at 9.09 mm (909 counts"),
            std::string::npos)
      << e->text;
  // Once: the watch ends with its stop.
  status("j", 950, 100);
  EXPECT_EQ(own_stops(), 1u);
}

TEST_F(Limits, JogWatchUsesTheSlowerCommandedDecelerationAndTheInvertedDirection) {
  // n inverted: user +30 mm is -3000 counts; jog counts down at 200 counts/s with 100 counts/s^2:
  // 200 braking + 40 + 1 = 241 counts.
  ASSERT_EQ(send(gateway_command_t::JOG, "n", 0, -200, 100, 100).status, k(gateway_reply_t::DONE));
  status("n", -2758, -200);
  EXPECT_EQ(own_stops(), 0u);
  status("n", -2759, -200);
  EXPECT_EQ(own_stops(), 1u);
}

TEST_F(Limits, StopOrAStartedMoveEndsTheWatch) {
  ASSERT_EQ(send(gateway_command_t::JOG, "j", 0, 200, 400, 400).status, k(gateway_reply_t::DONE));
  ASSERT_EQ(send(gateway_command_t::STOP, "j", 0, 0).status, k(gateway_reply_t::DONE));
  status("j", 990, 50);
  EXPECT_EQ(own_stops(), 0u);

  status("j", 0, 0, false);
  ASSERT_EQ(send(gateway_command_t::JOG, "j", 0, 200, 400, 400).status, k(gateway_reply_t::DONE));
  const auto armed = send(gateway_command_t::ARM_MOVE, "j", 1000, 200, 400, 400);
  ASSERT_EQ(armed.status, k(gateway_reply_t::ARMED));
  status("j", 950, 200);  // armed only: the jog is still watched
  EXPECT_EQ(own_stops(), 1u);

  status("j", 0, 0, false);
  ASSERT_EQ(send(gateway_command_t::JOG, "j", 0, 200, 400, 400).status, k(gateway_reply_t::DONE));
  const auto move = send(gateway_command_t::ARM_MOVE, "j", 1000, 200, 400, 400);
  gateway_reply_t started{};
  started.command_id = move.command_id;
  started.status = gateway_reply_t::STARTED;
  gateway.command_reply(started);
  status("j", 990, 200);  // a move to the limit is not a jog
  EXPECT_EQ(own_stops(), 1u);
}

TEST_F(Limits, AJogTheDriverRefusedLeavesTheWatchAsItWas) {
  status("j", 0, 0, false);
  driver->fail_kind = gateway_command_t::JOG;
  ASSERT_EQ(send(gateway_command_t::JOG, "j", 0, 200, 400, 400).status, k(gateway_reply_t::FAILED));
  status("j", 995, 0, false);
  EXPECT_EQ(own_stops(), 0u);  // no jog, no watch

  // A jog toward -10 mm runs; a reversal the driver refuses leaves it watched toward -10 mm.
  driver->fail_kind = 0;
  status("j", 0, 0, false);
  ASSERT_EQ(send(gateway_command_t::JOG, "j", 0, -200, 400, 400).status, k(gateway_reply_t::DONE));
  driver->fail_kind = gateway_command_t::JOG;
  ASSERT_EQ(send(gateway_command_t::JOG, "j", 0, 200, 400, 400).status, k(gateway_reply_t::FAILED));
  status("j", 950, -200);
  EXPECT_EQ(own_stops(), 0u);
  status("j", -950, -200);
  EXPECT_EQ(own_stops(), 1u);
}

// A drive that lost power: whoever sends them, moves and jogs of its axis are refused (code 22,
// with an event) until a HOME or SET_POSITION of it is DONE; its state says so meanwhile.
TEST_F(Limits, PositionLostRefusesMovesAndJogsUntilASetPositionIsDone) {
  std::vector<motionlcm::axis_state_t> states;
  node.subscribe<motionlcm::axis_state_t>(
      lcm::channels::kAxisState, [&](const motionlcm::axis_state_t& a, const std::string&) { states.push_back(a); });
  status("j", 0, 0, false);
  gateway.position_lost("j", "jd answers as freshly powered up");
  pump_until([&] { return event_of(event_t::REBOOT) != nullptr && !states.empty() && states.back().fault_code != 0; });
  const auto* e = event_of(event_t::REBOOT);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->axis, "j");
  EXPECT_NE(e->text.find("position lost"), std::string::npos) << e->text;
  ASSERT_FALSE(states.empty());
  EXPECT_EQ(states.back().fault_code, motionlcm::axis_state_t::POSITION_LOST);
  EXPECT_FALSE(states.back().fault);
  EXPECT_FALSE(states.back().homed);

  const auto move = send(gateway_command_t::ARM_MOVE, "j", 100, 100, 100, 100);
  EXPECT_EQ(move.status, k(gateway_reply_t::FAILED));
  EXPECT_EQ(move.error_code, error_code(ReplyError::kPositionLost)) << move.reason;
  EXPECT_NE(move.reason.find("axis j lost its position"), std::string::npos) << move.reason;
  EXPECT_EQ(send(gateway_command_t::JOG, "j", 0, 50, 100).error_code, error_code(ReplyError::kPositionLost));
  EXPECT_TRUE(driver->commands.empty());
  // The other axis is not concerned.
  EXPECT_EQ(send(gateway_command_t::ARM_MOVE, "n", 100, 100, 100, 100).status, k(gateway_reply_t::ARMED));
  // A SET_POSITION the drive refuses leaves it lost; one that is DONE makes it valid again.
  driver->fail_kind = gateway_command_t::SET_POSITION;
  EXPECT_EQ(send(gateway_command_t::SET_POSITION, "j", 0, 0).status, k(gateway_reply_t::FAILED));
  EXPECT_EQ(send(gateway_command_t::ARM_MOVE, "j", 100, 100, 100, 100).error_code,
            error_code(ReplyError::kPositionLost));
  driver->fail_kind = 0;
  EXPECT_EQ(send(gateway_command_t::SET_POSITION, "j", 0, 0).status, k(gateway_reply_t::DONE));
  pump_until([&] { return !states.empty() && states.back().fault_code != motionlcm::axis_state_t::POSITION_LOST; });
  EXPECT_NE(states.back().fault_code, motionlcm::axis_state_t::POSITION_LOST);
  EXPECT_EQ(send(gateway_command_t::ARM_MOVE, "j", 100, 100, 100, 100).status, k(gateway_reply_t::ARMED));
}

// An axis that cannot be heard is not published as moving on its last word.
TEST_F(Limits, AnOfflineAxisIsNotReportedMoving) {
  std::vector<motionlcm::axis_state_t> states;
  node.subscribe<motionlcm::axis_state_t>(
      lcm::channels::kAxisState, [&](const motionlcm::axis_state_t& a, const std::string&) { states.push_back(a); });
  DriveStatus s;
  s.online = false;
  s.moving = true;
  gateway.axis_status("j", s);
  pump_until([&] { return !states.empty(); });
  ASSERT_FALSE(states.empty());
  EXPECT_FALSE(states.back().online);
  EXPECT_FALSE(states.back().moving);
}

// gateway_command2_t (GW_COMMAND2_<bus>): grid integers of the model the gateway published, for
// axis j velocity in 0.5 counts/s steps 1..1000, acceleration in 2 counts/s^2 steps 1..150.
struct Command2 : Limits {
  Command2() {
    node.subscribe<motionlcm::drive_model_t>(
        lcm::channels::kDriveModel,
        [this](const motionlcm::drive_model_t& m, const std::string&) { models.push_back(m); });
    gateway.set_model_builder([](const config::Axis& axis, const DriveFacts&) {
      motionlcm::drive_model_t m{};
      m.bus = "can0";
      m.axis = axis.name;
      m.family = "uim342";
      m.velocity_step = 0.5;
      m.velocity_min = 1;
      m.velocity_max = 1000;
      m.acceleration_kind = motionlcm::drive_model_t::ACCEL_RATE;
      m.acceleration_step = 2;
      m.acceleration_min = 1;
      m.acceleration_max = 150;
      return std::variant<motionlcm::drive_model_t, std::string>(m);
    });
    status("j", 0, 0, false);  // online: its model goes out
    pump_until([&] { return !models.empty(); });
  }
  std::vector<motionlcm::drive_model_t> models;
};

TEST_F(Command2, GridIntegersReachTheDriverAsExactValuesAndARepeatIsAnsweredNotRun) {
  ASSERT_EQ(models.size(), 1u);
  const std::int64_t utime = models[0].utime;
  const auto move = command2(gateway_command_t::ARM_MOVE, "j", 700, 301, 150, 77, utime);
  EXPECT_EQ(send2(move).status, k(gateway_reply_t::ARMED));
  ASSERT_EQ(driver->commands.size(), 1u);
  EXPECT_EQ(driver->commands[0].axes[0].velocity, 150.5);  // 301 * 0.5, exactly
  EXPECT_EQ(driver->commands[0].axes[0].acceleration, 300.0);
  EXPECT_EQ(driver->commands[0].axes[0].deceleration, 154.0);
  EXPECT_EQ(driver->commands[0].axes[0].target_counts, 700);
  // The same bytes again (a re-send): its latest reply again, nothing runs twice.
  const std::size_t heard = replies.size();
  node.publish(lcm::channels::gateway_command2("can0"), move);
  pump_until([&] { return replies.size() > heard; });
  EXPECT_EQ(replies.back().command_id, move.command_id);
  EXPECT_EQ(replies.back().status, k(gateway_reply_t::ARMED));
  EXPECT_EQ(driver->commands.size(), 1u);
  // A model published again on request keeps its utime: a plan made before stays valid.
  node.publish(lcm::channels::kDriveModelRequest, motionlcm::drive_model_request_t{});
  pump_until([&] { return models.size() > 1; });
  ASSERT_EQ(models.size(), 2u);
  EXPECT_EQ(models[1].utime, utime);
  const auto jog = command2(gateway_command_t::JOG, "j", 0, -400, 0, 0, utime);
  EXPECT_EQ(send2(jog).status, k(gateway_reply_t::DONE));
  ASSERT_EQ(driver->commands.size(), 2u);
  EXPECT_EQ(driver->commands[1].axes[0].velocity, -200.0);
}

TEST_F(Command2, AStaleModelOrAValueOutsideItsRangeIsRefusedNamingIt) {
  const std::int64_t utime = models.at(0).utime;
  auto r = send2(command2(gateway_command_t::ARM_MOVE, "j", 700, 300, 100, 100, utime - 5));
  EXPECT_EQ(r.status, k(gateway_reply_t::FAILED));
  EXPECT_EQ(r.error_code, error_code(ReplyError::kPlanningFailed));
  EXPECT_EQ(r.reason, "drive model of axis j changed since the move was planned (planned with " +
                          std::to_string(utime - 5) + ", now " + std::to_string(utime) + "): plan again");
  r = send2(command2(gateway_command_t::ARM_MOVE, "j", 700, 1001, 100, 100, utime));
  expect_outside(r, "axis j: velocity 1001 is outside its drive model's range 1..1000");
  r = send2(command2(gateway_command_t::ARM_MOVE, "j", 700, 300, 100, 151, utime));
  expect_outside(r, "axis j: deceleration 151 is outside its drive model's range 1..150");
  r = send2(command2(gateway_command_t::ARM_MOVE, "j", 700, 300, 0, 100, utime));
  expect_outside(r, "axis j: acceleration 0 is outside its drive model's range 1..150");
  r = send2(command2(gateway_command_t::JOG, "j", 0, -1001, 0, 0, utime));
  expect_outside(r, "axis j: velocity 1001 is outside its drive model's range 1..1000 (or 0)");
  // Within the model but beyond the configured limit (200 counts/s): the gateway's limits, as for
  // gateway_command_t.
  expect_outside(send2(command2(gateway_command_t::ARM_MOVE, "j", 700, 404, 100, 100, utime)),
                 "velocity 2.02 mm/s (202 counts/s) exceeds the limit 2 mm/s");
  // An axis without a model (n never came online).
  r = send2(command2(gateway_command_t::ARM_MOVE, "n", 700, 300, 100, 100, utime));
  EXPECT_EQ(r.status, k(gateway_reply_t::FAILED));
  EXPECT_EQ(r.error_code, error_code(ReplyError::kNoDriveModel));
  EXPECT_TRUE(driver->commands.empty());
  // Kinds without motion values need no model.
  EXPECT_EQ(send2(command2(gateway_command_t::STOP, "n", 0, 0, 0, 0, 0)).status, k(gateway_reply_t::DONE));
}

TEST(CountLimits, CheckedDirectly) {
  const auto cfg = *config::load_string(kConfig).config;
  const auto limits = CountLimits::of(*cfg.find_axis("n"));
  EXPECT_DOUBLE_EQ(limits.min_counts, -3000);
  EXPECT_DOUBLE_EQ(limits.max_counts, 1000);
  EXPECT_DOUBLE_EQ(limits.max_velocity, 200);
  EXPECT_DOUBLE_EQ(limits.max_acceleration, 400);
  motionlcm::axis_command_t a{};
  a.axis = "n";
  a.target_counts = 1000;
  EXPECT_FALSE(check_axis_command(gateway_command_t::SET_POSITION, a, limits, std::nullopt));
  a.target_counts = 1001;
  EXPECT_TRUE(check_axis_command(gateway_command_t::SET_POSITION, a, limits, std::nullopt));
  EXPECT_FALSE(check_axis_command(gateway_command_t::STOP, a, limits, std::nullopt));  // no motion values
}

}  // namespace
}  // namespace motion::gateway
