// The UC57 (CANopen CiA 301/402) family end to end on a simulated lab of its own
// (tests/integration/configs/uc57-three.yaml: three UC57 nodes 1, 2, 3 on one bit-timed simulated
// CAN bus): client -> coordinator -> motion-gateway (Uc57Stack: SDO, NMT, PDO, SYNC, EMCY,
// heartbeat) -> motion-sim (simulated UC57s), and replies, axis state and events all the way back.
// The simulated drives' own reports (SIM_REPORT) are the ground truth for the start frames; fault
// injection goes through SIM_CONTROL. No timed assertions: every wait is bounded, nothing asserts
// on how long anything took.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <motionlcm/event_t.hpp>
#include <motionlcm/param_t.hpp>

#include "motion/lcm/reply_error.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

const std::vector<std::string> kAxes{"a", "b", "c"};
constexpr double kTolerance = 1.0 / 8.888888888888889 + 1e-9;  // one pulse, in degrees

bool saw(const std::vector<reply_t>& replies, std::int8_t status) {
  return std::any_of(replies.begin(), replies.end(), [&](const reply_t& r) { return r.status == status; });
}
bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// Parameter: the lab's configuration, TPDOs at every SYNC (uc57-three.yaml) or staggered
// (uc57-three-staggered.yaml, tpdo_mode: staggered).
class Uc57Lab : public ::testing::TestWithParam<std::string> {
 protected:
  Uc57Lab() : lab(source_path("tests/integration/configs/" + GetParam() + ".yaml")) {}

  void SetUp() override {
    lab.client().on_event([this](const event_t& e) { events.push_back(e); });
    ASSERT_TRUE(lab.start(kAxes));
    const auto enabled = lab.call(Client::make(request_t::ENABLE, kAxes));
    ASSERT_EQ(enabled.status, st(reply_t::DONE)) << enabled.reason;
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }

  const motionlcm::axis_state_t& state(const std::string& axis) { return lab.client().axes().at(axis); }
  double position(const std::string& axis) { return state(axis).position; }
  bool settled_at(const std::string& axis, double target) {
    return !state(axis).moving && std::abs(position(axis) - target) <= kTolerance;
  }
  std::size_t index_of(const reply_t& r, const std::string& axis) {
    return static_cast<std::size_t>(std::find(r.axes.begin(), r.axes.end(), axis) - r.axes.begin());
  }
  bool saw_event(const std::string& axis, std::int16_t kind) {
    return std::any_of(events.begin(), events.end(),
                       [&](const event_t& e) { return e.axis == axis && e.kind == kind; });
  }
  const event_t* find_event(const std::string& axis, std::int16_t kind) {
    const auto it =
        std::find_if(events.begin(), events.end(), [&](const event_t& e) { return e.axis == axis && e.kind == kind; });
    return it == events.end() ? nullptr : &*it;
  }
  reply_t param(std::int8_t kind, const std::string& axis, std::int32_t index, std::int32_t subindex,
                std::int64_t value = 0) {
    request_t r = Client::make(kind, std::vector<std::string>{axis});
    r.param.space = motionlcm::param_t::CANOPEN_OBJECT;
    r.param.index = index;
    r.param.subindex = subindex;
    r.param.value = value;
    return lab.call(r);
  }

  SimLab lab;
  std::vector<event_t> events;
};

TEST_P(Uc57Lab, ThreeNodesBootConfigureAndEnable) {
  for (const auto& axis : kAxes) {
    EXPECT_TRUE(lab.client().wait_until([&] { return state(axis).online && state(axis).enabled && !state(axis).fault; },
                                        seconds(5)))
        << axis;
    EXPECT_TRUE(saw_event(axis, ev(event_t::ONLINE)) || state(axis).online) << axis;
  }
  // The setup keys reached the drives: 2005h = 20 (2.0 A), 2006h = the code of 3200 pulses/rev.
  const auto current = param(request_t::PARAM_READ, "c", 0x2005, 0);
  ASSERT_EQ(current.status, st(reply_t::DONE)) << current.reason;
  EXPECT_EQ(current.param.value, 20);
  // The SDO path answers every node (1000h: a CiA 402 device).
  for (const auto& axis : kAxes) {
    const auto type = param(request_t::PARAM_READ, axis, 0x1000, 0);
    ASSERT_EQ(type.status, st(reply_t::DONE)) << axis << ": " << type.reason;
    EXPECT_EQ(type.param.value & 0xFFFF, 402) << axis;
  }
}

TEST_P(Uc57Lab, AbsoluteAndRelativeProfilePositionMoves) {
  std::vector<reply_t> replies;
  const auto absolute = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 90.0}}), &replies);
  ASSERT_EQ(absolute.status, st(reply_t::DONE)) << absolute.reason;
  EXPECT_TRUE(saw(replies, reply_t::ACCEPTED));
  EXPECT_TRUE(saw(replies, reply_t::STARTED));
  ASSERT_EQ(absolute.num_axes, 1);
  EXPECT_NEAR(absolute.positions[0], 90.0, kTolerance);
  ASSERT_EQ(lab.starts_of("a-drive").size(), 1u);
  EXPECT_EQ(lab.starts_of("a-drive")[0].target_counts, 800);  // 90 degrees x 3200/360
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("a", 90.0); }, seconds(5))) << position("a");

  const auto relative = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"a", -30.0}, {"b", 45.0}}));
  ASSERT_EQ(relative.status, st(reply_t::DONE)) << relative.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("a", 60.0) && settled_at("b", 45.0); }, seconds(5)))
      << position("a") << " " << position("b");
  // c was not part of either move.
  EXPECT_TRUE(lab.starts_of("c-drive").empty());
  EXPECT_NEAR(position("c"), 0.0, kTolerance);
}

TEST_P(Uc57Lab, JogRunsInProfileVelocityUntilStopped) {
  const auto jog = lab.call(Client::make(request_t::JOG, Values{{"b", 90.0}}));
  ASSERT_EQ(jog.status, st(reply_t::DONE)) << jog.reason;
  // Running forward: the position grows while jogging.
  ASSERT_TRUE(lab.client().wait_until([&] { return state("b").moving && position("b") > 10.0; }, seconds(10)))
      << position("b");
  const double before = position("b");
  ASSERT_TRUE(lab.client().wait_until([&] { return position("b") > before + 5.0; }, seconds(10))) << position("b");

  const auto stop = lab.call(Client::make(request_t::STOP, std::vector<std::string>{"b"}));
  ASSERT_EQ(stop.status, st(reply_t::DONE)) << stop.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !state("b").moving; }, seconds(10)));
  // Standing still: two samples a few SYNC cycles apart agree.
  const double stopped = position("b");
  lab.client().wait_until([] { return false; }, std::chrono::milliseconds(300));
  EXPECT_NEAR(position("b"), stopped, kTolerance);
  EXPECT_GT(stopped, 10.0);

  // The axis takes position moves again after the jog (mode switched back to profile position).
  const auto back = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"b", 0.0}}));
  ASSERT_EQ(back.status, st(reply_t::DONE)) << back.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("b", 0.0); }, seconds(5))) << position("b");
}

TEST_P(Uc57Lab, HomingFindsTheOriginSwitch) {
  // Start away from zero so that the homed position (0 at the switch, offset 0) means something.
  const auto away = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", -45.0}}));
  ASSERT_EQ(away.status, st(reply_t::DONE)) << away.reason;
  ASSERT_FALSE(state("a").homed);

  const auto home = lab.call(Client::make(request_t::HOME, std::vector<std::string>{"a"}), nullptr, seconds(60));
  ASSERT_EQ(home.status, st(reply_t::DONE)) << home.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return state("a").homed && !state("a").moving; }, seconds(5)));
  // The switch (IN2, origin) is at +2000 pulses from the power-up position; homing makes it 0.
  EXPECT_NEAR(position("a"), 0.0, 2 * kTolerance);
  // The other axes did not move.
  EXPECT_NEAR(position("b"), 0.0, kTolerance);

  // And the homed axis moves in its new frame.
  const auto move = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 30.0}}));
  ASSERT_EQ(move.status, st(reply_t::DONE)) << move.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("a", 30.0); }, seconds(5))) << position("a");
}

TEST_P(Uc57Lab, ThreeAxesStartOnOneSyncAndArrive) {
  const Values targets{{"a", 180.0}, {"b", -120.0}, {"c", 270.0}};
  std::vector<reply_t> replies;
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, targets), &replies);
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  EXPECT_TRUE(saw(replies, reply_t::STARTED));

  // Ground truth: one start per drive, all on the same SYNC frame (equal end-of-frame times).
  const auto a = lab.starts_of("a-drive");
  const auto b = lab.starts_of("b-drive");
  const auto c = lab.starts_of("c-drive");
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_NE(a[0].frame_utime, 0);
  EXPECT_EQ(a[0].frame_utime, b[0].frame_utime) << "a and b did not start on the same SYNC";
  EXPECT_EQ(a[0].frame_utime, c[0].frame_utime) << "a and c did not start on the same SYNC";
  EXPECT_EQ(a[0].target_counts, 1600);
  EXPECT_NEAR(static_cast<double>(b[0].target_counts), -1066.67, 1.0);
  EXPECT_EQ(c[0].target_counts, 2400);

  ASSERT_EQ(done.num_axes, 3);
  for (const auto& [axis, target] : targets) {
    const auto i = index_of(done, axis);
    ASSERT_LT(i, done.axes.size()) << axis;
    EXPECT_NEAR(done.positions[i], target, kTolerance) << axis;
    EXPECT_TRUE(lab.client().wait_until([&, &a = axis, &t = target] { return settled_at(a, t); }, seconds(5)))
        << axis << " at " << position(axis);
  }
  EXPECT_NEAR(done.measured_start_skew_us, 0.0, 1.0);
}

TEST_P(Uc57Lab, PowerCycledNodeIsDetectedReconfiguredAndMovesAgain) {
  const auto first = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"b", 45.0}}));
  ASSERT_EQ(first.status, st(reply_t::DONE)) << first.reason;

  // Power-cycled in the middle of a long move.
  std::vector<reply_t> replies;
  ASSERT_NE(lab.client().send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"b", 400.0}}),
                              [&](const reply_t& r) { replies.push_back(r); }),
            0);
  ASSERT_TRUE(lab.client().wait_until([&] { return state("b").moving && position("b") > 60.0; }, seconds(10)))
      << position("b");
  lab.control("b-drive", sim_control_t::POWER_CYCLE);
  // The boot-up message is seen: a REBOOT event naming b, and b goes through offline.
  ASSERT_TRUE(lab.client().wait_until([&] { return saw_event("b", ev(event_t::REBOOT)); }, seconds(10)));
  const event_t* reboot = find_event("b", ev(event_t::REBOOT));
  ASSERT_NE(reboot, nullptr);
  EXPECT_TRUE(contains(reboot->text, "b-drive")) << reboot->text;
  // Exactly one terminal reply to the move, not DONE.
  const auto terminal = [&] {
    return std::count_if(replies.begin(), replies.end(),
                         [](const reply_t& r) { return client::is_terminal(r.status); });
  };
  ASSERT_TRUE(lab.client().wait_until([&] { return terminal() == 1; }, seconds(15)));
  EXPECT_FALSE(saw(replies, reply_t::DONE));
  // Re-configured: online again (an ONLINE event after the reboot) with the drive's fresh state:
  // position 0 (volatile), disabled (CiA 402 starts in Switch on disabled).
  ASSERT_TRUE(lab.client().wait_until(
      [&] {
        const auto reboot_at = std::find_if(events.begin(), events.end(), [](const event_t& e) {
          return e.axis == "b" && e.kind == ev(event_t::REBOOT);
        });
        return std::any_of(reboot_at, events.end(),
                           [](const event_t& e) { return e.axis == "b" && e.kind == ev(event_t::ONLINE); }) &&
               state("b").online;
      },
      seconds(15)));
  ASSERT_TRUE(
      lab.client().wait_until([&] { return !state("b").enabled && std::abs(position("b")) <= kTolerance; }, seconds(5)))
      << "enabled " << state("b").enabled << " position " << position("b");
  // Position lost / not homed, in its state and in an event naming it.
  EXPECT_EQ(state("b").fault_code, motionlcm::axis_state_t::POSITION_LOST) << state("b").fault_text;
  EXPECT_FALSE(state("b").homed);
  EXPECT_TRUE(std::any_of(events.begin(), events.end(), [](const event_t& e) {
    return e.axis == "b" && e.kind == ev(event_t::REBOOT) && e.text.find("position lost") != std::string::npos;
  }));
  // The setup keys were written again (2005h is volatile in the simulated drive too).
  const auto current = param(request_t::PARAM_READ, "b", 0x2005, 0);
  ASSERT_EQ(current.status, st(reply_t::DONE)) << current.reason;
  EXPECT_EQ(current.param.value, 20);

  // Enabled again, it still does not move until it is homed.
  const auto enabled = lab.call(Client::make(request_t::ENABLE, std::vector<std::string>{"b"}));
  ASSERT_EQ(enabled.status, st(reply_t::DONE)) << enabled.reason;
  const auto refused = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"b", 60.0}}));
  EXPECT_EQ(refused.status, st(reply_t::REJECTED)) << refused.reason;
  EXPECT_EQ(refused.error_code, code(ReplyError::kPositionLost)) << refused.reason;
  const auto homed = lab.call(Client::make(request_t::HOME, std::vector<std::string>{"b"}));
  ASSERT_EQ(homed.status, st(reply_t::DONE)) << homed.reason;
  ASSERT_TRUE(lab.client().wait_until(
      [&] { return state("b").homed && state("b").fault_code != motionlcm::axis_state_t::POSITION_LOST; }, seconds(5)));

  // It can move again, in step with the others.
  lab.clear_reports();
  const auto again = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 20.0}, {"b", 60.0}}));
  ASSERT_EQ(again.status, st(reply_t::DONE)) << again.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("b", 60.0) && settled_at("a", 20.0); }, seconds(5)))
      << position("b");
  const auto a = lab.starts_of("a-drive");
  const auto b = lab.starts_of("b-drive");
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(a[0].frame_utime, b[0].frame_utime);
}

TEST_P(Uc57Lab, SdoAbortSurfacesAsAFailureWithTheAbortTextAndCode) {
  // 1000h (device type) is read-only: abort 06010002h.
  const auto read_only = param(request_t::PARAM_WRITE, "a", 0x1000, 0, 5);
  EXPECT_EQ(read_only.status, st(reply_t::FAILED)) << read_only.reason;
  EXPECT_EQ(read_only.error_code, code(ReplyError::kDriveError)) << read_only.reason;
  EXPECT_TRUE(contains(read_only.reason, "0x06010002")) << read_only.reason;
  EXPECT_TRUE(contains(read_only.reason, "read only")) << read_only.reason;
  EXPECT_TRUE(contains(read_only.reason, "0x1000")) << read_only.reason;
  EXPECT_TRUE(contains(read_only.reason, "a-drive")) << read_only.reason;

  // 2005h (run current) takes 1..25 (x 0.1 A): 99 is too high, abort 06090031h.
  const auto too_high = param(request_t::PARAM_WRITE, "b", 0x2005, 0, 99);
  EXPECT_EQ(too_high.status, st(reply_t::FAILED)) << too_high.reason;
  EXPECT_EQ(too_high.error_code, code(ReplyError::kDriveError)) << too_high.reason;
  EXPECT_TRUE(contains(too_high.reason, "0x06090031")) << too_high.reason;
  EXPECT_TRUE(contains(too_high.reason, "too high")) << too_high.reason;

  // An object the UC57 does not have: abort 06020000h (the width must be given).
  request_t missing = Client::make(request_t::PARAM_WRITE, std::vector<std::string>{"c"});
  missing.param.space = motionlcm::param_t::CANOPEN_OBJECT;
  missing.param.index = 0x5555;
  missing.param.subindex = 0;
  missing.param.width = 2;
  missing.param.value = 1;
  const auto no_object = lab.call(missing);
  EXPECT_EQ(no_object.status, st(reply_t::FAILED)) << no_object.reason;
  EXPECT_TRUE(contains(no_object.reason, "0x06020000")) << no_object.reason;

  // Nothing was changed, and the node is still fine: a valid write and read back work.
  const auto still = param(request_t::PARAM_READ, "b", 0x2005, 0);
  ASSERT_EQ(still.status, st(reply_t::DONE)) << still.reason;
  EXPECT_EQ(still.param.value, 20);
  const auto write = param(request_t::PARAM_WRITE, "b", 0x2005, 0, 18);
  ASSERT_EQ(write.status, st(reply_t::DONE)) << write.reason;
  const auto read_back = param(request_t::PARAM_READ, "b", 0x2005, 0);
  ASSERT_EQ(read_back.status, st(reply_t::DONE)) << read_back.reason;
  EXPECT_EQ(read_back.param.value, 18);
  EXPECT_TRUE(state("b").online && state("b").enabled);
}

TEST_P(Uc57Lab, HeartbeatLossRaisesAnEventAndAbortsTheGroupNamingTheAxis) {
  // A long group move of a and c; c falls silent while it runs.
  std::vector<reply_t> replies;
  lab.client().send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 700.0}, {"c", 700.0}}),
                    [&](const reply_t& r) { replies.push_back(r); });
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(replies, reply_t::STARTED); }, seconds(10)));
  ASSERT_TRUE(lab.client().wait_until([&] { return state("a").moving && state("c").moving; }, seconds(5)));
  lab.control("c-drive", sim_control_t::SILENCE, 1);

  ASSERT_TRUE(lab.client().wait_until([&] { return !replies.empty() && client::is_terminal(replies.back().status); },
                                      seconds(15)));
  const reply_t& last = replies.back();
  EXPECT_EQ(last.status, st(reply_t::ABORTED)) << last.reason;
  EXPECT_TRUE(contains(last.reason, "c-drive") || contains(last.reason, "axis c")) << last.reason;
  EXPECT_TRUE(contains(last.reason, "heartbeat")) << last.reason;

  // The event names the axis.
  ASSERT_TRUE(lab.client().wait_until([&] { return saw_event("c", ev(event_t::HEARTBEAT_LOST)); }, seconds(5)));
  EXPECT_TRUE(contains(find_event("c", ev(event_t::HEARTBEAT_LOST))->text, "c-drive"));
  EXPECT_TRUE(lab.client().wait_until([&] { return !state("c").online; }, seconds(5)));

  // The rest of the group was stopped short of its target.
  ASSERT_TRUE(lab.client().wait_until([&] { return !state("a").moving; }, seconds(10)));
  EXPECT_LT(position("a"), 699.0);
  const double stopped = position("a");
  lab.client().wait_until([] { return false; }, std::chrono::milliseconds(300));
  EXPECT_NEAR(position("a"), stopped, kTolerance);

  // A move of the silent axis is refused or fails, naming it; b (not in the group) still moves.
  const auto refused = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"c", 1.0}}));
  EXPECT_TRUE(refused.status == st(reply_t::REJECTED) || refused.status == st(reply_t::FAILED)) << refused.reason;
  EXPECT_TRUE(contains(refused.reason, "c")) << refused.reason;
  const auto b = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"b", 10.0}}));
  EXPECT_EQ(b.status, st(reply_t::DONE)) << b.reason;

  // Answering again: the node is re-configured and comes back online.
  lab.control("c-drive", sim_control_t::SILENCE, 0);
  EXPECT_TRUE(lab.client().wait_until([&] { return state("c").online; }, seconds(20)));
}

INSTANTIATE_TEST_SUITE_P(TpdoModes, Uc57Lab, ::testing::Values("uc57-three", "uc57-three-staggered"),
                         [](const ::testing::TestParamInfo<std::string>& p) {
                           return p.param == "uc57-three" ? std::string("sync") : std::string("staggered");
                         });

}  // namespace
}  // namespace motion::testing
