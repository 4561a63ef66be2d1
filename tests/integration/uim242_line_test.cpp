// The UIROBOT UIM242 family end to end over a real pseudo-terminal: ONE simulated RS232 line
// (tests/integration/configs/uim242-two.yaml) to a UIM2501 RS232-CAN gateway with two UIM242
// controllers behind it, CAN ids 5 and 6 (axes u1, u2): client -> motion-coordinator ->
// `motion-gateway --bus rs232` (Uim242BusDriver: `ADR η;` routing, string instructions, binary
// replies and notifications) -> motion-sim (a simulated UIM2501 + UIM242s on the pty), and replies,
// axis state and events all the way back. Each test has its own LCM URL and simulation directory.
// The simulated controllers' reports (SIM_REPORT) are the ground truth of when motion started: a
// move of both axes at one speed is loaded with `SPD 0;` + `STP d;` per controller and started by
// ONE global `gSPD v;`, so their MOTION_STARTED reports carry the same frame_utime. Faults come in
// through SIM_CONTROL (SILENCE, STALL, SET_INPUT, LINE_NOISE on the line). u1 homes where it
// stands, u2 on a switch (S1). No timed assertions: every wait is bounded generously.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <motionlcm/param_t.hpp>

#include "motion/lcm/reply_error.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using Axes = std::vector<std::string>;

constexpr double kStepsPerMm = 160.0;
constexpr double kTolerance = 1.0 / kStepsPerMm + 1e-9;  // one micro-step, in mm
const Axes kAxes{"u1", "u2"};
// Homing (configs/uim242-two.yaml): u1 where it stands, u2 on S1; the home positions, mm.
constexpr double kU1Home = 2.5;
constexpr double kU2Home = -1.0;
constexpr int kHomeSwitchInput = 1;
// SCF register indices (param_t subindex) and S12CON/S34CON fields (EN/CN §8.6, §8.7).
constexpr std::int32_t kS12con = 0;
constexpr std::int32_t kS34con = 1;
constexpr std::int64_t kS2NotifyOnBothEdges = 0x1100;  // S2 rising and falling action 0001: notify only
constexpr std::int64_t kStallNotifyOnly = 0x1000;      // S34CON.STALL 0001, bound by the set-up
constexpr std::int32_t kS2 = 2;                        // input number; bit 1 of axis_state_t.inputs

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
  ::testing::AssertionResult move_arrives(std::int8_t kind, const Values& move, const Values& at,
                                          reply_t* reply = nullptr) {
    std::vector<reply_t> seen;
    const auto done = lab.call(Client::make(kind, move), &seen);
    if (reply != nullptr) *reply = done;
    if (done.status != reply_t::DONE)
      return ::testing::AssertionFailure() << client::status_name(done.status) << ": " << done.reason;
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
      if (!settled_at(axis, where))
        return ::testing::AssertionFailure() << axis << " at " << position(axis) << ", not " << where;
    }
    return ::testing::AssertionSuccess();
  }
  // Sends without waiting; the replies collect in `replies`.
  void send(request_t request, std::vector<reply_t>& replies) {
    lab.client().send(std::move(request), [&replies](const reply_t& r) { replies.push_back(r); });
  }
  static bool ended(const std::vector<reply_t>& replies) {
    return !replies.empty() && client::is_terminal(replies.back().status);
  }
  bool event_arrives(std::int16_t kind, const std::string& axis, const std::string& text) {
    return lab.client().wait_until([&] { return lab.has_event(kind, axis, text); }, seconds(5));
  }
  // An expert parameter request in UIM242 terms: the instruction's mnemonic, SCF register / STG port.
  reply_t param(std::int8_t kind, const std::string& axis, const std::string& mnemonic, std::int32_t subindex = -1,
                std::int64_t value = 0) {
    request_t r = Client::make(kind, Axes{axis});
    r.param.space = motionlcm::param_t::UIM242_INSTRUCTION;
    r.param.mnemonic = mnemonic;
    r.param.subindex = subindex;
    r.param.value = value;
    return lab.call(r);
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
  EXPECT_TRUE(lab.client().wait_until(
      [&] { return lab.has_event(ev(event_t::ONLINE), "u1", "u1-drive (node 5): UIM242"); }, seconds(2)));
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
  ASSERT_TRUE(
      move_arrives(request_t::MOVE_RELATIVE, Values{{"u1", -20.0}, {"u2", 7.0}}, Values{{"u1", -7.5}, {"u2", 7.0}}));
  EXPECT_EQ(start_targets("u1-drive"), (std::vector<std::int64_t>{2000, -1200}));
  EXPECT_EQ(start_targets("u2-drive"), std::vector<std::int64_t>{1120});
}

TEST_F(Uim242Line, TwoAxisMoveStartsOnOneGlobalSpeedFrame) {
  reply_t done;
  // Equal distances: one planned speed, so one `gSPD v;` can start both.
  ASSERT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u1", 10.0}, {"u2", -10.0}},
                           Values{{"u1", 10.0}, {"u2", -10.0}}, &done));

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
  EXPECT_LT(std::abs(started->trigger_utime - u1[0].frame_utime), 20'000)
      << "trigger time vs the simulator's frame time";
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

// Stopped mid-move and moved again at once (the move sent right behind the stop, while the axis
// still brakes): the move's relative STP is computed from a position read at rest, so it ends
// exactly at its absolute target and the request ends DONE (the coordinator waits for the
// reported position to equal the target).
TEST_F(Uim242Line, StopMidMoveThenMoveAgainAtOnceEndsExactlyAtTheTarget) {
  std::vector<reply_t> first;
  send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"u1", 90.0}}), first);
  ASSERT_TRUE(lab.client().wait_until([&] { return position("u1") > 5.0 && state("u1").moving; }, seconds(10)))
      << "u1 at " << position("u1");
  // The stop and, without waiting for it, the next move: it is armed while u1 still brakes.
  std::vector<reply_t> stop;
  send(Client::make(request_t::STOP, Axes{"u1"}), stop);
  const auto again = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"u1", 20.0}}));
  ASSERT_EQ(again.status, st(reply_t::DONE)) << client::status_name(again.status) << ": " << again.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return ended(stop); }, seconds(10)));
  EXPECT_EQ(stop.back().status, st(reply_t::DONE)) << stop.back().reason;
  EXPECT_TRUE(ended(first));
  EXPECT_TRUE(settled_at("u1", 20.0)) << "u1 at " << position("u1");
  EXPECT_EQ(state("u1").position_counts, 3200);  // 20 mm x 160, exactly
  const auto starts = start_targets("u1-drive");
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[1], 3200);
}

TEST_F(Uim242Line, DeadDriveGoesOfflineWhileTheOtherKeepsWorking) {
  lab.control("u2-drive", sim_control_t::SILENCE, 1);
  // u2 goes offline (timeout, one retry, then the event naming drive, node and instruction) ...
  ASSERT_TRUE(lab.client().wait_until([&] { return !state("u2").online; }, seconds(5)));
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.has_event(ev(event_t::OFFLINE), "u2", "u2-drive (node 6): '"); },
                                      seconds(2)));
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
  EXPECT_TRUE(stop.status == st(reply_t::FAILED) || stop.status == st(reply_t::ABORTED))
      << client::status_name(stop.status);
  EXPECT_TRUE(contains(stop.reason, "u2-drive (node 6)")) << stop.reason;

  // The gateway keeps identifying the dead drive: when it answers again it comes back online.
  lab.control("u2-drive", sim_control_t::SILENCE, 0);
  EXPECT_TRUE(lab.client().wait_until([&] { return state("u2").online; }, seconds(10)));
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.has_event(ev(event_t::ONLINE), "u2", "u2-drive (node 6)"); },
                                      seconds(2)));
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

TEST_F(Uim242Line, HomeWithoutASwitchMakesWhereTheAxisStandsTheHomePosition) {
  ASSERT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u1", 10.0}}, Values{{"u1", 10.0}}));
  ASSERT_FALSE(state("u1").homed);

  // `ORG 400;`: the drive's counter says 2.5 mm where the axis stands (10 mm before).
  const auto home = lab.call(Client::make(request_t::HOME, Axes{"u1"}));
  ASSERT_EQ(home.status, st(reply_t::DONE)) << home.reason;
  // The state HOME led to came before its DONE (no poll awaited).
  EXPECT_TRUE(state("u1").homed);
  EXPECT_NEAR(position("u1"), kU1Home, kTolerance);
  EXPECT_FALSE(state("u2").homed);

  // Planned right away, from the home position: +2.5 mm ends at 5 mm (not 12.5).
  ASSERT_TRUE(move_arrives(request_t::MOVE_RELATIVE, Values{{"u1", 2.5}}, Values{{"u1", 5.0}}));
  // Absolute targets are in the new frame: -2.5 mm is 5 mm back from 2.5 mm, 7.5 mm from where it stood.
  ASSERT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u1", -2.5}}, Values{{"u1", -2.5}}));
  // Ground truth: the drive started from its new counter values.
  const auto starts = lab.starts_of("u1-drive");
  ASSERT_EQ(starts.size(), 3u);
  EXPECT_EQ(starts[1].position_counts, 400);
  EXPECT_EQ(starts[1].target_counts, 800);
  EXPECT_EQ(starts[2].position_counts, 800);
  EXPECT_EQ(starts[2].target_counts, -400);
  EXPECT_TRUE(state("u1").homed);
}

TEST_F(Uim242Line, HomeOnTheSwitchStopsThereAndSetsTheOffset) {
  // The run goes towards min at 5 mm/s until S1 falls (the switch closes: 0 V); that edge resets
  // and e-stops the drive (sensor action 1100) and its RTCN ends the homing.
  constexpr double kUnderWay = -0.5;  // mm: the run has left the start
  std::vector<reply_t> replies;
  send(Client::make(request_t::HOME, Axes{"u2"}), replies);
  ASSERT_TRUE(lab.client().wait_until([&] { return state("u2").moving && position("u2") < kUnderWay; }, seconds(10)))
      << "u2 at " << position("u2");
  ASSERT_FALSE(ended(replies)) << replies.back().reason;
  lab.control("u2-drive", sim_control_t::SET_INPUT, kHomeSwitchInput, 0);
  ASSERT_TRUE(lab.client().wait_until([&] { return ended(replies); }, seconds(10)));
  ASSERT_EQ(replies.back().status, st(reply_t::DONE)) << replies.back().reason;
  EXPECT_TRUE(state("u2").homed);
  EXPECT_NEAR(position("u2"), kU2Home, kTolerance);
  EXPECT_TRUE(lab.has_event(ev(event_t::INPUT_EDGE), "u2", "u2-drive (node 6): input S1 falling"));

  // It stays at the switch: enabling it again does not resume the homing run.
  ASSERT_TRUE(lab.enable(Axes{"u2"}));
  lab.pause(milliseconds(300));
  EXPECT_TRUE(settled_at("u2", kU2Home)) << "u2 at " << position("u2");
  EXPECT_EQ(lab.starts_of("u2-drive").size(), 1u);
  // Targets are from the switch now: 1 mm is 160 counts, from -160 at the switch.
  ASSERT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u2", 1.0}}, Values{{"u2", 1.0}}));
  const auto starts = lab.starts_of("u2-drive");
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[1].position_counts, -160);
  EXPECT_EQ(starts[1].target_counts, 160);
  EXPECT_FALSE(state("u1").homed);
}

TEST_F(Uim242Line, ArrivalAndInputNotificationsArriveAsEvents) {
  // A8 (displacement complete): MOTION_COMPLETE naming drive, node and the target in counts.
  ASSERT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u1", 3.0}}, Values{{"u1", 3.0}}));
  EXPECT_TRUE(event_arrives(ev(event_t::MOTION_COMPLETE), "u1", "u1-drive (node 5) at 480"));
  EXPECT_FALSE(lab.has_event(ev(event_t::MOTION_COMPLETE), "u2", ""));

  // Input edges notify once an action is bound to them (S12CON; 0000 means "no RTCN").
  const auto bound = param(request_t::PARAM_WRITE, "u2", "SCF", kS12con, kS2NotifyOnBothEdges);
  ASSERT_EQ(bound.status, st(reply_t::DONE)) << bound.reason;
  lab.control("u2-drive", sim_control_t::SET_INPUT, kS2, 0);
  EXPECT_TRUE(event_arrives(ev(event_t::INPUT_EDGE), "u2", "u2-drive (node 6): input S2 falling"));
  lab.control("u2-drive", sim_control_t::SET_INPUT, kS2, 1);
  EXPECT_TRUE(event_arrives(ev(event_t::INPUT_EDGE), "u2", "u2-drive (node 6): input S2 rising"));
  EXPECT_TRUE(lab.client().wait_until([&] { return (state("u2").inputs & (1 << (kS2 - 1))) != 0; }, seconds(5)))
      << "inputs " << state("u2").inputs;
  // Information, not a fault; u1 has nothing bound.
  EXPECT_FALSE(state("u2").fault);
  EXPECT_FALSE(lab.has_event(ev(event_t::INPUT_EDGE), "u1", ""));
}

TEST_F(Uim242Line, StallMidMoveAbortsTheMoveWithTheCause) {
  std::vector<reply_t> replies;
  send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"u1", 90.0}}), replies);  // 3 s at 30 mm/s
  ASSERT_TRUE(lab.client().wait_until([&] { return state("u1").moving && position("u1") > 1.0; }, seconds(10)))
      << "u1 at " << position("u1");
  ASSERT_FALSE(ended(replies)) << replies.back().reason;
  lab.control("u1-drive", sim_control_t::STALL);

  // The stall RTCN: a STALL event, and the move ends ABORTED naming axis, drive and cause.
  ASSERT_TRUE(lab.client().wait_until([&] { return ended(replies); }, seconds(10)));
  const reply_t& last = replies.back();
  EXPECT_EQ(last.status, st(reply_t::ABORTED)) << last.reason;
  EXPECT_EQ(last.error_code, code(ReplyError::kAxisFault)) << last.reason;
  EXPECT_TRUE(contains(last.reason, "u1-drive (node 5): stall notification")) << last.reason;
  EXPECT_TRUE(lab.has_event(ev(event_t::STALL), "u1", "u1-drive (node 5): stall notification"));
  ASSERT_TRUE(lab.client().wait_until([&] { return state("u1").fault && !state("u1").moving; }, seconds(5)));
  EXPECT_LT(position("u1"), 89.0);
  EXPECT_FALSE(state("u2").fault);

  // FAULT_RESET clears it (in the state before its DONE) and the axis moves again at once.
  const auto reset = lab.call(Client::make(request_t::FAULT_RESET, Axes{"u1"}));
  ASSERT_EQ(reset.status, st(reply_t::DONE)) << reset.reason;
  EXPECT_FALSE(state("u1").fault);
  EXPECT_TRUE(move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u1", 0.0}}, Values{{"u1", 0.0}}));
}

TEST_F(Uim242Line, NoiseOnTheLineIsCountedAndDoesNotWedgeTheGateway) {
  constexpr std::int32_t kNoiseBytes = 40;
  constexpr std::int32_t kBetweenFrames = 0;
  constexpr std::int32_t kInsideAFrame = 1;
  const auto errors = [&] { return lab.bus_stats("rs232").value().errors; };
  ASSERT_TRUE(lab.client().wait_until([&] { return lab.bus_stats("rs232").has_value(); }, seconds(5)));
  const auto before = errors();
  lab.control_bus("rs232", sim_control_t::LINE_NOISE, kNoiseBytes, kBetweenFrames);
  ASSERT_TRUE(lab.client().wait_until([&] { return errors() > before; }, seconds(10)))
      << "noise between frames not counted";
  const auto between = errors();
  // Into a reply: that one is lost (retried); the framer resynchronises on the next frame.
  lab.control_bus("rs232", sim_control_t::LINE_NOISE, kNoiseBytes, kInsideAFrame);
  ASSERT_TRUE(lab.client().wait_until([&] { return errors() > between; }, seconds(10)))
      << "noise inside a frame not counted";

  // Both axes stayed online and are still polled ...
  for (const auto& axis : kAxes) EXPECT_FALSE(lab.has_event(ev(event_t::OFFLINE), axis, "")) << axis;
  const auto u1_sample = state("u1").sample_utime;
  const auto u2_sample = state("u2").sample_utime;
  ASSERT_TRUE(lab.client().wait_until(
      [&] { return state("u1").sample_utime > u1_sample && state("u2").sample_utime > u2_sample; }, seconds(5)));
  EXPECT_TRUE(state("u1").online && state("u2").online);
  // ... and a move of both still arrives, on one global start.
  ASSERT_TRUE(
      move_arrives(request_t::MOVE_ABSOLUTE, Values{{"u1", 10.0}, {"u2", -10.0}}, Values{{"u1", 10.0}, {"u2", -10.0}}));
  EXPECT_EQ(lab.bus_stats("rs232").value().drives_online, 2);
}

TEST_F(Uim242Line, ExpertParametersReadAndWriteByMnemonic) {
  // What the set-up wrote: MCFG = CM + STLIE + STPIE + S1IE..S3IE, CUR 1.0 A, S34CON.STALL.
  constexpr std::int64_t kSetUpMcfg = 0x0400 | 0x0040 | 0x0010 | 0x0007;
  constexpr std::int64_t kCurrentTenths = 10;
  const auto mcfg = param(request_t::PARAM_READ, "u1", "MCFG");
  ASSERT_EQ(mcfg.status, st(reply_t::DONE)) << mcfg.reason;
  EXPECT_EQ(mcfg.param.value, kSetUpMcfg);
  const auto current = param(request_t::PARAM_READ, "u2", "CUR");
  ASSERT_EQ(current.status, st(reply_t::DONE)) << current.reason;
  EXPECT_EQ(current.param.value, kCurrentTenths);
  const auto s34con = param(request_t::PARAM_READ, "u2", "SCF", kS34con);
  ASSERT_EQ(s34con.status, st(reply_t::DONE)) << s34con.reason;
  EXPECT_EQ(s34con.param.value, kStallNotifyOnly);

  // A write reads back, on that drive only (SQT, the stall tolerance: its reply looks like QEC's).
  constexpr std::int64_t kStallTolerance = 150;
  const auto write = param(request_t::PARAM_WRITE, "u2", "SQT", -1, kStallTolerance);
  ASSERT_EQ(write.status, st(reply_t::DONE)) << write.reason;
  const auto read_back = param(request_t::PARAM_READ, "u2", "SQT");
  ASSERT_EQ(read_back.status, st(reply_t::DONE)) << read_back.reason;
  EXPECT_EQ(read_back.param.value, kStallTolerance);
  const auto other = param(request_t::PARAM_READ, "u1", "SQT");
  ASSERT_EQ(other.status, st(reply_t::DONE)) << other.reason;
  EXPECT_EQ(other.param.value, 0);

  // Refused, saying what was wrong and naming the drive where it got that far; nothing written.
  const auto unknown = param(request_t::PARAM_READ, "u2", "XYZ");
  EXPECT_EQ(unknown.status, st(reply_t::FAILED)) << unknown.reason;
  EXPECT_EQ(unknown.error_code, code(ReplyError::kMalformedRequest))
      << unknown.reason;  // the gateway's code, passed on
  EXPECT_TRUE(contains(unknown.reason, "'XYZ' is not a UIM242 controller instruction")) << unknown.reason;
  constexpr std::int64_t kAboveSixteenBits = 70000;
  const auto too_big = param(request_t::PARAM_WRITE, "u2", "SQT", -1, kAboveSixteenBits);
  EXPECT_EQ(too_big.status, st(reply_t::FAILED)) << too_big.reason;
  EXPECT_EQ(too_big.error_code, code(ReplyError::kOutsideLimits)) << too_big.reason;
  EXPECT_TRUE(contains(too_big.reason, "u2-drive (node 6): value 70000 outside the range of SQT")) << too_big.reason;
  const auto too_wide = param(request_t::PARAM_WRITE, "u2", "SCF", kS34con, kAboveSixteenBits);
  EXPECT_EQ(too_wide.status, st(reply_t::FAILED)) << too_wide.reason;
  EXPECT_TRUE(contains(too_wide.reason, "u2-drive (node 6): value 70000 outside the range of SCF")) << too_wide.reason;
  EXPECT_EQ(param(request_t::PARAM_READ, "u2", "SQT").param.value, kStallTolerance);
  EXPECT_EQ(param(request_t::PARAM_READ, "u2", "SCF", kS34con).param.value, kStallNotifyOnly);
  EXPECT_TRUE(state("u2").online && state("u2").enabled);
}

}  // namespace
}  // namespace motion::testing
