// The UIROBOT UIM242 family end to end over a real pseudo-terminal: ONE simulated RS232 line
// (tests/integration/configs/uim242-two.yaml) to a UIM2501 RS232-CAN gateway with two UIM242
// controllers behind it, CAN ids 5 and 6 (axes u1, u2): client -> motion-coordinator ->
// `motion-gateway --bus rs232` (Uim242BusDriver: `ADR η;` routing, string instructions, binary
// replies and notifications) -> motion-sim (a simulated UIM2501 + UIM242s on the pty), and replies,
// axis state and events all the way back. Each test has its own LCM URL and simulation directory.
// The simulated controllers' reports (SIM_REPORT) are the ground truth of when motion started: a
// move of both axes at one speed is loaded with `SPD 0;` + `STP d;` per controller and started by
// ONE global `gSPD v;`, so their MOTION_STARTED reports carry the same frame_utime. Faults come in
// through SIM_CONTROL (SILENCE). No timed assertions: every wait is bounded generously.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "motion/lcm/reply_error.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using client::Client;
using motionlcm::event_t;
using motionlcm::reply_t;
using motionlcm::request_t;
using motionlcm::sim_control_t;
using std::chrono::milliseconds;
using std::chrono::seconds;
using Values = std::map<std::string, double>;
using Axes = std::vector<std::string>;

// LCM in-class constants are never ODR-used: copy them into values.
std::int8_t st(std::int8_t s) { return s; }
std::int16_t ev(std::int16_t k) { return k; }
std::int32_t code(ReplyError e) { return error_code(e); }

constexpr double kStepsPerMm = 160.0;
constexpr double kTolerance = 1.0 / kStepsPerMm + 1e-9;  // one micro-step, in mm
const Axes kAxes{"u1", "u2"};

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class Uim242Line : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(lab.start(kAxes));
    ASSERT_TRUE(lab.enable(kAxes));
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }
  const motionlcm::axis_state_t& state(const std::string& axis) { return lab.state(axis); }
  double position(const std::string& axis) { return lab.position(axis); }
  bool settled_at(const std::string& axis, double where) { return lab.settled_at(axis, where, kTolerance); }

  // Requests a move; it must end DONE after ACCEPTED and STARTED, its reply and every axis at rest
  // at `at` (user units).
  ::testing::AssertionResult move_arrives(std::int8_t kind, const Values& move, const Values& at, reply_t* reply = nullptr) {
    std::vector<reply_t> seen;
    const auto done = lab.call(Client::make(kind, move), &seen);
    if (reply != nullptr) *reply = done;
    if (done.status != reply_t::DONE) return ::testing::AssertionFailure() << client::status_name(done.status) << ": " << done.reason;
    for (const std::int8_t status : {st(reply_t::ACCEPTED), st(reply_t::STARTED)}) {
      if (std::none_of(seen.begin(), seen.end(), [status](const reply_t& r) { return r.status == status; })) {
        return ::testing::AssertionFailure() << "no " << client::status_name(status) << " before DONE";
      }
    }
    for (std::size_t i = 0; i < done.axes.size(); ++i) {
      if (std::abs(done.positions[i] - at.at(done.axes[i])) > kTolerance) {
        return ::testing::AssertionFailure() << "reply: " << done.axes[i] << " at " << done.positions[i];
      }
    }
    for (const auto& [axis, where] : at) {
      if (!settled_at(axis, where)) return ::testing::AssertionFailure() << axis << " at " << position(axis) << ", not " << where;
    }
    return ::testing::AssertionSuccess();
  }
  // The targets (counts) of the MOTION_STARTED reports of `drive`, in order.
  std::vector<std::int64_t> start_targets(const std::string& drive) const {
    std::vector<std::int64_t> out;
    for (const auto& r : lab.starts_of(drive)) out.push_back(r.target_counts);
    return out;
  }

  SimLab lab{source_path("tests/integration/configs/uim242-two.yaml")};
};

TEST_F(Uim242Line, BothDrivesComeOnlineIdentifiedAndEnableRoundTrips) {
  for (const auto& axis : kAxes) {
    EXPECT_TRUE(state(axis).online && state(axis).enabled && !state(axis).fault) << axis;
    EXPECT_EQ(state(axis).family, "uim242") << axis;
  }
  EXPECT_EQ(state("u2").node_id, 6);
  // `MDL η;` identified each controller behind the gateway.
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.has_event(ev(event_t::ONLINE), "u1", "u1-drive (node 5): UIM242"); }, seconds(2)));
  EXPECT_TRUE(lab.has_event(ev(event_t::ONLINE), "u2", "u2-drive (node 6): UIM242"));

  // `OFF;`: the axis reports disabled and a move of it is refused before anything is sent.
  const auto disabled = lab.call(Client::make(request_t::DISABLE, Axes{"u2"}));
  ASSERT_EQ(disabled.status, st(reply_t::DONE)) << disabled.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !state("u2").enabled; }, seconds(5)));
  EXPECT_TRUE(state("u1").enabled);
  const auto refused = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"u2", 5.0}}));
  EXPECT_EQ(refused.status, st(reply_t::REJECTED)) << refused.reason;
  EXPECT_EQ(refused.error_code, code(ReplyError::kAxisDisabled)) << refused.reason;
  EXPECT_TRUE(contains(refused.reason, "u2")) << refused.reason;
  EXPECT_TRUE(lab.starts_of("u2-drive").empty());
  // `ENA;` again: it moves.
  ASSERT_TRUE(lab.enable(Axes{"u2"}));
  EXPECT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u2", 5.0}}, Values{{"u2", 5.0}}));
}

TEST_F(Uim242Line, AbsoluteAndRelativeMovesArrive) {
  ASSERT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u1", 12.5}}, Values{{"u1", 12.5}}));
  EXPECT_EQ(start_targets("u1-drive"), std::vector<std::int64_t>{2000});  // 12.5 mm x 160
  // One axis of the two: its own `SPD v;` started it, the other never moved.
  const auto* started = lab.last_gateway_started();
  ASSERT_NE(started, nullptr);
  EXPECT_EQ(started->start_mechanism, "sequential");
  EXPECT_TRUE(lab.starts_of("u2-drive").empty());

  // Relative, two axes: each from where it is (u1 from 12.5, u2 from 0).
  ASSERT_TRUE(move_arrives(request_t::MOVE_RELATIVE, Values{{"u1", -20.0}, {"u2", 7.0}}, Values{{"u1", -7.5}, {"u2", 7.0}}));
  EXPECT_EQ(start_targets("u1-drive"), (std::vector<std::int64_t>{2000, -1200}));
  EXPECT_EQ(start_targets("u2-drive"), std::vector<std::int64_t>{1120});
}

TEST_F(Uim242Line, TwoAxisMoveStartsOnOneGlobalSpeedFrame) {
  reply_t done;
  // Equal distances: one planned speed, so one `gSPD v;` can start both.
  ASSERT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u1", 10.0}, {"u2", -10.0}}, Values{{"u1", 10.0}, {"u2", -10.0}}, &done));

  // Ground truth: both controllers started on the same frame (the gateway-wide `gSPD v;`).
  const auto u1 = lab.starts_of("u1-drive");
  const auto u2 = lab.starts_of("u2-drive");
  ASSERT_EQ(u1.size(), 1u);
  ASSERT_EQ(u2.size(), 1u);
  EXPECT_EQ(u1[0].frame_utime, u2[0].frame_utime) << "u1 and u2 did not start on the same frame";
  EXPECT_EQ(start_targets("u1-drive"), std::vector<std::int64_t>{1600});
  EXPECT_EQ(start_targets("u2-drive"), std::vector<std::int64_t>{-1600});

  // The gateway's STARTED names the mechanism; its trigger time is that frame's sending.
  const auto* started = lab.last_gateway_started();
  ASSERT_NE(started, nullptr);
  EXPECT_EQ(started->start_mechanism, "broadcast");
  EXPECT_DOUBLE_EQ(started->predicted_skew_us, 0.0);
  EXPECT_LT(std::abs(started->trigger_utime - u1[0].frame_utime), 20'000) << "trigger time vs the simulator's frame time";
  EXPECT_NEAR(done.measured_start_skew_us, 0.0, 1.0);
}

TEST_F(Uim242Line, JogThenStop) {
  const auto jog = lab.call(Client::make(request_t::JOG, Values{{"u2", 10.0}}));  // 10 mm/s = 1600 pps
  ASSERT_EQ(jog.status, st(reply_t::DONE)) << jog.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return position("u2") > 1.0 && state("u2").moving; }, seconds(5)))
      << "u2 at " << position("u2");
  EXPECT_EQ(lab.starts_of("u2-drive").size(), 1u);
  const auto stop = lab.call(Client::make(request_t::STOP, Axes{"u2"}));
  ASSERT_EQ(stop.status, st(reply_t::DONE)) << stop.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !state("u2").moving; }, seconds(5)));
  const double stopped_at = position("u2");
  EXPECT_GT(stopped_at, 1.0);
  // Stopped is stopped: still there a while later, and the other axis never moved.
  lab.pause(milliseconds(300));
  EXPECT_NEAR(position("u2"), stopped_at, kTolerance);
  EXPECT_TRUE(lab.starts_of("u1-drive").empty());
  EXPECT_NEAR(position("u1"), 0.0, kTolerance);
}

TEST_F(Uim242Line, DeadDriveGoesOfflineWhileTheOtherKeepsWorking) {
  lab.control("u2-drive", sim_control_t::SILENCE, 1);
  // u2 goes offline (timeout, one retry, then the event naming drive, node and instruction) ...
  ASSERT_TRUE(lab.client().wait_until([&] { return !state("u2").online; }, seconds(5)));
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.has_event(ev(event_t::OFFLINE), "u2", "u2-drive (node 6): '"); }, seconds(2)));
  EXPECT_FALSE(lab.has_event(ev(event_t::OFFLINE), "u1", ""));
  // ... while u1 keeps being polled and moves.
  const auto u1_sample = state("u1").sample_utime;
  ASSERT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u1", 5.0}}, Values{{"u1", 5.0}}));
  EXPECT_GT(state("u1").sample_utime, u1_sample);
  EXPECT_TRUE(state("u1").online);
  EXPECT_TRUE(lab.starts_of("u2-drive").empty());

  // Commands for the dead drive fail, naming it: the coordinator refuses motion of an offline
  // axis; a stop (always accepted) reaches the gateway, which names drive and node.
  const auto refused = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"u2", 1.0}}));
  EXPECT_EQ(refused.status, st(reply_t::REJECTED)) << refused.reason;
  EXPECT_TRUE(contains(refused.reason, "u2")) << refused.reason;
  const auto stop = lab.call(Client::make(request_t::STOP, Axes{"u2"}));
  EXPECT_TRUE(stop.status == st(reply_t::FAILED) || stop.status == st(reply_t::ABORTED)) << client::status_name(stop.status);
  EXPECT_TRUE(contains(stop.reason, "u2-drive (node 6)")) << stop.reason;

  // The gateway keeps identifying the dead drive: when it answers again it comes back online.
  lab.control("u2-drive", sim_control_t::SILENCE, 0);
  EXPECT_TRUE(lab.client().wait_until([&] { return state("u2").online; }, seconds(10)));
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.has_event(ev(event_t::ONLINE), "u2", "u2-drive (node 6)"); }, seconds(2)));
}

TEST_F(Uim242Line, MoveBeyondTheLimitsIsRejectedNamingTheAxis) {
  const auto refused = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"u1", 10.0}, {"u2", 150.0}}));
  EXPECT_EQ(refused.status, st(reply_t::REJECTED)) << refused.reason;
  EXPECT_EQ(refused.error_code, code(ReplyError::kOutsideLimits)) << refused.reason;
  EXPECT_TRUE(contains(refused.reason, "u2")) << refused.reason;
  const auto relative = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"u1", -101.0}}));
  EXPECT_EQ(relative.status, st(reply_t::REJECTED)) << relative.reason;
  EXPECT_EQ(relative.error_code, code(ReplyError::kOutsideLimits)) << relative.reason;
  // Nothing reached the drives.
  lab.pause(milliseconds(300));
  EXPECT_TRUE(lab.starts_of("u1-drive").empty());
  EXPECT_TRUE(lab.starts_of("u2-drive").empty());
  EXPECT_NEAR(position("u1"), 0.0, kTolerance);
}

}  // namespace
}  // namespace motion::testing
