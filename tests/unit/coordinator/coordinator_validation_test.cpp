// Requests the coordinator refuses before anything is sent: unknown axes, missing or contradicting
// drive models, limits, malformed and duplicate requests, axes disabled, faulted, offline or lost.
#include "coordinator_fixture.hpp"

namespace motion::coordinator::test_fixture {
namespace {

TEST_F(CoordinatorTest, UnknownAxisIsRejectedWithTheKnownAxes) {
  const auto r = terminal(send(request_t::MOVE_ABSOLUTE, {"q"}, {1.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kUnknownAxis));
  EXPECT_NE(r.reason.find("unknown axis 'q' (axes: x, y, c, r)"), std::string::npos) << r.reason;
}

// The coordinator quantizes from the drive model only: an axis whose gateway has not published
// one is refused by name (code 21), and the coordinator asks for it once a second, no more.
TEST_F(CoordinatorTest, MoveOfAnAxisWithoutADriveModelIsRefusedAndTheModelIsRequested) {
  Coordinator& fresh = add_coordinator();
  gateways.publish_models = false;
  gateways.model_requests.clear();
  pump(milliseconds(2500));
  EXPECT_EQ(fresh.drive_model("x"), nullptr);
  ASSERT_GE(gateways.model_requests.size(), 2u);
  EXPECT_LE(gateways.model_requests.size(), 3u) << "DRIVE_MODEL_REQUEST once a second while models are missing";
  EXPECT_GE(gateways.model_requests[1] - gateways.model_requests[0], milliseconds(1000));
  // The first coordinator has its models (from before); the fresh one refuses, naming the axis.
  std::vector<reply_t> fresh_replies;
  client.on_reply = [&](const reply_t& r) {
    if (r.request_id == 91) fresh_replies.push_back(r);
  };
  request_t move{};
  move.client_id = "test";
  move.request_id = 91;
  move.kind = request_t::MOVE_ABSOLUTE;
  move.axes = {"x"};
  move.values = {1.0};
  move.num_axes = 1;
  loop.send([&fresh, move, this] {
    loop.deliver_to(fresh, [move](Coordinator& c, TimePoint now) { c.on_request(move, now); });
  });
  pump(milliseconds(50));
  ASSERT_FALSE(fresh_replies.empty());
  EXPECT_EQ(fresh_replies.back().status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(fresh_replies.back().error_code, static_cast<int>(ReplyError::kNoDriveModel));
  EXPECT_NE(fresh_replies.back().reason.find(
                "axis x has no drive model yet: the gateway of bus can0 has not published DRIVE_MODEL"),
            std::string::npos)
      << fresh_replies.back().reason;
  // Once the models come, the requests stop and the move is planned.
  gateways.publish_models = true;
  pump(milliseconds(200));
  ASSERT_NE(fresh.drive_model("x"), nullptr);
  const auto requests = gateways.model_requests.size();
  pump(milliseconds(2000));
  EXPECT_EQ(gateways.model_requests.size(), requests);
}

// A model that contradicts the configuration is ignored (PROTOCOL_ERROR event); an unusable one
// makes the axis's moves fail planning with the reason.
TEST_F(CoordinatorTest, DriveModelsContradictingTheConfigurationAreIgnored) {
  std::vector<motionlcm::event_t> events;
  client.on_event = [&](const motionlcm::event_t& e) { events.push_back(e); };
  auto wrong_family = test_model("x", "can0", "uc57");
  loop.send_to_cores([wrong_family](Coordinator& c, TimePoint now) { c.on_drive_model(wrong_family, now); });
  auto wrong_bus = test_model("c", "can0", "adam-modbus");
  loop.send_to_cores([wrong_bus](Coordinator& c, TimePoint now) { c.on_drive_model(wrong_bus, now); });
  pump(milliseconds(10));
  ASSERT_GE(events.size(), 2u);
  EXPECT_NE(
      events[0].text.find("drive model of axis x ignored: it says family 'uc57', the configuration says 'uim342'"),
      std::string::npos)
      << events[0].text;
  EXPECT_NE(events[1].text.find("drive model of axis c ignored: it comes from bus 'can0', the axis is on bus 'rs485'"),
            std::string::npos)
      << events[1].text;
  EXPECT_EQ(coordinator.drive_model("x")->family, "uim342");
}

TEST_F(CoordinatorTest, TargetBeyondLimitIsRejectedNamingTheLimit) {
  const auto r = terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {1.0, 12.5}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kOutsideLimits));
  EXPECT_NE(r.reason.find("target 12.5 mm of axis y is outside its limits [-10, 10]"), std::string::npos) << r.reason;
  // Relative moves are checked against current position + distance.
  gateways.put("x", 900, false);  // 9 mm
  pump(milliseconds(120));
  EXPECT_EQ(terminal(send(request_t::MOVE_RELATIVE, {"x"}, {2.0})).error_code,
            static_cast<int>(ReplyError::kOutsideLimits));
}

// A jog toward a limit the axis stands at or beyond has nowhere to go: REJECTED naming the limit,
// nothing sent; the other direction runs.
TEST_F(CoordinatorTest, JogTowardALimitTheAxisStandsAtIsRejectedAndTheOtherWayIsNot) {
  gateways.put("x", -1000, false);  // -10 mm: at its minimum
  pump(milliseconds(120));
  const auto r = terminal(send(request_t::JOG, {"x"}, {-1.0}));
  EXPECT_EQ(r.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kOutsideLimits));
  EXPECT_NE(
      r.reason.find(
          "jog of axis x toward its limit -10 mm refused: it stands at -10 mm, less than one count from (or beyond)"),
      std::string::npos)
      << r.reason;
  EXPECT_TRUE(gateways.commands.empty()) << "a refused jog sent " << gateways.commands.size() << " commands";
  send(request_t::JOG, {"x"}, {1.0});
  ASSERT_TRUE(pump_until([&] { return !gateways.commands.empty(); })) << "the jog away from the limit was not sent";
  EXPECT_EQ(gateways.commands.front().kind, std::int8_t{gateway_command_t::JOG});
}

// One whole count to go before the limit is room enough for a jog.
TEST_F(CoordinatorTest, JogWithOneWholeCountToItsLimitIsSent) {
  gateways.put("x", -999, false);
  pump(milliseconds(120));
  send(request_t::JOG, {"x"}, {-1.0});
  ASSERT_TRUE(pump_until([&] { return !gateways.commands.empty(); })) << "a jog with one count to go was not sent";
  EXPECT_EQ(gateways.commands.front().kind, std::int8_t{gateway_command_t::JOG});
}

TEST_F(CoordinatorTest, MalformedAndDuplicateRequestsAreRejected) {
  request_t bad{};
  bad.client_id = "test";
  bad.request_id = 500;
  bad.kind = request_t::MOVE_ABSOLUTE;
  bad.num_axes = 1;
  bad.axes = {"x"};
  bad.values = {std::nan("")};
  client.publish(bad);
  const auto r = terminal(500);
  EXPECT_EQ(r.error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_NE(r.reason.find("not a finite number"), std::string::npos) << r.reason;

  bad.request_id = 501;
  bad.kind = 99;
  client.publish(bad);
  EXPECT_NE(terminal(501).reason.find("unknown request kind 99"), std::string::npos);
}

TEST_F(CoordinatorTest, MalformedRequestWithReadableIdsIsRejectedNamingWhy) {
  request_t r{};
  r.client_id = "test";
  r.request_id = 510;
  r.kind = request_t::MOVE_ABSOLUTE;
  r.axes = {"x", "y"};
  r.values = {1.0, 2.0};
  r.num_axes = 2;
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(r.getEncodedSize()));
  ASSERT_EQ(r.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  bytes.resize(bytes.size() - 10);  // the arrays claim more than the message carries
  client.publish_raw(bytes);
  const auto reply = terminal(510);
  EXPECT_EQ(reply.status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(reply.error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_NE(reply.reason.find("malformed request"), std::string::npos) << reply.reason;
  EXPECT_TRUE(gateways.commands.empty());
}

TEST_F(CoordinatorTest, DisabledFaultedAndOfflineAxesAreRejected) {
  gateways.states["x"].enabled = false;
  gateways.states["y"].fault = true;
  gateways.states["y"].fault_text = "stall";
  pump(milliseconds(120));
  EXPECT_EQ(terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {1.0})).error_code,
            static_cast<int>(ReplyError::kAxisDisabled));
  const auto faulted = terminal(send(request_t::MOVE_ABSOLUTE, {"y"}, {1.0}));
  EXPECT_EQ(faulted.error_code, static_cast<int>(ReplyError::kAxisFaulted));
  EXPECT_NE(faulted.reason.find("stall"), std::string::npos);
  gateways.silent.insert("rs485");
  pump(milliseconds(500));
  EXPECT_EQ(terminal(send(request_t::MOVE_ABSOLUTE, {"c"}, {1.0})).error_code,
            static_cast<int>(ReplyError::kGatewayOffline));
}

// An axis is refused as offline for one of three reasons, and the reply says which: no state
// since the coordinator started (its health lists such axes), a state older than
// gateway_timeout_ms while the gateway heartbeats, or a state saying the drive cannot be reached.
struct CoordinatorMissingAState : CoordinatorTest {
  void SetUp() override {
    withheld = gateways.states.at("y");
    gateways.states.erase("y");
    CoordinatorTest::SetUp();
  }
  motionlcm::axis_state_t withheld{};
};

TEST_F(CoordinatorMissingAState, OfflineRefusalsNameWhyAndUnheardAxesAreListed) {
  EXPECT_EQ(coordinator.axes_never_heard(), std::vector<std::string>{"y"});
  const auto unheard = terminal(send(request_t::MOVE_ABSOLUTE, {"y"}, {1.0}));
  EXPECT_EQ(unheard.error_code, static_cast<int>(ReplyError::kAxisOffline));
  EXPECT_NE(unheard.reason.find("axis y: no state from the gateway of bus can0 yet"), std::string::npos)
      << unheard.reason;

  gateways.states["y"] = withheld;
  pump(milliseconds(100));
  EXPECT_TRUE(coordinator.axes_never_heard().empty());
  auto_execute_moves();
  EXPECT_EQ(run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"y"}, {1.0})).status, std::int8_t{reply_t::DONE});

  gateways.states.erase("y");  // the gateway heartbeats on, y's states stop
  pump(milliseconds(450));
  const auto stale = terminal(send(request_t::MOVE_ABSOLUTE, {"y"}, {2.0}));
  EXPECT_EQ(stale.error_code, static_cast<int>(ReplyError::kAxisOffline));
  EXPECT_NE(stale.reason.find("axis y: its last state is"), std::string::npos) << stale.reason;
  EXPECT_NE(stale.reason.find("(gateway_timeout_ms 400)"), std::string::npos) << stale.reason;
  EXPECT_TRUE(coordinator.axes_never_heard().empty());  // heard once: stale, not unheard

  gateways.states["y"] = withheld;
  gateways.states["y"].online = false;
  pump(milliseconds(100));
  const auto offline = terminal(send(request_t::MOVE_ABSOLUTE, {"y"}, {2.0}));
  EXPECT_EQ(offline.error_code, static_cast<int>(ReplyError::kAxisOffline));
  EXPECT_NE(offline.reason.find("axis y is offline: the gateway of bus can0 cannot reach its drive"), std::string::npos)
      << offline.reason;
}

// An axis whose drive lost power (fault_code POSITION_LOST, not faulted): moves and jogs are
// refused with code 22 naming it and why; set-position (how it becomes valid again) is not.
TEST_F(CoordinatorTest, AnAxisThatLostItsPositionIsRefusedMovesAndJogsButNotASetPosition) {
  gateways.states["x"].fault_code = motionlcm::axis_state_t::POSITION_LOST;
  gateways.states["x"].fault_text = "position lost: x-drive answers as freshly powered up; home or set-position";
  pump(milliseconds(120));
  for (const auto kind : {request_t::MOVE_ABSOLUTE, request_t::MOVE_RELATIVE, request_t::JOG}) {
    const auto refused = terminal(send(kind, {"x"}, {1.0}));
    EXPECT_EQ(refused.status, std::int8_t{reply_t::REJECTED}) << refused.reason;
    EXPECT_EQ(refused.error_code, static_cast<int>(ReplyError::kPositionLost)) << refused.reason;
    EXPECT_NE(refused.reason.find("axis x lost its position (position lost: x-drive answers"), std::string::npos)
        << refused.reason;
  }
  EXPECT_TRUE(gateways.commands.empty());
  send(request_t::SET_POSITION, {"x"}, {0.0});
  ASSERT_TRUE(pump_until([&] { return !gateways.commands.empty(); })) << "the set-position was not sent";
  EXPECT_EQ(gateways.commands.back().kind, std::int8_t{gateway_command_t::SET_POSITION});
}

}  // namespace
}  // namespace motion::coordinator::test_fixture
