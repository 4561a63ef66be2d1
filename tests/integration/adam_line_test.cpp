// ADAM Modbus RTU end to end over a real pseudo-terminal: ONE simulated RS485 line
// (tests/integration/configs/adam-line.yaml) carrying three drives, slaves 1, 2, 3 (axes c1, c2,
// c3), with motion-sim (AdamLineSim on the pty), `motion-gateway --bus rs485` (AdamBusDriver,
// our RTU master) and motion-coordinator, each test on its own LCM URL and simulation directory.
// The simulated drives' own reports (SIM_REPORT) are the ground truth of when motion started:
// a synchronized move preloads each drive's table and starts them with ONE broadcast
// "execute table entry" frame, so their MOTION_STARTED reports carry the same frame_utime.
// Faults come in through SIM_CONTROL (ALARM, SILENCE).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>

#include <motionlcm/arm_timing_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/line_timing_t.hpp>

#include "sim_lab.hpp"

namespace motion::testing {
namespace {

constexpr double kCountsPerMm = 320.0;
constexpr double kPositionTolerance = 1.0 / kCountsPerMm;  // one pulse, in mm
const std::vector<std::string> kAxes{"c1", "c2", "c3"};

std::int8_t status(std::int8_t s) { return s; }

bool saw(const std::vector<reply_t>& replies, std::int8_t s) {
  return std::any_of(replies.begin(), replies.end(), [s](const reply_t& r) { return r.status == s; });
}

class AdamLine : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_TRUE(lab.start(kAxes));
    const auto enabled = lab.call(Client::make(request_t::ENABLE, kAxes));
    ASSERT_EQ(enabled.status, status(reply_t::DONE)) << enabled.reason;
    startup_ms = std::chrono::duration_cast<milliseconds>(std::chrono::steady_clock::now() - t0).count();
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }
  double position(const std::string& axis) { return lab.client().axes().at(axis).position; }
  bool settled_at(const std::string& axis, double where, seconds timeout = seconds(5)) {
    return lab.client().wait_until(
        [&] {
          const auto& a = lab.client().axes().at(axis);
          return !a.moving && std::abs(a.position - where) < kPositionTolerance;
        },
        timeout);
  }

  SimLab lab{source_path("tests/integration/configs/adam-line.yaml")};
  long long startup_ms = 0;
};

TEST_F(AdamLine, EnableReachesEveryDrive) {
  for (const auto& axis : kAxes) {
    const auto& a = lab.client().axes().at(axis);
    EXPECT_TRUE(a.online) << axis;
    EXPECT_TRUE(a.enabled) << axis;
    EXPECT_FALSE(a.fault) << axis;
  }
  const auto disabled = lab.call(Client::make(request_t::DISABLE, std::vector<std::string>{"c2"}));
  ASSERT_EQ(disabled.status, status(reply_t::DONE)) << disabled.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return !lab.client().axes().at("c2").enabled; }, seconds(2)));
  // A disabled axis does not move: the coordinator refuses, naming it.
  const auto refused = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"c2", 1.0}}));
  EXPECT_EQ(refused.status, status(reply_t::REJECTED));
  EXPECT_NE(refused.reason.find("c2"), std::string::npos) << refused.reason;
  const auto enabled = lab.call(Client::make(request_t::ENABLE, std::vector<std::string>{"c2"}));
  ASSERT_EQ(enabled.status, status(reply_t::DONE)) << enabled.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.client().axes().at("c2").enabled; }, seconds(2)));
  std::printf("[ adam ] start-up to three enabled axes: %lld ms\n", startup_ms);
}

// `motionctl status --model` shows each axis's ARM_TIMING as its gateway published it and, per
// bus, the line time the coordinator adds to its arming deadline: every axis armed together (the
// three arm_line_us; no other drive to ready) and one axis alone (its arm_line_us and two
// bystanders readied for the broadcast start). ADAM arming is long (a flash Save per drive). And
// the bus's start wait (LINE_TIMING): its longest poll read.
TEST_F(AdamLine, StatusModelShowsTheArmingLineTimePerBus) {
  std::map<std::string, motionlcm::arm_timing_t> published;
  lab.group().node().subscribe<motionlcm::arm_timing_t>(
      lcm::channels::kArmTiming, [&](const motionlcm::arm_timing_t& t, const std::string&) { published[t.axis] = t; });
  std::optional<motionlcm::line_timing_t> line_timing;
  lab.group().node().subscribe<motionlcm::line_timing_t>(
      lcm::channels::kLineTiming, [&](const motionlcm::line_timing_t& t, const std::string&) { line_timing = t; });
  std::string printed;
  ASSERT_EQ(lab.group().run_to_completion(
                {"status-model", "motionctl", {"--config", lab.config_path(), "status", "--model"}, {}}, &printed,
                seconds(20)),
            0)
      << printed;
  ASSERT_TRUE(lab.client().wait_until([&] { return published.size() == kAxes.size(); }, seconds(5)))
      << "ARM_TIMING of every axis (sent again with the models motionctl asked for)";
  double all_us = 0;
  double one_us = 0;
  EXPECT_NE(printed.find("arming on rs485 (ARM_TIMING: line time of the frames arming sends; 3 drives on the bus)"),
            std::string::npos)
      << printed;
  for (const auto& axis : kAxes) {
    const auto& t = published.at(axis);
    ASSERT_GT(t.arm_line_us, 0) << axis;
    ASSERT_GT(t.arm_bystander_us, 0) << axis;
    char line[160];
    std::snprintf(line, sizeof line, "  %-11s %.1f us loading its move, %.1f us readying each other drive",
                  axis.c_str(), t.arm_line_us, t.arm_bystander_us);
    EXPECT_NE(printed.find(line), std::string::npos) << line << "\n" << printed;
    all_us += t.arm_line_us;
    one_us = std::max(one_us, t.arm_line_us + 2 * t.arm_bystander_us);
  }
  char bus_line[160];
  std::snprintf(bus_line, sizeof bus_line,
                "  bus         %.1f us every axis armed together, at most %.1f us one axis armed alone", all_us,
                one_us);
  EXPECT_NE(printed.find(bus_line), std::string::npos) << bus_line << "\n" << printed;
  std::printf("[ adam ] status --model, arming on rs485:%s\n", bus_line + 11);
  ASSERT_TRUE(lab.client().wait_until([&] { return line_timing.has_value(); }, seconds(5))) << "LINE_TIMING of rs485";
  EXPECT_EQ(line_timing->bus, "rs485");
  EXPECT_GT(line_timing->start_wait_us, 1000.0) << "a poll read and its reply on the line";
  char wait_line[160];
  std::snprintf(wait_line, sizeof wait_line, "  start wait  %.1f us (LINE_TIMING", line_timing->start_wait_us);
  EXPECT_NE(printed.find(wait_line), std::string::npos) << wait_line << "\n" << printed;

  std::string json_text;
  ASSERT_EQ(lab.group().run_to_completion(
                {"status-model-json", "motionctl", {"--config", lab.config_path(), "--json", "status", "--model"}, {}},
                &json_text, seconds(20)),
            0)
      << json_text;
  const auto first = json_text.find('{');
  const auto last = json_text.rfind('}');
  ASSERT_TRUE(first != std::string::npos && last != std::string::npos) << json_text;
  const auto doc = nlohmann::json::parse(json_text.substr(first, last - first + 1), nullptr, false);
  ASSERT_TRUE(doc.is_object()) << json_text;
  for (const auto& axis : kAxes) {
    const auto& arming = doc[axis]["arm_timing"];
    ASSERT_TRUE(arming.is_object()) << axis << ": " << json_text;
    EXPECT_DOUBLE_EQ(arming["arm_line_us"].get<double>(), published.at(axis).arm_line_us) << axis;
    EXPECT_DOUBLE_EQ(arming["arm_bystander_us"].get<double>(), published.at(axis).arm_bystander_us) << axis;
    EXPECT_DOUBLE_EQ(arming["bus_all_armed_us"].get<double>(), all_us) << axis;
    EXPECT_DOUBLE_EQ(arming["bus_one_armed_max_us"].get<double>(), one_us) << axis;
    ASSERT_TRUE(doc[axis]["start_wait_us"].is_number()) << axis << ": " << json_text;
    EXPECT_DOUBLE_EQ(doc[axis]["start_wait_us"].get<double>(), line_timing->start_wait_us) << axis;
  }
}

TEST_F(AdamLine, SynchronizedMoveStartsOnOneBroadcastFrameAndArrives) {
  std::vector<reply_t> replies;
  const Values targets{{"c1", 10.0}, {"c2", -5.0}, {"c3", 20.0}};
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, targets), &replies);
  ASSERT_EQ(done.status, status(reply_t::DONE)) << done.reason;
  EXPECT_TRUE(saw(replies, reply_t::ACCEPTED));
  EXPECT_TRUE(saw(replies, reply_t::STARTED));

  // Ground truth: the three drives started on the same frame (the broadcast table execute).
  const auto c1 = lab.starts_of("c1-drive");
  const auto c2 = lab.starts_of("c2-drive");
  const auto c3 = lab.starts_of("c3-drive");
  ASSERT_EQ(c1.size(), 1u);
  ASSERT_EQ(c2.size(), 1u);
  ASSERT_EQ(c3.size(), 1u);
  EXPECT_EQ(c1[0].frame_utime, c2[0].frame_utime) << "c1 and c2 did not start on the same frame";
  EXPECT_EQ(c1[0].frame_utime, c3[0].frame_utime) << "c1 and c3 did not start on the same frame";
  EXPECT_EQ(c1[0].target_counts, 3200);
  EXPECT_EQ(c2[0].target_counts, -1600);
  EXPECT_EQ(c3[0].target_counts, 6400);

  // The gateway's STARTED names the mechanism; its trigger time is that frame's end.
  const auto* started = lab.last_gateway_started();
  ASSERT_NE(started, nullptr);
  EXPECT_EQ(started->start_mechanism, "broadcast");
  EXPECT_DOUBLE_EQ(started->predicted_skew_us, 0.0);
  EXPECT_LT(std::abs(started->trigger_utime - c1[0].frame_utime), 20'000)
      << "trigger time vs the simulator's frame time";
  EXPECT_NEAR(done.measured_start_skew_us, 0.0, 1.0);

  ASSERT_EQ(done.num_axes, 3);
  for (std::size_t i = 0; i < done.axes.size(); ++i) {
    EXPECT_NEAR(done.positions[i], done.targets[i], kPositionTolerance) << done.axes[i];
    EXPECT_NEAR(done.targets[i], targets.at(done.axes[i]), 1e-9) << done.axes[i];
  }
  for (const auto& [axis, target] : targets) EXPECT_TRUE(settled_at(axis, target)) << axis << " at " << position(axis);
  std::printf("[ adam ] broadcast start: trigger - frame = %lld us, predicted duration %.3f s\n",
              static_cast<long long>(started->trigger_utime - c1[0].frame_utime), done.predicted_duration_s);
}

TEST_F(AdamLine, RelativeMoveOfTwoLeavesTheThirdStill) {
  const auto done = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"c1", 2.0}, {"c3", -3.0}}));
  ASSERT_EQ(done.status, status(reply_t::DONE)) << done.reason;
  const auto c1 = lab.starts_of("c1-drive");
  const auto c3 = lab.starts_of("c3-drive");
  ASSERT_EQ(c1.size(), 1u);
  ASSERT_EQ(c3.size(), 1u);
  const auto* started = lab.last_gateway_started();
  ASSERT_NE(started, nullptr);
  EXPECT_EQ(started->start_mechanism, "broadcast");
  EXPECT_EQ(c1[0].frame_utime, c3[0].frame_utime);
  // c2 executed the same broadcast with its table entry set to where it stands: no motion.
  EXPECT_TRUE(lab.starts_of("c2-drive").empty());
  EXPECT_TRUE(settled_at("c1", 2.0));
  EXPECT_TRUE(settled_at("c3", -3.0));
  EXPECT_NEAR(position("c2"), 0.0, kPositionTolerance);

  // And relative again from there.
  const auto again = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"c1", -1.5}}));
  ASSERT_EQ(again.status, status(reply_t::DONE)) << again.reason;
  EXPECT_TRUE(settled_at("c1", 0.5));
}

TEST_F(AdamLine, JogThenStop) {
  const auto jog = lab.call(Client::make(request_t::JOG, Values{{"c2", 10.0}}));  // 10 mm/s = 60 rpm
  ASSERT_EQ(jog.status, status(reply_t::DONE)) << jog.reason;
  ASSERT_EQ(lab.starts_of("c2-drive").size(), 1u);
  ASSERT_TRUE(
      lab.client().wait_until([&] { return position("c2") > 1.0 && lab.client().axes().at("c2").moving; }, seconds(5)))
      << "c2 at " << position("c2");
  const auto stop = lab.call(Client::make(request_t::STOP, std::vector<std::string>{"c2"}));
  ASSERT_EQ(stop.status, status(reply_t::DONE)) << stop.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !lab.client().axes().at("c2").moving; }, seconds(5)));
  const double stopped_at = position("c2");
  EXPECT_GT(stopped_at, 1.0);
  // Stopped is stopped: still there a while later, and the others never moved.
  lab.client().wait_until([] { return false; }, milliseconds(300));
  EXPECT_NEAR(position("c2"), stopped_at, kPositionTolerance);
  EXPECT_TRUE(lab.starts_of("c1-drive").empty());
  EXPECT_TRUE(lab.starts_of("c3-drive").empty());
}

TEST_F(AdamLine, EmergencyStopAbortsAMoveShortOfItsTarget) {
  std::vector<reply_t> replies;
  lab.client().send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"c1", 90.0}, {"c2", 80.0}}),
                    [&](const reply_t& r) { replies.push_back(r); });
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(replies, reply_t::STARTED); }, seconds(10)));
  ASSERT_TRUE(lab.client().wait_until([&] { return position("c1") > 5.0; }, seconds(5)));
  const auto estop = lab.call(Client::make(request_t::ESTOP, std::vector<std::string>{"c1", "c2"}));
  ASSERT_EQ(estop.status, status(reply_t::DONE)) << estop.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !replies.empty() && client::is_terminal(replies.back().status); },
                                      seconds(5)));
  EXPECT_TRUE(replies.back().status == status(reply_t::ABORTED) || replies.back().status == status(reply_t::FAILED))
      << client::status_name(replies.back().status) << ": " << replies.back().reason;
  ASSERT_TRUE(lab.client().wait_until(
      [&] { return !lab.client().axes().at("c1").moving && !lab.client().axes().at("c2").moving; }, seconds(5)));
  EXPECT_LT(position("c1"), 89.0);
  EXPECT_LT(position("c2"), 79.0);
}

TEST_F(AdamLine, SetPositionPresetsTheCounterWithoutMotion) {
  const auto set = lab.call(Client::make(request_t::SET_POSITION, Values{{"c3", 12.5}}));
  ASSERT_EQ(set.status, status(reply_t::DONE)) << set.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return std::abs(position("c3") - 12.5) < kPositionTolerance; }, seconds(2)))
      << "c3 at " << position("c3");
  EXPECT_TRUE(lab.starts_of("c3-drive").empty());
  // Moves are relative to the new origin.
  const auto move = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"c3", 10.0}}));
  ASSERT_EQ(move.status, status(reply_t::DONE)) << move.reason;
  const auto starts = lab.starts_of("c3-drive");
  ASSERT_EQ(starts.size(), 1u);
  EXPECT_EQ(starts[0].target_counts, 3200);
  EXPECT_TRUE(settled_at("c3", 10.0));
}

TEST_F(AdamLine, AlarmRaisesAnEventAndAbortsTheMoveWithTheReason) {
  std::vector<reply_t> replies;
  lab.client().send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"c1", 80.0}, {"c2", 70.0}}),
                    [&](const reply_t& r) { replies.push_back(r); });
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(replies, reply_t::STARTED); }, seconds(10)));
  lab.control("c2-drive", sim_control_t::ALARM, 1);  // over-current (§8.52 code 1)
  ASSERT_TRUE(lab.client().wait_until([&] { return !replies.empty() && client::is_terminal(replies.back().status); },
                                      seconds(5)));
  const reply_t& last = replies.back();
  EXPECT_TRUE(last.status == status(reply_t::ABORTED) || last.status == status(reply_t::FAILED))
      << client::status_name(last.status);
  EXPECT_NE(last.reason.find("c2-drive"), std::string::npos) << last.reason;
  EXPECT_NE(last.reason.find("Over-current"), std::string::npos) << last.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.has_event(event_t::ALARM, "c2", "Over-current"); }, seconds(2)));
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.client().axes().at("c2").fault; }, seconds(2)));
  // c1 was stopped with c2, short of its target.
  EXPECT_TRUE(lab.client().wait_until([&] { return !lab.client().axes().at("c1").moving; }, seconds(5)));
  EXPECT_LT(position("c1"), 79.0);
  // The faulted axis is refused until reset; the reset clears the drive's alarm (0x00A4).
  const auto refused = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"c2", 1.0}}));
  EXPECT_EQ(refused.status, status(reply_t::REJECTED));
  EXPECT_NE(refused.reason.find("c2"), std::string::npos) << refused.reason;
  const auto reset = lab.call(Client::make(request_t::FAULT_RESET, std::vector<std::string>{"c2"}));
  ASSERT_EQ(reset.status, status(reply_t::DONE)) << reset.reason;
  EXPECT_TRUE(lab.client().wait_until([&] { return !lab.client().axes().at("c2").fault; }, seconds(2)));
}

TEST_F(AdamLine, DeadDriveDoesNotStallTheOthers) {
  lab.control("c3-drive", sim_control_t::SILENCE, 1);
  // c3 goes offline (timeout, one retry, then the event) ...
  ASSERT_TRUE(lab.client().wait_until([&] { return !lab.client().axes().at("c3").online; }, seconds(5)));
  EXPECT_TRUE(lab.has_event(event_t::OFFLINE, "c3", "c3-drive (slave 3)"));
  // ... while c1 and c2 keep being polled and move.
  const auto c1_sample = lab.client().axes().at("c1").sample_utime;
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"c1", 5.0}, {"c2", -4.0}}));
  ASSERT_EQ(done.status, status(reply_t::DONE)) << done.reason;
  EXPECT_TRUE(settled_at("c1", 5.0));
  EXPECT_TRUE(settled_at("c2", -4.0));
  EXPECT_GT(lab.client().axes().at("c1").sample_utime, c1_sample);
  EXPECT_TRUE(lab.client().axes().at("c1").online);
  EXPECT_TRUE(lab.client().axes().at("c2").online);
  EXPECT_TRUE(lab.starts_of("c3-drive").empty());

  // A command for the dead drive fails, naming it: the coordinator refuses motion of an offline
  // axis; a stop (always accepted) goes to the line and times out naming the drive and register.
  const auto refused = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"c3", 1.0}}));
  EXPECT_EQ(refused.status, status(reply_t::REJECTED)) << refused.reason;
  EXPECT_NE(refused.reason.find("c3"), std::string::npos) << refused.reason;
  const auto stop = lab.call(Client::make(request_t::STOP, std::vector<std::string>{"c3"}));
  EXPECT_TRUE(stop.status == status(reply_t::FAILED) || stop.status == status(reply_t::ABORTED))
      << client::status_name(stop.status);
  EXPECT_NE(stop.reason.find("c3-drive (slave 3)"), std::string::npos) << stop.reason;
  EXPECT_NE(stop.reason.find("0x00C8"), std::string::npos) << stop.reason;

  // The line keeps re-probing the dead drive: when it answers again it comes back online.
  lab.control("c3-drive", sim_control_t::SILENCE, 0);
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.client().axes().at("c3").online; }, seconds(10)));
  EXPECT_TRUE(lab.client().wait_until([&] { return lab.has_event(event_t::ONLINE, "c3", "c3-drive"); }, seconds(2)));
}

// Even and odd parity on the simulated line (configs/adam-line-even.yaml, -odd.yaml): the pty may
// refuse PARENB; motion-sim and the gateway then model the parity bit instead of setting it. The
// line opens, the drives come online and a synchronized move arrives.
class AdamParity : public ::testing::TestWithParam<const char*> {
 protected:
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }
  SimLab lab{source_path(std::string("tests/integration/configs/adam-line-") + GetParam() + ".yaml")};
};

TEST_P(AdamParity, LineOpensDrivesComeOnlineAndAMoveArrives) {
  const std::vector<std::string> axes{"p1", "p2"};
  ASSERT_TRUE(lab.start(axes));
  ASSERT_TRUE(lab.enable(axes));
  // The heartbeat (every period) catches up with the drives coming online.
  ASSERT_TRUE(lab.group().pump_until(
      [&] {
        const auto s = lab.bus_stats("rs485");
        return s && s->drives_online == 2;
      },
      seconds(5)));
  EXPECT_EQ(lab.bus_stats("rs485")->state, "open");
  const Values targets{{"p1", 4.0}, {"p2", -2.5}};
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, targets));
  ASSERT_EQ(done.status, status(reply_t::DONE)) << done.reason;
  for (const auto& [axis, target] : targets)
    EXPECT_TRUE(lab.settled_at(axis, target, kPositionTolerance)) << axis << " at " << lab.position(axis);
  ASSERT_EQ(lab.starts_of("p1-drive").size(), 1u);
  EXPECT_EQ(lab.starts_of("p1-drive")[0].target_counts, 1280);
  EXPECT_EQ(lab.starts_of("p2-drive")[0].target_counts, -800);
}

INSTANTIATE_TEST_SUITE_P(Parity, AdamParity, ::testing::Values("even", "odd"));

// A bus whose device cannot be opened says why in the gateway's heartbeat: the bus state and the
// health detail (what `motionctl health` prints), not only "drives not all online".
TEST(AdamUnopenable, HealthSaysWhyTheBusIsClosed) {
  SimLab lab{source_path("tests/integration/configs/adam-unopenable.yaml")};
  lab.start_gateway("rs485");
  ASSERT_TRUE(lab.group().wait_for_heartbeat("gateway:rs485", seconds(20), true));
  const std::string why = "closed: cannot open /nonexistent-motion-test/ttyUSB0: No such file or directory";
  ASSERT_TRUE(lab.group().pump_until([&] { return lab.bus_stats("rs485").has_value(); }, seconds(5)));
  EXPECT_EQ(lab.bus_stats("rs485")->state, why);
  const auto health = lab.group().heartbeat("gateway:rs485");
  ASSERT_TRUE(health.has_value());
  EXPECT_EQ(health->state, st(motionlcm::health_t::DEGRADED));
  EXPECT_NE(health->detail.find("bus rs485 " + why), std::string::npos) << health->detail;
  if (HasFailure()) lab.group().print_logs();
}

}  // namespace
}  // namespace motion::testing
