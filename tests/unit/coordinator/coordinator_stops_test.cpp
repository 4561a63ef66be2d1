// Stops that do not take: the coordinator watches every stop it sends until the axis states show
// standstill, repeats it, then e-stops, and the aborted request says what happened only then.
#include "coordinator_fixture.hpp"

namespace motion::coordinator::test_fixture {
namespace {

struct StopsThatDoNotTake : CoordinatorTest {
  // The first `ignored` stops (STOP or ESTOP) for x change nothing; later ones stop it.
  void ignore_stops(int ignored) {
    auto_execute_moves(/*complete=*/false);
    gateways.on_command = [this, ignored, base = gateways.on_command](const gateway_command_t& c) {
      if (c.kind == gateway_command_t::STOP || c.kind == gateway_command_t::ESTOP) {
        stops.push_back(c);
        gateways.reply(c, gateway_reply_t::DONE);  // the gateway sent it; the drive did not take it
        if (static_cast<int>(stops.size()) > ignored) {
          for (const auto& a : c.axes) gateways.states[a.axis].moving = false;
        }
        return;
      }
      base(c);
    };
    client.on_event = [this](const motionlcm::event_t& e) { events.push_back(e); };
  }
  std::int64_t moving_x() {
    const auto id = send(request_t::MOVE_ABSOLUTE, {"x"}, {5.0});
    pump_until([&] {
      pump_triggers();
      return !gateways.triggers.empty();
    });
    pump(milliseconds(100));
    return id;
  }
  [[nodiscard]] bool event_says(std::int16_t kind, const std::string& text) const {
    return std::any_of(events.begin(), events.end(),
                       [&](const auto& e) { return e.kind == kind && e.text.find(text) != std::string::npos; });
  }
  std::vector<gateway_command_t> stops;
  std::vector<motionlcm::event_t> events;
};

TEST_F(StopsThatDoNotTake, ALostStopIsRepeatedAndTheAbortWaitsForStandstill) {
  ignore_stops(1);
  const auto move = moving_x();
  // A fault of x aborts the move; the first STOP is lost.
  gateways.states["x"].fault = true;
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::ABORTED});
  ASSERT_EQ(stops.size(), 2u) << "the unconfirmed stop was not repeated";
  EXPECT_EQ(stops[1].kind, std::int8_t{gateway_command_t::STOP});
  EXPECT_FALSE(gateways.states["x"].moving);  // ABORTED came after standstill
  EXPECT_EQ(r.reason.find("could not stop"), std::string::npos) << r.reason;
  EXPECT_TRUE(event_says(motionlcm::event_t::STOP_UNCONFIRMED, "axis x still reports moving"));
  EXPECT_TRUE(event_says(motionlcm::event_t::STOP_UNCONFIRMED, "stopping it again"));
}

TEST_F(StopsThatDoNotTake, TwoLostStopsAreFollowedByAnEStopAndAStopRequestSaysSo) {
  ignore_stops(2);
  const auto move = moving_x();
  const auto stop = send(request_t::STOP, {"x"}, {0.0});
  const auto preempted = terminal(move);
  EXPECT_EQ(preempted.status, std::int8_t{reply_t::ABORTED});
  const auto r = terminal(stop);
  EXPECT_EQ(r.status, std::int8_t{reply_t::FAILED});
  EXPECT_NE(r.reason.find("axis x did not stop on STOP; it was e-stopped"), std::string::npos) << r.reason;
  ASSERT_EQ(stops.size(), 3u);
  EXPECT_EQ(stops[0].kind, std::int8_t{gateway_command_t::STOP});
  EXPECT_EQ(stops[1].kind, std::int8_t{gateway_command_t::STOP});
  EXPECT_EQ(stops[2].kind, std::int8_t{gateway_command_t::ESTOP});
  EXPECT_TRUE(event_says(motionlcm::event_t::STOP_UNCONFIRMED, "e-stopping it"));
}

TEST_F(StopsThatDoNotTake, AnAxisThatNeverStopsIsGivenUpAndTheAbortNamesIt) {
  ignore_stops(100);
  const auto move = moving_x();
  gateways.states["x"].fault = true;
  EXPECT_TRUE(pump_until(
      [&] {
        return std::any_of(replies[move].begin(), replies[move].end(),
                           [](const reply_t& r) { return is_terminal(r.status); });
      },
      milliseconds(5000)));
  const auto r = terminal(move);
  EXPECT_EQ(r.status, std::int8_t{reply_t::ABORTED});
  EXPECT_NE(r.reason.find("could not stop x (still moving after an e-stop)"), std::string::npos) << r.reason;
  EXPECT_EQ(stops.size(), 3u);  // STOP, STOP, ESTOP, then given up
  EXPECT_TRUE(event_says(motionlcm::event_t::STOP_UNCONFIRMED, "giving up"));
}

TEST_F(StopsThatDoNotTake, AnAxisMovingWhenANewCoordinatorStartsIsStopped) {
  ignore_stops(0);
  gateways.put("x", 120, true);  // moved by a coordinator that is gone
  pump(milliseconds(100));
  EXPECT_TRUE(stops.empty());  // the running coordinator has heard of x before: not its business
  add_coordinator();           // a second coordinator on the same wire, started now
  ASSERT_TRUE(pump_until([&] { return !stops.empty(); }));
  EXPECT_EQ(stops[0].axes.at(0).axis, "x");
  EXPECT_TRUE(event_says(motionlcm::event_t::UNOWNED_MOTION, "axis x was moving"));
  EXPECT_TRUE(pump_until([&] { return !gateways.states["x"].moving; }));
}

}  // namespace
}  // namespace motion::coordinator::test_fixture
