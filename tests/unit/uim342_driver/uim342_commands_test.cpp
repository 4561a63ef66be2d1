// Uim342Stack commands: enable, armed group moves and sequential starts, timeouts and drive
// errors, stall, stop and e-stop, jog, home and set position, outputs, parameters, disarm,
// refusals, foreign frames, input edges and alarms (bench: uim342_stack_fixture.hpp).
#include "motion/can_frame/bit_timing.hpp"
#include "uim342_stack_fixture.hpp"

namespace motion::gateway::test {
namespace {

TEST_F(Uim342StackTest, EnableAndDisable) {
  start_and_set_up();
  const auto on = enable({"x", "z"});
  EXPECT_EQ(statuses_of(on), (std::vector<std::int8_t>{kDone}));
  EXPECT_TRUE(drives.at(5).enabled());
  EXPECT_TRUE(drives.at(7).enabled());
  EXPECT_TRUE(stack->status("x")->enabled);
  EXPECT_EQ(sent_to(5).back(), uim342::request::driver_on(true));
  const auto off = execute(command(gateway_command_t::DISABLE, {"x"}));
  EXPECT_EQ(statuses_of(off), (std::vector<std::int8_t>{kDone}));
  EXPECT_FALSE(drives.at(5).enabled());
}

TEST_F(Uim342StackTest, ArmedGroupMoveStartsWithOneBgToTheGroupId) {
  start_and_set_up();
  enable({"x", "y"});
  auto move = command(gateway_command_t::ARM_MOVE, {"x", "y"}, 77);
  move.axes[0].target_counts = 6400;
  move.axes[1].target_counts = -3200;
  const auto id = execute(move);
  EXPECT_EQ(statuses_of(id), (std::vector<std::int8_t>{kArmed}));
  // PA first, then SP (§5.19 ordering rule), then AC and DC.
  const auto x = sent_to(5);
  const auto pa = std::find(x.begin(), x.end(), uim342::request::set_absolute_position(6400));
  ASSERT_NE(pa, x.end());
  ASSERT_LT(pa + 3, x.end());
  EXPECT_EQ(*(pa + 1), uim342::request::set_ptp_speed(3200));
  EXPECT_EQ(*(pa + 2), uim342::request::set_acceleration(10000));
  EXPECT_EQ(*(pa + 3), uim342::request::set_deceleration(10000));
  EXPECT_FALSE(drives.at(5).moving());

  // Armed nodes are not polled (the trigger goes out at once), and no deadline is due for them.
  sent.clear();
  run_for(milliseconds(200));
  EXPECT_EQ(count_sent(5, FC::kMS), 0u);
  EXPECT_EQ(count_sent(7, FC::kMS), 8u);  // z is still polled
  EXPECT_GT(stack->process(now), now);
  stack->fire(77, now);
  settle();
  EXPECT_EQ(count_sent(20, FC::kBG), 1u);
  EXPECT_EQ(count_sent(5, FC::kBG) + count_sent(6, FC::kBG), 0u);
  EXPECT_TRUE(drives.at(5).moving());
  EXPECT_TRUE(drives.at(6).moving());
  ASSERT_EQ(replies_of(id).size(), 2u);
  const auto started = replies_of(id)[1];
  EXPECT_EQ(started.status, kStarted);
  EXPECT_EQ(started.start_mechanism, "group-bg");
  EXPECT_EQ(started.predicted_skew_us, 0.0);
  EXPECT_EQ(started.trigger_utime, kEpochUs + 10'201'000);

  deliver(drives.at(5).finish_move());
  EXPECT_EQ(replies_of(id).size(), 2u);  // y still moving
  deliver(drives.at(6).finish_move());
  EXPECT_EQ(last_reply(id).status, kDone);
  EXPECT_EQ(stack->status("x")->position_counts, 6400);
  EXPECT_EQ(stack->status("y")->position_counts, -3200);
  EXPECT_TRUE(has_event(event_t::MOTION_COMPLETE, "y"));
}

TEST_F(Uim342StackTest, MoveOfAxesWithoutACommonGroupStartsSequentiallyAndEndsByPolling) {
  start_and_set_up();
  enable({"x", "z"});
  drives.at(5).notify_in_position = false;
  drives.at(7).notify_in_position = false;
  auto move = command(gateway_command_t::ARM_MOVE, {"x", "z"});  // trigger 0: start at once
  move.axes[0].target_counts = 100;
  move.axes[1].target_counts = 200;
  const auto id = execute(move);
  EXPECT_EQ(statuses_of(id), (std::vector<std::int8_t>{kArmed, kStarted}));
  EXPECT_EQ(count_sent(5, FC::kBG), 1u);
  EXPECT_EQ(count_sent(7, FC::kBG), 1u);
  const auto started = replies_of(id)[1];
  EXPECT_EQ(started.start_mechanism, "sequential");
  const auto bg = *uim342::instruction_frame(5, uim342::request::begin());
  const double frame_us = std::chrono::duration<double, std::micro>(can::frame_duration(bg, 1'000'000)).count();
  EXPECT_DOUBLE_EQ(started.predicted_skew_us, frame_us);
  run_for(milliseconds(60));
  EXPECT_EQ(last_reply(id).status, kStarted);  // polled while moving
  drives.at(5).finish_move();
  drives.at(7).finish_move();
  run_for(milliseconds(60));
  EXPECT_EQ(last_reply(id).status, kDone);
}

TEST_F(Uim342StackTest, GroupIsNotUsedWhenAGroupMemberIsNotPartOfTheMove) {
  start_and_set_up();
  enable({"x"});
  const auto id = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
  EXPECT_EQ(count_sent(20, FC::kBG), 0u);  // y is in group 20 too and must not start
  EXPECT_EQ(count_sent(5, FC::kBG), 1u);
  EXPECT_EQ(replies_of(id).at(1).start_mechanism, "sequential");
  EXPECT_EQ(replies_of(id).at(1).predicted_skew_us, 0.0);
  EXPECT_FALSE(drives.at(6).moving());
  deliver(drives.at(5).finish_move());
  EXPECT_EQ(last_reply(id).status, kDone);
}

TEST_F(Uim342StackTest, TimeoutAfterTheLastRetryFailsWithTheDriveNodeAndInstruction) {
  start_and_set_up();
  drives.at(5).silent = true;
  auto move = command(gateway_command_t::ARM_MOVE, {"x"});
  const auto id = execute(move);
  run_for(milliseconds(200));
  const auto r = last_reply(id);
  EXPECT_EQ(r.status, kFailed);
  EXPECT_EQ(r.reason, "x-drive (node 5) did not answer PA after 3 tries");
  EXPECT_EQ(r.error_code, error_code(ReplyError::kTimeout));
  EXPECT_EQ(count_sent(5, FC::kPA), 3u);
  EXPECT_EQ(count_sent(5, FC::kSP), 0u);  // nothing else of the command went out
  EXPECT_TRUE(has_event(event_t::TIMEOUT, "x"));
  EXPECT_TRUE(has_event(event_t::OFFLINE, "x"));
  EXPECT_EQ(stack->counters().retries, 2);
  EXPECT_EQ(stack->counters().timeouts, 1);
  EXPECT_FALSE(stack->ready());
}

TEST_F(Uim342StackTest, ErrorReportFailsTheCommandWithTheDriveError) {
  start_and_set_up();
  enable({"x"});
  drives.at(5).refuse[FC::kPA] = uim342::DriveErrc::kDataError;
  const auto id = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
  const auto r = last_reply(id);
  EXPECT_EQ(r.status, kFailed);
  EXPECT_EQ(r.error_code, error_code(ReplyError::kDriveError));
  EXPECT_EQ(r.reason, "x-drive (node 5) refused PA=0: instruction data error (0x33)");
  const auto* e = find_event(event_t::ERROR_REPORT);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->code, 0x33);
  EXPECT_EQ(count_sent(5, FC::kSP), 0u);
}

TEST_F(Uim342StackTest, BgWhileDriverOffIsReportedAsDriveError) {
  start_and_set_up();
  const auto id = execute(command(gateway_command_t::ARM_MOVE, {"z"}));
  EXPECT_EQ(last_reply(id).status, kFailed);
  EXPECT_EQ(last_reply(id).reason, "z-drive (node 7) refused BG: BG not allowed while the motor driver is off (0x3E)");
}

TEST_F(Uim342StackTest, StallNotificationFailsTheMoveAndRaisesAStallEvent) {
  start_and_set_up();
  enable({"x", "y"});
  const auto id = execute(command(gateway_command_t::ARM_MOVE, {"x", "y"}));
  ASSERT_EQ(last_reply(id).status, kStarted);
  deliver(drives.at(6).alarm(uim342::AlarmCode::kStall));
  const auto r = last_reply(id);
  EXPECT_EQ(r.status, kFailed);
  EXPECT_EQ(r.error_code, error_code(ReplyError::kAxisFault));
  EXPECT_EQ(r.reason, "y-drive (node 6): motor stall detected (alarm 0x1D)");
  const auto* e = find_event(event_t::STALL);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->severity, kError);
  EXPECT_TRUE(stack->status("y")->fault);
  EXPECT_EQ(stack->status("y")->fault_code, 0x1D);
  // A later in-position of x does not produce a second terminal reply (TearDown checks).
  deliver(drives.at(5).finish_move());

  // FAULT_RESET clears the flags (MS[0]=0).
  const auto reset = execute(command(gateway_command_t::FAULT_RESET, {"y"}));
  EXPECT_EQ(last_reply(reset).status, kDone);
  EXPECT_FALSE(stack->status("y")->fault);
}

TEST_F(Uim342StackTest, FaultResetOfALockedDriveFails) {
  start_and_set_up();
  drives.at(5).locked = true;
  const auto id = execute(command(gateway_command_t::FAULT_RESET, {"x"}));
  EXPECT_EQ(last_reply(id).status, kFailed);
  EXPECT_NE(last_reply(id).reason.find("locked down"), std::string::npos);
}

TEST_F(Uim342StackTest, StopEndsTheMoveAndSendsSt) {
  start_and_set_up();
  enable({"x"});
  const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
  const auto stop = execute(command(gateway_command_t::STOP, {"x"}));
  EXPECT_EQ(last_reply(move).status, kFailed);
  EXPECT_EQ(last_reply(move).error_code, error_code(ReplyError::kStopped));
  EXPECT_EQ(last_reply(stop).status, kDone);
  EXPECT_EQ(count_sent(5, FC::kST), 1u);
  EXPECT_FALSE(drives.at(5).moving());
}

// The coordinator aborts a group whose drive fell silent with one stop naming every axis: the
// offline drive must not keep the others running; it still gets its ST (it may hear), and the
// reply fails naming it and the stop as unconfirmed.
TEST_F(Uim342StackTest, StopNamingAnOfflineDriveStillStopsTheOthers) {
  start_and_set_up();
  enable({"x"});
  drives.at(7).silent = true;
  run_for(milliseconds(400));  // its polls run out of retries
  ASSERT_FALSE(stack->status("z")->online);
  for (const std::int8_t kind : {gateway_command_t::STOP, gateway_command_t::ESTOP}) {
    const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
    run_for(milliseconds(20));
    ASSERT_TRUE(drives.at(5).moving());
    sent.clear();
    const auto stop = execute(command(kind, {"x", "z"}));
    run_for(milliseconds(60));
    EXPECT_EQ(count_sent(5, FC::kST), 1u);
    EXPECT_EQ(count_sent(7, FC::kST), 1u);
    EXPECT_FALSE(drives.at(5).moving());
    EXPECT_EQ(last_reply(move).status, kFailed);
    EXPECT_EQ(last_reply(stop).status, kFailed);
    EXPECT_EQ(last_reply(stop).error_code, error_code(ReplyError::kAxisOffline));
    EXPECT_EQ(last_reply(stop).reason,
              kind == gateway_command_t::STOP
                  ? "z-drive (node 7) is offline (not answering): ST sent, stop not confirmed"
                  : "z-drive (node 7) is offline (not answering): ST and MO=0 sent, stop not confirmed");
  }
}

TEST_F(Uim342StackTest, EstopGoesAheadOfQueuedWorkAndFailsIt) {
  start_and_set_up();
  enable({"x"});
  drives.at(5).silent = true;  // keep the first request outstanding
  const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
  const auto estop = execute(command(gateway_command_t::ESTOP, {"x"}));
  EXPECT_EQ(last_reply(move).status, kFailed);
  EXPECT_EQ(last_reply(move).reason, "x-drive (node 5) stopped by ESTOP command " + std::to_string(estop));
  drives.at(5).silent = false;
  run_for(milliseconds(60));  // PA is retried, then ST goes out
  EXPECT_EQ(last_reply(estop).status, kDone);
  EXPECT_EQ(count_sent(5, FC::kSP), 0u);
  EXPECT_EQ(count_sent(5, FC::kST), 1u);
  // Like every family after an e-stop, the drive ends with its power stage off: ST, then MO=0.
  const auto x = sent_to(5);
  const auto st = std::find(x.begin(), x.end(), uim342::request::stop());
  ASSERT_NE(st, x.end());
  EXPECT_NE(std::find(st, x.end(), uim342::request::driver_on(false)), x.end()) << "no MO=0 after the ST";
  EXPECT_FALSE(stack->status("x")->enabled);
}

TEST_F(Uim342StackTest, JogLoadsJvAndBegins) {
  start_and_set_up();
  enable({"z"});
  auto jog = command(gateway_command_t::JOG, {"z"});
  jog.axes[0].velocity = -1000;
  jog.axes[0].acceleration = 0;  // keep the drive's AC/DC
  jog.axes[0].deceleration = 0;
  const auto id = execute(jog);
  EXPECT_EQ(statuses_of(id), (std::vector<std::int8_t>{kDone}));
  const auto z = sent_to(7);
  ASSERT_GE(z.size(), 2u);
  EXPECT_EQ(z[z.size() - 2], uim342::request::set_jog_velocity(-1000));
  EXPECT_EQ(z.back(), uim342::request::begin());
}

TEST_F(Uim342StackTest, HomeSetsTheOriginAndSetPositionKeepsAnOffset) {
  start_and_set_up();
  enable({"x"});
  const auto home = execute(command(gateway_command_t::HOME, {"x"}));
  EXPECT_EQ(last_reply(home).status, kDone);
  EXPECT_EQ(count_sent(5, FC::kOG), 1u);
  EXPECT_TRUE(stack->status("x")->homed);
  // x has no `homing:`: zero in place, and the reply says that no switch was searched.
  EXPECT_NE(last_reply(home).reason.find("no switch search"), std::string::npos) << last_reply(home).reason;
  EXPECT_EQ(count_sent(5, FC::kJV), 0u);

  auto set = command(gateway_command_t::SET_POSITION, {"x"});
  set.axes[0].target_counts = 1000;
  const auto id = execute(set);
  EXPECT_EQ(last_reply(id).status, kDone);
  EXPECT_EQ(stack->status("x")->position_counts, 1000);
  auto move = command(gateway_command_t::ARM_MOVE, {"x"});
  move.axes[0].target_counts = 1500;
  const auto m = execute(move);
  EXPECT_EQ(drives.at(5).target(), 500);  // drive counter = position - offset
  deliver(drives.at(5).finish_move());
  EXPECT_EQ(last_reply(m).status, kDone);
  EXPECT_EQ(stack->status("x")->position_counts, 1500);
}

TEST_F(Uim342StackTest, SetOutputsWritesOp1AndRefusesOtherBits) {
  start_and_set_up();
  auto set = command(gateway_command_t::SET_OUTPUTS, {"x"});
  set.axes[0].output_mask = 1;
  set.axes[0].output_value = 1;
  const auto id = execute(set);
  EXPECT_EQ(last_reply(id).status, kDone);
  EXPECT_EQ(sent_to(5).back(), uim342::request::set_outputs(1));
  EXPECT_EQ(stack->status("x")->outputs, 1);
  set = command(gateway_command_t::SET_OUTPUTS, {"x"});
  set.axes[0].output_mask = 2;
  const auto bad = execute(set);
  EXPECT_EQ(last_reply(bad).error_code, error_code(ReplyError::kUnsupported));
}

TEST_F(Uim342StackTest, ParameterReadAndWriteInInstructionTerms) {
  start_and_set_up();
  auto read = command(gateway_command_t::PARAM_READ, {"x"});
  read.param.space = motionlcm::param_t::UIM342_INSTRUCTION;
  read.param.index = 0x10;  // MT
  read.param.subindex = 1;  // working current
  const auto r = execute(read);
  EXPECT_EQ(last_reply(r).status, kDone);
  EXPECT_EQ(last_reply(r).param.value, 20);

  auto write = command(gateway_command_t::PARAM_WRITE, {"x"});
  write.param.space = motionlcm::param_t::UIM342_INSTRUCTION;
  write.param.index = 0x1B;  // SS
  write.param.subindex = -1;
  write.param.value = 1000;
  const auto w = execute(write);
  EXPECT_EQ(last_reply(w).status, kDone);
  EXPECT_EQ(last_reply(w).param.value, 1000);
  EXPECT_EQ(sent_to(5).back(), uim342::request::set_cut_in_speed(1000));

  write = command(gateway_command_t::PARAM_WRITE, {"x"});
  write.param.space = motionlcm::param_t::UIM342_INSTRUCTION;
  write.param.index = 0x10;  // MT[0] = 12: no such micro-step resolution
  write.param.subindex = 0;
  write.param.value = 12;
  const auto bad = execute(write);
  EXPECT_EQ(last_reply(bad).error_code, error_code(ReplyError::kOutsideLimits));

  read.command_id = ++next_id_;
  read.param.space = motionlcm::param_t::CANOPEN_OBJECT;
  const auto wrong_space = execute(read);
  EXPECT_EQ(last_reply(wrong_space).error_code, error_code(ReplyError::kUnsupported));
}

TEST_F(Uim342StackTest, DisarmEndsAnArmedMove) {
  start_and_set_up();
  enable({"x", "y"});
  const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x", "y"}, 5));
  ASSERT_EQ(last_reply(move).status, kArmed);
  const auto disarm = execute(command(gateway_command_t::DISARM, {"x", "y"}, 5));
  EXPECT_EQ(last_reply(move).status, kFailed);
  EXPECT_EQ(last_reply(disarm).status, kDone);
  stack->fire(5, now);
  settle();
  EXPECT_EQ(count_sent(20, FC::kBG), 0u);
}

TEST_F(Uim342StackTest, RefusesUnknownAxesBusyAxesAndEmptyCommands) {
  start_and_set_up();
  enable({"x"});
  EXPECT_EQ(last_reply(execute(command(gateway_command_t::ENABLE, {"q"}))).error_code,
            error_code(ReplyError::kUnknownAxis));
  EXPECT_EQ(last_reply(execute(command(gateway_command_t::ENABLE, {}))).error_code,
            error_code(ReplyError::kMalformedRequest));
  const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x"}, 9));
  EXPECT_EQ(last_reply(execute(command(gateway_command_t::JOG, {"x"}))).error_code, error_code(ReplyError::kAxisBusy));
  EXPECT_EQ(last_reply(execute(command(13 + 50, {"x"}))).error_code, error_code(ReplyError::kUnsupported));
  execute(command(gateway_command_t::DISARM, {"x"}));
  EXPECT_EQ(last_reply(move).status, kFailed);
}

TEST_F(Uim342StackTest, MalformedForeignAndUnexpectedFramesAreIgnoredAndCounted) {
  start_and_set_up();
  // From node 5, an MO ACK with a trailing byte: refused by the codec, consumed, counted.
  EXPECT_TRUE(stack->on_frame(*can::Frame::make(0x05200015, true, std::vector<std::uint8_t>{1, 0}), now));
  EXPECT_EQ(stack->counters().malformed, 1);
  // From node 99 (not configured) and a standard frame: left to other stacks.
  EXPECT_FALSE(stack->on_frame(*uim342::reply_frame(99, {FC::kMO, uim342::Byte{1}}), now));
  EXPECT_EQ(stack->counters().foreign, 1);
  EXPECT_FALSE(stack->on_frame(*can::Frame::make(0x181, false, std::vector<std::uint8_t>{1}), now));
  // A well-formed ACK nobody waited for.
  EXPECT_TRUE(stack->on_frame(*uim342::reply_frame(5, {FC::kMO, uim342::Byte{1}}), now));
  EXPECT_EQ(stack->counters().unexpected, 1);
  motionlcm::bus_stats_t stats{};
  stack->add_statistics(stats);
  EXPECT_EQ(stats.errors, 1);
  EXPECT_TRUE(stack->ready());
}

TEST_F(Uim342StackTest, InputEdgesAndAlarmsBecomeEvents) {
  start_and_set_up();
  deliver(
      *uim342::notification_frame(5, uim342::InputEdgeNotification{uim342::InputPort::kIn2, uim342::Edge::kRising}));
  const auto* edge = find_event(event_t::INPUT_EDGE);
  ASSERT_NE(edge, nullptr);
  EXPECT_EQ(edge->text, "x-drive (node 5): IN2 rising edge");
  EXPECT_EQ(stack->status("x")->inputs, 2);
  deliver(*uim342::notification_frame(7, uim342::AlarmNotification{uim342::AlarmCode::kAboveUpperLimit}));
  EXPECT_TRUE(has_event(event_t::LIMIT, "z"));
  deliver(*uim342::notification_frame(6, uim342::AlarmNotification{uim342::AlarmCode::kEncoderBatteryLow}));
  const auto* battery = find_event(event_t::ALARM);
  ASSERT_NE(battery, nullptr);
  EXPECT_EQ(battery->severity, kWarning);
  EXPECT_FALSE(stack->status("y")->fault);
}

TEST_F(Uim342StackTest, RefusedSetupValueIsAConfigMismatchAndNotReady) {
  drives.at(7).refuse[FC::kMT] = uim342::DriveErrc::kDataError;
  stack->start(now);
  settle();
  EXPECT_FALSE(stack->ready());
  const auto* e = find_event(event_t::CONFIG_MISMATCH);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->text, "z-drive (node 7) refused MT[1]=15: instruction data error (0x33)");
  EXPECT_TRUE(stack->status("z")->online);
}

}  // namespace
}  // namespace motion::gateway::test
