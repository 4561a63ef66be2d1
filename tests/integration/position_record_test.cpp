// A drive that lost power while no gateway ran (README "Safety and faults"): each gateway keeps a
// position record of its axes (where they were, homed or not) and compares each drive's first
// answer after it starts with it. On tests/integration/configs/position-record.yaml: a UIM342 (z)
// and a UC57 (a) on one simulated CAN bus, an ADAM (c) on an RS485 line, a UIM242 (u) on an RS232
// line. The gateways are stopped (SIGTERM), the simulated drives power-cycled (SIM_CONTROL) or
// not, and the gateways started again; the simulated z, a and c come back at their power-on
// position 0 with nothing said; the UIM242 keeps its position counter (UIM242 manual §7.6).
// No timed assertions: every wait is bounded generously.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using Axes = std::vector<std::string>;
const Axes kAxes{"z", "a", "c", "u"};
const Axes kLosing{"z", "a", "c"};  // their drives lose the position with the power
const std::vector<std::string> kBuses{"can0", "rs485", "rs232"};

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class PositionRecord : public ::testing::Test {
 protected:
  PositionRecord() : lab(source_path("tests/integration/configs/position-record.yaml")) {}

  void SetUp() override {
    lab.client().on_event([this](const event_t& e) { events.push_back(e); });
    ASSERT_TRUE(lab.start(kAxes));
    ASSERT_TRUE(lab.enable(kAxes));
    // First start ever (no record): nothing is lost.
    for (const auto& axis : kAxes) EXPECT_NE(lab.state(axis).fault_code, motionlcm::axis_state_t::POSITION_LOST);
    // Homed where they stand (z, c: current position) or on the origin switch (a, UC57 homing
    // mode); then z and c away from 0. a stays at its origin 0, where its power-on counter reads the
    // same: only the drive's own homed flag tells a power cycle there.
    for (const auto& axis : kAxes) {
      const auto home = lab.call(Client::make(request_t::HOME, Axes{axis}), nullptr, seconds(60));
      ASSERT_EQ(home.status, st(reply_t::DONE)) << axis << ": " << home.reason;
      ASSERT_TRUE(
          lab.client().wait_until([&] { return lab.state(axis).homed && !lab.state(axis).moving; }, seconds(10)))
          << axis;
    }
    const auto moved = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"z", 12.0}, {"c", 20.0}, {"u", 15.0}}));
    ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
    ASSERT_TRUE(lab.settled_at("z", 12.0, tolerance("z")));
    ASSERT_TRUE(lab.settled_at("c", 20.0, tolerance("c")));
    ASSERT_TRUE(lab.settled_at("u", 15.0, tolerance("u")));
    ASSERT_TRUE(lab.settled_at("a", 0.0, tolerance("a")));
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }

  double tolerance(const std::string& axis) { return 1.5 / lab.config().find_axis(axis)->steps_per_unit; }

  // Stops every gateway (SIGTERM), runs `meanwhile`, starts them again and waits until every axis
  // has said something since (the client keeps the last state of the old process until then).
  ::testing::AssertionResult restart_gateways(const std::function<void()>& meanwhile) {
    for (const auto& bus : kBuses) {
      const auto health = lab.group().heartbeat("gateway:" + bus);
      if (!health) return ::testing::AssertionFailure() << "no heartbeat of gateway:" << bus;
      lab.group().stop(static_cast<pid_t>(health->pid));
    }
    meanwhile();
    lab.pause(milliseconds(300));  // the simulated drives are back up
    const std::int64_t since = wall_time_us();
    first_event = events.size();
    for (const auto& bus : kBuses) lab.start_gateway(bus);
    for (const auto& bus : kBuses) {
      if (!lab.group().wait_for_heartbeat("gateway:" + bus, seconds(20)))
        return ::testing::AssertionFailure() << "gateway:" << bus << " not OK after its restart";
    }
    const bool fresh = lab.client().wait_until(
        [&] {
          return std::all_of(kAxes.begin(), kAxes.end(), [&](const std::string& axis) {
            return lab.state(axis).utime > since && lab.state(axis).online;
          });
        },
        seconds(20));
    if (!fresh) return ::testing::AssertionFailure() << "not every axis online after the gateways' restart";
    lab.pause(milliseconds(300));  // a few status polls
    return ::testing::AssertionSuccess();
  }
  const event_t* lost_event(const std::string& axis) const {
    const auto it =
        std::find_if(events.begin() + static_cast<std::ptrdiff_t>(first_event), events.end(), [&](const event_t& e) {
          return e.axis == axis && e.kind == ev(event_t::REBOOT) && contains(e.text, "position lost / not homed");
        });
    return it == events.end() ? nullptr : &*it;
  }

  SimLab lab;
  std::vector<event_t> events;
  std::size_t first_event = 0;
};

TEST_F(PositionRecord, AGatewayRestartedWithoutAPowerCycleKeepsHomedAndValidPositions) {
  // a away from 0 too: its first position after the restart is compared with the record.
  const auto away = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 90.0}}));
  ASSERT_EQ(away.status, st(reply_t::DONE)) << away.reason;
  ASSERT_TRUE(lab.settled_at("a", 90.0, tolerance("a")));
  ASSERT_TRUE(restart_gateways([] {}));
  for (const auto& axis : kAxes) {
    EXPECT_TRUE(lab.state(axis).homed) << axis;
    EXPECT_NE(lab.state(axis).fault_code, motionlcm::axis_state_t::POSITION_LOST)
        << axis << ": " << lab.state(axis).fault_text;
    EXPECT_EQ(lost_event(axis), nullptr) << axis;
  }
  EXPECT_NEAR(lab.position("z"), 12.0, tolerance("z"));
  EXPECT_NEAR(lab.position("c"), 20.0, tolerance("c"));
  EXPECT_NEAR(lab.position("a"), 90.0, tolerance("a"));
  EXPECT_NEAR(lab.position("u"), 15.0, tolerance("u"));
  ASSERT_TRUE(lab.enable(kAxes));
  const Values targets{{"z", 5.0}, {"a", 30.0}, {"c", 10.0}, {"u", 5.0}};
  const auto moved = lab.call(Client::make(request_t::MOVE_ABSOLUTE, targets));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  for (const auto& [axis, target] : targets)
    EXPECT_TRUE(lab.settled_at(axis, target, tolerance(axis))) << axis << " at " << lab.position(axis);
}

TEST_F(PositionRecord, DrivesPowerCycledWhileNoGatewayRanSayPositionLostUntilHomedOrSet) {
  ASSERT_TRUE(restart_gateways([&] {
    for (const auto& axis : kAxes) lab.control(axis + "-drive", sim_control_t::POWER_CYCLE);
  }));
  // The UIM242 kept its counter (UIM242 manual §7.6): where it was, still homed.
  EXPECT_NE(lab.state("u").fault_code, motionlcm::axis_state_t::POSITION_LOST) << lab.state("u").fault_text;
  EXPECT_TRUE(lab.state("u").homed);
  EXPECT_NEAR(lab.position("u"), 15.0, tolerance("u"));
  EXPECT_EQ(lost_event("u"), nullptr);
  // Said in the state and by a REBOOT event, as a power cycle seen by a running gateway is.
  for (const auto& axis : kLosing) {
    const auto& s = lab.state(axis);
    EXPECT_EQ(s.fault_code, motionlcm::axis_state_t::POSITION_LOST) << axis << ": " << s.fault_text;
    EXPECT_FALSE(s.homed) << axis;
    EXPECT_FALSE(s.fault) << axis;
    EXPECT_TRUE(contains(s.fault_text, "position lost")) << axis << ": " << s.fault_text;
    EXPECT_TRUE(contains(s.fault_text, "while no gateway ran")) << axis << ": " << s.fault_text;
    EXPECT_NE(lost_event(axis), nullptr) << axis;
  }
  // z and c by their position (0, recorded far from it), a (at 0) by its cleared homed flag.
  EXPECT_TRUE(contains(lab.state("z").fault_text, "recorded at rest")) << lab.state("z").fault_text;
  EXPECT_TRUE(contains(lab.state("c").fault_text, "recorded at rest")) << lab.state("c").fault_text;
  EXPECT_TRUE(contains(lab.state("a").fault_text, "no longer reports homed")) << lab.state("a").fault_text;

  // Absolute moves are refused naming the lost position; nothing starts.
  ASSERT_TRUE(lab.enable(kAxes));
  lab.clear_reports();
  for (const auto& axis : kLosing) {
    const auto refused = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{axis, 5.0}}));
    EXPECT_EQ(refused.status, st(reply_t::REJECTED)) << axis << ": " << refused.reason;
    EXPECT_EQ(refused.error_code, code(ReplyError::kPositionLost)) << axis << ": " << refused.reason;
    EXPECT_TRUE(contains(refused.reason, "axis " + axis + " lost its position")) << refused.reason;
    EXPECT_TRUE(lab.starts_of(axis + "-drive").empty()) << axis;
  }

  // A lost position stays lost over a further restart (it is in the record too).
  ASSERT_TRUE(restart_gateways([] {}));
  for (const auto& axis : kLosing) {
    EXPECT_EQ(lab.state(axis).fault_code, motionlcm::axis_state_t::POSITION_LOST) << axis;
    EXPECT_FALSE(lab.state(axis).homed) << axis;
  }

  // Homed (z, a) or its position set (c): valid again, and they move.
  ASSERT_TRUE(lab.enable(kAxes));
  for (const auto& axis : Axes{"z", "a"}) {
    const auto home = lab.call(Client::make(request_t::HOME, Axes{axis}), nullptr, seconds(60));
    ASSERT_EQ(home.status, st(reply_t::DONE)) << axis << ": " << home.reason;
  }
  const auto set = lab.call(Client::make(request_t::SET_POSITION, Values{{"c", 0.0}}));
  ASSERT_EQ(set.status, st(reply_t::DONE)) << set.reason;
  for (const auto& axis : kAxes) {
    EXPECT_TRUE(lab.client().wait_until(
        [&] { return lab.state(axis).fault_code != motionlcm::axis_state_t::POSITION_LOST; }, seconds(5)))
        << axis;
  }
  EXPECT_TRUE(lab.state("z").homed);
  EXPECT_TRUE(lab.state("a").homed);
  const Values targets{{"z", 5.0}, {"a", 30.0}, {"c", 10.0}, {"u", 5.0}};
  const auto moved = lab.call(Client::make(request_t::MOVE_ABSOLUTE, targets));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  for (const auto& [axis, target] : targets)
    EXPECT_TRUE(lab.settled_at(axis, target, tolerance(axis))) << axis << " at " << lab.position(axis);
}

}  // namespace
}  // namespace motion::testing
