// The UIROBOT UIM342 family end to end on a simulated lab of its own
// (tests/integration/configs/uim342-three-group.yaml: x1, x2, x3 on nodes 5, 6, 7 sharing group id
// 20, w on node 8 without a group, one bit-timed simulated CAN bus at 1 Mbit/s):
// client -> coordinator -> motion-gateway (Uim342Stack: SimpleCAN 3.0 instructions, ACKs, error
// reports, notifications, status polling) -> motion-sim (simulated UIM342s), and replies, axis
// state and events all the way back. The simulated drives' own reports (SIM_REPORT) are the ground
// truth for starts and ends; inputs and faults are injected through SIM_CONTROL. Every test has
// its own LCM URL and simulation directory (ProcessGroup). No timed assertions: every wait is
// bounded generously, nothing asserts on how long anything took.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <motionlcm/event_t.hpp>

#include "motion/lcm/reply_error.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using motionlcm::sim_report_t;
using Axes = std::vector<std::string>;

// LCM in-class constants are never ODR-used: copy them into values.
std::int8_t report_kind(std::int8_t k) { return k; }

const Axes kAxes{"x1", "x2", "x3", "w"};
constexpr double kStepsPerMm = 640.0;
constexpr double kTolerance = 1.0 / kStepsPerMm + 1e-9;  // one micro-step, in mm

bool saw(const std::vector<reply_t>& replies, std::int8_t status) {
  return std::any_of(replies.begin(), replies.end(), [&](const reply_t& r) { return r.status == status; });
}
bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class Uim342Lab : public ::testing::Test {
 protected:
  Uim342Lab() : lab(source_path("tests/integration/configs/uim342-three-group.yaml")) {
    lab.group().node().subscribe<sim_report_t>(lcm::channels::kSimReport,
                                               [this](const sim_report_t& r, const std::string&) {
                                                 if (r.kind == report_kind(sim_report_t::MOTION_FINISHED))
                                                   finished.push_back(r);
                                               });
  }

  void SetUp() override {
    lab.client().on_event([this](const event_t& e) { events.push_back(e); });
    ASSERT_TRUE(lab.start(kAxes));
    ASSERT_TRUE(lab.enable(kAxes));
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }

  const motionlcm::axis_state_t& state(const std::string& axis) { return lab.state(axis); }
  double position(const std::string& axis) { return lab.position(axis); }
  bool settled_at(const std::string& axis, double target) {
    return !state(axis).moving && std::abs(position(axis) - target) <= kTolerance;
  }
  std::size_t index_of(const reply_t& r, const std::string& axis) {
    return static_cast<std::size_t>(std::find(r.axes.begin(), r.axes.end(), axis) - r.axes.begin());
  }
  const event_t* find_event(const std::string& axis, std::int16_t kind, std::size_t from = 0) {
    const auto it = std::find_if(events.begin() + static_cast<std::ptrdiff_t>(std::min(from, events.size())),
                                 events.end(), [&](const event_t& e) { return e.axis == axis && e.kind == kind; });
    return it == events.end() ? nullptr : &*it;
  }
  std::vector<sim_report_t> finishes_of(const std::string& drive) const {
    std::vector<sim_report_t> out;
    for (const auto& r : finished) {
      if (r.drive == drive) out.push_back(r);
    }
    return out;
  }
  void pause(std::chrono::milliseconds period) { lab.pause(period); }

  SimLab lab;
  std::vector<event_t> events;
  std::vector<sim_report_t> finished;
};

TEST_F(Uim342Lab, FourDrivesComeOnlineAndEnableDisableRoundTrips) {
  for (const auto& axis : kAxes) {
    EXPECT_TRUE(state(axis).online && state(axis).enabled && !state(axis).fault) << axis;
    EXPECT_EQ(state(axis).family, "uim342") << axis;
    EXPECT_NE(find_event(axis, ev(event_t::ONLINE)), nullptr) << axis;
  }
  EXPECT_EQ(state("x1").group_id, 20);
  EXPECT_EQ(state("x3").node_id, 7);
  EXPECT_EQ(state("w").group_id, 0);

  // MO=0: the axis reports disabled and a move of it is refused before anything is sent.
  const auto disabled = lab.call(Client::make(request_t::DISABLE, Axes{"w"}));
  ASSERT_EQ(disabled.status, st(reply_t::DONE)) << disabled.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !state("w").enabled; }, seconds(10)));
  const auto refused = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"w", 5.0}}));
  EXPECT_EQ(refused.status, st(reply_t::REJECTED)) << refused.reason;
  EXPECT_EQ(refused.error_code, code(ReplyError::kAxisDisabled)) << refused.reason;
  EXPECT_TRUE(lab.starts_of("w-drive").empty());
  // MO=1 again: it moves.
  const auto enabled = lab.call(Client::make(request_t::ENABLE, Axes{"w"}));
  ASSERT_EQ(enabled.status, st(reply_t::DONE)) << enabled.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return state("w").enabled; }, seconds(10)));
  const auto moved = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"w", 5.0}}));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("w", 5.0); }, seconds(10))) << position("w");
}

TEST_F(Uim342Lab, AbsoluteAndRelativeMovesArrive) {
  std::vector<reply_t> replies;
  const auto absolute = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"w", 12.5}}), &replies);
  ASSERT_EQ(absolute.status, st(reply_t::DONE)) << absolute.reason;
  EXPECT_TRUE(saw(replies, reply_t::ACCEPTED));
  EXPECT_TRUE(saw(replies, reply_t::STARTED));
  ASSERT_EQ(absolute.num_axes, 1);
  EXPECT_NEAR(absolute.positions[0], 12.5, kTolerance);
  const auto w = lab.starts_of("w-drive");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].target_counts, 8000);  // 12.5 mm x 640
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("w", 12.5); }, seconds(10))) << position("w");

  // Relative, two axes: each from where it is (w from 12.5, x2 from 0).
  const auto relative = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"w", -20.0}, {"x2", 7.0}}));
  ASSERT_EQ(relative.status, st(reply_t::DONE)) << relative.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("w", -7.5) && settled_at("x2", 7.0); }, seconds(10)))
      << position("w") << " " << position("x2");
  ASSERT_EQ(lab.starts_of("w-drive").size(), 2u);
  EXPECT_EQ(lab.starts_of("w-drive")[1].target_counts, -4800);
  ASSERT_EQ(lab.starts_of("x2-drive").size(), 1u);
  EXPECT_EQ(lab.starts_of("x2-drive")[0].target_counts, 4480);
  // Not part of either move.
  EXPECT_TRUE(lab.starts_of("x1-drive").empty());
  EXPECT_TRUE(lab.starts_of("x3-drive").empty());
  EXPECT_NEAR(position("x1"), 0.0, kTolerance);
}

TEST_F(Uim342Lab, JogRunsUntilStoppedThenTheAxisStandsStill) {
  const auto jog = lab.call(Client::make(request_t::JOG, Values{{"w", 10.0}}));
  ASSERT_EQ(jog.status, st(reply_t::DONE)) << jog.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return state("w").moving && position("w") > 1.0; }, seconds(10)))
      << position("w");
  const double before = position("w");
  ASSERT_TRUE(lab.client().wait_until([&] { return position("w") > before + 1.0; }, seconds(10))) << position("w");
  EXPECT_GT(state("w").velocity, 0.0);

  const auto stop = lab.call(Client::make(request_t::STOP, Axes{"w"}));
  ASSERT_EQ(stop.status, st(reply_t::DONE)) << stop.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !state("w").moving; }, seconds(10)));
  // Standing still: the ground truth says the jog ended, and samples a few polls apart agree.
  ASSERT_TRUE(lab.client().wait_until([&] { return !finishes_of("w-drive").empty(); }, seconds(10)));
  const double stopped = position("w");
  pause(std::chrono::milliseconds(300));
  EXPECT_NEAR(position("w"), stopped, kTolerance);
  EXPECT_NEAR(position("w"), static_cast<double>(finishes_of("w-drive").back().position_counts) / kStepsPerMm,
              kTolerance);
  EXPECT_GT(stopped, before);

  // The axis takes position moves again after the jog (PA switches the drive back to PTP).
  const auto back = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"w", 0.0}}));
  ASSERT_EQ(back.status, st(reply_t::DONE)) << back.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("w", 0.0); }, seconds(10))) << position("w");
}

TEST_F(Uim342Lab, HomeSearchesTheSwitchAndSetsTheOriginAtItsEdge) {
  const auto away = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x1", 12.0}}));
  ASSERT_EQ(away.status, st(reply_t::DONE)) << away.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return settled_at("x1", 12.0); }, seconds(10))) << position("x1");
  ASSERT_FALSE(state("x1").homed);
  const auto finished_before = finishes_of("x1-drive").size();

  // x1 homes on IN1 (falling edge) toward min; the simulated switch edge is half way to min:
  // -25 mm (-16000 counts) from power-up. The stack arms IL[0] with "set origin, then decelerate
  // to stop" (§5.26), jogs at -10 mm/s, restores IL[0] and returns to the edge.
  const auto home = lab.call(Client::make(request_t::HOME, Axes{"x1"}), nullptr, seconds(60));
  ASSERT_EQ(home.status, st(reply_t::DONE)) << home.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return state("x1").homed && settled_at("x1", 0.0); }, seconds(10)))
      << "homed " << state("x1").homed << " at " << position("x1");
  // The motion happened: the search jog stopped past the switch edge (just below the new origin),
  // then the return move ended on it.
  const auto finishes = finishes_of("x1-drive");
  ASSERT_EQ(finishes.size(), finished_before + 2);
  EXPECT_LT(finishes[finished_before].position_counts, 0);
  EXPECT_EQ(finishes.back().position_counts, 0);
  const auto* edge = find_event("x1", ev(event_t::INPUT_EDGE));
  ASSERT_NE(edge, nullptr);
  EXPECT_TRUE(contains(edge->text, "IN1 falling")) << edge->text;
  EXPECT_FALSE(state("x2").homed);

  // The homed axis moves in its new frame: 5 mm from the origin is PA = 3200, i.e. 30 mm above
  // where it powered up.
  const auto move = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x1", 5.0}}));
  ASSERT_EQ(move.status, st(reply_t::DONE)) << move.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("x1", 5.0); }, seconds(10))) << position("x1");
  EXPECT_EQ(lab.starts_of("x1-drive").back().target_counts, 3200);
  EXPECT_TRUE(state("x1").homed);
}

TEST_F(Uim342Lab, InputEdgesArriveAsNotificationsInStateAndEvents) {
  lab.control("x2-drive", sim_control_t::SET_INPUT, 2, 1);
  ASSERT_TRUE(lab.client().wait_until(
      [&] { return find_event("x2", ev(event_t::INPUT_EDGE)) != nullptr && (state("x2").inputs & 2) != 0; },
      seconds(10)))
      << "inputs " << state("x2").inputs;
  const event_t* rising = find_event("x2", ev(event_t::INPUT_EDGE));
  EXPECT_TRUE(contains(rising->text, "IN2")) << rising->text;
  EXPECT_TRUE(contains(rising->text, "rising")) << rising->text;
  EXPECT_TRUE(contains(rising->text, "x2-drive")) << rising->text;
  EXPECT_EQ(rising->node_id, 6);
  // x1's inputs did not change: only IN1, held high by its simulated home switch (released).
  EXPECT_EQ(state("x1").inputs, 1);

  const std::size_t seen = events.size();
  lab.control("x2-drive", sim_control_t::SET_INPUT, 2, 0);
  ASSERT_TRUE(lab.client().wait_until(
      [&] { return find_event("x2", ev(event_t::INPUT_EDGE), seen) != nullptr && (state("x2").inputs & 2) == 0; },
      seconds(10)))
      << "inputs " << state("x2").inputs;
  EXPECT_TRUE(contains(find_event("x2", ev(event_t::INPUT_EDGE), seen)->text, "falling"));
  // An input edge is information, not a fault.
  EXPECT_FALSE(state("x2").fault);
}

TEST_F(Uim342Lab, PositionReachedNotificationEndsTheMove) {
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x3", 3.0}}));
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  // The drive's PTP-finished notification (IE[8], §2.4) carries the final position: the stack's
  // MOTION_COMPLETE event names it exactly (a status poll would only have an earlier sample).
  ASSERT_TRUE(
      lab.client().wait_until([&] { return find_event("x3", ev(event_t::MOTION_COMPLETE)) != nullptr; }, seconds(10)));
  const event_t* complete = find_event("x3", ev(event_t::MOTION_COMPLETE));
  EXPECT_TRUE(contains(complete->text, "in position at 1920")) << complete->text;
  EXPECT_TRUE(contains(complete->text, "x3-drive")) << complete->text;
  // Ground truth: the simulated drive finished at its target, not aborted.
  ASSERT_TRUE(lab.client().wait_until([&] { return !finishes_of("x3-drive").empty(); }, seconds(10)));
  EXPECT_EQ(finishes_of("x3-drive").back().position_counts, 1920);
  EXPECT_TRUE(lab.client().wait_until([&] { return state("x3").in_position && settled_at("x3", 3.0); }, seconds(10)));
  ASSERT_EQ(done.num_axes, 1);
  EXPECT_NEAR(done.positions[0], 3.0, kTolerance);
}

TEST_F(Uim342Lab, GroupBgStartsAllThreeAxesOnTheSameFrame) {
  const Values targets{{"x1", 20.0}, {"x2", -15.0}, {"x3", 42.5}};
  std::vector<reply_t> replies;
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, targets), &replies);
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  EXPECT_TRUE(saw(replies, reply_t::STARTED));

  // Ground truth: one start per drive, all on one frame (the BG to group 20: equal end-of-frame
  // times), each with its own PA target.
  const auto x1 = lab.starts_of("x1-drive");
  const auto x2 = lab.starts_of("x2-drive");
  const auto x3 = lab.starts_of("x3-drive");
  ASSERT_EQ(x1.size(), 1u);
  ASSERT_EQ(x2.size(), 1u);
  ASSERT_EQ(x3.size(), 1u);
  EXPECT_NE(x1[0].frame_utime, 0);
  EXPECT_EQ(x1[0].frame_utime, x2[0].frame_utime) << "x1 and x2 did not start on the same frame";
  EXPECT_EQ(x1[0].frame_utime, x3[0].frame_utime) << "x1 and x3 did not start on the same frame";
  EXPECT_EQ(x1[0].target_counts, 12800);
  EXPECT_EQ(x2[0].target_counts, -9600);
  EXPECT_EQ(x3[0].target_counts, 27200);
  EXPECT_TRUE(lab.starts_of("w-drive").empty());

  ASSERT_EQ(done.num_axes, 3);
  for (const auto& [axis, target] : targets) {
    const auto i = index_of(done, axis);
    ASSERT_LT(i, done.axes.size()) << axis;
    EXPECT_NEAR(done.positions[i], target, kTolerance) << axis;
    EXPECT_TRUE(lab.client().wait_until([&, &a = axis, &t = target] { return settled_at(a, t); }, seconds(10)))
        << axis << " at " << position(axis);
  }
  EXPECT_NEAR(done.measured_start_skew_us, 0.0, 1.0);
  EXPECT_NEAR(done.predicted_skew_us, 0.0, 1.0);
  // The start time in the reply is the BG's end on the wire (its echo), the drives' start frame.
  EXPECT_EQ(done.start_utime[index_of(done, "x1")], x1[0].frame_utime);
}

// Two of the group's three move: one BG to group 20 starts both (equal end-of-frame times), and
// x3, at rest with nothing to do, is held by its gateway at PR=0 (a relative move of zero
// counts) until that BG, though its drive was left in jog mode, where a BG alone runs the jog.
TEST_F(Uim342Lab, TwoOfTheGroupStartOnItsBgWhileTheThirdIsHeldAtRest) {
  const auto jog = lab.call(Client::make(request_t::JOG, Values{{"x3", 10.0}}));
  ASSERT_EQ(jog.status, st(reply_t::DONE)) << jog.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return state("x3").moving; }, seconds(10)));
  const auto stop = lab.call(Client::make(request_t::STOP, Axes{"x3"}));
  ASSERT_EQ(stop.status, st(reply_t::DONE)) << stop.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !state("x3").moving; }, seconds(10)));
  pause(std::chrono::milliseconds(300));  // polled at rest since
  const double x3_at = position("x3");
  lab.clear_reports();

  const Values targets{{"x1", 12.0}, {"x2", -7.5}};
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, targets));
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  const auto x1 = lab.starts_of("x1-drive");
  const auto x2 = lab.starts_of("x2-drive");
  const auto x3 = lab.starts_of("x3-drive");
  ASSERT_EQ(x1.size(), 1u);
  ASSERT_EQ(x2.size(), 1u);
  EXPECT_EQ(x1[0].frame_utime, x2[0].frame_utime) << "x1 and x2 did not start on the same frame";
  // x3 heard the same BG and ran a move of zero counts.
  ASSERT_EQ(x3.size(), 1u) << "x3 did not hear the group BG";
  EXPECT_EQ(x3[0].frame_utime, x1[0].frame_utime);
  EXPECT_EQ(x3[0].target_counts, std::llround(x3_at * kStepsPerMm));
  EXPECT_NEAR(done.measured_start_skew_us, 0.0, 1.0);
  EXPECT_NEAR(done.predicted_skew_us, 0.0, 1.0);
  for (const auto& [axis, target] : targets) {
    EXPECT_TRUE(lab.client().wait_until([&, &a = axis, &t = target] { return settled_at(a, t); }, seconds(10)))
        << axis << " at " << position(axis);
  }
  pause(std::chrono::milliseconds(300));
  EXPECT_NEAR(position("x3"), x3_at, kTolerance) << "the group BG moved x3";
  EXPECT_FALSE(state("x3").moving);

  // x3 takes moves of its own again.
  const auto own = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x3", x3_at + 2.0}}));
  ASSERT_EQ(own.status, st(reply_t::DONE)) << own.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("x3", x3_at + 2.0); }, seconds(10))) << position("x3");
}

TEST_F(Uim342Lab, SilentDriveGoesOfflineWhileTheOthersKeepWorking) {
  lab.control("x3-drive", sim_control_t::SILENCE, 1);
  // Its status polls run out of retries: TIMEOUT and OFFLINE events naming the drive.
  ASSERT_TRUE(lab.client().wait_until(
      [&] { return find_event("x3", ev(event_t::OFFLINE)) != nullptr && !state("x3").online; }, seconds(15)));
  const event_t* offline = find_event("x3", ev(event_t::OFFLINE));
  EXPECT_TRUE(contains(offline->text, "x3-drive")) << offline->text;
  const event_t* timeout = find_event("x3", ev(event_t::TIMEOUT));
  ASSERT_NE(timeout, nullptr);
  EXPECT_TRUE(contains(timeout->text, "did not answer")) << timeout->text;
  for (const auto& axis : {"x1", "x2", "w"}) {
    EXPECT_EQ(find_event(axis, ev(event_t::OFFLINE)), nullptr) << axis;
    EXPECT_TRUE(state(axis).online) << axis;
  }

  // A move of the silent axis is refused or fails, naming it; nothing starts.
  const auto refused = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"x3", 1.0}}));
  EXPECT_TRUE(refused.status == st(reply_t::REJECTED) || refused.status == st(reply_t::FAILED)) << refused.reason;
  EXPECT_TRUE(contains(refused.reason, "x3")) << refused.reason;
  EXPECT_TRUE(lab.starts_of("x3-drive").empty());

  // The rest of its group and the other drive still move (the group without x3 cannot use the
  // group BG, which would reach x3 too: they start node by node, on one trigger).
  const Values targets{{"x1", 4.0}, {"x2", 6.0}, {"w", -3.0}};
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, targets));
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  for (const auto& [axis, target] : targets) {
    EXPECT_TRUE(lab.client().wait_until([&, &a = axis, &t = target] { return settled_at(a, t); }, seconds(10)))
        << axis << " at " << position(axis);
  }
  EXPECT_EQ(lab.starts_of("x1-drive").size(), 1u);
  EXPECT_EQ(lab.starts_of("x2-drive").size(), 1u);
  EXPECT_TRUE(lab.starts_of("x3-drive").empty());

  // Answering again: identified, set up and online again; the whole group starts on one BG.
  const std::size_t seen = events.size();
  lab.control("x3-drive", sim_control_t::SILENCE, 0);
  ASSERT_TRUE(lab.client().wait_until(
      [&] { return find_event("x3", ev(event_t::ONLINE), seen) != nullptr && state("x3").online; }, seconds(30)));
  ASSERT_TRUE(lab.client().wait_until([&] { return state("x3").enabled; }, seconds(10)));
  lab.clear_reports();
  const auto group = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x1", 1.0}, {"x2", 2.0}, {"x3", 3.0}}));
  ASSERT_EQ(group.status, st(reply_t::DONE)) << group.reason;
  const auto x1 = lab.starts_of("x1-drive");
  const auto x3 = lab.starts_of("x3-drive");
  ASSERT_EQ(x1.size(), 1u);
  ASSERT_EQ(x3.size(), 1u);
  EXPECT_EQ(x1[0].frame_utime, x3[0].frame_utime);
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("x3", 3.0); }, seconds(10))) << position("x3");
}

TEST_F(Uim342Lab, PowerCycledMidMoveSaysPositionLostRefusesMovesUntilItsPositionIsSet) {
  // A known position first (the origin set to 10 mm), then a long move of w alone.
  const auto set = lab.call(Client::make(request_t::SET_POSITION, Values{{"w", 10.0}}));
  ASSERT_EQ(set.status, st(reply_t::DONE)) << set.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return settled_at("w", 10.0); }, seconds(10))) << position("w");
  std::vector<reply_t> replies;
  const auto id = lab.client().send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"w", 48.0}}),
                                    [&](const reply_t& r) { replies.push_back(r); });
  ASSERT_NE(id, 0);
  ASSERT_TRUE(lab.client().wait_until([&] { return state("w").moving && position("w") > 12.0; }, seconds(10)))
      << position("w");
  const std::size_t seen = events.size();
  lab.control("w-drive", sim_control_t::POWER_CYCLE);  // back at once: counter 0, driver off, no message (§5.3)

  // Exactly one terminal reply, not DONE, naming what happened; w at rest, not at its target.
  const auto terminal = [&] {
    return std::count_if(replies.begin(), replies.end(),
                         [](const reply_t& r) { return client::is_terminal(r.status); });
  };
  ASSERT_TRUE(lab.client().wait_until([&] { return terminal() == 1; }, seconds(15)));
  const auto end =
      *std::find_if(replies.begin(), replies.end(), [](const reply_t& r) { return client::is_terminal(r.status); });
  EXPECT_NE(end.status, st(reply_t::DONE)) << end.reason;
  EXPECT_TRUE(contains(end.reason, "powered up")) << end.reason;
  // The state says it: not homed, position lost, at rest; a REBOOT event names the axis.
  ASSERT_TRUE(lab.client().wait_until(
      [&] { return state("w").fault_code == motionlcm::axis_state_t::POSITION_LOST && !state("w").moving; },
      seconds(10)))
      << state("w").fault_code << " " << state("w").fault_text;
  EXPECT_FALSE(state("w").homed);
  EXPECT_FALSE(state("w").fault);
  EXPECT_TRUE(contains(state("w").fault_text, "position lost")) << state("w").fault_text;
  const event_t* lost = find_event("w", ev(event_t::REBOOT), seen);
  ASSERT_NE(lost, nullptr);
  EXPECT_TRUE(contains(lost->text, "position lost")) << lost->text;
  // Set up again (its RAM settings are gone): online, and it can be enabled.
  const auto set_up_again = [&] {
    return std::any_of(events.begin() + static_cast<std::ptrdiff_t>(seen), events.end(), [](const event_t& e) {
      return e.axis == "w" && e.kind == ev(event_t::ONLINE) && contains(e.text, "set up");
    });
  };
  ASSERT_TRUE(lab.client().wait_until([&] { return set_up_again() && state("w").online; }, seconds(15)));
  ASSERT_TRUE(lab.enable(Axes{"w"}));
  // Moves and jogs are refused, naming the axis; the others still move.
  lab.clear_reports();
  const auto refused = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"w", 1.0}}));
  EXPECT_EQ(refused.status, st(reply_t::REJECTED)) << refused.reason;
  EXPECT_EQ(refused.error_code, code(ReplyError::kPositionLost)) << refused.reason;
  EXPECT_TRUE(contains(refused.reason, "w")) << refused.reason;
  const auto jog = lab.call(Client::make(request_t::JOG, Values{{"w", 5.0}}));
  EXPECT_EQ(jog.status, st(reply_t::REJECTED)) << jog.reason;
  EXPECT_EQ(jog.error_code, code(ReplyError::kPositionLost)) << jog.reason;
  EXPECT_TRUE(lab.starts_of("w-drive").empty());
  const auto others = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x1", 2.0}}));
  EXPECT_EQ(others.status, st(reply_t::DONE)) << others.reason;
  // Its position set: valid again, and it moves.
  const auto again = lab.call(Client::make(request_t::SET_POSITION, Values{{"w", 0.0}}));
  ASSERT_EQ(again.status, st(reply_t::DONE)) << again.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return state("w").fault_code != motionlcm::axis_state_t::POSITION_LOST; },
                                      seconds(5)));
  const auto moved = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"w", 3.0}}));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return settled_at("w", 3.0); }, seconds(10))) << position("w");
}

}  // namespace
}  // namespace motion::testing
