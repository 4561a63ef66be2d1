// A request's lifecycle across gateways: arm, trigger, complete; preemption, group aborts, lost,
// restarted and silent gateways, timeouts, the desired state of active moves. Every request ends in
// exactly one terminal reply, with the right cause.
#include "coordinator_fixture.hpp"

namespace motion::coordinator::test_fixture {
namespace {

TEST_F(CoordinatorTest, SynchronizedMoveAcrossTwoBusesArmsTriggersAndCompletes) {
  auto_execute_moves();
  const auto id = send(request_t::MOVE_ABSOLUTE, {"x", "y", "c"}, {1.0, -2.0, 3.0});
  const auto r = run_to_terminal(id);
  EXPECT_EQ(r.status, std::int8_t{reply_t::DONE}) << r.reason;
  EXPECT_DOUBLE_EQ(r.progress, 1.0);
  ASSERT_EQ(r.positions.size(), 3u);
  EXPECT_DOUBLE_EQ(r.positions[0], 1.0);
  EXPECT_DOUBLE_EQ(r.positions[2], 3.0);
  // Every bus got one ARM_MOVE with the same trigger id; one trigger names both buses.
  ASSERT_EQ(gateways.triggers.size(), 1u);
  EXPECT_EQ(gateways.triggers[0].num_buses, 2);
  const auto& arms = armed[gateways.triggers[0].trigger_id];
  ASSERT_EQ(arms.size(), 2u);
  std::int64_t x_target = 0;
  for (const auto& c : arms)
    for (const auto& a : c.axes)
      if (a.axis == "x") x_target = a.target_counts;
  EXPECT_EQ(x_target, 100);
  // Cross-bus trigger is scheduled ahead; the order of replies was ACCEPTED, STARTED, ..., DONE.
  EXPECT_GT(gateways.triggers[0].fire_utime, gateways.triggers[0].utime);
  // The scheduled trigger: each bus hands its start frame over early by its wire time (from the
  // drive models), so both act at act_utime; the old trigger's fire time is the earliest hand-over.
  ASSERT_EQ(gateways.triggers2.size(), 1u);
  const auto& t2 = gateways.triggers2[0];
  EXPECT_EQ(t2.trigger_id, gateways.triggers[0].trigger_id);
  ASSERT_EQ(t2.buses, (std::vector<std::string>{"can0", "rs485"}));
  EXPECT_DOUBLE_EQ(t2.lead_us[0], 70.0);   // x + y: one group BG
  EXPECT_DOUBLE_EQ(t2.lead_us[1], 694.0);  // c: the broadcast
  EXPECT_EQ(t2.send_utime[0], t2.act_utime - 70);
  EXPECT_EQ(t2.send_utime[1], t2.act_utime - 694);
  EXPECT_EQ(t2.send_utime[1], gateways.triggers[0].fire_utime);
  EXPECT_EQ(t2.num_starts, 2);
  EXPECT_DOUBLE_EQ(t2.predicted_spread_us, 0.0);
  const auto& all = replies[id];
  EXPECT_EQ(all.front().status, std::int8_t{reply_t::ACCEPTED});
  EXPECT_TRUE(std::any_of(all.begin(), all.end(), [](const reply_t& x) { return x.status == reply_t::STARTED; }));
}

// A serial line's LINE_TIMING (its longest poll exchange, which may be under way when the gateway
// hears the trigger) makes a start of several buses ask for the trigger that much earlier before
// that bus's hand-over; the act instant moves, the leads (and so the acts' order) do not. A start
// of one bus is not delayed: its frames wait for the line together.
TEST_F(CoordinatorTest, ASerialLinesStartWaitIsHeardBeforeItsHandOver) {
  auto_execute_moves();
  std::vector<motionlcm::event_t> events;
  client.on_event = [&](const motionlcm::event_t& e) { events.push_back(e); };
  const auto two_bus = [&](double at) {
    const auto made = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {at, at}));
    EXPECT_EQ(made.status, std::int8_t{reply_t::DONE}) << made.reason;
    return gateways.triggers2.back();
  };
  const auto before = two_bus(1.0);
  ASSERT_EQ(before.buses, (std::vector<std::string>{"can0", "rs485"}));
  const std::int64_t lead = before.act_utime - before.utime - 694;  // the trigger lead in force
  EXPECT_EQ(before.send_utime[1] - before.utime, lead);
  gateways.lines["rs485"].bus = "rs485";
  gateways.lines["rs485"].start_wait_us = 20'000.0;
  pump(milliseconds(100));
  const auto after = two_bus(2.0);
  EXPECT_EQ(after.lead_us, before.lead_us);
  EXPECT_DOUBLE_EQ(after.lead_us[1], 694.0);
  EXPECT_EQ(after.send_utime[1], after.act_utime - 694);
  EXPECT_EQ(after.send_utime[1] - after.utime, lead + 20'000) << "rs485 hears it its start wait earlier";
  EXPECT_EQ(after.predicted_spread_us, before.predicted_spread_us);
  // One bus: the act instant is its lead after the trigger, wait or not.
  const auto one = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"c"}, {3.0}));
  EXPECT_EQ(one.status, std::int8_t{reply_t::DONE}) << one.reason;
  EXPECT_EQ(gateways.triggers2.back().act_utime - gateways.triggers2.back().utime, 694);
  // A wait that is not a time from 0 to 1 s is refused with an event naming it, and the last good
  // one stays.
  for (const double bad : {-1.0, 2e6, std::nan("")}) {
    gateways.lines["rs485"].start_wait_us = bad;
    pump(milliseconds(100));
    ASSERT_FALSE(events.empty());
    EXPECT_EQ(events.back().kind, std::int16_t{motionlcm::event_t::PROTOCOL_ERROR});
    EXPECT_NE(events.back().text.find("line timing of bus rs485 ignored: start_wait_us"), std::string::npos)
        << events.back().text;
  }
  const auto kept = two_bus(4.0);
  EXPECT_EQ(kept.send_utime[1] - kept.utime, lead + 20'000);
}

// The trigger lead of a move of two buses adapts to when the gateways heard the recent triggers
// (TRIGGER_HEARD): the configured 30 ms until each bus has 8 samples, then the slower bus's p99 x
// 1.5 + 2 ms; a trigger heard late raises it again, up to 30 ms.
TEST_F(CoordinatorTest, TwoBusMoveSchedulesItsStartWithTheAdaptedTriggerLead) {
  auto_execute_moves();
  std::map<std::string, std::int64_t> delay_us{{"can0", 1'200}, {"rs485", 4'000}};
  std::size_t heard = 0;
  const auto hear = [&] {
    for (; heard < gateways.triggers2.size(); ++heard) {
      const auto& t = gateways.triggers2[heard];
      for (std::size_t i = 0; i < t.buses.size(); ++i) {
        motionlcm::trigger_heard_t h{};
        h.bus = t.buses[i];
        h.trigger_id = t.trigger_id;
        h.trigger_utime = t.utime;
        h.send_utime = t.send_utime[i];
        h.utime = t.utime + delay_us.at(h.bus);
        loop.send_to_cores([h](Coordinator& c, TimePoint now) { c.on_trigger_heard(h, now); });
      }
    }
  };
  // The lead in force: the first hand-over (the broadcast on rs485, the longest start frame)
  // after the trigger's publication.
  const auto lead_of = [](const motionlcm::sync_trigger2_t& t) {
    return *std::min_element(t.send_utime.begin(), t.send_utime.end()) - t.utime;
  };
  const auto move = [&](double to) {
    const auto id = send(request_t::MOVE_ABSOLUTE, {"x", "y", "c"}, {to, to, to});
    EXPECT_TRUE(pump_until([&] {
      pump_triggers();
      hear();
      for (const auto& r : replies[id])
        if (is_terminal(r.status)) return true;
      return false;
    }));
    EXPECT_EQ(terminal(id).status, std::int8_t{reply_t::DONE});
    return gateways.triggers2.back();
  };
  for (int i = 0; i < 8; ++i) {
    const auto t = move(i % 2 == 0 ? 1.0 : 0.0);
    EXPECT_EQ(lead_of(t), 30'000) << "move " << i << ": fewer than 8 samples, the configured lead";
    EXPECT_EQ(t.act_utime - t.utime, 30'000 + 694);
  }
  auto t = move(1.0);
  EXPECT_EQ(lead_of(t), 4'000 * 3 / 2 + 2'000);  // rs485's p99 decides
  EXPECT_EQ(t.act_utime - t.utime, 8'000 + 694);
  EXPECT_EQ(coordinator.trigger_lead_us({"can0", "rs485"}), 8'000);
  // A move of one bus still starts at once.
  const auto one = send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {0.5, 0.5});
  run_to_terminal(one);
  EXPECT_EQ(lead_of(gateways.triggers2.back()), 0);
  // rs485 hears the next trigger 12 ms after it was published, 4 ms after its send time: the lead grows
  // to cover that (12 x 1.5 + 2), and to the configured 30 ms for a delay beyond it.
  delay_us["rs485"] = 12'000;
  move(0.0);
  EXPECT_EQ(lead_of(move(1.0)), 20'000);
  delay_us["rs485"] = 25'000;
  move(0.0);
  EXPECT_EQ(lead_of(move(1.0)), 30'000);
  // A hearing of a trigger it never sent, or of an unknown bus, is no sample.
  motionlcm::trigger_heard_t stray{};
  stray.bus = "can9";
  stray.trigger_id = t.trigger_id;
  stray.utime = t.utime + 1'000'000;
  loop.send_to_cores([stray](Coordinator& c, TimePoint now) { c.on_trigger_heard(stray, now); });
  stray.bus = "can0";
  stray.trigger_id = 999'999;
  loop.send_to_cores([stray](Coordinator& c, TimePoint now) { c.on_trigger_heard(stray, now); });
  pump(milliseconds(10));
  EXPECT_EQ(coordinator.trigger_lead_us({"can0"}), 5'000);  // 1.2 ms x 1.5 + 2 ms, below the 5 ms minimum
}

TEST_F(CoordinatorTest, BusyAxisIsRejectedAndStopPreemptsTheMove) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {5.0, 5.0});
  pump_until([&] {
    pump_triggers();
    return !gateways.triggers.empty();
  });
  pump(milliseconds(50));
  EXPECT_EQ(terminal(send(request_t::MOVE_ABSOLUTE, {"y"}, {1.0})).error_code, static_cast<int>(ReplyError::kAxisBusy));
  const auto stop = send(request_t::STOP, {"y"}, {0.0});
  const auto moved = terminal(move);
  EXPECT_EQ(moved.status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(moved.error_code, static_cast<int>(ReplyError::kStopped));
  EXPECT_EQ(terminal(stop).status, std::int8_t{reply_t::DONE});
}

TEST_F(CoordinatorTest, StallOfOneAxisAbortsTheGroupAndStopsTheOthers) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {5.0, 5.0});
  pump_until([&] {
    pump_triggers();
    return !gateways.triggers.empty();
  });
  pump(milliseconds(50));
  motionlcm::event_t stall{};
  stall.axis = "y";
  stall.bus = "can0";
  stall.kind = motionlcm::event_t::STALL;
  stall.severity = motionlcm::event_t::ERROR;
  stall.text = "motor stall detected";
  gateways.publish(stall);
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kAxisFault));
  EXPECT_NE(r.reason.find("axis y: motor stall detected"), std::string::npos) << r.reason;
  const bool stopped_both =
      std::any_of(gateways.commands.begin(), gateways.commands.end(),
                  [](const gateway_command_t& c) { return c.kind == gateway_command_t::STOP && c.num_axes == 2; });
  EXPECT_TRUE(stopped_both);
}

// A coordinator started after its gateways has missed their last heartbeat: their axis states
// show them alive at once (no heartbeat period of "gateway offline"); when the states stop too,
// the gateway is offline after gateway_timeout_ms as before.
struct CoordinatorWithoutHeartbeats : CoordinatorTest {
  void SetUp() override {
    gateways.heartbeats = false;
    CoordinatorTest::SetUp();
  }
};

TEST_F(CoordinatorWithoutHeartbeats, AxisStatesShowTheGatewayAliveUntilTheyStop) {
  auto_execute_moves();
  const auto moved = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {2.0, 3.0}));
  EXPECT_EQ(moved.status, std::int8_t{reply_t::DONE}) << moved.reason;
  gateways.silent.insert("rs485");
  pump(milliseconds(500));
  const auto refused = terminal(send(request_t::MOVE_ABSOLUTE, {"c"}, {1.0}));
  EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kGatewayOffline)) << refused.reason;
  // Its first heartbeat is not taken for a restart.
  gateways.silent.erase("rs485");
  gateways.heartbeats = true;
  pump(milliseconds(200));
  EXPECT_EQ(run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"c"}, {1.0})).status, std::int8_t{reply_t::DONE});
}

// The desired state of active moves: one row per axis with request, bus, gateway command,
// target (counts and user units) and fire time, republished while the move runs, then an empty
// message once it is done.
// Rows a gateway kept from a coordinator that died: each request that is not this coordinator's
// own ends once, ABORTED with code 20 naming its axes, however often the rows arrive; a request
// this coordinator runs is left alone.
TEST_F(CoordinatorTest, OrphanedMovesOfAPredecessorEndOnceAndOwnRequestsAreLeftAlone) {
  auto_execute_moves(/*complete=*/false);
  const auto own = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0});
  ASSERT_TRUE(pump_until([&] {
    pump_triggers();
    return !replies[own].empty() && replies[own].back().status == reply_t::STARTED;
  }));
  motionlcm::active_moves_t rows{};
  const auto row = [&rows](const std::string& axis, const std::string& client_id, std::int64_t request) {
    rows.axes.push_back(axis);
    rows.buses.push_back("can0");
    rows.client_ids.push_back(client_id);
    rows.request_ids.push_back(request);
    rows.kinds.push_back(std::int8_t{request_t::MOVE_ABSOLUTE});
    rows.phases.push_back(std::int8_t{motionlcm::active_moves_t::MOVING});
    rows.command_ids.push_back(1);
    rows.target_counts.push_back(0);
    rows.targets.push_back(0.0);
    rows.fire_utime.push_back(1);
    rows.num_axes = static_cast<std::int32_t>(rows.axes.size());
  };
  row("y", "test", 7001);
  row("r", "test", 7001);
  row("x", "test", own);
  for (int i = 0; i < 2; ++i) {
    loop.send_to_cores([rows](Coordinator& c, TimePoint now) { c.on_orphaned_moves(rows, now); });
    pump(milliseconds(50));
  }
  ASSERT_EQ(replies[7001].size(), 1u);
  EXPECT_EQ(replies[7001][0].status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(replies[7001][0].error_code, static_cast<int>(ReplyError::kCoordinatorRestarted));
  EXPECT_NE(replies[7001][0].reason.find("y (can0), r (can0)"), std::string::npos) << replies[7001][0].reason;
  for (const auto& r : replies[own]) EXPECT_FALSE(is_terminal(r.status)) << "its own request was ended: " << r.reason;
}

TEST_F(CoordinatorTest, ActiveMovesAreRepublishedWhileTheyRunAndClearedAtTheEnd) {
  std::vector<motionlcm::active_moves_t> seen;
  client.on_active_moves = [&](const motionlcm::active_moves_t& m) { seen.push_back(m); };
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {5.0, 2.0});
  ASSERT_TRUE(pump_until([&] {
    pump_triggers();
    return std::count_if(seen.begin(), seen.end(), [](const auto& m) { return m.num_axes == 2; }) >=
           3;  // fire + 2 periods
  }));
  const auto& m = seen.back();
  ASSERT_EQ(m.num_axes, 2);
  EXPECT_EQ(m.axes, (std::vector<std::string>{"x", "c"}));
  EXPECT_EQ(m.buses, (std::vector<std::string>{"can0", "rs485"}));
  EXPECT_EQ(m.request_ids[0], move);
  EXPECT_EQ(m.client_ids[1], "test");
  EXPECT_EQ(m.phases[0], std::int8_t{motionlcm::active_moves_t::MOVING});
  EXPECT_EQ(m.target_counts, (std::vector<std::int64_t>{500, 20}));  // 100 and 10 counts per unit
  EXPECT_DOUBLE_EQ(m.targets[0], 5.0);
  EXPECT_DOUBLE_EQ(m.targets[1], 2.0);
  EXPECT_NE(m.command_ids[0], 0);
  EXPECT_NE(m.command_ids[0], m.command_ids[1]);  // one ARM_MOVE per bus
  ASSERT_EQ(gateways.triggers.size(), 1u);
  EXPECT_EQ(m.fire_utime[0], gateways.triggers[0].fire_utime);
  // The axes arrive: DONE, and the set is published empty once.
  gateways.put("x", 500, false);
  gateways.put("c", 20, false);
  EXPECT_EQ(terminal(move).status, std::int8_t{reply_t::DONE});
  ASSERT_TRUE(pump_until([&] { return seen.back().num_axes == 0; }));
  const auto count = seen.size();
  pump(milliseconds(1200));
  EXPECT_EQ(seen.size(), count);  // nothing active: nothing more
}

TEST_F(CoordinatorTest, LostGatewayAbortsTheRequestAndStopsTheOtherBus) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {5.0, 5.0});
  pump_until([&] {
    pump_triggers();
    return !gateways.triggers.empty();
  });
  gateways.silent.insert("rs485");
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::ABORTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kGatewayLost));
  EXPECT_NE(r.reason.find("bus rs485"), std::string::npos) << r.reason;
  EXPECT_TRUE(std::any_of(gateways.commands.begin(), gateways.commands.end(), [](const gateway_command_t& c) {
    return c.kind == gateway_command_t::STOP && c.bus == "can0";
  }));
}

TEST_F(CoordinatorTest, RestartedGatewayAbortsTheRequest) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0});
  pump_until([&] {
    pump_triggers();
    return !gateways.triggers.empty();
  });
  gateways.pid_of["can0"] = 101;  // a new process on the same bus
  const auto r = terminal(move);
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kGatewayLost));
  EXPECT_NE(r.reason.find("restarted"), std::string::npos) << r.reason;
}

TEST_F(CoordinatorTest, SilentGatewayDuringArmingFailsTheRequest) {
  gateways.on_command = [](const gateway_command_t&) {};  // never answers
  const auto r = terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kArmFailed));
}

TEST_F(CoordinatorTest, ArmingDeadlineAddsTheLineTimeOfArmingFromItsArmTiming) {
  // A long serial line: arming c takes 1.5 s of frames (its ARM_TIMING says so), the arm timeout is
  // 0.5 s. Its gateway answers ARMED after 1.2 s: in time, since the line time counts on top.
  auto_execute_moves();
  const auto answer = gateways.on_command;
  gateways.on_command = [this, answer](const gateway_command_t& c) {
    if (c.kind != gateway_command_t::ARM_MOVE || c.bus != "rs485") return answer(c);
    loop.call_after(milliseconds(1200), [answer, c] { answer(c); });
  };
  gateways.armings["c"].arm_line_us = 1'500'000;
  pump(milliseconds(100));  // the timings reach the coordinator
  const auto made = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {1.0, 1.0}));
  EXPECT_EQ(made.status, std::int8_t{reply_t::DONE}) << made.reason;
  // Readying other drives of the bus counts per other drive: c has none on rs485, so the same
  // 1.5 s given as a bystander's cost adds nothing and the 1.2 s answer is too late.
  gateways.armings["c"].arm_line_us = 0;
  gateways.armings["c"].arm_bystander_us = 1'500'000;
  pump(milliseconds(100));
  const auto late = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {2.0, 2.0}));
  EXPECT_EQ(late.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(late.error_code, static_cast<int>(ReplyError::kArmFailed));
  EXPECT_NE(late.reason.find("rs485"), std::string::npos) << late.reason;
}

TEST_F(CoordinatorTest, RequestTimeoutFailsAndStops) {
  auto_execute_moves(/*complete=*/false);
  const auto move = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0}, /*timeout_ms=*/300);
  pump_until([&] {
    pump_triggers();
    return !gateways.triggers.empty();
  });
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kTimeout));
}

// LCM loses datagrams. A STARTED reply lost on the way: the move ends DONE once its axes rest at
// their targets, not at the request's timeout.
TEST_F(CoordinatorTest, ALostStartedReplyEndsTheMoveDoneOnceItsAxesArrive) {
  auto_execute_moves();
  trigger_handler = [this](const motionlcm::sync_trigger_t& t) {
    for (const auto& c : armed[t.trigger_id]) {
      if (c.bus != "rs485") gateways.reply(c, gateway_reply_t::STARTED);  // the rs485 STARTED is lost
      for (const auto& a : c.axes) gateways.put(a.axis, a.target_counts, false);
    }
  };
  const auto t0 = loop.now();
  const auto r = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {2.0, 3.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::DONE}) << r.reason;
  // By the predicted end (the plan's 0.1 s and two gateway timeouts of 400 ms), far from the
  // request's 60 s timeout.
  EXPECT_LT(loop.now() - t0, milliseconds(1500));
}

// A trigger lost on the way to one gateway: its axes never start. The move fails at its predicted
// end, naming the axis and the bus that reported no start; the group is stopped, and the axes take
// the next move.
TEST_F(CoordinatorTest, ALostTriggerFailsTheMoveAtItsPredictedEndAndFreesTheAxes) {
  auto_execute_moves();
  trigger_handler = [this](const motionlcm::sync_trigger_t& t) {
    for (const auto& c : armed[t.trigger_id]) {
      if (c.bus == "rs485") continue;  // never heard the trigger
      gateways.reply(c, gateway_reply_t::STARTED);
      for (const auto& a : c.axes) gateways.put(a.axis, a.target_counts, false);
    }
  };
  const auto t0 = loop.now();
  const auto r = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {2.0, 3.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED}) << r.reason;
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kTimeout));
  EXPECT_NE(r.reason.find("axis c rests at 0 counts, its target is 30"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("bus rs485 reported no start"), std::string::npos) << r.reason;
  EXPECT_LT(loop.now() - t0, milliseconds(1500));
  EXPECT_TRUE(std::any_of(gateways.commands.begin(), gateways.commands.end(),
                          [](const gateway_command_t& c) { return c.kind == gateway_command_t::STOP; }));
  auto_execute_moves();
  const auto next = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "c"}, {1.0, 1.0}));
  EXPECT_EQ(next.status, std::int8_t{reply_t::DONE}) << next.reason;
}

TEST_F(CoordinatorTest, GatewaysOwnErrorCodeReachesTheClient) {
  gateways.on_command = [this](const gateway_command_t& c) {
    gateway_reply_t r{};
    r.command_id = c.command_id;
    r.bus = c.bus;
    r.status = gateway_reply_t::FAILED;
    r.error_code = static_cast<std::int32_t>(ReplyError::kOutsideLimits);
    r.reason = "x-drive (node 5): value 70000 outside the range of SQT";
    gateways.publish(r);
  };
  const auto r = terminal(send(request_t::ENABLE, {"x"}, {0.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kOutsideLimits));
  EXPECT_NE(r.reason.find("bus can0: x-drive (node 5): value 70000"), std::string::npos) << r.reason;
}

TEST_F(CoordinatorTest, GatewayFailureOfASimpleCommandFailsTheRequestWithItsReason) {
  gateways.on_command = [this](const gateway_command_t& c) {
    gateways.reply(c, gateway_reply_t::FAILED, "node 5 did not answer MO=1");
  };
  const auto r = terminal(send(request_t::ENABLE, {"x"}, {0.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kDriveError));
  EXPECT_NE(r.reason.find("bus can0: node 5 did not answer MO=1"), std::string::npos) << r.reason;
}

TEST_F(CoordinatorTest, EnableOnTwoBusesIsDoneWhenBothGatewaysAre) {
  auto_execute_moves();
  const auto r = terminal(send(request_t::ENABLE, {"x", "c"}, {0.0, 0.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::DONE});
  int enables = 0;
  for (const auto& c : gateways.commands) enables += c.kind == gateway_command_t::ENABLE;
  EXPECT_EQ(enables, 2);
}

}  // namespace
}  // namespace motion::coordinator::test_fixture
