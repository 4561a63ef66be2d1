#include "motion/gateway/gateway.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include <motionlcm/arm_timing_t.hpp>
#include <motionlcm/drive_model_request_t.hpp>
#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/request_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>
#include <motionlcm/trigger_heard_t.hpp>

#include "motion/lcm/channels.hpp"
#include "motion/security/signed_messages.hpp"
#include "motion/testing/lcm_url.hpp"

namespace motion::gateway {
namespace {

using std::chrono::milliseconds;

const char* kConfig = R"(
buses:
  - {name: can0, transport: simcan:can0}
  - {name: can1, transport: simcan:can1}
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5}
  - {name: yd, family: uim342, bus: can1, node_id: 5}
axes:
  - {name: x, drive: xd, steps_per_unit: 100, invert: true, limits: {min: -10, max: 10, velocity: 1, acceleration: 1}}
  - {name: y, drive: yd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 1, acceleration: 1}}
)";

class FakeDriver : public BusDriver {
 public:
  explicit FakeDriver(GatewayOutput& out, EventLoop& loop) : out_(out), loop_(loop) {}
  void start() override { started = true; }
  void execute(const motionlcm::gateway_command_t& command) override {
    commands.push_back(command);
    motionlcm::gateway_reply_t r{};
    r.command_id = command.command_id;
    r.status = motionlcm::gateway_reply_t::ARMED;
    out_.command_reply(r);
  }
  void fire(std::int64_t trigger_id) override {
    fired.emplace_back(trigger_id, loop_.now());
    if (reply_on_fire) {
      motionlcm::gateway_reply_t r{};
      r.command_id = 77;
      r.status = motionlcm::gateway_reply_t::STARTED;
      out_.command_reply(r);
    }
  }
  void fire_ordered(std::int64_t trigger_id, const std::vector<std::int64_t>& order) override {
    fire(trigger_id);
    orders.push_back(order);
  }
  void prepare_fire(TimePoint at) override { prepared.push_back(at); }
  void hold_traffic(TimePoint from, TimePoint until) override { holds.emplace_back(from, until); }
  Duration start_wait() const override { return wait; }
  std::vector<motionlcm::bus_stats_t> statistics() const override {
    motionlcm::bus_stats_t s{};
    s.name = "can0";
    return {s};
  }
  bool ready() const override { return true; }

  bool started = false;
  std::vector<motionlcm::gateway_command_t> commands;
  std::vector<std::pair<std::int64_t, TimePoint>> fired;
  std::vector<std::vector<std::int64_t>> orders;
  std::vector<TimePoint> prepared;
  std::vector<std::pair<TimePoint, TimePoint>> holds;  // hold_traffic()
  Duration wait{};                                     // start_wait()
  bool reply_on_fire = false;                          // a STARTED reply for command 77 from each fire

 private:
  GatewayOutput& out_;
  EventLoop& loop_;
};

struct Fixture : ::testing::Test {
  explicit Fixture(const std::string& config_text = kConfig)
      : config(*config::load_string(config_text).config),
        node(loop, {testing::unique_lcm_url(11), "GT_"}),
        health(loop, node, "gateway:can0", "gateway"),
        gateway(loop, node, health, config, "can0") {
    auto d = std::make_unique<FakeDriver>(gateway, loop);
    driver = d.get();
    gateway.attach(std::move(d));
    node.subscribe<motionlcm::gateway_reply_t>(
        lcm::channels::kGatewayReply,
        [this](const motionlcm::gateway_reply_t& r, const std::string&) { replies.push_back(r); });
    node.subscribe<motionlcm::axis_state_t>(
        lcm::channels::kAxisState,
        [this](const motionlcm::axis_state_t& s, const std::string&) { states.push_back(s); });
    node.subscribe<motionlcm::event_t>(
        lcm::channels::kEvent, [this](const motionlcm::event_t& e, const std::string&) { events.push_back(e); });
  }
  void pump_until(const std::function<bool()>& done) {
    const auto deadline = loop.now() + milliseconds(3000);
    while (!done() && loop.now() < deadline) loop.run_once(milliseconds(5));
  }
  motionlcm::gateway_command_t command_for(const std::string& bus, const std::string& axis) {
    motionlcm::gateway_command_t c{};
    c.bus = bus;
    c.command_id = 77;
    c.kind = motionlcm::gateway_command_t::ARM_MOVE;
    motionlcm::axis_command_t a{};
    a.axis = axis;
    c.axes = {a};
    c.num_axes = 1;
    return c;
  }

  config::Config config;
  EventLoop loop;
  lcm::Node node;
  lcm::HealthPublisher health;
  Gateway gateway;
  FakeDriver* driver = nullptr;
  std::vector<motionlcm::gateway_reply_t> replies;
  std::vector<motionlcm::axis_state_t> states;
  std::vector<motionlcm::event_t> events;
};

TEST_F(Fixture, CommandForItsAxesReachesTheDriverAndTheReplyCarriesTheBus) {
  EXPECT_TRUE(driver->started);
  node.publish(lcm::channels::gateway_command("can0"), command_for("can0", "x"));
  pump_until([&] { return !replies.empty(); });
  ASSERT_EQ(driver->commands.size(), 1u);
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].bus, "can0");
  EXPECT_EQ(replies[0].command_id, 77);
  EXPECT_EQ(replies[0].status, std::int8_t{motionlcm::gateway_reply_t::ARMED});
}

// The coordinator sends a command again, word for word, when it heard no reply (LCM may lose
// either): the drive gets it once, and the repeat gets the latest reply again. The same id with
// other bytes (a restarted coordinator's ids start again at 1) is a new command.
TEST_F(Fixture, ACommandSentAgainRunsOnceAndGetsItsLatestReplyAgain) {
  auto command = command_for("can0", "x");
  command.utime = 1'000'000;
  node.publish(lcm::channels::gateway_command("can0"), command);
  pump_until([&] { return !replies.empty(); });
  node.publish(lcm::channels::gateway_command("can0"), command);
  pump_until([&] { return replies.size() == 2; });
  EXPECT_EQ(driver->commands.size(), 1u);
  ASSERT_EQ(replies.size(), 2u);
  EXPECT_EQ(replies[1].command_id, 77);
  EXPECT_EQ(replies[1].status, std::int8_t{motionlcm::gateway_reply_t::ARMED});
  EXPECT_EQ(replies[1].utime, replies[0].utime);  // the same reply, not a new one
  command.utime = 2'000'000;
  node.publish(lcm::channels::gateway_command("can0"), command);
  pump_until([&] { return replies.size() == 3; });
  EXPECT_EQ(driver->commands.size(), 2u);
}

TEST(CommandMemory, KeepsTheLatestReplyPerCommandAndForgetsTheOldest) {
  CommandMemory memory;
  motionlcm::gateway_command_t c{};
  c.command_id = 1;
  std::optional<motionlcm::gateway_reply_t> latest;
  EXPECT_FALSE(memory.repeated(c, &latest));
  EXPECT_TRUE(memory.repeated(c, &latest));
  EXPECT_FALSE(latest.has_value());  // not answered yet
  motionlcm::gateway_reply_t r{};
  r.command_id = 1;
  r.status = motionlcm::gateway_reply_t::ARMED;
  memory.replied(r);
  r.status = motionlcm::gateway_reply_t::STARTED;
  memory.replied(r);
  ASSERT_TRUE(memory.repeated(c, &latest));
  ASSERT_TRUE(latest.has_value());
  EXPECT_EQ(latest->status, std::int8_t{motionlcm::gateway_reply_t::STARTED});
  for (std::int64_t id = 2; id <= static_cast<std::int64_t>(CommandMemory::kRemembered); ++id) {
    motionlcm::gateway_command_t other{};
    other.command_id = id;
    EXPECT_FALSE(memory.repeated(other, &latest));
  }
  EXPECT_TRUE(memory.repeated(c, &latest));  // the 1024th most recent: still kept
  motionlcm::gateway_command_t newest{};
  newest.command_id = 5000;
  EXPECT_FALSE(memory.repeated(newest, &latest));
  EXPECT_FALSE(memory.repeated(c, &latest));  // now the oldest was forgotten
}

TEST_F(Fixture, AxisOfAnotherBusIsRefusedWithAReason) {
  node.publish(lcm::channels::gateway_command("can0"), command_for("can0", "y"));
  pump_until([&] { return !replies.empty(); });
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].status, std::int8_t{motionlcm::gateway_reply_t::FAILED});
  EXPECT_NE(replies[0].reason.find("axis 'y' is not on bus 'can0'"), std::string::npos) << replies[0].reason;
  EXPECT_TRUE(driver->commands.empty());
}

TEST_F(Fixture, TriggerFiresAtItsWallClockTimeOnlyOnListedBuses) {
  motionlcm::sync_trigger_t other{};
  other.trigger_id = 1;
  other.fire_utime = wall_time_us();
  other.buses = {"can1"};
  other.num_buses = 1;
  node.publish(lcm::channels::kSyncTrigger, other);

  motionlcm::sync_trigger_t t{};
  t.trigger_id = 2;
  t.fire_utime = wall_time_us() + 50'000;
  t.buses = {"can1", "can0"};
  t.num_buses = 2;
  const TimePoint published = loop.now();
  node.publish(lcm::channels::kSyncTrigger, t);
  pump_until([&] { return !driver->fired.empty(); });
  ASSERT_EQ(driver->fired.size(), 1u);
  EXPECT_EQ(driver->fired[0].first, 2);
  EXPECT_GE(driver->fired[0].second - published, milliseconds(49));  // not early
}

// A gateway holds its bus's own traffic (polls, SYNCs) from 1 ms before the start's quiet interval
// (0.5 ms before the first bus's send time) until its own fire, so that no gateway of the start is
// busy with its polls when another one's fire is due; a trigger of this bus alone holds 1 ms.
TEST_F(Fixture, ATriggerHoldsTheBusesOwnTrafficFromJustBeforeTheStartsQuietIntervalUntilItFires) {
  motionlcm::sync_trigger2_t t{};
  t.trigger_id = 4;
  t.act_utime = wall_time_us() + 60'000;
  t.buses = {"can0", "can1"};
  t.send_utime = {t.act_utime - 3'000, t.act_utime - 6'000};  // can1 (a slow line) sends first
  t.lead_us = {3'000.0, 6'000.0};
  t.num_buses = 2;
  t.utime = wall_time_us();
  node.publish(lcm::channels::kSyncTrigger2, t);
  pump_until([&] { return !driver->fired.empty(); });
  ASSERT_EQ(driver->holds.size(), 1u);
  const auto [from, until] = driver->holds[0];
  // Wall-clock send times on the steady clock: the two clocks are read a few µs apart.
  const double held_us = std::chrono::duration<double, std::micro>(until - from).count();
  EXPECT_NEAR(held_us, 6000.0 + 500.0 + 1000.0 - 3000.0, 10.0)
      << "from 1 ms before the quiet interval (can1's send - 0.5 ms) to can0's fire";
  ASSERT_EQ(driver->fired.size(), 1u);
  EXPECT_LE(until, driver->fired[0].second);
}

TEST_F(Fixture, ScheduledTriggerFiresAtThisBusesSendTimeInItsOrderAndOnce) {
  motionlcm::sync_trigger2_t t{};
  t.trigger_id = 3;
  // can0 leads by 1.98 s (far more than any frame: the test tells the send time from the act time).
  t.act_utime = wall_time_us() + 2'000'000;
  t.buses = {"can0", "can1"};
  t.send_utime = {t.act_utime - 1'980'000, t.act_utime - 100};
  t.lead_us = {1'980'000.0, 100.0};
  t.num_buses = 2;
  t.start_command_ids = {12, 11, 13};
  t.num_starts = 3;
  t.utime = wall_time_us();
  std::vector<motionlcm::trigger_heard_t> heard;  // TRIGGER_HEARD: when it reached this gateway
  node.subscribe<motionlcm::trigger_heard_t>(
      lcm::channels::kTriggerHeard,
      [&](const motionlcm::trigger_heard_t& h, const std::string&) { heard.push_back(h); });
  const TimePoint published = loop.now();
  node.publish(lcm::channels::kSyncTrigger2, t);
  // The deprecated trigger of the same id (fire_utime = the earliest send) must not fire again.
  motionlcm::sync_trigger_t old{};
  old.trigger_id = 3;
  old.fire_utime = t.send_utime[0];
  old.buses = {"can0", "can1"};
  old.num_buses = 2;
  node.publish(lcm::channels::kSyncTrigger, old);
  pump_until([&] { return !driver->fired.empty(); });
  ASSERT_EQ(driver->fired.size(), 1u);
  EXPECT_EQ(driver->fired[0].first, 3);
  EXPECT_GE(driver->fired[0].second - published, milliseconds(19));    // at can0's send time, not at once
  EXPECT_LT(driver->fired[0].second - published, milliseconds(1000));  // and not at the act time
  ASSERT_EQ(driver->orders.size(), 1u);
  EXPECT_EQ(driver->orders[0], (std::vector<std::int64_t>{12, 11, 13}));
  ASSERT_EQ(driver->prepared.size(), 1u);  // the bus was told ahead
  EXPECT_LE(driver->prepared[0], driver->fired[0].second);
  // Its own traffic held until it fires, from 1 ms before the start's quiet interval; that
  // interval (at most 10 ms, up to 0.5 ms after the act time) begins long after can0's send time
  // here, so the hold is the shortest: 1 ms.
  ASSERT_EQ(driver->holds.size(), 1u);
  const auto [hold_from, hold_until] = driver->holds[0];
  EXPECT_LE(hold_until, driver->fired[0].second);
  EXPECT_GE(hold_until, driver->fired[0].second - milliseconds(2));
  EXPECT_EQ(hold_until - hold_from, Gateway::kTrafficHoldBefore);
  // Nothing more comes for it.
  const auto later = loop.now() + milliseconds(100);
  pump_until([&] { return loop.now() >= later; });
  EXPECT_EQ(driver->fired.size(), 1u);
  // Its hearing, once, with the trigger's own stamps; heard before this bus's send time.
  ASSERT_EQ(heard.size(), 1u);
  EXPECT_EQ(heard[0].bus, "can0");
  EXPECT_EQ(heard[0].trigger_id, 3);
  EXPECT_EQ(heard[0].trigger_utime, t.utime);
  EXPECT_EQ(heard[0].send_utime, t.send_utime[0]);
  EXPECT_GE(heard[0].utime, t.utime);
  EXPECT_LT(heard[0].utime, t.send_utime[0]);
  // One heard after its send time fires at once, and says so by its stamps.
  t.trigger_id = 4;
  t.utime = wall_time_us() - 5'000;
  t.send_utime = {t.utime + 1'000, t.utime + 1'000};
  node.publish(lcm::channels::kSyncTrigger2, t);
  pump_until([&] { return driver->fired.size() == 2 && heard.size() == 2; });
  ASSERT_EQ(heard.size(), 2u);
  EXPECT_EQ(driver->fired[1].first, 4);
  EXPECT_GT(heard[1].utime, heard[1].send_utime);
}

// Around a start across buses the gateway publishes nothing (every publication wakes every
// process of the LCM group, which delays the other buses' fires): from 0.5 ms before the first
// bus's send time until 0.5 ms after the act time its replies and states wait, then go out in
// their order. Never longer than 10 ms.
TEST_F(Fixture, NothingIsPublishedFromJustBeforeTheFirstSendUntilJustAfterTheActTime) {
  driver->reply_on_fire = true;
  std::vector<std::pair<motionlcm::gateway_reply_t, std::int64_t>> seen;  // reply, wall time heard
  node.subscribe<motionlcm::gateway_reply_t>(
      lcm::channels::kGatewayReply,
      [&](const motionlcm::gateway_reply_t& r, const std::string&) { seen.emplace_back(r, wall_time_us()); });
  std::vector<std::int64_t> state_heard;
  node.subscribe<motionlcm::axis_state_t>(
      lcm::channels::kAxisState,
      [&](const motionlcm::axis_state_t&, const std::string&) { state_heard.push_back(wall_time_us()); });
  motionlcm::sync_trigger2_t t{};
  t.trigger_id = 5;
  t.utime = wall_time_us();
  t.act_utime = t.utime + 80'000;
  t.buses = {"can1", "can0"};
  t.send_utime = {t.act_utime - 6'000, t.act_utime - 100};  // can1 sends first; can0 fires 5.9 ms later
  t.lead_us = {6'000.0, 100.0};
  t.num_buses = 2;
  node.publish(lcm::channels::kSyncTrigger2, t);
  // A state published between can1's send time and can0's is held as well.
  std::int64_t state_published = 0;
  loop.call_after(milliseconds(77), [&] {
    state_published = wall_time_us();
    DriveStatus s;
    s.position_counts = 5;
    gateway.axis_status("x", s);
  });
  pump_until([&] { return !seen.empty() && !state_heard.empty(); });
  ASSERT_EQ(driver->fired.size(), 1u);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].first.status, std::int8_t{motionlcm::gateway_reply_t::STARTED});
  EXPECT_GE(seen[0].second, t.act_utime + 500) << "the STARTED reply went out inside the quiet interval";
  ASSERT_GT(state_published, t.send_utime[0] - 500);
  ASSERT_LT(state_published, t.act_utime);
  ASSERT_EQ(state_heard.size(), 1u);
  EXPECT_GE(state_heard[0], t.act_utime + 500) << "the state went out inside the quiet interval";
  EXPECT_FALSE(node.quiet());
  // A trigger whose first bus leads by 250 ms keeps quiet for the last 10 ms only: a state
  // published 150 ms before the act time goes out at once.
  t.trigger_id = 6;
  t.utime = wall_time_us();
  t.act_utime = t.utime + 300'000;
  t.send_utime = {t.act_utime - 250'000, t.act_utime - 100};
  node.publish(lcm::channels::kSyncTrigger2, t);
  const std::size_t states_then = states.size();
  loop.call_after(milliseconds(150), [&] {
    DriveStatus s;
    s.position_counts = 6;
    gateway.axis_status("x", s);
  });
  std::size_t fired_when_heard = 99;
  pump_until([&] {
    if (states.size() > states_then && fired_when_heard == 99) fired_when_heard = driver->fired.size();
    return driver->fired.size() == 2;
  });
  EXPECT_EQ(fired_when_heard, 1u) << "the state waited for the start 150 ms later";
  pump_until([&] { return !node.quiet(); });
  EXPECT_FALSE(node.quiet());
}

// Whatever a sender names, the starts waiting for their send time are bounded (each holds a
// timer): past 256, a trigger for later is not scheduled and fires nothing; those already waiting
// still fire.
TEST_F(Fixture, AFloodOfTriggersForLaterSchedulesAtMost256Starts) {
  motionlcm::sync_trigger2_t t{};
  t.buses = {"can0"};
  t.num_buses = 1;
  t.lead_us = {100.0};
  t.utime = wall_time_us();
  for (int id = 1000; id < 1300; ++id) {
    t.trigger_id = id;
    t.act_utime = t.utime + 400'000 + (id - 1000) * 100;
    t.send_utime = {t.act_utime - 100};
    node.publish(lcm::channels::kSyncTrigger2, t);
  }
  const TimePoint after_all = loop.now() + milliseconds(800);  // every send time has passed
  pump_until([&] { return loop.now() >= after_all; });
  ASSERT_EQ(driver->fired.size(), 256u);
  // The first 256 (starts 100 us apart: two that a late loop finds due together fire in either
  // order).
  std::vector<std::int64_t> ids;
  for (const auto& f : driver->fired) ids.push_back(f.first);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids.front(), 1000);
  EXPECT_EQ(ids.back(), 1255);
  EXPECT_EQ(std::adjacent_find(ids.begin(), ids.end()), ids.end()) << "a start fired twice";
}

// can0 writes through an adapter that takes 15 ms from the hand-over to the wire (egress_latency_us):
// the start frames are handed over 15 ms before the send time the trigger names, so that they begin
// on the wire at it.
struct LatentBus : Fixture {
  LatentBus()
      : Fixture(std::string(kConfig).replace(std::string(kConfig).find("transport: simcan:can0}"), 23,
                                             "transport: simcan:can0, egress_latency_us: 15000}") +
                "coordinator: {trigger_lead_ms: 30, trigger_lead_min_ms: 20}\n") {}
};

TEST_F(LatentBus, TheStartIsHandedOverItsEgressLatencyBeforeTheSendTime) {
  ASSERT_EQ(config.find_bus("can0")->egress_latency_us, 15000);
  motionlcm::sync_trigger2_t t{};
  t.trigger_id = 3;
  t.utime = wall_time_us();
  t.act_utime = t.utime + 60'000;
  t.buses = {"can0"};
  t.send_utime = {t.act_utime - 100};
  t.lead_us = {100.0};
  t.num_buses = 1;
  const std::int64_t published_utime = wall_time_us();
  const TimePoint published = loop.now();
  node.publish(lcm::channels::kSyncTrigger2, t);
  pump_until([&] { return !driver->fired.empty(); });
  ASSERT_EQ(driver->fired.size(), 1u);
  const auto fired_after = std::chrono::duration_cast<std::chrono::microseconds>(driver->fired[0].second - published);
  const auto hand_over = std::chrono::microseconds(t.send_utime[0] - 15'000 - published_utime);
  EXPECT_GE(fired_after, hand_over) << "not before its hand-over time";
  EXPECT_LT(fired_after, hand_over + milliseconds(10)) << "15 ms before the send time, not at it";
}

TEST_F(Fixture, StatusIsPublishedInUserUnitsWithInvertAndIdentity) {
  DriveStatus s;
  s.position_counts = 250;
  s.velocity_counts = -50;
  s.enabled = true;
  s.inputs = 0b101;
  gateway.axis_status("x", s);
  pump_until([&] { return !states.empty(); });
  ASSERT_EQ(states.size(), 1u);
  EXPECT_EQ(states[0].axis, "x");
  EXPECT_EQ(states[0].family, "uim342");
  EXPECT_EQ(states[0].bus, "can0");
  EXPECT_EQ(states[0].node_id, 5);
  EXPECT_DOUBLE_EQ(states[0].position, -2.5);  // invert: counts up = units down
  EXPECT_DOUBLE_EQ(states[0].velocity, 0.5);
  EXPECT_EQ(states[0].position_counts, 250);
  EXPECT_TRUE(states[0].enabled);
  EXPECT_EQ(states[0].inputs, 5);
}

TEST_F(Fixture, EventsNameTheirSource) {
  gateway.axis_event("x", {motionlcm::event_t::STALL, motionlcm::event_t::ERROR, 0x1D, "motor stall detected"});
  pump_until([&] { return !events.empty(); });
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].source, "gateway:can0");
  EXPECT_EQ(events[0].axis, "x");
  EXPECT_EQ(events[0].node_id, 5);
  EXPECT_EQ(events[0].code, 0x1D);
}

TEST_F(Fixture, DriveWithoutADriverFailsItsCommandsAndShowsInTheHealth) {
  std::vector<motionlcm::health_t> heartbeats;
  node.subscribe<motionlcm::health_t>(
      lcm::channels::kHealth, [&](const motionlcm::health_t& h, const std::string&) { heartbeats.push_back(h); });
  gateway.set_unsupported({config.find_drive("xd")});
  node.publish(lcm::channels::gateway_command("can0"), command_for("can0", "x"));
  // A heartbeat sent before set_unsupported() says OK: wait for one after it.
  pump_until(
      [&] { return !replies.empty() && !heartbeats.empty() && heartbeats.back().state != motionlcm::health_t::OK; });
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].status, std::int8_t{motionlcm::gateway_reply_t::FAILED});
  EXPECT_NE(replies[0].reason.find("drive xd is a uim342 drive, which this gateway does not drive yet"),
            std::string::npos)
      << replies[0].reason;
  EXPECT_TRUE(driver->commands.empty());
  ASSERT_FALSE(heartbeats.empty());
  EXPECT_EQ(heartbeats.back().state, std::int8_t{motionlcm::health_t::DEGRADED});
  EXPECT_NE(heartbeats.back().detail.find("no driver yet for xd (uim342)"), std::string::npos)
      << heartbeats.back().detail;
}

}  // namespace
}  // namespace motion::gateway

namespace motion::gateway {
namespace {

// LINE_TIMING goes out with each DRIVE_MODEL, for the bus: the driver's start wait, in us.
TEST_F(Fixture, LineTimingIsPublishedWithEachDriveModelFromTheDriversStartWait) {
  std::vector<motionlcm::line_timing_t> lines;
  node.subscribe<motionlcm::line_timing_t>(
      lcm::channels::kLineTiming, [&](const motionlcm::line_timing_t& t, const std::string&) { lines.push_back(t); });
  std::size_t models = 0;
  node.subscribe<motionlcm::drive_model_t>(lcm::channels::kDriveModel,
                                           [&](const motionlcm::drive_model_t&, const std::string&) { ++models; });
  gateway.set_model_builder(
      [](const config::Axis& axis, const DriveFacts&) -> std::variant<motionlcm::drive_model_t, std::string> {
        motionlcm::drive_model_t m{};
        m.axis = axis.name;
        return m;
      });
  driver->wait = std::chrono::microseconds(16'625);
  DriveStatus online;
  online.online = true;
  gateway.axis_status("x", online);
  pump_until([&] { return !lines.empty(); });
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].bus, "can0");
  EXPECT_DOUBLE_EQ(lines[0].start_wait_us, 16'625.0);
  // Again on a DRIVE_MODEL_REQUEST, with what the driver says now.
  driver->wait = std::chrono::microseconds(7'000);
  motionlcm::drive_model_request_t all{};
  node.publish(lcm::channels::kDriveModelRequest, all);
  pump_until([&] { return lines.size() >= 2; });
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_DOUBLE_EQ(lines[1].start_wait_us, 7'000.0);
  EXPECT_EQ(models, lines.size());
}

// DRIVE_MODEL: published before the axis's first online status, again only when what the driver
// read changes it, and for every set-up axis on a DRIVE_MODEL_REQUEST for this bus (or all buses).
// ARM_TIMING goes out with each DRIVE_MODEL of the axis, from the arming builder, dated like it.
TEST_F(Fixture, ArmTimingIsPublishedWithEachDriveModel) {
  std::vector<motionlcm::drive_model_t> models;
  std::vector<motionlcm::arm_timing_t> timings;
  node.subscribe<motionlcm::drive_model_t>(
      lcm::channels::kDriveModel, [&](const motionlcm::drive_model_t& m, const std::string&) { models.push_back(m); });
  node.subscribe<motionlcm::arm_timing_t>(
      lcm::channels::kArmTiming, [&](const motionlcm::arm_timing_t& t, const std::string&) { timings.push_back(t); });
  gateway.set_model_builder(
      [](const config::Axis& axis, const DriveFacts&) -> std::variant<motionlcm::drive_model_t, std::string> {
        motionlcm::drive_model_t m{};
        m.axis = axis.name;
        return m;
      });
  gateway.set_arming_builder([](const config::Axis& axis) -> std::variant<motionlcm::arm_timing_t, std::string> {
    motionlcm::arm_timing_t t{};
    t.axis = axis.name;
    t.arm_line_us = 1234.5;
    t.arm_bystander_us = 67.0;
    return t;
  });
  DriveStatus online;
  online.online = true;
  gateway.axis_status("x", online);
  motionlcm::drive_model_request_t all{};
  node.publish(lcm::channels::kDriveModelRequest, all);
  pump_until([&] { return timings.size() >= 2 && models.size() >= 2; });
  ASSERT_EQ(timings.size(), 2u);
  EXPECT_EQ(timings[0].axis, "x");
  EXPECT_DOUBLE_EQ(timings[0].arm_line_us, 1234.5);
  EXPECT_DOUBLE_EQ(timings[0].arm_bystander_us, 67.0);
  EXPECT_EQ(timings[0].utime, models[0].utime);
}

TEST_F(Fixture, DriveModelIsPublishedWhenSetUpOnChangeAndOnRequest) {
  std::vector<std::string> order;  // "model:<cpr>" / "state"
  std::vector<motionlcm::drive_model_t> models;
  node.subscribe<motionlcm::drive_model_t>(lcm::channels::kDriveModel,
                                           [&](const motionlcm::drive_model_t& m, const std::string&) {
                                             models.push_back(m);
                                             order.push_back("model:" + std::to_string(m.counts_per_revolution));
                                           });
  node.subscribe<motionlcm::axis_state_t>(
      lcm::channels::kAxisState, [&](const motionlcm::axis_state_t&, const std::string&) { order.push_back("state"); });
  gateway.set_model_builder(
      [](const config::Axis& axis, const DriveFacts& facts) -> std::variant<motionlcm::drive_model_t, std::string> {
        motionlcm::drive_model_t m{};
        m.axis = axis.name;
        m.counts_per_revolution = static_cast<std::int32_t>(facts.counts_per_revolution.value_or(10000));
        return m;
      });
  DriveStatus offline;
  gateway.axis_status("x", offline);  // not set up yet: no model
  DriveStatus online;
  online.online = true;
  gateway.axis_status("x", online);
  gateway.axis_status("x", online);
  pump_until([&] { return order.size() >= 4; });
  ASSERT_EQ(models.size(), 1u);
  EXPECT_EQ((std::vector<std::string>{"state", "model:10000", "state", "state"}), order);
  EXPECT_EQ(models[0].axis, "x");
  EXPECT_GT(models[0].utime, 0);

  gateway.drive_facts("x", {3200u, std::nullopt, {}});  // read back: changed
  gateway.drive_facts("x", {3200u, std::nullopt, {}});  // same again: nothing new
  pump_until([&] { return models.size() >= 2; });
  motionlcm::drive_model_request_t other{};
  other.bus = "can1";
  node.publish(lcm::channels::kDriveModelRequest, other);
  motionlcm::drive_model_request_t all{};
  node.publish(lcm::channels::kDriveModelRequest, all);
  pump_until([&] { return models.size() >= 3; });
  loop.run_once(milliseconds(100));
  ASSERT_EQ(models.size(), 3u);
  EXPECT_EQ(models[1].counts_per_revolution, 3200);
  EXPECT_EQ(models[2].counts_per_revolution, 3200);  // the answer to the request for every bus

  // A model that cannot be made is an event, and nothing is published.
  gateway.set_model_builder(
      [](const config::Axis&, const DriveFacts&) -> std::variant<motionlcm::drive_model_t, std::string> {
        return std::string("no resolution");
      });
  gateway.drive_facts("x", {0u, std::nullopt, {}});
  pump_until([&] { return !events.empty(); });
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().text, "no drive model for axis x: no resolution (its moves are refused)");
  EXPECT_EQ(models.size(), 3u);
}

}  // namespace
}  // namespace motion::gateway

namespace motion::gateway {
namespace {

// security.mode enforce: triggers and ACTIVE_MOVES count only when signed by the coordinator's key;
// anything else fires or stops nothing and is a SECURITY event (at most 5 a second).
struct Enforced : Fixture {
  Enforced()
      : Fixture(
            std::string(kConfig) +
            "security: {mode: enforce, authorized_keys: ak, key: c.key, coordinator_public_key: c.pub, gateway_key: "
            "g.key, window_ms: 2000}\n") {
    gateway.set_coordinator_key(coordinator.public_key());
  }
  // A trigger of can0 whose send time is now: it would fire at once.
  static motionlcm::sync_trigger2_t trigger(std::int64_t id) {
    motionlcm::sync_trigger2_t t{};
    t.trigger_id = id;
    t.act_utime = wall_time_us() + 100;
    t.buses = {"can0"};
    t.send_utime = {t.act_utime - 100};
    t.lead_us = {100.0};
    t.num_buses = 1;
    return t;
  }
  // The desired state of a request moving x since before this gateway started: a gateway that
  // takes it stops x (a restarted gateway's duty).
  static motionlcm::active_moves_t moving_x() {
    motionlcm::active_moves_t m{};
    m.axes = {"x"};
    m.buses = {"can0"};
    m.client_ids = {"op/ctl"};
    m.request_ids = {41};
    m.kinds = {motionlcm::request_t::MOVE_ABSOLUTE};
    m.phases = {motionlcm::active_moves_t::MOVING};
    m.command_ids = {12};
    m.target_counts = {500};
    m.targets = {5.0};
    m.fire_utime = {wall_time_us() - 10'000'000};
    m.num_axes = 1;
    return m;
  }
  template <typename Msg>
  void publish_signed(security::MessageSigner& by, std::string_view channel, const Msg& msg) {
    node.publish(security::signed_channel(channel), by.sign(channel, msg, wall_time_us()));
  }
  // Pumps until a SECURITY event containing `text` (or 3 s).
  bool refused(const std::string& text) {
    const auto said = [&] {
      return std::any_of(events.begin(), events.end(), [&](const motionlcm::event_t& e) {
        return e.kind == motionlcm::event_t::SECURITY && e.text.find(text) != std::string::npos;
      });
    };
    pump_until(said);
    return said();
  }
  void pump_for(milliseconds d) {
    const auto until = loop.now() + d;
    pump_until([&] { return loop.now() >= until; });
  }

  security::KeyPair coordinator = security::KeyPair::generate("coordinator");
  security::MessageSigner signer{coordinator, "GT_"};
};

TEST_F(Enforced, UnsignedOrWronglySignedTriggersFireNothingAndOnlyTheCoordinatorsDoes) {
  node.publish(lcm::channels::kSyncTrigger2, trigger(1));
  EXPECT_TRUE(refused("unsigned SYNC_TRIGGER2 (trigger 1) refused: security is enforced"));
  motionlcm::sync_trigger_t old{};
  old.trigger_id = 2;
  old.fire_utime = wall_time_us();
  old.buses = {"can0"};
  old.num_buses = 1;
  node.publish(lcm::channels::kSyncTrigger, old);
  EXPECT_TRUE(refused("unsigned SYNC_TRIGGER (trigger 2) refused"));
  security::MessageSigner impostor(security::KeyPair::generate("coordinator"), "GT_");
  publish_signed(impostor, lcm::channels::kSyncTrigger2, trigger(3));
  EXPECT_TRUE(refused("signed SYNC_TRIGGER2 refused: key " + security::to_hex(impostor.key().id()) +
                      " is not the coordinator's"));
  auto altered = signer.sign(lcm::channels::kSyncTrigger2, trigger(4), wall_time_us());
  altered.message.back() ^= 1;
  node.publish(security::signed_channel(lcm::channels::kSyncTrigger2), altered);
  EXPECT_TRUE(refused("signed SYNC_TRIGGER2 refused: bad signature"));
  pump_for(milliseconds(50));
  EXPECT_TRUE(driver->fired.empty());
  // The coordinator's own fires (and so would the others have, had they been taken).
  publish_signed(signer, lcm::channels::kSyncTrigger2, trigger(5));
  publish_signed(signer, lcm::channels::kSyncTrigger, old);
  pump_until([&] { return driver->fired.size() >= 2; });
  ASSERT_EQ(driver->fired.size(), 2u);
  EXPECT_EQ(driver->fired[0].first, 5);
  EXPECT_EQ(driver->fired[1].first, 2);
}

TEST_F(Enforced, ReplayedTriggerFiresNothing) {
  // Two triggers the coordinator signed; an eavesdropper holds back the first and sends it after
  // the second was taken: its counter is not above the last accepted.
  const auto first = signer.sign(lcm::channels::kSyncTrigger2, trigger(7), wall_time_us());
  publish_signed(signer, lcm::channels::kSyncTrigger2, trigger(8));
  pump_until([&] { return !driver->fired.empty(); });
  ASSERT_EQ(driver->fired.size(), 1u);
  node.publish(security::signed_channel(lcm::channels::kSyncTrigger2), first);
  EXPECT_TRUE(refused("signed SYNC_TRIGGER2 refused: replayed counter " + std::to_string(first.counter)));
  pump_for(milliseconds(50));
  EXPECT_EQ(driver->fired.size(), 1u);
}

TEST_F(Enforced, UnsignedActiveMovesStopNothingAndTheCoordinatorsDo) {
  node.publish(lcm::channels::kActiveMoves, moving_x());
  EXPECT_TRUE(refused("unsigned ACTIVE_MOVES (1 rows) refused"));
  security::MessageSigner impostor(security::KeyPair::generate("coordinator"), "GT_");
  publish_signed(impostor, lcm::channels::kActiveMoves, moving_x());
  EXPECT_TRUE(refused("signed ACTIVE_MOVES refused: key"));
  pump_for(milliseconds(50));
  EXPECT_TRUE(driver->commands.empty());
  publish_signed(signer, lcm::channels::kActiveMoves, moving_x());
  pump_until([&] { return !driver->commands.empty(); });
  ASSERT_EQ(driver->commands.size(), 1u);
  EXPECT_EQ(driver->commands[0].kind, std::int8_t{motionlcm::gateway_command_t::STOP});
}

TEST_F(Enforced, AFloodOfForgedTriggersIsFiveEventsASecond) {
  for (int i = 0; i < 40; ++i) node.publish(lcm::channels::kSyncTrigger2, trigger(100 + i));
  pump_for(milliseconds(300));
  const auto security_events =
      std::count_if(events.begin(), events.end(), [](const auto& e) { return e.kind == motionlcm::event_t::SECURITY; });
  EXPECT_EQ(security_events, 5);
  EXPECT_TRUE(driver->fired.empty());
}

// With a gateway key (security.gateway_key) under enforce, the replies go out signed only and the
// axis states and heartbeats signed and plain (for observers); the coordinator verifies them with the key's
// public half (role gateway in authorized_keys).
TEST_F(Enforced, RepliesGoOutSignedOnlyAndStatesSignedAndPlain) {
  const auto key = security::KeyPair::generate("gateway");
  gateway.set_gateway_key(key);
  security::MessageVerifier replies_in({key.public_key()}, "the gateway's", "GT_",
                                       std::string(lcm::channels::kGatewayReply), milliseconds(2000),
                                       wall_time_us() - 1000);
  security::MessageVerifier states_in({key.public_key()}, "the gateway's", "GT_",
                                      std::string(lcm::channels::kAxisState), milliseconds(2000),
                                      wall_time_us() - 1000);
  security::MessageVerifier heartbeats_in({key.public_key()}, "the gateway's", "GT_",
                                          std::string(lcm::channels::kHealth), milliseconds(2000),
                                          wall_time_us() - 1000);
  std::vector<motionlcm::gateway_reply_t> signed_replies;
  std::vector<motionlcm::axis_state_t> signed_states;
  std::vector<motionlcm::health_t> signed_heartbeats;
  node.subscribe<motionlcm::signed_message_t>(security::signed_channel(lcm::channels::kHealth),
                                              [&](const motionlcm::signed_message_t& e, const std::string&) {
                                                auto v = heartbeats_in.verify<motionlcm::health_t>(e, wall_time_us());
                                                ASSERT_TRUE(v.message) << v.reason;
                                                signed_heartbeats.push_back(*v.message);
                                              });
  node.subscribe<motionlcm::signed_message_t>(security::signed_channel(lcm::channels::kGatewayReply),
                                              [&](const motionlcm::signed_message_t& e, const std::string&) {
                                                auto v =
                                                    replies_in.verify<motionlcm::gateway_reply_t>(e, wall_time_us());
                                                ASSERT_TRUE(v.message) << v.reason;
                                                signed_replies.push_back(*v.message);
                                              });
  node.subscribe<motionlcm::signed_message_t>(security::signed_channel(lcm::channels::kAxisState),
                                              [&](const motionlcm::signed_message_t& e, const std::string&) {
                                                auto v = states_in.verify<motionlcm::axis_state_t>(e, wall_time_us());
                                                ASSERT_TRUE(v.message) << v.reason;
                                                signed_states.push_back(*v.message);
                                              });
  motionlcm::gateway_reply_t reply{};
  reply.command_id = 31;
  reply.status = motionlcm::gateway_reply_t::DONE;
  gateway.command_reply(reply);
  DriveStatus status;
  status.online = true;
  status.position_counts = -250;
  gateway.axis_status("x", status);
  pump_until([&] { return !signed_replies.empty() && !signed_states.empty() && !states.empty(); });
  pump_for(milliseconds(50));
  ASSERT_EQ(signed_replies.size(), 1u);
  EXPECT_EQ(signed_replies[0].command_id, 31);
  EXPECT_EQ(signed_replies[0].bus, "can0");
  EXPECT_TRUE(replies.empty()) << "a plain GW_REPLY under enforce";
  ASSERT_EQ(signed_states.size(), 1u);
  EXPECT_DOUBLE_EQ(signed_states[0].position, 2.5);  // inverted, 100 counts a unit
  ASSERT_EQ(states.size(), 1u);
  EXPECT_DOUBLE_EQ(states[0].position, 2.5);
  // Heartbeats signed too (the coordinator under enforce takes a gateway's liveness only from
  // these), the plain ones going on for observers.
  health.publish_now();
  pump_until([&] { return !signed_heartbeats.empty(); });
  ASSERT_FALSE(signed_heartbeats.empty());
  EXPECT_EQ(signed_heartbeats.back().process, "gateway:can0");
  EXPECT_EQ(signed_heartbeats.back().role, "gateway");
}

}  // namespace
}  // namespace motion::gateway
