// The fault matrix (issue 14, README "Safety and faults"), one table row per fault, on ONE
// simulated lab of every family (config/sim-lab.yaml: UIM342 x/y/z and UC57 a/b on can0, ADAM c
// on rs485, UIM242 u on rs232) shared by the rows: each row leaves the lab recovered, which is
// part of what it checks. Every row:
//   1. moves one axis (about a second of motion), and injects its fault while the axis moves;
//   2. asserts exactly one terminal reply to that move, and the event that names the fault;
//   3. once the fault ends, asserts that every axis is online, at rest and within its limits, and
//      that every process heartbeats OK;
//   4. recovers as an operator would (reset, enable; home or set-position where the position was
//      lost) and asserts that a new move of the axis is DONE and ends at its target.
// Faults go in through SIM_CONTROL (motion-sim), raw LCM publications, and killing or starting
// processes. Rows left out, and why, are listed in the README.
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>

#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>

#include "sim_lab.hpp"

namespace motion::testing {
namespace {

// Faults that are not a SIM_CONTROL action.
constexpr std::int8_t kKillGateway = -1;    // SIGKILL the axis's gateway, start it again at once
constexpr std::int8_t kMalformed = -2;      // malformed and oversized messages on its channels
constexpr std::int8_t kSecondGateway = -3;  // a second gateway for the axis's bus
constexpr std::int8_t kDropWithStop = -4;   // the bus drops frames, a STOP is sent into it
// SIGKILL the axis's gateway, start it again after `hold_ms` (the coordinator has declared it lost)
constexpr std::int8_t kKillGatewayUntilLost = -5;

struct Row {
  const char* name;
  const char* axis;
  std::int8_t fault;  // sim_control_t action, or one of the k... above
  std::int32_t value = 0;
  std::int16_t event = 0;      // an event of this kind must name the axis (0: none required)
  bool position_lost = false;  // the axis ends with its position lost (and is refused a move)
  bool done = false;           // the move rides through the fault and ends DONE at its target
  bool offline = false;        // during the fault the axis goes offline and stops saying "moving"
  int hold_ms = 0;             // the fault lasts this long at least (0: until the terminal reply, 1.5 s at most)
  double velocity_scale = 0;   // of the move the fault hits (0: full speed)
};

std::ostream& operator<<(std::ostream& os, const Row& r) { return os << r.name; }

const Row kRows[] = {
    {"DriveSilent", "z", sim_control_t::SILENCE, 1, event_t::OFFLINE},
    {"PowerCycledUim342", "z", sim_control_t::POWER_CYCLE, 0, event_t::REBOOT, true},
    {"PowerCycledUc57", "a", sim_control_t::POWER_CYCLE, 0, event_t::REBOOT, true},
    {"PowerCycledAdam", "c", sim_control_t::POWER_CYCLE, 0, event_t::REBOOT, true},
    // The UIM242 keeps its absolute position counter over a power failure (UIM242 manual §7.6):
    // its position is not lost, the move ends short of its target.
    {"PowerCycledUim242", "u", sim_control_t::POWER_CYCLE, 0, 0, false},
    {"Stall", "z", sim_control_t::STALL, 0, event_t::STALL},
    // Dropped CAN frames hit every drive of the bus; the moving axis is a UC57 (a UIM342 that
    // drops out mid-move is set up again only at rest: its set-up is refused while it moves).
    {"FramesDropped", "a", sim_control_t::BUS_DROP, 50, 0},
    {"FramesDroppedWithTheStop", "a", kDropWithStop, 20, 0},
    // The gateway's CAN controller bus-off for 600 ms, then restarted (SocketCAN restart-ms): a
    // BUS_OFF and a BUS_RECOVERED event of the bus; the move that was running ends once.
    {"GatewayBusOff", "a", sim_control_t::BUS_OFF, 600, event_t::BUS_OFF},
    // Persistent CRC errors: the drive goes on executing, nothing it sends gets through (CAN: the
    // frames fail the CRC at every receiver; Modbus: the master discards the replies); held until
    // the move is over on the drive, so that it answers again at rest.
    {"CrcErrorsUim342", "z", sim_control_t::CRC_ERRORS, 1, event_t::OFFLINE, false, false, true, 2000},
    {"CrcErrorsUc57", "a", sim_control_t::CRC_ERRORS, 1, event_t::HEARTBEAT_LOST, false, false, true, 2000},
    {"CrcErrorsAdam", "c", sim_control_t::CRC_ERRORS, 1, event_t::OFFLINE, false, false, true, 2000},
    {"CrcErrorsUim242", "u", sim_control_t::CRC_ERRORS, 1, event_t::OFFLINE, false, false, true, 2000},
    {"ReplyLatency", "a", sim_control_t::REPLY_LATENCY, 30000, 0, false, true},
    {"LineNoise", "c", sim_control_t::LINE_NOISE, 24, event_t::PROTOCOL_ERROR},
    {"GatewayKilledAndRestarted", "c", kKillGateway, 0, event_t::GATEWAY_RESTARTED},
    // Restarted only 2.5 x gateway_timeout_ms (1500 ms) later, one row per family: the request ended
    // ABORTED 16 when the coordinator lost the gateway; the slow move (15 % speed, 7-11 s) still runs
    // on the drive when the new gateway finds it, which stops it (GATEWAY_RESTARTED) and sets it up.
    {"GatewayLostThenRestarted", "c", kKillGatewayUntilLost, 0, event_t::GATEWAY_RESTARTED, false, false, false, 3750,
     0.15},
    {"GatewayLostThenRestartedUim342", "z", kKillGatewayUntilLost, 0, event_t::GATEWAY_RESTARTED, false, false, false,
     3750, 0.15},
    {"GatewayLostThenRestartedUc57", "a", kKillGatewayUntilLost, 0, event_t::GATEWAY_RESTARTED, false, false, false,
     3750, 0.15},
    // The UIM242's set-up ends its motion itself (STP 0, UIM242 manual #44): at rest when first heard, no event.
    {"GatewayLostThenRestartedUim242", "u", kKillGatewayUntilLost, 0, 0, false, false, false, 3750, 0.15},
    {"MalformedMessages", "z", kMalformed, 0, 0, false, true},
    {"SecondGatewayOnTheBus", "z", kSecondGateway, 0, 0, false, true},
};

class FaultMatrix : public ::testing::TestWithParam<Row> {
 protected:
  static void SetUpTestSuite() {
    lab_ = std::make_unique<SimLab>();
    lab_->client().on_event([](const event_t& e) { events_.push_back(e); });
    started_ = lab_->start(all_axes());
  }
  static void TearDownTestSuite() { lab_.reset(); }  // kills every process of the lab

  void SetUp() override {
    ASSERT_TRUE(started_) << "the lab did not start";
    first_event_ = events_.size();
  }
  void TearDown() override {
    if (HasFailure()) lab_->group().print_logs();
  }

  static std::vector<std::string> all_axes() { return {"x", "y", "z", "a", "b", "c", "u"}; }
  static SimLab& lab() { return *lab_; }
  const motionlcm::axis_state_t& state(const std::string& axis) { return lab().state(axis); }
  const config::Axis& axis_config(const std::string& axis) {
    const auto* a = lab().config().find_axis(axis);
    if (a == nullptr) throw std::runtime_error("no axis " + axis);
    return *a;
  }
  // A target about a second of motion away from where the axis stands, toward its middle.
  double target_from(const std::string& axis, double seconds_of_motion) {
    const auto& lim = axis_config(axis).limits;
    const double here = state(axis).position;
    const double span = std::min(lim.max_velocity * seconds_of_motion, (lim.max_position - lim.min_position) / 3.0);
    return here > (lim.min_position + lim.max_position) / 2.0 ? here - span : here + span;
  }
  bool event_since(std::int16_t kind, const std::string& axis) const {
    return std::any_of(events_.begin() + static_cast<std::ptrdiff_t>(first_event_), events_.end(),
                       [&](const event_t& e) {
                         return e.kind == kind && (e.axis == axis || (e.axis.empty() && e.bus == bus_of(axis)));
                       });
  }
  std::string bus_of(const std::string& axis) const {
    return lab_->config().drive_of(*lab_->config().find_axis(axis))->bus;
  }
  std::string process_of(const std::string& axis) {
    return "gateway:" + lab().config().drive_of(axis_config(axis))->bus;
  }

  // Reset and enable every axis, retried while an axis is still being stopped or set up; the
  // position of an axis that lost it is set to where it stands.
  ::testing::AssertionResult recover() {
    for (const std::int8_t kind : {request_t::FAULT_RESET, request_t::ENABLE}) {
      reply_t got{};
      for (int attempt = 0; attempt < 40; ++attempt) {
        got = lab().call(Client::make(kind, all_axes()));
        if (got.status == reply_t::DONE) break;
        lab().pause(milliseconds(250));
      }
      if (got.status != reply_t::DONE)
        return ::testing::AssertionFailure() << "kind " << int{kind} << ": " << got.reason;
    }
    for (const auto& axis : all_axes()) {
      if (state(axis).fault_code != motionlcm::axis_state_t::POSITION_LOST) continue;
      const auto set = lab().call(Client::make(request_t::SET_POSITION, Values{{axis, state(axis).position}}));
      if (set.status != reply_t::DONE)
        return ::testing::AssertionFailure() << "set-position " << axis << ": " << set.reason;
    }
    return ::testing::AssertionSuccess();
  }

  // Starts `fault`; returns what ends it (nothing to end: a no-op).
  std::function<void()> inject(const Row& row) {
    const std::string axis = row.axis;
    const std::string drive = axis_config(axis).drive;
    const std::string bus = lab().config().drive_of(axis_config(axis))->bus;
    switch (row.fault) {
      case kKillGateway:
      case kKillGatewayUntilLost: {
        const auto gateway = lab().group().heartbeat(process_of(axis));
        EXPECT_TRUE(gateway.has_value());
        if (!gateway) return [] {};
        EXPECT_EQ(::kill(static_cast<pid_t>(gateway->pid), SIGKILL), 0);
        lab().group().stop(static_cast<pid_t>(gateway->pid));  // reap it
        const auto restart = [this, bus] {
          restarted_at_ = std::chrono::steady_clock::now();
          EXPECT_GT(lab().start_gateway(bus), 0);
        };
        if (row.fault == kKillGateway) {
          restart();
          return [] {};
        }
        return restart;
      }
      case kMalformed: {
        // A 20-byte message claiming a huge array count, and a 64 KiB one of garbage, on the
        // gateway's command channel and on the coordinator's request channel.
        std::vector<std::uint8_t> claim(20, 0xFF);
        std::vector<std::uint8_t> garbage(std::size_t{64} * 1024, 0xA5);
        for (const auto& channel : {lcm::channels::gateway_command(bus), lcm::channels::gateway_command2(bus),
                                    std::string(lcm::channels::kRequest)}) {
          const std::string full = lab().config().lcm.channel_prefix + channel;
          EXPECT_TRUE(lab().group().node().publish_raw(full, claim));
          EXPECT_TRUE(lab().group().node().publish_raw(full, garbage));
        }
        return [] {};
      }
      case kSecondGateway: {
        const pid_t second = lab().group().start(
            {"gateway:" + bus + "-second", "motion-gateway", {"--config", lab().config_path(), "--bus", bus}, {}});
        std::optional<int> status;
        lab().group().pump_until([&] { return (status = lab().group().exit_status(second)).has_value(); }, seconds(10));
        EXPECT_EQ(status, std::optional<int>{4}) << "a second gateway of " << bus << " kept running or ended otherwise";
        return [] {};
      }
      case kDropWithStop:
        lab().control_bus(bus, sim_control_t::BUS_DROP, row.value);
        stop_id_ = lab().client().send(Client::make(request_t::STOP, std::vector<std::string>{axis}),
                                       [this](const reply_t& r) {
                                         if (client::is_terminal(r.status)) stop_reply_ = r;
                                       });
        return [] {};
      case sim_control_t::LINE_NOISE: lab().control_bus(bus, sim_control_t::LINE_NOISE, row.value, 1); return [] {};
      case sim_control_t::BUS_DROP: lab().control_bus(bus, sim_control_t::BUS_DROP, row.value); return [] {};
      case sim_control_t::BUS_OFF: lab().control_bus(bus, sim_control_t::BUS_OFF, row.value); return [] {};
      case sim_control_t::SILENCE:
      case sim_control_t::CRC_ERRORS:
      case sim_control_t::REPLY_LATENCY:
        lab().control(drive, row.fault, row.value);
        return [drive, fault = row.fault] { lab().control(drive, fault, 0); };
      default: lab().control(drive, row.fault, row.value); return [] {};
    }
  }

  static std::unique_ptr<SimLab> lab_;
  static std::vector<event_t> events_;
  static bool started_;
  std::size_t first_event_ = 0;
  std::int64_t stop_id_ = 0;
  std::chrono::steady_clock::time_point restarted_at_{};
  std::optional<reply_t> stop_reply_;
};

std::unique_ptr<SimLab> FaultMatrix::lab_;
std::vector<event_t> FaultMatrix::events_;
bool FaultMatrix::started_ = false;

TEST_P(FaultMatrix, OneTerminalReplyAxesAtRestWithinLimitsAndTheLabMovesAgain) {
  const Row& row = GetParam();
  const std::string axis = row.axis;
  ASSERT_TRUE(recover());  // whatever the previous row left
  const double target = target_from(axis, 1.0);
  std::vector<reply_t> replies;
  auto request = Client::make(request_t::MOVE_ABSOLUTE, Values{{axis, target}});
  request.velocity_scale = row.velocity_scale;
  const auto id = lab().client().send(request, [&](const reply_t& r) { replies.push_back(r); });
  ASSERT_NE(id, 0);
  const auto terminals = [&] {
    return std::count_if(replies.begin(), replies.end(),
                         [](const reply_t& r) { return client::is_terminal(r.status); });
  };
  ASSERT_TRUE(lab().client().wait_until([&] { return state(axis).moving || terminals() > 0; }, seconds(10)));
  ASSERT_EQ(terminals(), 0) << replies.back().reason;
  lab().pause(milliseconds(200));
  const auto fault_start = std::chrono::steady_clock::now();
  auto end_fault = inject(row);
  if (row.offline) {
    EXPECT_TRUE(lab().client().wait_until([&] { return !state(axis).online && !state(axis).moving; }, seconds(5)))
        << axis << " still online or moving during the fault";
  }
  if (row.hold_ms > 0) {
    lab().client().wait_until([] { return false; },
                              milliseconds(row.hold_ms) - std::chrono::duration_cast<milliseconds>(
                                                              std::chrono::steady_clock::now() - fault_start));
  } else {
    lab().client().wait_until([&] { return terminals() > 0; }, milliseconds(1500));
  }
  const bool ended_during_fault = terminals() > 0;
  end_fault();
  if (row.fault == kKillGatewayUntilLost) {
    // The new gateway finds the drive still moving: stopped, set up, polled (a state sampled after).
    const std::int64_t restart_utime = wall_time_us();
    EXPECT_TRUE(lab().client().wait_until(
        [&] { return state(axis).online && !state(axis).moving && state(axis).sample_utime > restart_utime; },
        seconds(30)))
        << axis << " not online and at rest after the gateway restarted";
    std::cout << "[ row      ] " << row.name << ": " << axis << " online and at rest "
              << std::chrono::duration_cast<milliseconds>(std::chrono::steady_clock::now() - restarted_at_).count()
              << " ms after the gateway restarted\n";
  }

  // 1. Exactly one terminal reply (a second one would come within a few status periods).
  ASSERT_TRUE(lab().client().wait_until([&] { return terminals() > 0; }, seconds(40))) << "no terminal reply";
  lab().pause(milliseconds(300));
  ASSERT_EQ(terminals(), 1);
  const reply_t end =
      *std::find_if(replies.begin(), replies.end(), [](const reply_t& r) { return client::is_terminal(r.status); });
  std::cout << "[ row      ] " << row.name << ": " << client::status_name(end.status) << " code " << end.error_code
            << " (" << end.reason << ")\n";
  if (row.done) { EXPECT_EQ(end.status, st(reply_t::DONE)) << end.reason; }
  if (row.fault == kKillGatewayUntilLost) {
    EXPECT_TRUE(ended_during_fault) << "the coordinator had not ended the request when the gateway came back";
    EXPECT_EQ(end.status, st(reply_t::ABORTED)) << end.reason;
    EXPECT_EQ(end.error_code, code(ReplyError::kGatewayLost)) << end.reason;
    EXPECT_NE(end.reason.find(bus_of(axis)), std::string::npos) << end.reason;
  }
  if (row.fault == kDropWithStop) {
    EXPECT_NE(end.status, st(reply_t::DONE)) << "the stop did not take: " << end.reason;
    ASSERT_TRUE(lab().client().wait_until([&] { return stop_reply_.has_value(); }, seconds(30)))
        << "no terminal reply to the STOP";
  }
  // 2. The event naming the fault.
  if (row.event != 0) {
    EXPECT_TRUE(lab().client().wait_until([&] { return event_since(row.event, axis); }, seconds(10)))
        << "no event of kind " << row.event << " naming " << axis;
  }
  if (row.fault == sim_control_t::BUS_OFF) {
    EXPECT_TRUE(lab().client().wait_until([&] { return event_since(event_t::BUS_RECOVERED, axis); }, seconds(10)))
        << "no BUS_RECOVERED event of bus " << bus_of(axis);
  }
  // 3. Every axis online, at rest, within its limits; DONE means at the target; every process OK.
  const bool settled = lab().client().wait_until(
      [&] {
        for (const auto& a : all_axes()) {
          if (!state(a).online || state(a).moving) return false;
        }
        return true;
      },
      seconds(30));
  EXPECT_TRUE(settled) << "not every axis online and at rest";
  if (row.fault == kKillGatewayUntilLost) {
    // Still moving when the new gateway found it: stopped there, not run on to the aborted target.
    EXPECT_GT(std::abs(state(axis).position - target), 1.0) << axis << " ran on to the aborted move's target";
  }
  for (const auto& a : all_axes()) {
    const auto& lim = axis_config(a).limits;
    EXPECT_GE(state(a).position, lim.min_position - 1e-6) << a;
    EXPECT_LE(state(a).position, lim.max_position + 1e-6) << a;
  }
  const double tolerance = 1.5 / axis_config(axis).steps_per_unit;
  if (end.status == reply_t::DONE) { EXPECT_NEAR(state(axis).position, target, tolerance); }
  for (const auto& process : {std::string("sim"), std::string("coordinator"), std::string("gateway:can0"),
                              std::string("gateway:rs485"), std::string("gateway:rs232")}) {
    EXPECT_TRUE(lab().group().wait_for_heartbeat(process, seconds(20))) << process << " not OK";
  }
  if (row.fault == kMalformed) {
    const auto health = lab().group().heartbeat(process_of(axis));
    ASSERT_TRUE(health.has_value());
    EXPECT_NE(health->detail.find("malformed"), std::string::npos) << health->detail;
  }
  // 4. Position lost: said, and a move refused until its position is set; then a new move is DONE.
  if (row.position_lost) {
    EXPECT_TRUE(lab().client().wait_until(
        [&] { return state(axis).fault_code == motionlcm::axis_state_t::POSITION_LOST; }, seconds(10)))
        << state(axis).fault_text;
    EXPECT_FALSE(state(axis).homed);
    ASSERT_TRUE(lab().client().wait_until([&] { return state(axis).online; }, seconds(10)));
    const auto refused = lab().call(Client::make(request_t::MOVE_RELATIVE, Values{{axis, 1.0}}));
    EXPECT_EQ(refused.status, st(reply_t::REJECTED)) << refused.reason;
    EXPECT_TRUE(refused.error_code == code(ReplyError::kPositionLost) ||
                refused.error_code == code(ReplyError::kAxisDisabled))
        << refused.reason;
  } else {
    EXPECT_NE(state(axis).fault_code, motionlcm::axis_state_t::POSITION_LOST) << state(axis).fault_text;
  }
  ASSERT_TRUE(recover());
  const double again = target_from(axis, 0.3);
  const auto moved = lab().call(Client::make(request_t::MOVE_ABSOLUTE, Values{{axis, again}}));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  EXPECT_TRUE(lab().settled_at(axis, again, tolerance)) << state(axis).position;
}

INSTANTIATE_TEST_SUITE_P(Rows, FaultMatrix, ::testing::ValuesIn(kRows),
                         [](const ::testing::TestParamInfo<Row>& row) { return std::string(row.param.name); });

}  // namespace
}  // namespace motion::testing
