// LabView: the lab's LCM messages in, the browser's JSON out; what a late browser's snapshot holds;
// a move from its ACCEPTED reply to its terminal one collects the samples of its axes only.
#include "motion/web/lab_view.hpp"

#include <gtest/gtest.h>

#include "shipped_lab.hpp"

#include <string>
#include <vector>

namespace motion::web {
namespace {

using motionlcm::reply_t;
using motionlcm::request_t;
using nlohmann::json;
using testing::lab;

std::vector<json> parsed(const std::vector<Outgoing>& out) {
  std::vector<json> messages;
  messages.reserve(out.size());
  for (const auto& m : out) messages.push_back(json::parse(m.text));
  return messages;
}

std::vector<json> of_type(const Snapshot& snap, const std::string& type) {
  std::vector<json> messages;
  for (const auto& text : snap.texts) {
    auto j = json::parse(text);
    if (j["type"] == type) messages.push_back(std::move(j));
  }
  return messages;
}

motionlcm::axis_state_t state(const std::string& axis, std::int64_t utime, double position, double velocity) {
  motionlcm::axis_state_t s{};
  s.utime = utime;
  s.sample_utime = utime - 100;
  s.axis = axis;
  s.family = "uim342";
  s.bus = "can0";
  s.node_id = 5;
  s.position = position;
  s.velocity = velocity;
  s.online = true;
  s.enabled = true;
  s.moving = velocity != 0;
  return s;
}

request_t request(std::int8_t kind, std::vector<std::string> axes, std::vector<double> values, std::int64_t id = 7) {
  request_t r{};
  r.client_id = "cli";
  r.request_id = id;
  r.kind = kind;
  r.num_axes = static_cast<std::int32_t>(axes.size());
  r.axes = std::move(axes);
  r.values = std::move(values);
  return r;
}

reply_t reply(std::int8_t status, std::int64_t utime, std::vector<std::string> axes = {},
              std::vector<double> targets = {}, std::int64_t id = 7) {
  reply_t r{};
  r.utime = utime;
  r.client_id = "cli";
  r.request_id = id;
  r.status = status;
  r.num_axes = static_cast<std::int32_t>(axes.size());
  r.positions.assign(axes.size(), 0.0);
  r.start_utime.assign(axes.size(), 0);
  r.axes = std::move(axes);
  r.targets = std::move(targets);
  return r;
}

TEST(LabView, SnapshotStartsWithTheConfiguredLab) {
  LabView view(lab());
  const auto snap = view.snapshot();
  ASSERT_FALSE(snap.texts.empty());
  const auto first = json::parse(snap.texts.front());
  EXPECT_EQ(first["type"], "lab");
  EXPECT_EQ(first["prefix"], lab().lcm.channel_prefix);
  ASSERT_EQ(first["axes"].size(), lab().axes.size());
  for (std::size_t i = 0; i < lab().axes.size(); ++i) {
    EXPECT_EQ(first["axes"][i]["name"], lab().axes[i].name);
    EXPECT_EQ(first["axes"][i]["unit"], lab().axes[i].unit);
    EXPECT_FALSE(first["axes"][i]["bus"].get<std::string>().empty());
  }
  EXPECT_EQ(first["buses"].size(), lab().buses.size());
  EXPECT_EQ(snap.seq, 0u);
}

TEST(LabView, AxisStatesAreSentAndTheLastOfEachAxisIsKept) {
  LabView view(lab());
  const auto out = parsed(view.on_axis_state(state("x", 1000, 1.5, 2.0)));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0]["type"], "axis");
  EXPECT_EQ(out[0]["axis"], "x");
  EXPECT_DOUBLE_EQ(out[0]["position"], 1.5);
  EXPECT_DOUBLE_EQ(out[0]["velocity"], 2.0);
  EXPECT_EQ(out[0]["moving"], true);
  EXPECT_EQ(out[0]["sample_utime"], 900);
  view.on_axis_state(state("x", 2000, 3.0, 0.0));
  view.on_axis_state(state("y", 2000, -1.0, 0.0));
  const auto axes = of_type(view.snapshot(), "axis");
  ASSERT_EQ(axes.size(), 2u);
  EXPECT_EQ(axes[0]["axis"], "x");
  EXPECT_DOUBLE_EQ(axes[0]["position"], 3.0);
  EXPECT_EQ(axes[1]["axis"], "y");
}

TEST(LabView, HealthCarriesStateWordsAndBusStats) {
  LabView view(lab());
  motionlcm::health_t h{};
  h.utime = 5;
  h.process = "gateway:can0";
  h.role = "gateway";
  h.state = motionlcm::health_t::DEGRADED;
  h.period_ms = 500;
  motionlcm::bus_stats_t b{};
  b.name = "can0";
  b.bus_load = 0.25;
  b.errors = 3;
  h.buses = {b};
  h.num_buses = 1;
  const auto out = parsed(view.on_health(h));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0]["state"], "degraded");
  ASSERT_EQ(out[0]["buses"].size(), 1u);
  EXPECT_DOUBLE_EQ(out[0]["buses"][0]["bus_load"], 0.25);
  EXPECT_EQ(out[0]["buses"][0]["errors"], 3);
  EXPECT_EQ(of_type(view.snapshot(), "health").size(), 1u);
}

TEST(LabView, ClientsAreForgottenWhenSilentOrStopped) {
  LabView view(lab());
  auto beat = [&](const std::string& process, const std::string& role, std::int64_t utime, std::int8_t state) {
    motionlcm::health_t h{};
    h.utime = utime;
    h.process = process;
    h.role = role;
    h.state = state;
    view.on_health(h);
  };
  beat("motionctl-1", "client", 1'000'000, motionlcm::health_t::STARTING);
  beat("motionctl-2", "client", 1'000'000, motionlcm::health_t::STARTING);
  beat("coordinator", "coordinator", 1'000'000, motionlcm::health_t::OK);
  beat("motionctl-2", "client", 5'000'000, motionlcm::health_t::STOPPING);
  beat("coordinator", "coordinator", 12'000'000, motionlcm::health_t::OK);  // motionctl-1 silent for 11 s
  const auto health = of_type(view.snapshot(), "health");
  ASSERT_EQ(health.size(), 1u);
  EXPECT_EQ(health[0]["process"], "coordinator");
}

TEST(LabView, EventsAreKeptOldestFirstUpToTheLimit) {
  LabView view(lab(), LabViewLimits{.events = 3});
  for (int i = 0; i < 5; ++i) {
    motionlcm::event_t e{};
    e.utime = i;
    e.kind = motionlcm::event_t::STALL;
    e.severity = motionlcm::event_t::ERROR;
    e.text = "e" + std::to_string(i);
    const auto out = parsed(view.on_event(e));
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0]["kind"], "stall");
    EXPECT_EQ(out[0]["severity"], "error");
  }
  const auto events = of_type(view.snapshot(), "event");
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0]["text"], "e2");
  EXPECT_EQ(events[2]["text"], "e4");
}

TEST(LabView, AMoveCollectsItsAxesSamplesFromAcceptedToItsTerminalReply) {
  LabView view(lab());
  view.on_request(request(request_t::MOVE_ABSOLUTE, {"x"}, {10.0}));
  view.on_axis_state(state("x", 900, 0.0, 0.0));  // before the move: not part of it

  auto out = parsed(view.on_reply(reply(reply_t::ACCEPTED, 1000, {"x"}, {10.0})));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0]["type"], "reply");
  EXPECT_EQ(out[0]["status"], "accepted");
  EXPECT_EQ(out[1]["type"], "move");
  EXPECT_EQ(out[1]["id"], "cli/7");
  EXPECT_EQ(out[1]["kind"], "move");
  EXPECT_EQ(out[1]["axes"], json::array({"x"}));
  EXPECT_EQ(out[1]["targets"], json::array({10.0}));
  EXPECT_EQ(out[1]["open"], true);
  EXPECT_FALSE(out[1].contains("samples"));  // live, the browser collects them itself

  auto started = reply(reply_t::STARTED, 1100, {"x"}, {10.0});
  EXPECT_EQ(out[1]["predicted_duration_s"], 0.0);  // not told yet
  started.start_utime = {1050};
  started.predicted_duration_s = 1.25;
  out = parsed(view.on_reply(started));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1]["started_utime"], 1050);
  EXPECT_EQ(out[1]["predicted_duration_s"], 1.25);  // the plot's planned arrival: start + 1.25 s

  for (int i = 1; i <= 4; ++i) view.on_axis_state(state("x", 1100 + i * 100, 2.5 * i, 5.0));
  view.on_axis_state(state("y", 1300, 7.0, 1.0));  // another axis: not part of the move
  out = parsed(view.on_reply(reply(reply_t::PROGRESS, 1400, {"x"}, {10.0})));
  ASSERT_EQ(out.size(), 1u);  // the reply only
  out = parsed(view.on_reply(reply(reply_t::DONE, 1600, {"x"}, {10.0})));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1]["status"], "done");
  EXPECT_EQ(out[1]["open"], false);
  EXPECT_EQ(out[1]["end_utime"], 1600);
  view.on_axis_state(state("x", 1700, 10.0, 0.0));  // after the end: not part of it

  const auto moves = of_type(view.snapshot(), "move");
  ASSERT_EQ(moves.size(), 1u);
  const auto& samples = moves[0]["samples"];
  ASSERT_TRUE(samples.contains("x"));
  EXPECT_FALSE(samples.contains("y"));
  ASSERT_EQ(samples["x"].size(), 4u);
  EXPECT_EQ(samples["x"][0], json::array({1100.0, 2.5, 5.0}));  // sample time, position, velocity
  EXPECT_DOUBLE_EQ(samples["x"][3][1], 10.0);
}

TEST(LabView, RequestsThatMoveNothingAreNoMoves) {
  LabView view(lab());
  view.on_request(request(request_t::ENABLE, {"x"}, {0.0}));
  view.on_reply(reply(reply_t::ACCEPTED, 1000, {"x"}));
  view.on_reply(reply(reply_t::DONE, 1100, {"x"}));
  EXPECT_TRUE(of_type(view.snapshot(), "move").empty());
  EXPECT_EQ(of_type(view.snapshot(), "reply").size(), 2u);
}

TEST(LabView, ARejectedRequestIsNoMove) {
  LabView view(lab());
  view.on_request(request(request_t::MOVE_ABSOLUTE, {"x"}, {1e9}));
  view.on_reply(reply(reply_t::REJECTED, 1000, {"x"}));
  EXPECT_TRUE(of_type(view.snapshot(), "move").empty());
}

TEST(LabView, AMoveWhoseRequestWasNotHeardTakesItsAxesFromTheReply) {
  LabView view(lab());
  const auto out = parsed(view.on_reply(reply(reply_t::STARTED, 1000, {"y", "z"}, {1.0, 2.0}, 9)));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1]["kind"], "motion");
  EXPECT_EQ(out[1]["axes"], json::array({"y", "z"}));
  EXPECT_EQ(out[1]["targets"], json::array({1.0, 2.0}));
}

TEST(LabView, ClosedMovesGoFirstWhenOverTheLimit) {
  LabView view(lab(), LabViewLimits{.moves = 2});
  view.on_request(request(request_t::JOG, {"x"}, {1.0}, 1));
  view.on_reply(reply(reply_t::ACCEPTED, 1000, {"x"}, {}, 1));  // stays open
  view.on_request(request(request_t::MOVE_RELATIVE, {"y"}, {1.0}, 2));
  view.on_reply(reply(reply_t::ACCEPTED, 1100, {"y"}, {1.0}, 2));
  view.on_reply(reply(reply_t::DONE, 1200, {"y"}, {1.0}, 2));
  view.on_request(request(request_t::HOME, {"z"}, {0.0}, 3));
  view.on_reply(reply(reply_t::ACCEPTED, 1300, {"z"}, {}, 3));
  const auto moves = of_type(view.snapshot(), "move");
  ASSERT_EQ(moves.size(), 2u);
  EXPECT_EQ(moves[0]["id"], "cli/1");
  EXPECT_EQ(moves[0]["kind"], "jog");
  EXPECT_EQ(moves[0]["targets"], json::array());  // a jog's values are velocities
  EXPECT_EQ(moves[1]["id"], "cli/3");
  EXPECT_EQ(moves[1]["kind"], "home");
}

TEST(LabView, AJogsPlotFollowsItsAxisAfterItsDoneUntilTheAxisStands) {
  LabView view(lab());
  view.on_request(request(request_t::JOG, {"x"}, {5.0}, 4));
  view.on_reply(reply(reply_t::ACCEPTED, 1000, {"x"}, {}, 4));
  view.on_axis_state(state("x", 1100, 0.0, 0.0));  // not moving yet when the DONE comes
  // DONE as soon as the jog runs: the move stays open while x moves.
  auto out = parsed(view.on_reply(reply(reply_t::DONE, 1150, {"x"}, {}, 4)));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1]["status"], "done");
  EXPECT_EQ(out[1]["open"], true);
  EXPECT_EQ(out[1]["end_utime"], 0);
  for (int i = 1; i <= 3; ++i) {
    out = parsed(view.on_axis_state(state("x", 1150 + i * 100, 0.5 + i, 5.0)));
    EXPECT_EQ(out.size(), 1u);  // the axis only
  }
  out = parsed(view.on_axis_state(state("x", 1600, 4.0, 0.0)));  // stopped (by a STOP from anyone)
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1]["type"], "move");
  EXPECT_EQ(out[1]["open"], false);
  EXPECT_EQ(out[1]["end_utime"], 1600);
  view.on_axis_state(state("x", 1700, 4.0, 0.0));  // after the end: not part of the move
  const auto moves = of_type(view.snapshot(), "move");
  ASSERT_EQ(moves.size(), 1u);
  EXPECT_EQ(moves[0]["samples"]["x"].size(), 5u);  // 1100, three while jogging, and the stop
}

TEST(LabView, ADoneJogWhoseAxisNeverMovesClosesASecondAfterItsDone) {
  LabView view(lab());
  view.on_request(request(request_t::JOG, {"x"}, {5.0}, 6));
  view.on_reply(reply(reply_t::ACCEPTED, 1000, {"x"}, {}, 6));
  view.on_reply(reply(reply_t::DONE, 2000, {"x"}, {}, 6));
  EXPECT_EQ(parsed(view.on_axis_state(state("x", 900'000, 0.0, 0.0))).size(), 1u);  // still following
  const auto out = parsed(view.on_axis_state(state("x", 1'100'000, 0.0, 0.0)));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1]["open"], false);
}

TEST(LabView, AJogThatEndsWithItsAxisStandingClosesAtItsReply) {
  LabView view(lab());
  view.on_request(request(request_t::JOG, {"x"}, {5.0}, 5));
  view.on_reply(reply(reply_t::ACCEPTED, 1000, {"x"}, {}, 5));
  view.on_axis_state(state("x", 1100, 0.0, 0.0));
  const auto out = parsed(view.on_reply(reply(reply_t::FAILED, 1150, {"x"}, {}, 5)));
  EXPECT_EQ(out[1]["open"], false);
  EXPECT_EQ(out[1]["end_utime"], 1150);
}

TEST(LabView, SequenceNumbersCountEveryMessageAndTheSnapshotNamesTheLast) {
  LabView view(lab());
  std::uint64_t last = 0;
  for (const auto& m : view.on_axis_state(state("x", 1, 0, 0))) {
    EXPECT_EQ(m.seq, last + 1);
    last = m.seq;
  }
  view.on_request(request(request_t::MOVE_ABSOLUTE, {"x"}, {1.0}));
  for (const auto& m : view.on_reply(reply(reply_t::ACCEPTED, 2, {"x"}, {1.0}))) {
    EXPECT_EQ(m.seq, last + 1);
    last = m.seq;
  }
  EXPECT_EQ(last, 3u);
  EXPECT_EQ(view.seq(), last);
  EXPECT_EQ(view.snapshot().seq, last);
}

TEST(LabView, ActiveMovesRowsNameTheirRequest) {
  LabView view(lab());
  motionlcm::active_moves_t m{};
  m.num_axes = 1;
  m.axes = {"x"};
  m.buses = {"can0"};
  m.client_ids = {"cli"};
  m.request_ids = {7};
  m.kinds = {request_t::MOVE_ABSOLUTE};
  m.phases = {motionlcm::active_moves_t::MOVING};
  m.command_ids = {1};
  m.target_counts = {100};
  m.targets = {1.0};
  m.fire_utime = {5};
  const auto out = parsed(view.on_active_moves(m));
  ASSERT_EQ(out.size(), 1u);
  ASSERT_EQ(out[0]["rows"].size(), 1u);
  EXPECT_EQ(out[0]["rows"][0]["id"], "cli/7");
  EXPECT_EQ(out[0]["rows"][0]["phase"], "moving");
  EXPECT_EQ(out[0]["rows"][0]["kind"], "move");
}

}  // namespace
}  // namespace motion::web
