// A drive power-cycled at rest while its gateway runs (README "Safety and faults"), on
// tests/integration/configs/position-record.yaml: a UIM342 (z) on a simulated CAN bus and an ADAM
// (c) on an RS485 line, each homed where it stands, so that its counter reads 0 at rest, the same
// as after a power-up. Neither drive says anything when it powers up; what tells is its power-on
// marker (UIM342: MT[3] written to RAM; ADAM: position reminder X19 written and not saved), lost
// with the power. Each axis is then reported "position lost / not homed" once, with that reason,
// and a move is refused until its position is set. No timed assertions: every wait is bounded
// generously.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using Axes = std::vector<std::string>;
const Axes kAxes{"z", "c"};

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class PowerAtRest : public ::testing::Test {
 protected:
  PowerAtRest() : lab(source_path("tests/integration/configs/position-record.yaml")) {}

  void SetUp() override {
    lab.client().on_event([this](const event_t& e) { events.push_back(e); });
    ASSERT_TRUE(lab.start(kAxes));
    ASSERT_TRUE(lab.enable(kAxes));
    for (const auto& axis : kAxes) {
      const auto home = lab.call(Client::make(request_t::HOME, Axes{axis}), nullptr, seconds(60));
      ASSERT_EQ(home.status, st(reply_t::DONE)) << axis << ": " << home.reason;
      ASSERT_TRUE(
          lab.client().wait_until([&] { return lab.state(axis).homed && !lab.state(axis).moving; }, seconds(10)))
          << axis;
    }
    lab.pause(milliseconds(1500));  // polls at rest: the markers are written
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }

  [[nodiscard]] long lost_events(const std::string& axis) const {
    return std::count_if(events.begin(), events.end(), [&](const event_t& e) {
      return e.axis == axis && e.kind == ev(event_t::REBOOT) && contains(e.text, "position lost / not homed");
    });
  }

  SimLab lab;
  std::vector<event_t> events;
};

TEST_F(PowerAtRest, APowerCycledDriveAtItsOriginSaysPositionLostOnceByItsMarkerUntilItsPositionIsSet) {
  for (const auto& axis : kAxes) {
    EXPECT_EQ(lost_events(axis), 0) << axis;
    lab.control(axis + "-drive", sim_control_t::POWER_CYCLE);
  }
  for (const auto& axis : kAxes) {
    ASSERT_TRUE(lab.client().wait_until(
        [&] { return lab.state(axis).fault_code == motionlcm::axis_state_t::POSITION_LOST; }, seconds(15)))
        << axis << ": " << lab.state(axis).fault_text;
    EXPECT_FALSE(lab.state(axis).homed) << axis;
    EXPECT_TRUE(contains(lab.state(axis).fault_text, "powered up, detected by its power-on marker"))
        << axis << ": " << lab.state(axis).fault_text;
    ASSERT_TRUE(lab.client().wait_until([&] { return lab.state(axis).online; }, seconds(15))) << axis;
  }
  lab.pause(milliseconds(2000));   // set up again and polled: said once
  ASSERT_TRUE(lab.enable(kAxes));  // a power-up turns a UIM342's driver off (§5.2 IC[0] unset)
  for (const auto& axis : kAxes) {
    EXPECT_EQ(lost_events(axis), 1) << axis;
    const auto refused = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{axis, 1.0}}));
    EXPECT_EQ(refused.status, st(reply_t::REJECTED)) << axis << ": " << refused.reason;
    EXPECT_EQ(refused.error_code, code(ReplyError::kPositionLost)) << axis << ": " << refused.reason;
  }
  // Its position set, a move is DONE.
  for (const auto& axis : kAxes) {
    const auto set = lab.call(Client::make(request_t::SET_POSITION, Values{{axis, 0.0}}));
    ASSERT_EQ(set.status, st(reply_t::DONE)) << axis << ": " << set.reason;
  }
  const auto moved = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"z", 2.0}, {"c", 3.0}}));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  for (const auto& axis : kAxes) EXPECT_EQ(lost_events(axis), 1) << axis;
}

}  // namespace
}  // namespace motion::testing
