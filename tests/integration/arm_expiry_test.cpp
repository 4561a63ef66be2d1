// Moves armed on every gateway of the simulated lab (config/sim-lab.yaml: UIM342 group BG and UC57
// SYNC on can0, ADAM broadcast on rs485, UIM242 global on rs232) that no trigger ever starts, as
// when the coordinator dies between ARM_MOVE and SYNC_TRIGGER: each gateway releases them itself
// after its arm expiry (README "Safety and faults"). The ARM_MOVEs are the coordinator's own from a
// real move (gateway_command2_t), published again on GW_COMMAND2_<bus> with new ids, targets back
// where the axes came from, and a trigger id nobody fires in time. No timed assertions; the times
// are printed. Also: a released move leaves nothing a foreign start frame could run.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <map>
#include <set>

#include <motionlcm/gateway_command2_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>

#include "motion/canopen/sync.hpp"
#include "motion/simbus/endpoint.hpp"
#include "motion/uim342/instructions.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using gateway_command_t = motionlcm::gateway_command2_t;
using motionlcm::gateway_reply_t;

const std::vector<std::string> kAxes{"x", "y", "z", "a", "b", "c", "u"};
const Values kTargets{{"x", 30.0}, {"y", 20.0}, {"z", 10.0}, {"a", 180.0}, {"b", -120.0}, {"c", 20.0}, {"u", 15.0}};
constexpr std::int64_t kIdOffset = 5'000'000;  // far above the coordinator's command ids
constexpr std::int64_t kTrigger = 7'000'001;

TEST(ArmExpiry, MovesArmedOnEveryBusAndNeverTriggeredAreReleasedAndTheLabMovesAgain) {
  SimLab lab;
  std::map<std::int64_t, gateway_command_t> arms;  // the coordinator's ARM_MOVEs, by id (sent again: once)
  for (const auto& bus : lab.config().buses) {
    lab.group().node().subscribe<gateway_command_t>(lcm::channels::gateway_command2(bus.name),
                                                    [&](const gateway_command_t& c, const std::string&) {
                                                      if (c.kind == gateway_command_t::ARM_MOVE && c.command_id > 0)
                                                        arms.emplace(c.command_id, c);
                                                    });
  }
  ASSERT_TRUE(lab.start(kAxes));
  ASSERT_TRUE(lab.enable(kAxes));
  std::map<std::string, std::int64_t> from_counts;
  Values from;
  for (const auto& axis : kAxes) {
    from_counts[axis] = lab.state(axis).position_counts;
    from[axis] = lab.position(axis);
  }
  const auto tolerance = [&](const std::string& axis) { return 1.5 / lab.config().find_axis(axis)->steps_per_unit; };

  // 1. A move through the coordinator: its ARM_MOVEs (one per bus and start mechanism).
  const auto there = lab.call(Client::make(request_t::MOVE_ABSOLUTE, kTargets));
  ASSERT_EQ(there.status, st(reply_t::DONE)) << there.reason;
  std::set<std::string> buses;
  for (const auto& [id, c] : arms) buses.insert(c.bus);
  ASSERT_EQ(buses.size(), 3u) << "the move did not arm on every bus";

  // 2. The same moves back, armed on each gateway directly and never triggered.
  std::vector<std::int64_t> ids;
  for (auto [id, c] : arms) {
    c.command_id = id + kIdOffset;
    c.trigger_id = kTrigger;
    c.utime = wall_time_us();
    for (auto& a : c.axes) a.target_counts = from_counts.at(a.axis);
    ids.push_back(c.command_id);
    lab.group().node().publish(lcm::channels::gateway_command2(c.bus), c);
  }
  const auto replies_to = [&](std::int64_t id, std::int8_t status) {
    return std::count_if(lab.gateway_replies().begin(), lab.gateway_replies().end(),
                         [&](const gateway_reply_t& r) { return r.command_id == id && r.status == status; });
  };
  const auto every = [&](std::int8_t status) {
    return std::all_of(ids.begin(), ids.end(), [&](std::int64_t id) { return replies_to(id, status) > 0; });
  };
  ASSERT_TRUE(lab.client().wait_until([&] { return every(gateway_reply_t::ARMED); }, seconds(20)))
      << "not every gateway armed its move";
  const auto armed_at = std::chrono::steady_clock::now();
  ASSERT_TRUE(lab.client().wait_until([&] { return every(gateway_reply_t::FAILED); }, seconds(30)))
      << "an armed move was never released";
  const auto released_after =
      std::chrono::duration_cast<milliseconds>(std::chrono::steady_clock::now() - armed_at).count();
  const std::int64_t released_utime = wall_time_us();
  lab.pause(milliseconds(500));  // a second terminal reply would come now

  // 3. One terminal reply per armed move: FAILED 13 naming its axes and the expiry.
  for (const auto id : ids) {
    EXPECT_EQ(replies_to(id, gateway_reply_t::FAILED) + replies_to(id, gateway_reply_t::DONE) +
                  replies_to(id, gateway_reply_t::STARTED),
              1)
        << "command " << id;
    const auto failed = std::find_if(
        lab.gateway_replies().begin(), lab.gateway_replies().end(),
        [&](const gateway_reply_t& r) { return r.command_id == id && r.status == gateway_reply_t::FAILED; });
    ASSERT_NE(failed, lab.gateway_replies().end());
    EXPECT_EQ(failed->error_code, code(ReplyError::kTimeout)) << failed->reason;
    EXPECT_NE(failed->reason.find("never triggered within"), std::string::npos) << failed->reason;
    for (const auto& a : arms.at(id - kIdOffset).axes)
      EXPECT_NE(failed->reason.find(a.axis), std::string::npos) << failed->reason;
    std::cout << "[ released ] " << failed->bus << ": " << failed->reason << "\n";
  }
  std::cout << "[ released ] every armed move FAILED " << released_after << " ms after the last ARMED\n";
  for (const auto& axis : kAxes)
    EXPECT_TRUE(lab.has_event(event_t::TIMEOUT, axis, "never triggered")) << "no TIMEOUT event naming " << axis;

  // 4. Every axis at rest where it was, polled again (states sampled after the release).
  const bool fresh = lab.client().wait_until(
      [&] {
        return std::all_of(kAxes.begin(), kAxes.end(), [&](const std::string& a) {
          const auto& s = lab.state(a);
          return s.online && !s.moving && s.sample_utime > released_utime;
        });
      },
      seconds(10));
  EXPECT_TRUE(fresh) << "not every axis polled again after the release";
  for (const auto& axis : kAxes) EXPECT_NEAR(lab.position(axis), kTargets.at(axis), tolerance(axis)) << axis;

  // 5. The trigger, late: nothing starts.
  lab.clear_reports();
  motionlcm::sync_trigger2_t t2{};
  t2.utime = wall_time_us();
  t2.trigger_id = kTrigger;
  t2.act_utime = t2.utime + 20'000;
  for (const auto& bus : buses) {
    t2.buses.push_back(bus);
    t2.send_utime.push_back(t2.act_utime);
    t2.lead_us.push_back(0.0);
  }
  t2.num_buses = static_cast<std::int32_t>(t2.buses.size());
  t2.start_command_ids = ids;
  t2.num_starts = static_cast<std::int32_t>(ids.size());
  lab.group().node().publish(lcm::channels::kSyncTrigger2, t2);
  motionlcm::sync_trigger_t t1{};
  t1.utime = t2.utime;
  t1.trigger_id = kTrigger;
  t1.fire_utime = t2.act_utime;
  t1.buses = t2.buses;
  t1.num_buses = t2.num_buses;
  lab.group().node().publish(lcm::channels::kSyncTrigger, t1);
  lab.pause(milliseconds(1000));
  for (const auto& r : lab.reports())
    EXPECT_NE(r.kind, st(motionlcm::sim_report_t::MOTION_STARTED)) << r.drive << " started on a released trigger";
  for (const auto& axis : kAxes) {
    EXPECT_FALSE(lab.state(axis).moving) << axis;
    EXPECT_NEAR(lab.position(axis), kTargets.at(axis), tolerance(axis)) << axis;
  }

  // 6. A move through the coordinator works: back where the axes came from.
  const auto back = lab.call(Client::make(request_t::MOVE_ABSOLUTE, from));
  ASSERT_EQ(back.status, st(reply_t::DONE)) << back.reason;
  for (const auto& axis : kAxes) EXPECT_TRUE(lab.settled_at(axis, from.at(axis), tolerance(axis))) << axis;
  if (HasFailure()) lab.group().print_logs();
}

// A released move leaves the drives nothing to start, whoever sends the start frame (README
// "Safety and faults"): on can0, moves of x and y (UIM342, group 20) and of a and b (UC57,
// preloaded for the SYNC) armed straight on GW_COMMAND_can0 (gateway_command_t, as any sender
// may) and DISARMed there; then a group BG
// and a SYNC from an endpoint of our own on the simulated bus. The simulators' ground truth
// (SIM_REPORT) shows no drive moving anywhere; a move through the coordinator works after.
TEST(ArmExpiry, ADisarmedMoveLeavesNothingAForeignBgOrSyncCouldStart) {
  const std::vector<std::string> axes{"x", "y", "a", "b"};
  SimLab lab;
  ASSERT_TRUE(lab.start(axes));
  ASSERT_TRUE(lab.enable(axes));
  std::map<std::string, std::int64_t> from;
  for (const auto& axis : axes) from[axis] = lab.state(axis).position_counts;
  const auto arm = [&](std::int64_t id, const std::vector<std::string>& names, double velocity, double rate) {
    motionlcm::gateway_command_t c{};  // the plain type other senders use
    c.utime = wall_time_us();
    c.command_id = id;
    c.bus = "can0";
    c.kind = motionlcm::gateway_command_t::ARM_MOVE;
    c.trigger_id = kTrigger + 1;
    for (const auto& name : names) {
      motionlcm::axis_command_t a{};
      a.axis = name;
      a.target_counts = from.at(name) + 1600;
      a.velocity = velocity;
      a.acceleration = a.deceleration = rate;
      c.axes.push_back(a);
    }
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    lab.group().node().publish(lcm::channels::gateway_command("can0"), c);
  };
  const auto replied = [&](std::int64_t id, std::int8_t status) {
    return std::any_of(lab.gateway_replies().begin(), lab.gateway_replies().end(),
                       [&](const gateway_reply_t& r) { return r.command_id == id && r.status == status; });
  };
  arm(kIdOffset + 1, {"x", "y"}, 16000, 128000);
  arm(kIdOffset + 2, {"a", "b"}, 1600, 6400);
  ASSERT_TRUE(lab.client().wait_until(
      [&] { return replied(kIdOffset + 1, gateway_reply_t::ARMED) && replied(kIdOffset + 2, gateway_reply_t::ARMED); },
      seconds(10)))
      << "not armed";
  motionlcm::gateway_command_t disarm{};
  disarm.utime = wall_time_us();
  disarm.command_id = kIdOffset + 3;
  disarm.bus = "can0";
  disarm.kind = motionlcm::gateway_command_t::DISARM;
  disarm.trigger_id = kTrigger + 1;
  for (const auto& axis : axes) {
    motionlcm::axis_command_t a{};
    a.axis = axis;
    disarm.axes.push_back(a);
  }
  disarm.num_axes = static_cast<std::int32_t>(disarm.axes.size());
  lab.group().node().publish(lcm::channels::gateway_command("can0"), disarm);
  ASSERT_TRUE(lab.client().wait_until([&] { return replied(kIdOffset + 3, gateway_reply_t::DONE); }, seconds(10)))
      << "DISARM not done";
  EXPECT_TRUE(replied(kIdOffset + 1, gateway_reply_t::FAILED));
  EXPECT_TRUE(replied(kIdOffset + 2, gateway_reply_t::FAILED));

  // Someone else's start frames: BG to group 20, a SYNC.
  lab.clear_reports();
  std::error_code ec;
  auto can0 = simbus::SocketEndpoint::connect("can0", {lab.group().work_dir() + "/sim", "it-foreign", false}, ec);
  ASSERT_TRUE(can0) << ec.message();
  const auto bg = uim342::instruction_frame(20, uim342::request::begin());
  ASSERT_TRUE(bg.ok());
  ASSERT_FALSE(can0->send(*bg));
  ASSERT_FALSE(can0->send(canopen::encode_sync({})));
  lab.pause(milliseconds(1500));
  for (const auto& r : lab.reports()) {
    if (r.kind == st(motionlcm::sim_report_t::MOTION_STARTED)) {
      EXPECT_EQ(r.target_counts, r.position_counts) << r.drive << " started the released move";
    }
  }
  for (const auto& axis : axes) {
    EXPECT_FALSE(lab.state(axis).moving) << axis;
    EXPECT_EQ(lab.state(axis).position_counts, from.at(axis)) << axis << " moved";
  }

  const auto back = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 5.0}, {"a", 45.0}}));
  ASSERT_EQ(back.status, st(reply_t::DONE)) << back.reason;
  if (HasFailure()) lab.group().print_logs();
}

}  // namespace
}  // namespace motion::testing
