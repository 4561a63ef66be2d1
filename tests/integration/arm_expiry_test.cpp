// Moves armed on every gateway of the simulated lab (config/sim-lab.yaml: UIM342 group BG and UC57
// SYNC on can0, ADAM broadcast on rs485, UIM242 global on rs232) that no trigger ever starts, as
// when the coordinator dies between ARM_MOVE and SYNC_TRIGGER: each gateway releases them itself
// after its arm expiry (README "Safety and faults"). The ARM_MOVEs are the coordinator's own from a
// real move (gateway_command2_t), published again on GW_COMMAND2_<bus> with new ids, targets back
// where the axes came from, and a trigger id nobody fires in time. No timed assertions; the times
// are printed.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <map>
#include <set>

#include <motionlcm/gateway_command2_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>

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

}  // namespace
}  // namespace motion::testing
