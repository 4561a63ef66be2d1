// A move armed for a trigger that never comes is released by the gateway itself
// (motion/gateway/arm_watch.hpp, README "Safety and faults"): on a manual clock (ArmWatch), and
// through a Gateway whose driver holds moves armed until a DISARM releases them.
#include "motion/gateway/arm_watch.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <iterator>

#include <motionlcm/event_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>

#include "motion/gateway/gateway.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/testing/lcm_url.hpp"

namespace motion::gateway {
namespace {

using Command = motionlcm::gateway_command_t;
using Reply = motionlcm::gateway_reply_t;
using std::chrono::milliseconds;

Command arm_move(std::int64_t id, std::int64_t trigger, std::vector<std::string> axes) {
  Command c{};
  c.bus = "can0";
  c.command_id = id;
  c.kind = Command::ARM_MOVE;
  c.trigger_id = trigger;
  for (auto& name : axes) {
    motionlcm::axis_command_t a{};
    a.axis = std::move(name);
    a.target_counts = 100;
    a.velocity = 50;
    c.axes.push_back(a);
  }
  c.num_axes = static_cast<std::int32_t>(c.axes.size());
  return c;
}

Reply reply(std::int64_t id, std::int8_t status, std::string reason = {}) {
  Reply r{};
  r.command_id = id;
  r.status = status;
  r.reason = std::move(reason);
  return r;
}

TEST(ArmWatch, AnArmedMoveNeverTriggeredIsReleasedOnceWithItsReasonAndItsLateTriggerDoesNothing) {
  ManualClock clock;
  ArmWatch watch(milliseconds(4000));
  watch.on_command(arm_move(12, 5, {"x", "y"}), clock.now());
  auto armed = reply(12, Reply::ARMED);
  watch.on_reply(armed);
  EXPECT_EQ(watch.next_deadline(), clock.now() + milliseconds(4000));
  clock.advance(milliseconds(3999));
  EXPECT_TRUE(watch.due(clock.now()).empty());
  clock.advance(milliseconds(1));
  const auto due = watch.due(clock.now());
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].command_id, 12);
  EXPECT_EQ(due[0].trigger_id, 5);
  EXPECT_EQ(due[0].axes, (std::vector<std::string>{"x", "y"}));
  EXPECT_TRUE(watch.due(clock.now() + milliseconds(10000)).empty()) << "released twice";
  EXPECT_EQ(watch.next_deadline(), kNever);
  // The driver's FAILED (its answer to the gateway's DISARM) says why, with code 13; one only.
  auto failed = reply(12, Reply::FAILED, "move disarmed by command -1");
  watch.on_reply(failed);
  EXPECT_EQ(failed.error_code, error_code(ReplyError::kTimeout));
  EXPECT_NE(failed.reason.find("axis x, y"), std::string::npos) << failed.reason;
  EXPECT_NE(failed.reason.find("never triggered within 4000 ms"), std::string::npos) << failed.reason;
  EXPECT_FALSE(watch.on_trigger(5)) << "a trigger of a released move must fire nothing";
  EXPECT_TRUE(watch.on_trigger(6)) << "another trigger is not this watch's business";
  EXPECT_EQ(watch.released_count(), 1);
}

TEST(ArmWatch, AMoveTriggeredBeforeItsDeadlineIsLeftAlone) {
  ManualClock clock;
  ArmWatch watch(milliseconds(4000));
  watch.on_command(arm_move(12, 5, {"x"}), clock.now());
  auto armed = reply(12, Reply::ARMED);
  watch.on_reply(armed);
  clock.advance(milliseconds(3999));
  EXPECT_TRUE(watch.on_trigger(5));
  EXPECT_EQ(watch.watched(), 0u);
  EXPECT_TRUE(watch.due(clock.now() + milliseconds(60000)).empty());
  auto done = reply(12, Reply::FAILED, "stalled");
  watch.on_reply(done);
  EXPECT_EQ(done.reason, "stalled");  // its own outcome, untouched
  EXPECT_EQ(done.error_code, 0);
}

TEST(ArmWatch, AMoveStillLoadingAtItsDeadlineIsReleasedWhenItReportsArmed) {
  ManualClock clock;
  ArmWatch watch(milliseconds(4000));
  watch.on_command(arm_move(12, 5, {"x"}), clock.now());
  clock.advance(milliseconds(5000));
  EXPECT_TRUE(watch.due(clock.now()).empty()) << "nothing armed yet to release";
  EXPECT_EQ(watch.next_deadline(), kNever);
  auto armed = reply(12, Reply::ARMED);
  watch.on_reply(armed);
  EXPECT_LE(watch.next_deadline(), clock.now());
  EXPECT_EQ(watch.due(clock.now()).size(), 1u);
}

TEST(ArmWatch, MovesThatEndOrStartAtOnceAreNotWatched) {
  ManualClock clock;
  ArmWatch watch(milliseconds(4000));
  watch.on_command(arm_move(1, 0, {"x"}), clock.now());  // trigger 0: starts at once
  watch.on_command(arm_move(2, 7, {"y"}), clock.now());
  auto armed = reply(2, Reply::ARMED);
  watch.on_reply(armed);
  auto disarmed = reply(2, Reply::FAILED, "disarmed by the coordinator");
  watch.on_reply(disarmed);
  EXPECT_EQ(watch.watched(), 0u);
  EXPECT_TRUE(watch.due(clock.now() + milliseconds(60000)).empty());
  EXPECT_EQ(disarmed.reason, "disarmed by the coordinator");
}

TEST(ArmWatch, AnExpiryThatTheCoordinatorCouldStillTriggerWithinIsRefusedByTheConfiguration) {
  const auto loaded = config::load_string(R"(
buses: [{name: can0, transport: simcan:can0}]
drives: [{name: xd, family: uim342, bus: can0, node_id: 5}]
axes: [{name: x, drive: xd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 1, acceleration: 1}}]
coordinator: {arm_timeout_ms: 2000, trigger_lead_ms: 30, arm_expiry_ms: 2000}
)");
  ASSERT_FALSE(loaded.ok());
  EXPECT_NE(loaded.error_text().find("coordinator.arm_expiry_ms"), std::string::npos) << loaded.error_text();
}

// A driver that holds ARM_MOVEs armed until a DISARM (by trigger and axes) releases them, as the
// family stacks do.
class HoldingDriver : public BusDriver {
 public:
  explicit HoldingDriver(GatewayOutput& out) : out_(out) {}
  void start() override {}
  void execute(const Command& command) override {
    commands.push_back(command);
    if (command.kind == Command::ARM_MOVE) {
      armed.push_back(command);
      out_.command_reply(reply(command.command_id, Reply::ARMED));
    } else if (command.kind == Command::DISARM) {
      std::vector<Command> keep;
      for (const auto& a : armed) {
        if (a.trigger_id == command.trigger_id) {
          out_.command_reply(
              reply(a.command_id, Reply::FAILED, "disarmed by command " + std::to_string(command.command_id)));
        } else {
          keep.push_back(a);
        }
      }
      armed = keep;
      out_.command_reply(reply(command.command_id, Reply::DONE));
    }
  }
  void fire(std::int64_t trigger_id) override { fired.push_back(trigger_id); }
  std::vector<motionlcm::bus_stats_t> statistics() const override { return {}; }
  bool ready() const override { return true; }

  std::vector<Command> commands;
  std::vector<Command> armed;
  std::vector<std::int64_t> fired;

 private:
  GatewayOutput& out_;
};

struct Released : ::testing::Test {
  Released()
      : config(*config::load_string(R"(
buses: [{name: can0, transport: simcan:can0}]
drives: [{name: xd, family: uim342, bus: can0, node_id: 5}]
axes: [{name: x, drive: xd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 1, acceleration: 1}}]
coordinator: {arm_timeout_ms: 100, trigger_lead_ms: 10, arm_expiry_ms: 300}
)")
                    .config),
        node(loop, {testing::unique_lcm_url(12), "AW_"}),
        health(loop, node, "gateway:can0", "gateway"),
        gateway(loop, node, health, config, "can0") {
    auto d = std::make_unique<HoldingDriver>(gateway);
    driver = d.get();
    gateway.attach(std::move(d));
    node.subscribe<Reply>(lcm::channels::kGatewayReply,
                          [this](const Reply& r, const std::string&) { replies.push_back(r); });
    node.subscribe<motionlcm::event_t>(
        lcm::channels::kEvent, [this](const motionlcm::event_t& e, const std::string&) { events.push_back(e); });
  }
  void pump_until(const std::function<bool()>& done, milliseconds limit = milliseconds(3000)) {
    const auto deadline = loop.now() + limit;
    while (!done() && loop.now() < deadline) loop.run_once(milliseconds(5));
  }
  void pump(milliseconds period) {
    pump_until([] { return false; }, period);
  }
  void trigger(std::int64_t id) {
    motionlcm::sync_trigger2_t t{};
    t.trigger_id = id;
    t.act_utime = wall_time_us();
    t.buses = {"can0"};
    t.send_utime = {t.act_utime};
    t.lead_us = {0.0};
    t.num_buses = 1;
    node.publish(lcm::channels::kSyncTrigger2, t);
  }
  std::vector<Reply> replies_to(std::int64_t id) const {
    std::vector<Reply> out;
    std::copy_if(replies.begin(), replies.end(), std::back_inserter(out),
                 [id](const Reply& r) { return r.command_id == id; });
    return out;
  }

  config::Config config;
  EventLoop loop;
  lcm::Node node;
  lcm::HealthPublisher health;
  Gateway gateway;
  HoldingDriver* driver = nullptr;
  std::vector<Reply> replies;
  std::vector<motionlcm::event_t> events;
};

TEST_F(Released, TheGatewayDisarmsAMoveNobodyTriggersRepliesOnceAndIgnoresItsLateTrigger) {
  EXPECT_EQ(gateway.arm_expiry(), milliseconds(300));
  node.publish(lcm::channels::gateway_command("can0"), arm_move(21, 9, {"x"}));
  pump_until([&] { return replies_to(21).size() >= 2; });
  pump(milliseconds(100));  // a second terminal reply would come now
  const auto got = replies_to(21);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].status, std::int8_t{Reply::ARMED});
  EXPECT_EQ(got[1].status, std::int8_t{Reply::FAILED});
  EXPECT_EQ(got[1].error_code, error_code(ReplyError::kTimeout));
  EXPECT_NE(got[1].reason.find("axis x"), std::string::npos) << got[1].reason;
  EXPECT_NE(got[1].reason.find("never triggered within 300 ms"), std::string::npos) << got[1].reason;
  // The release is the driver's own DISARM of that trigger and axis.
  const auto disarm = std::find_if(driver->commands.begin(), driver->commands.end(),
                                   [](const Command& c) { return c.kind == Command::DISARM; });
  ASSERT_NE(disarm, driver->commands.end());
  EXPECT_LT(disarm->command_id, 0);
  EXPECT_EQ(disarm->trigger_id, 9);
  ASSERT_EQ(disarm->axes.size(), 1u);
  EXPECT_EQ(disarm->axes[0].axis, "x");
  EXPECT_TRUE(driver->armed.empty());
  EXPECT_TRUE(std::any_of(events.begin(), events.end(), [](const motionlcm::event_t& e) {
    return e.kind == motionlcm::event_t::TIMEOUT && e.axis == "x" &&
           e.text.find("never triggered") != std::string::npos;
  }));
  trigger(9);
  pump(milliseconds(100));
  EXPECT_TRUE(driver->fired.empty()) << "the late trigger of a released move fired the bus";
}

TEST_F(Released, AMoveTriggeredInTimeIsFiredAndNeverReleased) {
  node.publish(lcm::channels::gateway_command("can0"), arm_move(31, 10, {"x"}));
  pump_until([&] { return !replies_to(31).empty(); });
  trigger(10);
  pump_until([&] { return !driver->fired.empty(); });
  pump(milliseconds(500));  // past its expiry
  EXPECT_EQ(driver->fired, (std::vector<std::int64_t>{10}));
  EXPECT_TRUE(std::none_of(driver->commands.begin(), driver->commands.end(),
                           [](const Command& c) { return c.kind == Command::DISARM; }));
  EXPECT_EQ(replies_to(31).size(), 1u);  // ARMED only: the driver's STARTED is its own business here
}

// What a previous gateway process left moving (its request ended when the coordinator lost it) is
// stopped by the new one when it first hears of the axis; an axis this process moves is not.
TEST_F(Released, AnAxisFoundMovingWhenTheGatewayStartsIsStoppedOnce) {
  DriveStatus moving;
  moving.online = true;
  moving.enabled = true;
  moving.moving = true;
  moving.position_read = true;
  moving.position_counts = 250;
  gateway.axis_status("x", moving);
  gateway.axis_status("x", moving);  // the next poll: stopped once
  const auto stops = std::count_if(driver->commands.begin(), driver->commands.end(), [](const Command& c) {
    return c.kind == Command::STOP && c.command_id < 0 && c.axes.size() == 1 && c.axes[0].axis == "x";
  });
  EXPECT_EQ(stops, 1);
  pump_until([&] { return !events.empty(); });
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, std::int16_t{motionlcm::event_t::GATEWAY_RESTARTED});
  EXPECT_EQ(events[0].axis, "x");
  EXPECT_NE(events[0].text.find("stopping it"), std::string::npos) << events[0].text;
}

}  // namespace
}  // namespace motion::gateway
