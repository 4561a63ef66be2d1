// Synchronized multi-axis moves over every drive family of the simulated lab (config/sim-lab.yaml):
// client -> coordinator -> gateways can0 (UIM342 + UC57), rs485 (ADAM Modbus), rs232 (UIM242 via a
// UIM2501) -> simulated drives, and back. The simulated drives' reports
// (SIM_REPORT) are the ground truth for the start frames; every request's replies on REPLY are
// counted by a listener of its own (the client stops listening after the terminal one), so a
// second terminal reply would be seen. Commands reach the gateways as gateway_command2_t (grid
// integers of the axes' drive models, GW_COMMAND2_<bus>). No timed assertions: waits are bounded, nothing asserts on
// how long anything took.
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <set>

#include <motionlcm/drive_model_request_t.hpp>
#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/gateway_command2_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>

#include "motion/core/event_loop.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/simbus/endpoint.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

const std::vector<std::string> kRequiredAxes{"x", "y", "z", "a", "b", "c", "u"};

// Targets of the full synchronized move (user units), well inside the limits; a and b fast
// enough (> the UC57 start speed 200Eh, 60 deg/s at 3200 pulses/rev) to have ramps at all.
const Values kTargets{{"x", 30.0}, {"y", 20.0}, {"z", 10.0}, {"a", 180.0}, {"b", -120.0}, {"c", 20.0}, {"u", 15.0}};

class SyncMove : public ::testing::Test {
 protected:
  void SetUp() override {
    lab.group().node().subscribe<reply_t>(lcm::channels::kReply, [this](const reply_t& r, const std::string&) {
      if (r.client_id == lab.client().id()) replies_[r.request_id].push_back(r);
    });
    ASSERT_TRUE(lab.start(kRequiredAxes));
    axes = kRequiredAxes;
    const auto enabled = lab.call(Client::make(request_t::ENABLE, axes));
    ASSERT_EQ(enabled.status, st(reply_t::DONE)) << enabled.reason;
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }

  double position(const std::string& axis) { return lab.client().axes().at(axis).position; }
  bool moving(const std::string& axis) { return lab.client().axes().at(axis).moving; }
  double tolerance(const std::string& axis) { return 1.0 / lab.config().find_axis(axis)->steps_per_unit + 1e-9; }

  // Sends without waiting; the replies are in replies_[id].
  std::int64_t send(request_t request) { return lab.client().send(std::move(request)); }
  bool ended(std::int64_t id) {
    const auto it = replies_.find(id);
    return it != replies_.end() && std::any_of(it->second.begin(), it->second.end(),
                                               [](const reply_t& r) { return client::is_terminal(r.status); });
  }
  bool saw(std::int64_t id, std::int8_t status) {
    const auto it = replies_.find(id);
    return it != replies_.end() &&
           std::any_of(it->second.begin(), it->second.end(), [&](const reply_t& r) { return r.status == status; });
  }
  reply_t wait_terminal(std::int64_t id, seconds timeout = seconds(30)) {
    EXPECT_TRUE(lab.client().wait_until([&] { return ended(id); }, timeout)) << "no terminal reply to request " << id;
    for (const auto& r : replies_[id]) {
      if (client::is_terminal(r.status)) return r;
    }
    return reply_t{};
  }
  // Every request seen got exactly one terminal reply, and nothing after it. Listens a little
  // longer first so that a late second terminal reply would be counted.
  void expect_one_terminal_each(std::size_t requests) {
    lab.client().wait_until([] { return false; }, std::chrono::milliseconds(500));
    EXPECT_EQ(replies_.size(), requests);
    for (const auto& [id, list] : replies_) {
      const auto terminals =
          std::count_if(list.begin(), list.end(), [](const reply_t& r) { return client::is_terminal(r.status); });
      EXPECT_EQ(terminals, 1) << "request " << id;
      EXPECT_TRUE(!list.empty() && client::is_terminal(list.back().status))
          << "request " << id << ": a reply after the terminal one";
    }
  }
  std::size_t index_of(const reply_t& r, const std::string& axis) {
    return static_cast<std::size_t>(std::find(r.axes.begin(), r.axes.end(), axis) - r.axes.begin());
  }

  SimLab lab;
  std::vector<std::string> axes;
  std::map<std::int64_t, std::vector<reply_t>> replies_;
};

TEST_F(SyncMove, EveryFamilyArrivesAndEachBusStartsOnOneFramePerMechanism) {
  // What goes to the gateways: gateway_command2_t on GW_COMMAND2_<bus>, never gateway_command_t;
  // and the drive models in force (asked for again: an unchanged model keeps its utime).
  struct Heard {
    std::map<std::string, motionlcm::drive_model_t> models;
    std::vector<motionlcm::gateway_command2_t> commands2;
    std::size_t commands1 = 0;
  };
  auto heard = std::make_shared<Heard>();
  auto& node = lab.group().node();
  node.subscribe<motionlcm::drive_model_t>(
      lcm::channels::kDriveModel,
      [heard](const motionlcm::drive_model_t& m, const std::string&) { heard->models[m.axis] = m; });
  for (const auto& bus : lab.config().buses) {
    node.subscribe<motionlcm::gateway_command2_t>(
        lcm::channels::gateway_command2(bus.name),
        [heard](const motionlcm::gateway_command2_t& c, const std::string&) { heard->commands2.push_back(c); });
    node.subscribe<motionlcm::gateway_command_t>(
        lcm::channels::gateway_command(bus.name),
        [heard](const motionlcm::gateway_command_t&, const std::string&) { ++heard->commands1; });
  }
  node.publish(lcm::channels::kDriveModelRequest, motionlcm::drive_model_request_t{});
  ASSERT_TRUE(lab.client().wait_until([&] { return heard->models.size() >= axes.size(); }, seconds(5)));

  Values targets;
  for (const auto& a : axes) targets[a] = kTargets.at(a);
  const auto id = send(Client::make(request_t::MOVE_ABSOLUTE, targets));
  const reply_t done = wait_terminal(id, seconds(60));
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  // Every family's move went out as grid integers of its axis's model in force, within its ranges.
  EXPECT_EQ(heard->commands1, 0u) << "a gateway_command_t was sent";
  std::set<std::string> armed;
  for (const auto& c : heard->commands2) {
    if (c.kind != motionlcm::gateway_command2_t::ARM_MOVE) continue;
    for (const auto& a : c.axes) {
      armed.insert(a.axis);
      const auto& m = heard->models.at(a.axis);
      EXPECT_EQ(a.model_utime, m.utime) << a.axis;
      EXPECT_GE(a.velocity, m.velocity_min) << a.axis;
      EXPECT_LE(a.velocity, m.velocity_max) << a.axis;
      EXPECT_GE(a.acceleration, m.acceleration_min) << a.axis;
      EXPECT_LE(a.deceleration, m.acceleration_max) << a.axis;
    }
  }
  EXPECT_EQ(armed.size(), axes.size()) << "not every axis was armed over GW_COMMAND2";
  EXPECT_TRUE(saw(id, reply_t::ACCEPTED));
  EXPECT_TRUE(saw(id, reply_t::STARTED));

  // Every axis at its target, in the reply and in the axis state.
  ASSERT_EQ(done.num_axes, static_cast<std::int32_t>(axes.size()));
  for (const auto& a : axes) {
    const auto i = index_of(done, a);
    ASSERT_LT(i, done.axes.size()) << a;
    EXPECT_NEAR(done.targets[i], targets[a], tolerance(a)) << a;
    EXPECT_NEAR(done.positions[i], targets[a], tolerance(a)) << a;
    EXPECT_TRUE(lab.client().wait_until([&] { return std::abs(position(a) - targets[a]) <= tolerance(a); }, seconds(2)))
        << a;
  }

  // Ground truth: one start per drive; on can0 x and y start on the group's BG frame, a and b on one SYNC.
  std::map<std::string, std::int64_t> frame;
  for (const auto& a : axes) {
    const auto starts = lab.starts_of(lab.config().find_axis(a)->drive);
    ASSERT_EQ(starts.size(), 1u) << a;
    frame[a] = starts[0].frame_utime;
  }
  EXPECT_EQ(frame["x"], frame["y"]) << "x and y did not start on the same BG frame";
  EXPECT_EQ(frame["a"], frame["b"]) << "a and b did not start on the same SYNC frame";

  // The reply's figures are there: per-axis start times from the gateways (equal per mechanism),
  // a measured start skew spanning them, and the predictions.
  for (const auto& a : axes) EXPECT_GT(done.start_utime[index_of(done, a)], 0) << a;
  // One start time per start mechanism: x and y share the group's BG, a and b the SYNC.
  EXPECT_EQ(done.start_utime[index_of(done, "x")], done.start_utime[index_of(done, "y")]) << "one BG start time";
  EXPECT_EQ(done.start_utime[index_of(done, "a")], done.start_utime[index_of(done, "b")]) << "one SYNC start time";
  // On can0 the gateway dates a start by its frame's echo, i.e. the frame's end on the wire:
  // exactly the time the simulated drives record for the frame that started them.
  EXPECT_EQ(done.start_utime[index_of(done, "x")], frame["x"]) << "BG: gateway's start time vs the drives' start frame";
  EXPECT_EQ(done.start_utime[index_of(done, "a")], frame["a"])
      << "SYNC: gateway's start time vs the drives' start frame";
  const auto [lo, hi] = std::minmax_element(done.start_utime.begin(), done.start_utime.end());
  EXPECT_TRUE(std::isfinite(done.measured_start_skew_us));
  EXPECT_GE(done.measured_start_skew_us, static_cast<double>(*hi - *lo));
  EXPECT_GT(done.measured_start_skew_us, 0.0)
      << "two buses and two mechanisms on can0 cannot start at the same microsecond";
  EXPECT_GT(done.predicted_duration_s, 0.0);
  EXPECT_TRUE(std::isfinite(done.predicted_skew_us) && done.predicted_skew_us >= 0.0);
  expect_one_terminal_each(2);  // enable + move
}

// Scheduled starts on one CAN bus (coordinator start_schedule.hpp): the UC57 start images (RPDO1,
// controlword 0x1F, synchronous) are on the wire before the fire, so only the SYNC
// goes out at the start; the group's BG (29-bit, the longer frame) goes first, the SYNC right
// behind it with no RPDO between. The wire is read from an endpoint of our own on the simulated
// can0; the ground truth is the drives' SIM_REPORT. Orders and contents only: nothing timed.
TEST_F(SyncMove, Uc57TargetsArePreloadedSoOnlyTheSyncGoesOutAtTheStart) {
  std::error_code ec;
  auto can0 = simbus::SocketEndpoint::connect("can0", {lab.group().work_dir() + "/sim", "it-wire", false}, ec);
  ASSERT_TRUE(can0) << ec.message();
  std::vector<can::Frame> wire;
  lab.group().loop().watch(can0->fd(), [&] {
    while (auto f = can0->receive()) wire.push_back(*f);
  });
  std::vector<motionlcm::sync_trigger2_t> triggers;
  lab.group().node().subscribe<motionlcm::sync_trigger2_t>(
      lcm::channels::kSyncTrigger2,
      [&](const motionlcm::sync_trigger2_t& t, const std::string&) { triggers.push_back(t); });
  const reply_t done =
      lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 12.0}, {"y", 6.0}, {"a", 90.0}, {"b", -90.0}}));
  lab.group().loop().unwatch(can0->fd());
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  ASSERT_EQ(triggers.size(), 1u);
  const auto& t = triggers[0];
  ASSERT_EQ(t.buses, std::vector<std::string>{"can0"});
  ASSERT_EQ(t.num_starts, 2);  // the group BG and the SYNC
  const auto starts_a = lab.starts_of("a-drive");
  const auto starts_x = lab.starts_of("x-drive");
  ASSERT_EQ(starts_a.size(), 1u);
  ASSERT_EQ(starts_x.size(), 1u);
  // The frame that started a and b: a SYNC; the one that started x and y: before it.
  const auto sync = std::find_if(wire.begin(), wire.end(),
                                 [&](const can::Frame& f) { return f.timestamp_us == starts_a[0].frame_utime; });
  ASSERT_NE(sync, wire.end()) << "the start frame of a is not in the wire log";
  EXPECT_EQ(sync->id, 0x080u);
  EXPECT_FALSE(sync->extended);
  EXPECT_LT(starts_x[0].frame_utime, sync->timestamp_us) << "the BG (the longer frame) goes first";
  // The last RPDO1 of each UC57 before the start SYNC: the start image, and not between the BG and
  // the SYNC.
  for (const std::uint32_t rpdo1 : {0x201u, 0x202u}) {
    const auto last = std::find_if(std::make_reverse_iterator(sync), wire.rend(),
                                   [&](const can::Frame& f) { return !f.extended && f.id == rpdo1; });
    ASSERT_NE(last, wire.rend()) << std::hex << rpdo1;
    ASSERT_GE(last->dlc, 2u);
    EXPECT_EQ(last->data[0], 0x1F) << std::hex << rpdo1 << ": the start image (new set-point) was not preloaded";
    // Before the BG, the first frame the fire hands over: it was on the wire before the fire.
    EXPECT_LT(last->timestamp_us, starts_x[0].frame_utime)
        << std::hex << rpdo1 << " went out with the fire, not at arming";
  }
}

TEST_F(SyncMove, StallOfOneAxisAbortsTheWholeGroupWithTheCause) {
  const auto id =
      send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 250.0}, {"a", 700.0}, {"b", -700.0}, {"c", 90.0}}));
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(id, reply_t::STARTED) || ended(id); }, seconds(20)));
  ASSERT_FALSE(ended(id)) << replies_[id].back().reason;
  lab.control("a-drive", motionlcm::sim_control_t::STALL);
  const reply_t last = wait_terminal(id);
  EXPECT_EQ(last.status, st(reply_t::ABORTED)) << last.reason;
  EXPECT_EQ(last.error_code, code(ReplyError::kAxisFault)) << last.reason;
  EXPECT_NE(last.reason.find('a'), std::string::npos) << last.reason;
  // The others were stopped short of their targets.
  for (const auto& a : std::vector<std::string>{"x", "b", "c"}) {
    EXPECT_TRUE(lab.client().wait_until([&] { return !moving(a); }, seconds(10))) << a << " still moving";
  }
  EXPECT_LT(position("x"), 249.0);
  EXPECT_GT(position("b"), -699.0);
  EXPECT_LT(position("c"), 89.0);
  expect_one_terminal_each(2);
}

TEST_F(SyncMove, LostGatewayAbortsNamingItAndStopsTheOtherAxes) {
  const auto id = send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 250.0}, {"a", 700.0}, {"c", 90.0}}));
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(id, reply_t::STARTED) || ended(id); }, seconds(20)));
  ASSERT_FALSE(ended(id)) << replies_[id].back().reason;
  const auto gateway = lab.group().heartbeat("gateway:rs485");
  ASSERT_TRUE(gateway.has_value());
  ASSERT_GT(gateway->pid, 0);
  // SIGKILL: no STOPPING heartbeat, the coordinator must notice the silence.
  ASSERT_EQ(::kill(static_cast<pid_t>(gateway->pid), SIGKILL), 0);
  const reply_t last = wait_terminal(id);
  lab.group().stop(static_cast<pid_t>(gateway->pid));  // reap it
  EXPECT_EQ(last.status, st(reply_t::ABORTED)) << last.reason;
  EXPECT_EQ(last.error_code, code(ReplyError::kGatewayLost)) << last.reason;
  EXPECT_NE(last.reason.find("rs485"), std::string::npos) << last.reason;
  for (const auto& a : std::vector<std::string>{"x", "a"}) {
    EXPECT_TRUE(lab.client().wait_until([&] { return !moving(a); }, seconds(10))) << a << " still moving";
  }
  EXPECT_LT(position("x"), 249.0);
  EXPECT_LT(position("a"), 699.0);
  expect_one_terminal_each(2);
}

// A gateway killed mid-move and started again at once: the coordinator sees a new process (its
// pid), republishes the desired state (ACTIVE_MOVES) and aborts the request; the new gateway
// learns from that state that c was moving under a request triggered before it started, says so
// (GATEWAY_RESTARTED, naming request, axis and target) and stops c.
TEST_F(SyncMove, RestartedGatewayIsToldWhatItWasDoingAndStopsIt) {
  const auto id = send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 250.0}, {"c", 90.0}}));
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(id, reply_t::STARTED) || ended(id); }, seconds(20)));
  ASSERT_FALSE(ended(id)) << replies_[id].back().reason;
  const auto gateway = lab.group().heartbeat("gateway:rs485");
  ASSERT_TRUE(gateway.has_value());
  ASSERT_EQ(::kill(static_cast<pid_t>(gateway->pid), SIGKILL), 0);
  lab.group().stop(static_cast<pid_t>(gateway->pid));  // reap it
  ASSERT_GT(lab.start_gateway("rs485"), 0);
  const reply_t last = wait_terminal(id);
  EXPECT_EQ(last.status, st(reply_t::ABORTED)) << last.reason;
  EXPECT_EQ(last.error_code, code(ReplyError::kGatewayLost)) << last.reason;
  EXPECT_NE(last.reason.find("rs485"), std::string::npos) << last.reason;
  const std::string told = "/" + std::to_string(id) + " was moving c to 90";
  EXPECT_TRUE(
      lab.client().wait_until([&] { return lab.has_event(ev(event_t::GATEWAY_RESTARTED), "c", told); }, seconds(10)))
      << told;
  EXPECT_FALSE(lab.has_event(ev(event_t::GATEWAY_RESTARTED), "x", ""));  // x is not on rs485
  for (const auto& a : std::vector<std::string>{"x", "c"}) {
    EXPECT_TRUE(lab.client().wait_until([&] { return !moving(a); }, seconds(10))) << a << " still moving";
  }
  EXPECT_LT(position("c"), 89.0);
  expect_one_terminal_each(2);
}

// A coordinator killed while c jogs leaves the jog running on the drive; the coordinator started
// in its place hears c moving under no request of its own, says so (UNOWNED_MOTION) and stops it,
// and the lab takes a new move afterwards.
TEST_F(SyncMove, RestartedCoordinatorStopsAJogItDidNotStart) {
  const auto jog = wait_terminal(send(Client::make(request_t::JOG, Values{{"c", 5.0}})));
  ASSERT_EQ(jog.status, st(reply_t::DONE)) << jog.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return moving("c"); }, seconds(5)));
  const auto coordinator = lab.group().heartbeat("coordinator");
  ASSERT_TRUE(coordinator.has_value());
  ASSERT_EQ(::kill(static_cast<pid_t>(coordinator->pid), SIGKILL), 0);
  lab.group().stop(static_cast<pid_t>(coordinator->pid));  // reap it
  const double at_kill = position("c");
  lab.pause(std::chrono::milliseconds(300));
  EXPECT_TRUE(moving("c"));  // nothing stops a jog by itself
  ASSERT_GT(lab.group().start({"coordinator-2", "motion-coordinator", {"--config", lab.config_path()}, {}}), 0);
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.has_event(ev(event_t::UNOWNED_MOTION), "c", "was moving"); },
                                      seconds(10)));
  EXPECT_TRUE(lab.client().wait_until([&] { return !moving("c"); }, seconds(10))) << "c still jogging";
  EXPECT_LT(position("c"), at_kill + 20.0);
  EXPECT_LT(position("c"), 100.0);
  ASSERT_TRUE(lab.group().wait_for_heartbeat("coordinator", seconds(10)));
  const auto back = wait_terminal(send(Client::make(request_t::MOVE_RELATIVE, Values{{"c", -1.0}})));
  EXPECT_EQ(back.status, st(reply_t::DONE)) << back.reason;
}

// A coordinator killed during a move leaves its client waiting: the gateways hand the rows of the
// last ACTIVE_MOVES to the coordinator that starts next (ORPHANED_MOVES), which ends the request
// once (ABORTED, code 20, naming the axes) and stops the axes as unowned motion.
TEST_F(SyncMove, AClientsMoveInFlightWhenTheCoordinatorDiesEndsWithTheSuccessorsReply) {
  const auto id = send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 250.0}, {"y", 150.0}}));
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(id, reply_t::STARTED) || ended(id); }, seconds(20)));
  ASSERT_FALSE(ended(id)) << replies_[id].back().reason;
  const auto coordinator = lab.group().heartbeat("coordinator");
  ASSERT_TRUE(coordinator.has_value());
  ASSERT_EQ(::kill(static_cast<pid_t>(coordinator->pid), SIGKILL), 0);
  lab.group().stop(static_cast<pid_t>(coordinator->pid));  // reap it
  lab.pause(std::chrono::milliseconds(500));
  EXPECT_FALSE(ended(id));
  ASSERT_GT(lab.group().start({"coordinator-2", "motion-coordinator", {"--config", lab.config_path()}, {}}), 0);
  const reply_t ended_by = wait_terminal(id, seconds(15));
  EXPECT_EQ(ended_by.status, st(reply_t::ABORTED)) << ended_by.reason;
  EXPECT_EQ(ended_by.error_code, code(ReplyError::kCoordinatorRestarted)) << ended_by.reason;
  EXPECT_NE(ended_by.reason.find("x (can0)"), std::string::npos) << ended_by.reason;
  for (const auto& a : std::vector<std::string>{"x", "y"}) {
    EXPECT_TRUE(lab.client().wait_until([&] { return !moving(a); }, seconds(15))) << a << " still moving";
  }
  EXPECT_LT(position("x"), 250.0);
  lab.pause(std::chrono::milliseconds(1500));  // no second terminal reply, e.g. from a later heartbeat
  EXPECT_EQ(std::count_if(replies_[id].begin(), replies_[id].end(),
                          [](const reply_t& r) { return client::is_terminal(r.status); }),
            1);
}

// Frames lost on can0 just as a stop is sent: whatever the lost frames were (the STOP, its
// acknowledgement, status polls), the request ends exactly once, x and y come to rest well short
// of their targets (stops are watched until the states show standstill, repeated, escalated),
// and the lab takes a new move afterwards.
TEST_F(SyncMove, AStopWhileTheBusDropsFramesStillStopsTheAxes) {
  const auto id = send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 250.0}, {"y", 150.0}}));
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(id, reply_t::STARTED) || ended(id); }, seconds(20)));
  ASSERT_FALSE(ended(id)) << replies_[id].back().reason;
  lab.control_bus("can0", motionlcm::sim_control_t::BUS_DROP, 40);
  const auto stop = wait_terminal(send(Client::make(request_t::STOP, std::vector<std::string>{"x", "y"})), seconds(30));
  EXPECT_TRUE(stop.status == st(reply_t::DONE) || stop.status == st(reply_t::FAILED)) << stop.reason;
  const reply_t moved = wait_terminal(id, seconds(30));
  EXPECT_EQ(moved.status, st(reply_t::ABORTED)) << moved.reason;
  for (const auto& a : std::vector<std::string>{"x", "y"}) {
    EXPECT_TRUE(lab.client().wait_until([&] { return !moving(a) && lab.state(a).online; }, seconds(15)))
        << a << " still moving";
  }
  EXPECT_EQ(moved.reason.find("not confirmed"), std::string::npos) << moved.reason;
  EXPECT_LT(position("x"), 240.0);
  EXPECT_LT(position("y"), 140.0);
  // Reset whatever the lost frames or an e-stop left (a drive that saw half a conversation may
  // flag an error), then a new move completes.
  const std::vector<std::string> both{"x", "y"};
  if (lab.state("x").fault || lab.state("y").fault) {
    const auto reset = lab.call(Client::make(request_t::FAULT_RESET, both));
    EXPECT_EQ(reset.status, st(reply_t::DONE)) << reset.reason;
  }
  if (!lab.state("x").enabled || !lab.state("y").enabled) { ASSERT_TRUE(lab.enable(both)); }
  const auto again =
      wait_terminal(send(Client::make(request_t::MOVE_RELATIVE, Values{{"x", -5.0}, {"y", -5.0}})), seconds(30));
  EXPECT_EQ(again.status, st(reply_t::DONE)) << again.reason;
}

TEST_F(SyncMove, BadRequestsAreRejectedWithReasonsAndEveryRequestEndsOnce) {
  std::size_t requests = 1;  // enable
  const auto unknown = wait_terminal(send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 1.0}, {"q", 1.0}})));
  ++requests;
  EXPECT_EQ(unknown.status, st(reply_t::REJECTED));
  EXPECT_EQ(unknown.error_code, code(ReplyError::kUnknownAxis));
  EXPECT_NE(unknown.reason.find("'q'"), std::string::npos) << unknown.reason;

  const auto beyond = wait_terminal(send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 721.0}, {"c", 1.0}})));
  ++requests;
  EXPECT_EQ(beyond.status, st(reply_t::REJECTED));
  EXPECT_EQ(beyond.error_code, code(ReplyError::kOutsideLimits));
  EXPECT_NE(beyond.reason.find("axis a"), std::string::npos) << beyond.reason;
  EXPECT_NE(beyond.reason.find("720"), std::string::npos) << beyond.reason;

  // A long move holds x and c; a move overlapping it on c is refused, one beside it is not.
  const auto holding = send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 250.0}, {"c", 90.0}}));
  ++requests;
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(holding, reply_t::ACCEPTED) || ended(holding); }, seconds(10)));
  const auto overlap = wait_terminal(send(Client::make(request_t::MOVE_RELATIVE, Values{{"c", -1.0}, {"b", 10.0}})));
  ++requests;
  EXPECT_EQ(overlap.status, st(reply_t::REJECTED));
  EXPECT_EQ(overlap.error_code, code(ReplyError::kAxisBusy));
  EXPECT_NE(overlap.reason.find("axis c"), std::string::npos) << overlap.reason;
  const auto beside = wait_terminal(send(Client::make(request_t::MOVE_RELATIVE, Values{{"b", 10.0}})));
  ++requests;
  EXPECT_EQ(beside.status, st(reply_t::DONE)) << beside.reason;

  // Stopping ends the long move (ABORTED by the stop) and the stop itself (DONE).
  const auto stop = wait_terminal(send(Client::make(request_t::STOP, std::vector<std::string>{"x", "c"})));
  ++requests;
  EXPECT_EQ(stop.status, st(reply_t::DONE)) << stop.reason;
  const auto stopped = wait_terminal(holding);
  EXPECT_EQ(stopped.status, st(reply_t::ABORTED)) << stopped.reason;
  EXPECT_EQ(stopped.error_code, code(ReplyError::kStopped)) << stopped.reason;
  expect_one_terminal_each(requests);
}

}  // namespace
}  // namespace motion::testing
