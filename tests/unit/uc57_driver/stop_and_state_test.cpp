// Uc57Stack: the states it reports around a command's end (homing, a move), and stops: of a group
// with an offline node, of a node at rest, during a jog's set-up (commands_test.cpp: the other
// commands).
#include <optional>

#include <gtest/gtest.h>

#include "command_steps.hpp"
#include "harness.hpp"
#include "motion/lcm/reply_error.hpp"

namespace motion::uc57_driver::testing {
namespace {

// Synchronous TPDO1 (statusword) and TPDO2 (position) sample one SYNC. Taken one by one, the SYNC
// that ends homing published "homed, not moving" next to the previous SYNC's position (the UC57
// lab saw 224.775 degrees, the switch before the zeroing, after HOME's DONE).
TEST(Uc57Commands, HomedStateAndHomingDoneCarryTheHomedPosition) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a"});
  bench.node(1).set_value(0x6064, 0, 1998);  // on the switch, before homing zeroes the position
  bench.run_for(std::chrono::milliseconds(200));
  ASSERT_EQ(bench.statuses["a"].position_counts, 1998);

  auto home = bench.command(Cmd::HOME, {"a"});
  home.axes[0].velocity = 3200;
  home.axes[0].acceleration = 32000;
  const std::size_t from = bench.status_log.size();
  bench.execute(home);
  bench.run_for(std::chrono::milliseconds(600));
  ASSERT_EQ(bench.replies_of(home.command_id).back().status, status(Reply::DONE))
      << bench.replies_of(home.command_id).back().reason;
  const std::size_t done_at = statuses_before_reply(bench, home.command_id, Reply::DONE);
  const auto before_done = last_status_before(bench, "a", done_at);
  ASSERT_TRUE(before_done);
  EXPECT_TRUE(before_done->homed && !before_done->moving) << "DONE went out before the homed state";
  EXPECT_EQ(before_done->position_counts, 0);
  bool homed_seen = false;
  for (std::size_t i = from; i < bench.status_log.size(); ++i) {
    const auto& [axis, s] = bench.status_log[i];
    if (axis != "a") continue;
    if (s.homed) {
      homed_seen = true;
      EXPECT_EQ(s.position_counts, 0) << "status " << i << " says homed at a position from before the homing";
    }
    if (i >= done_at) {
      EXPECT_TRUE(s.homed && !s.moving) << "status " << i << " after DONE";
      EXPECT_EQ(s.position_counts, 0) << "status " << i << " after DONE";
    }
  }
  EXPECT_TRUE(homed_seen);
  EXPECT_LT(done_at, bench.status_log.size()) << "no state after DONE";
}

// The same for a move: no state says "stopped" at a position from before the move's end.
TEST(Uc57Commands, AStoppedStateAfterAMoveCarriesItsEndPosition) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a"});
  const auto c = arm(bench, {{"a", 1000}}, 0);  // trigger 0: start at once
  bench.run_for(std::chrono::milliseconds(600));
  ASSERT_EQ(bench.replies_of(c.command_id).back().status, status(Reply::DONE));
  bool started = false;  // a sample taken before the start's SYNC may still follow STARTED
  for (std::size_t i = statuses_before_reply(bench, c.command_id, Reply::STARTED); i < bench.status_log.size(); ++i) {
    const auto& [axis, s] = bench.status_log[i];
    if (axis != "a") continue;
    started = started || s.moving;
    if (started && !s.moving) { EXPECT_EQ(s.position_counts, 1000) << "status " << i; }
  }
  EXPECT_TRUE(started);
  EXPECT_EQ(bench.statuses["a"].position_counts, 1000);
}

// A group whose node fell silent is stopped with one STOP naming every axis (the coordinator's
// abort): the offline node must not keep the others running; the reply fails naming it.
TEST(Uc57Commands, StopNamingAnOfflineNodeStillStopsTheReachableOnes) {
  for (const std::int8_t kind : {Cmd::STOP, Cmd::ESTOP}) {
    SCOPED_TRACE(kind == Cmd::STOP ? "STOP" : "ESTOP");
    Bench bench;
    bench.start_ready();
    enable(bench, {"a", "b"});
    bench.node(1).motion_syncs = 1000;
    bench.node(2).motion_syncs = 1000;
    const auto move = arm(bench, {{"a", 100000}, {"b", 100000}}, 0);
    bench.run_for(std::chrono::milliseconds(300));
    ASSERT_EQ(bench.replies_of(move.command_id).back().status, status(Reply::STARTED));
    ASSERT_TRUE(bench.statuses["a"].moving);

    bench.node(2).silent = true;
    bench.run_for(std::chrono::milliseconds(500));  // heartbeat 100 ms, loss after 300 ms
    ASSERT_FALSE(bench.statuses["b"].online);
    ASSERT_EQ(bench.terminal_count(move.command_id), 1U);
    ASSERT_TRUE(bench.statuses["a"].moving);

    const auto stop = bench.command(kind, {"a", "b"});
    bench.execute(stop);
    bench.run_for(std::chrono::milliseconds(300));
    if (kind == Cmd::STOP) {
      EXPECT_TRUE(cia402::is_set(bench.node(1).controlwords.back(), cia402::ControlBit::kHalt));
    } else {
      EXPECT_EQ(bench.node(1).state(), cia402::State::kQuickStopActive);
    }
    EXPECT_FALSE(bench.statuses["a"].moving);
    ASSERT_EQ(bench.terminal_count(stop.command_id), 1U);
    const auto r = bench.replies_of(stop.command_id).back();
    EXPECT_EQ(r.status, status(Reply::FAILED));
    EXPECT_EQ(r.error_code, error_code(ReplyError::kAxisOffline));
    EXPECT_NE(r.reason.find("b-drive (node 2) is offline"), std::string::npos) << r.reason;
    EXPECT_EQ(r.reason.find("a-drive"), std::string::npos) << r.reason;
  }
}

// A STOP on a node at rest is DONE at once and leaves no task behind: the coordinator's abort of a
// failed HOME is such a STOP, fire-and-forget, and the JOG a client sent next was refused "busy with
// command 3" while the idle halt waited two SYNC cycles for its confirmation (random lab seed 1).
TEST(Uc57Commands, StopOnANodeAtRestIsDoneAtOnceAndTheNextCommandRuns) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a", "b"});
  const auto stop = bench.command(Cmd::STOP, {"a", "b"});
  bench.execute(stop);
  ASSERT_EQ(bench.terminal_count(stop.command_id), 1U) << "a STOP with nothing to stop still holds the nodes";
  EXPECT_EQ(bench.replies_of(stop.command_id).back().status, status(Reply::DONE));
  auto jog = bench.command(Cmd::JOG, {"b", "a"});
  for (auto& a : jog.axes) {
    a.velocity = -3200;
    a.acceleration = a.deceleration = 32000;
  }
  bench.execute(jog);  // at once, as the coordinator does
  bench.run_for(std::chrono::milliseconds(600));
  ASSERT_EQ(bench.terminal_count(jog.command_id), 1U);
  const auto r = bench.replies_of(jog.command_id).back();
  EXPECT_EQ(r.status, status(Reply::DONE)) << r.reason;
  EXPECT_EQ(bench.node(1).value(0x60FF), -60);
  EXPECT_FALSE(cia402::is_set(bench.node(1).controlwords.back(), cia402::ControlBit::kHalt));
  // A STOP on the jogging nodes is not "at rest": DONE only when the motors stopped.
  const auto stop_jog = bench.command(Cmd::STOP, {"a", "b"});
  bench.execute(stop_jog);
  EXPECT_EQ(bench.terminal_count(stop_jog.command_id), 0U);
  bench.run_for(std::chrono::milliseconds(300));
  ASSERT_EQ(bench.terminal_count(stop_jog.command_id), 1U);
  EXPECT_EQ(bench.replies_of(stop_jog.command_id).back().status, status(Reply::DONE));
  EXPECT_TRUE(cia402::is_set(bench.node(1).controlwords.back(), cia402::ControlBit::kHalt));
  EXPECT_FALSE(bench.statuses["a"].moving);
}

// A STOP while ENABLE is still switching a drive on ends the ENABLE (FAILED, stopped) and its
// power sequence with it: no timer of the ended sequence stays due (found by the fuzz target
// can_bus_sequences: the stack returned a deadline of "now" for ever, a busy loop in the gateway).
TEST(Uc57Commands, StopDuringEnableLeavesNoTimerDue) {
  Bench bench;
  bench.start_ready();
  const auto enable_cmd = bench.command(Cmd::ENABLE, {"a"});
  bench.stack->execute(enable_cmd, bench.now);  // no settle: the drive has not answered yet
  const auto stop = bench.command(Cmd::STOP, {"a"});
  bench.execute(stop);
  ASSERT_EQ(bench.terminal_count(enable_cmd.command_id), 1U);
  EXPECT_EQ(bench.replies_of(enable_cmd.command_id).back().status, status(Reply::FAILED));
  bench.run_for(std::chrono::seconds(2));
  EXPECT_EQ(bench.terminal_count(stop.command_id), 1U);
  EXPECT_GT(bench.stack->process(bench.now), bench.now) << "a deadline that is already due, for ever";
  const auto again = bench.command(Cmd::ENABLE, {"a"});
  bench.execute(again);
  bench.run_for(std::chrono::seconds(1));
  ASSERT_EQ(bench.terminal_count(again.command_id), 1U);
  EXPECT_EQ(bench.replies_of(again.command_id).back().status, status(Reply::DONE));
}

// A STOP while a JOG's SDO writes are still going out ends the jog there: neither the velocity
// mode nor the jog's speed reaches the drive behind the halt.
TEST(Uc57Commands, StopDuringAJogsSetUpEndsItsSdoChain) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a"});
  auto jog = bench.command(Cmd::JOG, {"a"});
  jog.axes[0].velocity = -3200;
  jog.axes[0].acceleration = jog.axes[0].deceleration = 32000;
  bench.execute(jog);
  const auto stop = bench.command(Cmd::STOP, {"a"});
  bench.execute(stop);
  bench.run_for(std::chrono::milliseconds(600));
  ASSERT_EQ(bench.terminal_count(jog.command_id), 1U);
  EXPECT_EQ(bench.replies_of(jog.command_id).back().error_code, error_code(ReplyError::kStopped));
  ASSERT_EQ(bench.terminal_count(stop.command_id), 1U);
  EXPECT_EQ(bench.replies_of(stop.command_id).back().status, status(Reply::DONE));
  EXPECT_NE(bench.node(1).value(0x60FF), -60) << "the superseded jog's speed was written";
  EXPECT_NE(bench.node(1).value(0x6060), 3) << "the superseded jog switched the mode";
  // The node is free for the next command.
  const auto zero = bench.command(Cmd::SET_POSITION, {"a"});
  bench.execute(zero);
  bench.run_for(std::chrono::milliseconds(300));
  EXPECT_EQ(bench.replies_of(zero.command_id).back().status, status(Reply::DONE));
}

}  // namespace
}  // namespace motion::uc57_driver::testing
