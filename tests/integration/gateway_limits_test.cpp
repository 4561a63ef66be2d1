// The gateways' own limits on the simulated lab (config/sim-lab.yaml), whoever commands them
// (issue "Nothing lost, nothing runs away"):
//  - an ARM_MOVE published straight on GW_COMMAND_can0, past the coordinator, beyond the position
//    and velocity limits of x and a: FAILED with code 3 (outside limits), a PROTOCOL_ERROR event,
//    and nothing moves;
//  - a jog of c toward its +100 mm limit, within the velocity limit: the rs485 gateway stops it
//    before the limit and says so with a LIMIT event.
//  - a second gateway for a bus that already has one refuses to start, naming the process that
//    holds the bus, and the first one carries on.
// No timed assertions: waits are bounded.
#include <gtest/gtest.h>

#include <cstdio>

#include <motionlcm/gateway_command_t.hpp>

#include "motion/lcm/reply_error.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;

class GatewayLimits : public ::testing::Test {
 protected:
  void SetUp() override {
    lab.group().node().subscribe<gateway_reply_t>(lcm::channels::kGatewayReply,
                                                  [this](const gateway_reply_t& r, const std::string&) {
                                                    if (r.command_id >= kOwnIds) replies_[r.command_id] = r;
                                                  });
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }

  // Command ids far from the coordinator's (it counts from 1).
  static constexpr std::int64_t kOwnIds = 900'000'000;

  std::optional<gateway_reply_t> arm_move_directly(std::int64_t id,
                                                   const std::vector<motionlcm::axis_command_t>& axes) {
    gateway_command_t c{};
    c.utime = wall_time_us();
    c.bus = "can0";
    c.command_id = id;
    c.request_id = 0;
    c.kind = gateway_command_t::ARM_MOVE;
    c.trigger_id = 0;  // at once
    c.axes = axes;
    c.num_axes = static_cast<std::int32_t>(axes.size());
    lab.group().node().publish(lcm::channels::gateway_command("can0"), c);
    lab.client().wait_until([&] { return replies_.contains(id); }, seconds(5));
    if (!replies_.contains(id)) return std::nullopt;
    return replies_.at(id);
  }

  SimLab lab;
  std::map<std::int64_t, gateway_reply_t> replies_;
};

motionlcm::axis_command_t axis_command(const std::string& axis, std::int64_t target, double velocity,
                                       double acceleration) {
  motionlcm::axis_command_t a{};
  a.axis = axis;
  a.target_counts = target;
  a.velocity = velocity;
  a.acceleration = a.deceleration = acceleration;
  return a;
}

TEST_F(GatewayLimits, ArmMovePastTheCoordinatorBeyondTheLimitsFailsAndNothingMoves) {
  ASSERT_TRUE(lab.start({"x", "a"}));
  ASSERT_TRUE(lab.enable({"x", "a"}));
  const double x0 = lab.position("x");
  const double a0 = lab.position("a");
  lab.clear_reports();

  // x to 400 mm (limit 300) at 100 mm/s (limit 50): 640 counts/mm.
  const auto x = arm_move_directly(kOwnIds + 1, {axis_command("x", std::int64_t{400} * 640, 100 * 640, 400 * 640)});
  ASSERT_TRUE(x.has_value()) << "no GW_REPLY from gateway:can0";
  EXPECT_EQ(x->status, st(gateway_reply_t::FAILED));
  EXPECT_EQ(x->error_code, code(ReplyError::kOutsideLimits));
  EXPECT_NE(x->reason.find("axis x"), std::string::npos) << x->reason;
  EXPECT_NE(x->reason.find("400 mm"), std::string::npos) << x->reason;
  EXPECT_NE(x->reason.find("[-10, 300] mm"), std::string::npos) << x->reason;
  EXPECT_NE(x->reason.find("velocity 100 mm/s"), std::string::npos) << x->reason;  // every violation named

  // x within its positions but too fast: still refused.
  const auto fast = arm_move_directly(kOwnIds + 2, {axis_command("x", std::int64_t{100} * 640, 100 * 640, 400 * 640)});
  ASSERT_TRUE(fast.has_value());
  EXPECT_EQ(fast->status, st(gateway_reply_t::FAILED));
  EXPECT_EQ(fast->error_code, code(ReplyError::kOutsideLimits));
  EXPECT_NE(fast->reason.find("velocity 100 mm/s"), std::string::npos) << fast->reason;

  // a to 900 deg (limit 720): 3200 counts per 360 deg.
  const auto a = arm_move_directly(kOwnIds + 3, {axis_command("a", 8000, 1600, 6400)});
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->status, st(gateway_reply_t::FAILED));
  EXPECT_EQ(a->error_code, code(ReplyError::kOutsideLimits));
  EXPECT_NE(a->reason.find("axis a"), std::string::npos) << a->reason;
  EXPECT_NE(a->reason.find("900 deg"), std::string::npos) << a->reason;

  EXPECT_TRUE(lab.client().wait_until(
      [&] { return lab.has_event(ev(event_t::PROTOCOL_ERROR), "x", "outside the limits"); }, seconds(5)));
  // Nothing moves: a few status periods later both stand where they were, and no simulated drive
  // reported a start.
  lab.pause(std::chrono::milliseconds(600));
  EXPECT_FALSE(lab.state("x").moving);
  EXPECT_FALSE(lab.state("a").moving);
  EXPECT_DOUBLE_EQ(lab.position("x"), x0);
  EXPECT_DOUBLE_EQ(lab.position("a"), a0);
  EXPECT_TRUE(lab.starts_of("x-drive").empty());
  EXPECT_TRUE(lab.starts_of("a-drive").empty());
}

TEST_F(GatewayLimits, JogTowardTheLimitStopsBeforeItWithALimitEvent) {
  ASSERT_TRUE(lab.start({"c"}));
  ASSERT_TRUE(lab.enable({"c"}));
  const double start = lab.position("c");
  ASSERT_LT(start, 50.0);
  // 30 mm/s, within c's 40 mm/s.
  const auto jog = lab.call(Client::make(request_t::JOG, std::map<std::string, double>{{"c", 30.0}}));
  ASSERT_EQ(jog.status, st(reply_t::DONE)) << jog.reason;
  ASSERT_TRUE(
      lab.client().wait_until([&] { return lab.has_event(ev(event_t::LIMIT), "c", "limit 100 mm"); }, seconds(20)))
      << "no LIMIT event for c; at " << lab.position("c") << " mm";
  ASSERT_TRUE(
      lab.client().wait_until([&] { return !lab.state("c").moving && lab.state("c").sample_utime > 0; }, seconds(10)));
  lab.pause(std::chrono::milliseconds(500));  // a few more status polls: it stays stopped
  EXPECT_FALSE(lab.state("c").moving);
  EXPECT_LE(lab.position("c"), 100.0);
  EXPECT_GT(lab.position("c"), start + 20.0);  // it did jog
  std::printf("c jogged from %.3f mm and stopped at %.3f mm (limit 100 mm)\n", start, lab.position("c"));

  // A jog further toward the limit now starts within its stopping margin: stopped at once again,
  // never past the limit.
  const auto again = lab.call(Client::make(request_t::JOG, std::map<std::string, double>{{"c", 30.0}}));
  (void)again;
  lab.pause(std::chrono::milliseconds(1500));
  EXPECT_LE(lab.position("c"), 100.0);
}

TEST_F(GatewayLimits, ASecondGatewayOnTheSameBusRefusesToStartAndNamesTheHolder) {
  ASSERT_TRUE(lab.start({"x"}));
  const auto first = lab.group().heartbeat("gateway:can0");
  ASSERT_TRUE(first.has_value());
  const pid_t second = lab.group().start(
      {"gateway:can0-second", "motion-gateway", {"--config", lab.config_path(), "--bus", "can0"}, {}});
  ASSERT_GT(second, 0);
  std::optional<int> status;
  lab.group().pump_until([&] { return (status = lab.group().exit_status(second)).has_value(); }, seconds(10));
  ASSERT_TRUE(status.has_value()) << "the second gateway of can0 kept running";
  EXPECT_EQ(*status, 4);  // kExitUnavailable
  const std::string log = lab.group().log_of("gateway:can0-second");
  EXPECT_NE(log.find("bus can0 (simcan:can0) is already served by process " + std::to_string(first->pid)),
            std::string::npos)
      << log;
  // The first gateway still owns the bus: it heartbeats and moves x.
  ASSERT_TRUE(lab.group().wait_for_heartbeat("gateway:can0", seconds(5)));
  ASSERT_TRUE(lab.enable({"x"}));
  const double x0 = lab.position("x");
  const auto move = lab.call(Client::make(request_t::MOVE_ABSOLUTE, std::map<std::string, double>{{"x", x0 + 1.0}}));
  EXPECT_EQ(+move.status, +reply_t::DONE) << move.reason;
  EXPECT_TRUE(lab.settled_at("x", x0 + 1.0, 0.01));
}

}  // namespace
}  // namespace motion::testing
