// Ordinary requests outside the demo's path: axes already at their target, planning and arming
// failures, relative steps, set-position, reset, homing, stops, the active-request limit, refused
// (security) requests.
#include "coordinator_fixture.hpp"

namespace motion::coordinator::test_fixture {
namespace {

std::vector<gateway_command_t> commands_of_kind(const std::vector<gateway_command_t>& all, std::int8_t kind) {
  std::vector<gateway_command_t> out;
  for (const auto& c : all) {
    if (c.kind == kind) out.push_back(c);
  }
  return out;
}

TEST_F(CoordinatorTest, AxisAlreadyAtItsTargetIsDoneWithoutACommandWhileItsPartnerMoves) {
  auto_execute_moves();
  const auto r = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {0.0, 1.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::DONE}) << r.reason;
  const auto arms = commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE);
  ASSERT_EQ(arms.size(), 1u);
  ASSERT_EQ(arms[0].num_axes, 1);
  EXPECT_EQ(arms[0].axes[0].axis, "y");
  EXPECT_DOUBLE_EQ(gateways.states["y"].position, 1.0);
}

TEST_F(CoordinatorTest, MoveWithEveryAxisAtItsTargetIsDoneAtOnceWithoutBusTraffic) {
  auto_execute_moves();
  gateways.put("c", 30, false);  // 3.0 units
  pump(milliseconds(100));
  // A relative move below one count rounds to the position it starts from.
  const auto absolute = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {0.0, 3.0}));
  const auto relative = run_to_terminal(send(request_t::MOVE_RELATIVE, {"x"}, {0.004}));
  EXPECT_EQ(absolute.status, std::int8_t{reply_t::DONE}) << absolute.reason;
  EXPECT_EQ(relative.status, std::int8_t{reply_t::DONE}) << relative.reason;
  EXPECT_TRUE(gateways.commands.empty()) << gateways.commands.size() << " gateway commands";
  EXPECT_TRUE(gateways.triggers.empty());
}

TEST_F(CoordinatorTest, PlanningFailureIsRejectedAndSendsNothing) {
  auto_execute_moves();
  const auto refused = terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {7.77, 1.0}));
  EXPECT_EQ(refused.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kPlanningFailed));
  EXPECT_NE(refused.reason.find("777 counts"), std::string::npos) << refused.reason;
  EXPECT_TRUE(gateways.commands.empty()) << "a refused plan sent " << gateways.commands.size() << " commands (a STOP?)";
  // Nothing is left busy: the next move of the same axes runs.
  const auto next = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {1.0, 1.0}));
  EXPECT_EQ(next.status, std::int8_t{reply_t::DONE}) << next.reason;
}

TEST_F(CoordinatorTest, ArmingFailureDisarmsEveryArmedPartBeforeTheTerminalReply) {
  std::size_t replies_when_disarmed = 0;
  std::int64_t move = 0;
  gateways.on_command = [&](const gateway_command_t& c) {
    if (c.kind == gateway_command_t::ARM_MOVE) {
      gateways.reply(c, c.bus == "rs485" ? gateway_reply_t::FAILED : gateway_reply_t::ARMED,
                     "drive refused the profile");
    } else if (c.kind == gateway_command_t::DISARM) {
      replies_when_disarmed = replies[move].size();
      gateways.reply(c, gateway_reply_t::DONE);
    }
  };
  move = send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {1.0, 1.0});
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kArmFailed));
  EXPECT_NE(r.reason.find("bus rs485: drive refused the profile"), std::string::npos) << r.reason;
  const auto disarms = commands_of_kind(gateways.commands, gateway_command_t::DISARM);
  ASSERT_FALSE(disarms.empty());
  const auto arm = commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE).front();
  bool can0_disarmed = false;
  for (const auto& d : disarms) can0_disarmed = can0_disarmed || (d.bus == "can0" && d.trigger_id == arm.trigger_id);
  EXPECT_TRUE(can0_disarmed) << "the armed part on can0 was not released by trigger id";
  EXPECT_EQ(replies_when_disarmed, 1u) << "the terminal reply went out before the DISARM";
  EXPECT_TRUE(commands_of_kind(gateways.commands, gateway_command_t::STOP).empty()) << "nothing moved: no STOP";
  EXPECT_TRUE(gateways.triggers.empty());
}

TEST_F(CoordinatorTest, RelativeStepsCountFromTheCommandedTargetAndRoundOnce) {
  auto_execute_moves();
  std::vector<std::int64_t> targets;
  for (const double step : {4.0, 4.0, 100.0}) {
    const auto r = run_to_terminal(send(request_t::MOVE_RELATIVE, {"r"}, {step}));
    ASSERT_EQ(r.status, std::int8_t{reply_t::DONE}) << r.reason;
    targets.push_back(commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE).back().axes[0].target_counts);
  }
  // 4, 8 and 108 degrees at 8.89 counts per degree, each rounded once from user units.
  EXPECT_EQ(targets, (std::vector<std::int64_t>{36, 71, 960}));
  // Moved by anything else, the axis counts from where it stands.
  gateways.put("r", 100, false);
  pump(milliseconds(100));
  run_to_terminal(send(request_t::MOVE_RELATIVE, {"r"}, {1.0}));
  EXPECT_EQ(commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE).back().axes[0].target_counts, 109);
}

TEST_F(CoordinatorTest, OutOfRangeSetPositionScaleAndTimeoutAreRejectedNamingTheValue) {
  auto_execute_moves();
  const auto position = terminal(send(request_t::SET_POSITION, {"x"}, {100.0}));
  EXPECT_EQ(position.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(position.error_code, static_cast<int>(ReplyError::kOutsideLimits));
  EXPECT_NE(position.reason.find("position 100 "), std::string::npos) << position.reason;
  EXPECT_EQ(terminal(send(request_t::SET_POSITION, {"x"}, {1e12})).error_code,
            static_cast<int>(ReplyError::kOutsideLimits));

  const auto timeout = terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0}, -5));
  EXPECT_EQ(timeout.error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_NE(timeout.reason.find("timeout_ms -5"), std::string::npos) << timeout.reason;

  request_t slow{};
  slow.client_id = "test";
  slow.request_id = 900;
  slow.kind = request_t::MOVE_ABSOLUTE;
  slow.axes = {"x"};
  slow.values = {1.0};
  slow.num_axes = 1;
  slow.velocity_scale = 1.5;
  client.publish(slow);
  const auto scale = terminal(900);
  EXPECT_EQ(scale.error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_NE(scale.reason.find("velocity_scale 1.5"), std::string::npos) << scale.reason;
  // A plan longer than the request's timeout is refused up front, not failed on the timeout.
  const auto too_long = terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0}, 50));
  EXPECT_EQ(too_long.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(too_long.error_code, static_cast<int>(ReplyError::kPlanningFailed));
  EXPECT_TRUE(gateways.commands.empty());
}

TEST_F(CoordinatorTest, ResetIsDoneOnlyOnceTheAxisStateShowsNoFault) {
  gateways.states["x"].fault = true;
  gateways.states["x"].fault_text = "stall";
  bool clear_after_reset = true;
  gateways.on_command = [&](const gateway_command_t& c) {
    gateways.reply(c, gateway_reply_t::DONE);  // before the drive's state shows it
    if (c.kind == gateway_command_t::FAULT_RESET && clear_after_reset) {
      loop.call_after(milliseconds(200), [this] { gateways.states["x"].fault = false; });
    }
  };
  pump(milliseconds(100));
  const auto reset = send(request_t::FAULT_RESET, {"x"}, {0.0});
  ASSERT_TRUE(pump_until([&] { return !replies[reset].empty() && is_terminal(replies[reset].back().status); }));
  EXPECT_EQ(replies[reset].back().status, std::int8_t{reply_t::DONE}) << replies[reset].back().reason;
  // At once after DONE, the coordinator's own view agrees: a move is not refused as faulted.
  auto_execute_moves();
  const auto move = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0}));
  EXPECT_EQ(move.status, std::int8_t{reply_t::DONE}) << move.reason;

  // A drive that keeps its fault fails the reset, naming it.
  gateways.states["y"].fault = true;
  gateways.states["y"].fault_text = "over-current";
  clear_after_reset = false;
  gateways.on_command = [&](const gateway_command_t& c) { gateways.reply(c, gateway_reply_t::DONE); };
  pump(milliseconds(100));
  const auto stuck = terminal(send(request_t::FAULT_RESET, {"y"}, {0.0}));
  EXPECT_EQ(stuck.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(stuck.error_code, static_cast<int>(ReplyError::kAxisFaulted));
  EXPECT_NE(stuck.reason.find("over-current"), std::string::npos) << stuck.reason;
}

TEST_F(CoordinatorTest, HomeOfAnAxisWithoutHomingIsRejectedOnEveryFamily) {
  auto_execute_moves();
  const auto r = terminal(send(request_t::HOME, {"x", "c"}, {0.0, 0.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kUnsupported));
  EXPECT_NE(r.reason.find("axis x has no homing configured"), std::string::npos) << r.reason;
  EXPECT_TRUE(gateways.commands.empty());
}

TEST_F(CoordinatorTest, AStopSupersededByASecondStopEndsDone) {
  std::vector<gateway_command_t> stops;
  gateways.on_command = [&](const gateway_command_t& c) {
    if (c.kind != gateway_command_t::STOP) return;
    stops.push_back(c);
    if (stops.size() == 2) {
      // The gateway ends the first stop as superseded (code 14), then completes the second.
      gateway_reply_t r{};
      r.command_id = stops[0].command_id;
      r.bus = c.bus;
      r.status = gateway_reply_t::FAILED;
      r.error_code = error_code(ReplyError::kStopped);
      r.reason = "superseded by command " + std::to_string(c.command_id);
      gateways.publish(r);
      gateways.reply(c, gateway_reply_t::DONE);
    }
  };
  const auto first = send(request_t::STOP, {"x"}, {0.0});
  pump_until([&] { return stops.size() == 1; });
  const auto second = send(request_t::STOP, {"x"}, {0.0});
  EXPECT_EQ(terminal(first).status, std::int8_t{reply_t::DONE}) << terminal(first).reason;
  EXPECT_EQ(terminal(second).status, std::int8_t{reply_t::DONE});
}

TEST_F(CoordinatorTest, AMoveSentRightBehindAStopTakesTheAxisAndEndsThePreemptedMove) {
  auto_execute_moves(/*complete=*/false);
  const auto first = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0});
  pump_until([&] {
    pump_triggers();
    return !gateways.triggers.empty();
  });
  pump(milliseconds(50));
  // The stop, and without waiting for it, the next move of the same axis.
  const auto stop = send(request_t::STOP, {"x"}, {0.0});
  const auto again = send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0});
  const auto preempted = terminal(first);
  EXPECT_EQ(preempted.status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(preempted.error_code, static_cast<int>(ReplyError::kStopped));
  ASSERT_TRUE(pump_until([&] { return !replies[again].empty(); }));
  EXPECT_EQ(replies[again].front().status, std::int8_t{reply_t::ACCEPTED}) << replies[again].front().reason;
  EXPECT_NE(terminal(stop).status, std::int8_t{reply_t::REJECTED});
}

TEST_F(CoordinatorTest, BeyondMaxActiveRequestsARequestIsRefusedAsBusyButAStopPasses) {
  config.coordinator.max_active_requests = 2;
  gateways.on_command = [](const gateway_command_t&) {};  // nothing ends: requests stay active
  const auto first = send(request_t::ENABLE, {"x"}, {0.0});
  const auto second = send(request_t::ENABLE, {"c"}, {0.0});
  pump_until([&] { return !replies[first].empty() && !replies[second].empty(); });
  const auto refused = terminal(send(request_t::ENABLE, {"y"}, {0.0}));
  EXPECT_EQ(refused.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kBusy));
  EXPECT_NE(refused.reason.find("busy: 2 requests in progress (max_active_requests 2)"), std::string::npos)
      << refused.reason;
  const auto stop = send(request_t::STOP, {"y"}, {0.0});
  ASSERT_TRUE(pump_until([&] { return !replies[stop].empty(); }));
  EXPECT_EQ(replies[stop].front().status, std::int8_t{reply_t::ACCEPTED});
}

TEST_F(CoordinatorTest, RefusedRequestIsASecurityEventAndAnsweredOnlyWhenItsIdsAreAuthentic) {
  std::vector<motionlcm::event_t> security;
  client.on_event = [&](const motionlcm::event_t& e) {
    if (e.kind == motionlcm::event_t::SECURITY) security.push_back(e);
  };
  auto_execute_moves();
  request_t r{};
  r.client_id = "test";
  r.request_id = 900;
  r.kind = request_t::MOVE_ABSOLUTE;
  r.axes = {"x"};
  r.values = {5.0};
  r.num_axes = 1;
  // Ids that cannot be trusted: the event only, no reply, nothing sent to a gateway.
  loop.send_to_cores(
      [](Coordinator& c, TimePoint now) { c.on_refused_request(std::nullopt, "unsigned request refused: test", now); });
  // Authentic ids, role too low: the event and a REJECTED reply (kUnauthorized).
  loop.send_to_cores([r](Coordinator& c, TimePoint now) { c.on_refused_request(r, "role too low: test", now); });
  ASSERT_TRUE(pump_until([&] { return security.size() == 2; }));
  EXPECT_EQ(security[0].text, "unsigned request refused: test");
  EXPECT_EQ(security[0].source, "coordinator");
  EXPECT_EQ(security[0].severity, std::int8_t{motionlcm::event_t::WARNING});
  const auto refused = terminal(900);
  EXPECT_EQ(refused.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kUnauthorized));
  EXPECT_EQ(refused.reason, "role too low: test");
  EXPECT_EQ(replies.size(), 1u);
  EXPECT_TRUE(armed.empty());
  EXPECT_EQ(coordinator.active_requests(), 0u);
}

// A request sent again unchanged (its reply or itself lost on the way): the latest reply goes out
// again word for word and nothing runs twice; the same ids with other content are refused (9).
TEST_F(CoordinatorTest, ARequestSentAgainGetsItsLatestReplyAgainAndRunsOnce) {
  auto_execute_moves(/*complete=*/false);
  request_t r{};
  r.client_id = "test";
  r.request_id = 900;
  r.kind = request_t::MOVE_ABSOLUTE;
  r.axes = {"x"};
  r.values = {2.0};
  r.num_axes = 1;
  client.publish(r);
  pump_until([&] {
    pump_triggers();
    return !gateways.triggers.empty();
  });
  pump(milliseconds(30));
  const std::size_t heard = replies[900].size();
  ASSERT_GT(heard, 0u);
  r.utime += 500'000;  // sent again later: only its send time differs
  client.publish(r);
  pump(milliseconds(1));
  ASSERT_EQ(replies[900].size(), heard + 1);
  EXPECT_EQ(replies[900].back().status, replies[900][heard - 1].status);
  EXPECT_EQ(replies[900].back().utime, replies[900][heard - 1].utime);  // the same reply
  EXPECT_EQ(commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE).size(), 1u);
  request_t other = r;
  other.values = {3.0};
  client.publish(other);
  pump(milliseconds(1));
  EXPECT_EQ(replies[900].back().error_code, static_cast<int>(ReplyError::kDuplicateRequest));
  replies[900].pop_back();  // that refusal answered the other request, which shares the ids

  gateways.put("x", 200, false);  // arrives
  const auto done = terminal(900);
  EXPECT_EQ(done.status, std::int8_t{reply_t::DONE}) << done.reason;
  // Its DONE is lost on the way: the client sends the request again and hears the same DONE.
  client.publish(r);
  pump(milliseconds(1));
  ASSERT_FALSE(replies[900].empty());
  EXPECT_EQ(replies[900].back().status, std::int8_t{reply_t::DONE});
  EXPECT_EQ(replies[900].back().utime, done.utime);
  EXPECT_EQ(commands_of_kind(gateways.commands, gateway_command_t::ARM_MOVE).size(), 1u);
  // A new request id is a new request.
  auto_execute_moves();
  r.request_id = 901;
  r.values = {0.0};
  client.publish(r);
  EXPECT_EQ(run_to_terminal(901).status, std::int8_t{reply_t::DONE});
}

// Every command goes out as gateway_command2_t: a move with its plan's grid integers and the utime
// of the model it was planned with, a jog with its speed and ramps on the axis's model grids (not
// faster or steeper than asked), a stop with no motion values.
TEST_F(CoordinatorTest, CommandsGoOutAsGridIntegersOfTheModelTheyWerePlannedWith) {
  gateways.models["x"].utime = 4242;
  gateways.models["x"].velocity_step = 3.0;  // 200 counts/s is 66.67 steps: 66 goes out
  pump(milliseconds(100));
  auto_execute_moves();
  const auto moved = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {2.0}));
  ASSERT_EQ(moved.status, std::int8_t{reply_t::DONE}) << moved.reason;
  ASSERT_EQ(gateways.commands2.size(), gateways.commands.size());
  const auto& arm = gateways.commands2.at(0);
  ASSERT_EQ(arm.kind, std::int8_t{gateway_command_t::ARM_MOVE});
  EXPECT_EQ(arm.command_id, gateways.commands.at(0).command_id);
  EXPECT_EQ(arm.trigger_id, gateways.commands.at(0).trigger_id);
  ASSERT_EQ(arm.num_axes, 1);
  EXPECT_EQ(arm.axes[0].axis, "x");
  EXPECT_EQ(arm.axes[0].target_counts, 200);
  EXPECT_EQ(arm.axes[0].velocity, 500);  // the (simple) planner's natives: 5 units/s x 100
  EXPECT_EQ(arm.axes[0].acceleration, 5000);
  EXPECT_EQ(arm.axes[0].deceleration, 5000);
  EXPECT_EQ(arm.axes[0].model_utime, 4242);

  const std::size_t before = gateways.commands2.size();
  send(request_t::JOG, {"x"}, {-2.0});
  ASSERT_TRUE(pump_until([&] { return gateways.commands2.size() > before; })) << "no JOG sent";
  const auto& j = gateways.commands2.at(before);
  ASSERT_EQ(j.kind, std::int8_t{gateway_command_t::JOG});
  EXPECT_EQ(j.axes.at(0).velocity, -66);       // -200 counts/s on 3 counts/s steps, not faster
  EXPECT_EQ(j.axes.at(0).acceleration, 5000);  // 50 units/s^2 x 100 on 1 count/s^2 steps
  EXPECT_EQ(j.axes.at(0).model_utime, 4242);

  const auto stop = run_to_terminal(send(request_t::STOP, {"x"}, {0.0}));
  ASSERT_EQ(stop.status, std::int8_t{reply_t::DONE}) << stop.reason;
  const auto& s = gateways.commands2.back();
  ASSERT_EQ(s.kind, std::int8_t{gateway_command_t::STOP});
  EXPECT_EQ(s.axes.at(0).velocity, 0);
  EXPECT_EQ(s.axes.at(0).model_utime, 0);
}

// A jog slower than a ramp-time model's ramp start speed has no ramp: its ramps go out as 0 (the
// drive's own), not as the shortest ramp, whose slope the gateway's limits would refuse.
TEST_F(CoordinatorTest, AJogBelowTheRampStartSpeedSendsNoRamp) {
  auto& m = gateways.models["x"];
  m.acceleration_kind = motionlcm::drive_model_t::ACCEL_RAMP_TIME;
  m.acceleration_step = 0.001;  // ms
  m.acceleration_max = 65535;
  m.ramp_from = 300;  // counts/s
  pump(milliseconds(100));
  auto_execute_moves();
  send(request_t::JOG, {"x"}, {-2.0});  // 200 counts/s
  ASSERT_TRUE(pump_until([&] { return !gateways.commands2.empty(); })) << "no JOG sent";
  EXPECT_EQ(gateways.commands2[0].axes.at(0).velocity, -200);
  EXPECT_EQ(gateways.commands2[0].axes.at(0).acceleration, 0);
  EXPECT_EQ(gateways.commands2[0].axes.at(0).deceleration, 0);
  send(request_t::JOG, {"x"}, {4.0});  // 400 counts/s: 100 above, at 5000 counts/s^2 a 20 ms ramp
  ASSERT_TRUE(pump_until([&] { return gateways.commands2.size() > 1; })) << "no second JOG sent";
  EXPECT_EQ(gateways.commands2.back().axes.at(0).velocity, 400);
  EXPECT_EQ(gateways.commands2.back().axes.at(0).acceleration, 20);
}

}  // namespace
}  // namespace motion::coordinator::test_fixture
