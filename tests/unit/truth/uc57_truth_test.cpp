// UC57 synchronous RPDOs (UC57 manual §4.1.2 SYNC, §5 comm. table 1400h:02; CiA 301 §7.2.2):
// under each simulated variant of what a drive does with RPDO transmission type 1 (honoured,
// on_reception, refused), the stack comes online, finds out which one holds, and a scheduled
// (preloaded) synchronized move of two nodes ends at its targets, never starts before the trigger,
// and STARTED names the mechanism and the skew that the simulated drives' own start times show.
// Frames are stamped on a bit-timed wire (125 kbit/s, back to back), so a start node by node
// shows its real spread. A disarmed move leaves nothing a foreign SYNC could start. Also: the SYNC/TPDO polling of 32 nodes at 20 Hz keeps within the bus.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <deque>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <motionlcm/event_t.hpp>

#include "motion/can_frame/bit_timing.hpp"
#include "motion/canopen/sync.hpp"
#include "motion/config/config.hpp"
#include "motion/sim/uc57_drive.hpp"
#include "motion/uc57_driver/process_data.hpp"
#include "motion/uc57_driver/uc57_stack.hpp"

namespace motion::gateway {
namespace {

using motionlcm::event_t;
using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using std::chrono::milliseconds;

// Copies of LCM constants (never ODR-use the generated in-class constants).
constexpr std::int8_t kDone = gateway_reply_t::DONE;
constexpr std::int8_t kFailed = gateway_reply_t::FAILED;
constexpr std::int8_t kStarted = gateway_reply_t::STARTED;
constexpr std::int8_t kMotionStarted = motionlcm::sim_report_t::MOTION_STARTED;
constexpr std::int8_t kMotionFinished = motionlcm::sim_report_t::MOTION_FINISHED;
constexpr std::int16_t kOffline = event_t::OFFLINE;
constexpr std::int16_t kHeartbeatLost = event_t::HEARTBEAT_LOST;
constexpr std::uint32_t kBitrate = 125000;

constexpr const char* kLabTemplate = R"(
buses:
  - {name: can0, transport: "simcan:can0", bitrate: 125000, request_timeout_ms: 50, retries: 2, poll_hz: 20}
drives:
  - {name: a-drive, family: uc57, bus: can0, node_id: 1, setup: {pulses_per_revolution: 3200, heartbeat_ms: 100}}
  - {name: b-drive, family: uc57, bus: can0, node_id: 2, setup: {pulses_per_revolution: 3200, heartbeat_ms: 100}}
axes:
  - {name: a, drive: a-drive, unit: rev, steps_per_unit: 3200, limits: {min: -100, max: 100, velocity: 10, acceleration: 100},
     homing: {method: switch, input: 2, velocity: -0.5}}
  - {name: b, drive: b-drive, unit: rev, steps_per_unit: 3200, limits: {min: -100, max: 100, velocity: 10, acceleration: 100}}
simulation:
  variants:
    a-drive: {rpdo_sync: VARIANT}
    b-drive: {rpdo_sync: VARIANT}
)";

class Recorder final : public GatewayOutput {
 public:
  void axis_status(const std::string&, const DriveStatus&) override {}
  void axis_event(const std::string& axis, const DriveEvent& event) override { events.emplace_back(axis, event); }
  void command_reply(gateway_reply_t reply) override { replies.push_back(std::move(reply)); }
  void drive_facts(const std::string& axis, const DriveFacts& reported) override { facts[axis] = reported; }
  std::vector<std::pair<std::string, DriveEvent>> events;
  std::vector<gateway_reply_t> replies;
  std::map<std::string, DriveFacts> facts;
};

struct Report {
  std::int8_t kind;
  std::int64_t frame_utime;
  std::int64_t position;
  std::int64_t target;
};

// The stack and the simulated drives of `yaml` on one bit-timed wire, time advanced by hand.
// Delivery is immediate; each frame's timestamp is its end on a wire that sends back to back.
class Uc57Bench {
 public:
  explicit Uc57Bench(const std::string& yaml, sim::Uc57SimOptions sim_options = {}) {
    auto loaded = config::load_string(yaml, "truth.yaml");
    EXPECT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
    CanStackContext ctx;
    ctx.out = &out;
    ctx.send = [this](const can::Frame& f) {
      to_drives.push_back(stamp(f));
      return true;
    };
    uc57_driver::Uc57Stack::Options options;
    options.wall_clock_us = [](TimePoint t) {
      return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
    };
    stack = std::make_unique<uc57_driver::Uc57Stack>(config_, *config_.find_bus("can0"), ctx, options);
    const auto factory = sim::uc57_drive_factory(config_, sim_options);
    for (const auto& d : config_.drives) {
      sim::SimDriveContext context;
      context.drive = d.name;
      context.bus = d.bus;
      context.send = [this, name = d.name](const can::Frame& f) {
        if (muted.contains(name)) return;  // a muted drive hears but is not heard
        const can::Frame stamped = stamp(f);
        to_stack.push_back(stamped);
        to_peers.push_back(stamped);
      };
      context.report = [this, name = d.name](std::int8_t kind, std::int64_t frame_utime, std::int64_t position,
                                             std::int64_t target) {
        reports[name].push_back({kind, frame_utime, position, target});
      };
      drives.push_back(factory(d, context));
    }
    for (auto& d : drives) d->power_up(now);
  }

  can::Frame stamp(can::Frame f) {
    wire_busy += can::frame_duration(f, kBitrate);
    wire_free_ = std::max(wire_free_, now) + can::frame_duration(f, kBitrate);
    f.timestamp_us = std::chrono::duration_cast<std::chrono::microseconds>(wire_free_.time_since_epoch()).count();
    ++frames;
    return f;
  }

  void settle() {
    while (!to_drives.empty() || !to_stack.empty()) {
      while (!to_drives.empty()) {
        const auto f = to_drives.front();
        to_drives.pop_front();
        for (auto& d : drives) d->on_frame(f, now);
      }
      to_peers.clear();  // drives ignore each other's TPDOs, heartbeats and SDO answers
      while (!to_stack.empty()) {
        const auto f = to_stack.front();
        to_stack.pop_front();
        stack->on_frame(f, now);
      }
    }
  }
  void run_for(Duration span) {
    const auto end = now + span;
    while (true) {
      TimePoint next = stack->process(now);
      for (auto& d : drives) next = std::min(next, d->process(now));
      settle();
      if (next > end) break;
      now = std::max(next, now + std::chrono::microseconds(10));
    }
    now = end;
  }
  bool run_until(const std::function<bool()>& done, Duration limit) {
    for (Duration spent{}; spent < limit; spent += milliseconds(10)) {
      if (done()) return true;
      run_for(milliseconds(10));
    }
    return done();
  }
  std::int64_t execute(gateway_command_t c) {
    c.bus = "can0";
    c.command_id = ++next_id;
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    stack->execute(c, now);
    settle();
    return c.command_id;
  }
  [[nodiscard]] std::optional<gateway_reply_t> reply(std::int64_t id, std::int8_t status) const {
    for (const auto& r : out.replies) {
      if (r.command_id == id && r.status == status) return r;
    }
    return std::nullopt;
  }
  [[nodiscard]] std::optional<gateway_reply_t> terminal(std::int64_t id) const {
    for (const auto& r : out.replies) {
      if (r.command_id == id && (r.status == kDone || r.status == gateway_reply_t::FAILED)) return r;
    }
    return std::nullopt;
  }
  [[nodiscard]] std::vector<Report> reports_of(const std::string& drive, std::int8_t kind) const {
    std::vector<Report> r;
    if (const auto it = reports.find(drive); it != reports.end()) {
      std::copy_if(it->second.begin(), it->second.end(), std::back_inserter(r),
                   [kind](const Report& x) { return x.kind == kind; });
    }
    return r;
  }

  config::Config config_;
  Recorder out;
  std::unique_ptr<uc57_driver::Uc57Stack> stack;
  std::vector<std::unique_ptr<sim::CanDriveSim>> drives;
  std::map<std::string, std::vector<Report>> reports;
  std::deque<can::Frame> to_drives, to_stack, to_peers;
  std::set<std::string> muted;  // drives whose frames never reach the wire
  TimePoint now = TimePoint{} + std::chrono::seconds(10);
  std::int64_t next_id = 0;
  std::int64_t frames = 0;  // every frame on the wire
  Duration wire_busy{};     // their wire time

 private:
  TimePoint wire_free_ = TimePoint{} + std::chrono::seconds(10);
};

motionlcm::axis_command_t axis_move(const std::string& axis, std::int64_t target) {
  motionlcm::axis_command_t a{};
  a.axis = axis;
  a.target_counts = target;
  a.velocity = 16000;  // 5 rev/s
  a.acceleration = 160000;
  a.deceleration = 160000;
  return a;
}

class Uc57RpdoSync : public ::testing::TestWithParam<std::string> {};

// Set-up under `variant`, then a preloaded synchronized move of a and b judged by the drives.
// `staggered`: both nodes with tpdo_mode staggered (each TPDO every 4th SYNC in a slot of its own).
void synchronized_move_under(const std::string& variant, sim::Uc57SimOptions sim_options = {}, bool staggered = false) {
  std::string yaml = kLabTemplate;
  for (auto at = yaml.find("VARIANT"); at != std::string::npos; at = yaml.find("VARIANT")) yaml.replace(at, 7, variant);
  if (staggered) {
    for (auto at = yaml.find("heartbeat_ms: 100}"); at != std::string::npos; at = yaml.find("heartbeat_ms: 100}"))
      yaml.replace(at, 18, "heartbeat_ms: 100, tpdo_mode: staggered}");
  }
  Uc57Bench bench(yaml, sim_options);
  if (staggered) {
    EXPECT_EQ(bench.stack->stagger_cycle(), 4U);
    EXPECT_EQ(bench.stack->sync_period(), std::chrono::microseconds(12500))
        << "20 Hz per node, the bus is not the limit";
  }
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5))) << "never ready";
  const bool at_sync = variant == "honoured";
  if (staggered) {
    // Each TPDO in the slot planned for it: a-drive 0 and 1, b-drive 2 and 3.
    const auto a = bench.stack->tpdo_slots("a-drive");
    const auto b = bench.stack->tpdo_slots("b-drive");
    EXPECT_EQ(a[0], std::optional<unsigned>(0));
    EXPECT_EQ(a[1], std::optional<unsigned>(1));
    EXPECT_EQ(b[0], std::optional<unsigned>(2));
    EXPECT_EQ(b[1], std::optional<unsigned>(3));
  }
  for (const auto& [axis, e] : bench.out.events) {
    EXPECT_NE(e.kind, kOffline) << "set-up went through an offline retry: " << e.text;  // refused: no reset loop
  }
  for (const auto* drive : {"a-drive", "b-drive"}) {
    EXPECT_TRUE(bench.stack->rpdo_sync_finding(drive).starts_with(variant))
        << drive << ": " << bench.stack->rpdo_sync_finding(drive);
    EXPECT_TRUE(bench.reports_of(drive, kMotionStarted).empty()) << "the acceptance test moved " << drive;
  }
  for (const auto* axis : {"a", "b"}) {
    ASSERT_TRUE(bench.out.facts.contains(axis));
    EXPECT_EQ(bench.out.facts[axis].one_frame_start, std::optional<bool>(at_sync)) << axis;
  }

  gateway_command_t enable{};
  enable.kind = gateway_command_t::ENABLE;
  for (const auto* axis : {"a", "b"}) {
    motionlcm::axis_command_t a{};
    a.axis = axis;
    enable.axes.push_back(a);
  }
  const auto enabled = bench.execute(enable);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(enabled).has_value(); }, std::chrono::seconds(2)));
  ASSERT_EQ(bench.terminal(enabled)->status, kDone) << bench.terminal(enabled)->reason;

  // One command for both axes, armed for trigger 7 (preloaded where the drive honours SYNC).
  gateway_command_t move{};
  move.kind = gateway_command_t::ARM_MOVE;
  move.trigger_id = 7;
  move.axes = {axis_move("a", 6400), axis_move("b", -3200)};
  const auto id = bench.execute(move);
  ASSERT_TRUE(
      bench.run_until([&] { return bench.reply(id, gateway_reply_t::ARMED).has_value(); }, std::chrono::seconds(2)));
  bench.run_for(milliseconds(120));  // periodic SYNCs while armed must not start anything
  for (const auto* drive : {"a-drive", "b-drive"})
    EXPECT_TRUE(bench.reports_of(drive, kMotionStarted).empty()) << drive << " started early";
  const auto fired_us = std::chrono::duration_cast<std::chrono::microseconds>(bench.now.time_since_epoch()).count();
  bench.stack->fire(7, bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(id).has_value(); }, std::chrono::seconds(5)));
  ASSERT_EQ(bench.terminal(id)->status, kDone) << bench.terminal(id)->reason;

  // Ground truth: both at their targets, started once each, not before the trigger.
  const auto a_start = bench.reports_of("a-drive", kMotionStarted);
  const auto b_start = bench.reports_of("b-drive", kMotionStarted);
  ASSERT_EQ(a_start.size(), 1u);
  ASSERT_EQ(b_start.size(), 1u);
  EXPECT_GE(a_start[0].frame_utime, fired_us);
  EXPECT_GE(b_start[0].frame_utime, fired_us);
  ASSERT_EQ(bench.reports_of("a-drive", kMotionFinished).size(), 1u);
  ASSERT_EQ(bench.reports_of("b-drive", kMotionFinished).size(), 1u);
  EXPECT_EQ(bench.reports_of("a-drive", kMotionFinished)[0].position, 6400);
  EXPECT_EQ(bench.reports_of("b-drive", kMotionFinished)[0].position, -3200);

  // What STARTED said is what the drives did.
  const auto started = bench.reply(id, kStarted);
  ASSERT_TRUE(started.has_value());
  const double spread_us = static_cast<double>(std::abs(a_start[0].frame_utime - b_start[0].frame_utime));
  if (at_sync) {
    EXPECT_EQ(started->start_mechanism, "sync");
    EXPECT_EQ(spread_us, 0.0) << "one SYNC started both";
  } else {
    EXPECT_EQ(started->start_mechanism, "rpdo");
    EXPECT_GT(spread_us, 400.0) << "back to back: one RPDO1 (~0.5 ms at 125 kbit/s) apart";
  }
  EXPECT_NEAR(started->predicted_skew_us, spread_us, 1.0);  // the wire stamps are whole microseconds
  std::printf("rpdo_sync %s: found \"%s\"; STARTED %s, predicted skew %.1f us, drives started %.0f us apart\n",
              variant.c_str(), bench.stack->rpdo_sync_finding("a-drive").c_str(), started->start_mechanism.c_str(),
              started->predicted_skew_us, spread_us);

  // HOME a (origin switch IN2, searched toward min at 0.5 rev/s; CiA 402 homing, §4.2.6): the
  // simulated switch is +2000 pulses (100 either side) from the power-up position. From 6400 the
  // axis runs back onto the switch, and 0 is where it homed.
  auto& a_drive = dynamic_cast<sim::Uc57DriveSim&>(*bench.drives[0]);
  const std::size_t starts_before = bench.reports_of("a-drive", kMotionStarted).size();
  gateway_command_t home{};
  home.kind = gateway_command_t::HOME;
  motionlcm::axis_command_t a{};
  a.axis = "a";
  a.velocity = -1600;
  a.acceleration = a.deceleration = 16000;
  home.axes = {a};
  const auto homed = bench.execute(home);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(homed).has_value(); }, std::chrono::seconds(20)));
  ASSERT_EQ(bench.terminal(homed)->status, kDone) << bench.terminal(homed)->reason;
  bench.run_for(milliseconds(200));
  EXPECT_GT(bench.reports_of("a-drive", kMotionStarted).size(), starts_before) << "no search run";
  const std::int64_t physical = a_drive.physical_position(bench.now);
  EXPECT_LE(std::abs(physical - 2000), 100) << "a homed off its switch, at " << physical;
  EXPECT_EQ(a_drive.position(bench.now), 0) << "the home is not 0";
  std::printf("rpdo_sync %s: HOME a from 6400 pulses: at %lld pulses from power-up (switch 1900..2100), reads %lld\n",
              variant.c_str(), static_cast<long long>(physical), static_cast<long long>(a_drive.position(bench.now)));
}

TEST_P(Uc57RpdoSync, SetUpFindsTheVariantAndASynchronizedMoveReportsWhatTheDrivesDid) {
  synchronized_move_under(GetParam());
}

// The same with staggered TPDOs (tpdo_mode staggered: each node's TPDO1 and TPDO2 every 4th SYNC,
// each in a slot of its own, the SYNC 4 times as fast): the set-up still finds the variant (the
// acceptance test holds the SYNC while it reads), the move starts together and lands, HOME lands.
TEST_P(Uc57RpdoSync, WithStaggeredTpdos) { synchronized_move_under(GetParam(), {}, true); }

// The same with the manual's RO remap objects (§5 comm. table: 1400h:01, 1600h:00): the stack
// keeps the default RPDO1 (6040h + 60FFh + 6060h), tests with 60FFh outside profile velocity, and
// under refused writes 255 to 1400h:02 instead of failing the set-up over and over.
TEST_P(Uc57RpdoSync, WithTheManualsDefaultRpdo1) {
  sim::Uc57SimOptions options;
  options.pdo_configuration_writable = false;
  synchronized_move_under(GetParam(), options);
}

// A gateway restarted against drives that an earlier gateway set up (and left enabled) finds the same.
TEST(Uc57RpdoSyncRestart, ASecondGatewayFindsHonouredAgain) {
  std::string yaml = kLabTemplate;
  for (auto at = yaml.find("VARIANT"); at != std::string::npos; at = yaml.find("VARIANT"))
    yaml.replace(at, 7, "honoured");
  Uc57Bench bench(yaml);
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5)));
  gateway_command_t enable{};
  enable.kind = gateway_command_t::ENABLE;
  motionlcm::axis_command_t a{};
  a.axis = "a";
  enable.axes.push_back(a);
  const auto enabled = bench.execute(enable);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(enabled).has_value(); }, std::chrono::seconds(2)));
  bench.run_for(milliseconds(7));
  CanStackContext ctx;
  ctx.out = &bench.out;
  ctx.send = [&bench](const can::Frame& f) {
    bench.to_drives.push_back(bench.stamp(f));
    return true;
  };
  bench.stack = std::make_unique<uc57_driver::Uc57Stack>(bench.config_, *bench.config_.find_bus("can0"), ctx);
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5)));
  EXPECT_TRUE(bench.stack->rpdo_sync_finding("a-drive").starts_with("honoured"))
      << bench.stack->rpdo_sync_finding("a-drive");
}

// A released move (DISARM: the coordinator's, or the gateway's own at its arm expiry) leaves the
// drives nothing to start. Armed for a trigger, a drive that applies RPDO1 at the SYNC holds the
// start image (bit 4 = 1) ready for the next SYNC, whoever sends it, and 607Ah holds the target
// (manual §4.2.4). After the DISARM a SYNC from someone else (with the manual's default RPDO1,
// where 607Ah went by SDO, also a foreign new-set-point edge 0x0F -> 0x1F before it) moves neither
// drive; the next move runs as usual.
class Uc57Release : public ::testing::TestWithParam<bool> {};

TEST_P(Uc57Release, ADisarmedMoveLeavesNothingAForeignSyncOrEdgeCouldStart) {
  const bool default_rpdo = GetParam();
  std::string yaml = kLabTemplate;
  for (auto at = yaml.find("VARIANT"); at != std::string::npos; at = yaml.find("VARIANT"))
    yaml.replace(at, 7, "honoured");
  sim::Uc57SimOptions options;
  options.pdo_configuration_writable = !default_rpdo;
  Uc57Bench bench(yaml, options);
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5))) << "never ready";
  gateway_command_t enable{};
  enable.kind = gateway_command_t::ENABLE;
  enable.axes = {axis_move("a", 0), axis_move("b", 0)};
  const auto enabled = bench.execute(enable);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(enabled).has_value(); }, std::chrono::seconds(2)));
  ASSERT_EQ(bench.terminal(enabled)->status, kDone) << bench.terminal(enabled)->reason;
  const auto position = [&](std::size_t k) {
    return dynamic_cast<const sim::Uc57DriveSim&>(*bench.drives[k]).position(bench.now);
  };
  const std::int64_t a_from = position(0);
  const std::int64_t b_from = position(1);

  gateway_command_t move{};
  move.kind = gateway_command_t::ARM_MOVE;
  move.trigger_id = 7;
  move.axes = {axis_move("a", a_from + 6400), axis_move("b", b_from - 3200)};
  const auto armed = bench.execute(move);
  ASSERT_TRUE(
      bench.run_until([&] { return bench.reply(armed, gateway_reply_t::ARMED).has_value(); }, std::chrono::seconds(2)));
  gateway_command_t disarm{};
  disarm.kind = gateway_command_t::DISARM;
  disarm.trigger_id = 7;
  disarm.axes = {axis_move("a", 0), axis_move("b", 0)};
  const auto released = bench.execute(disarm);
  ASSERT_TRUE(bench.terminal(armed).has_value());
  EXPECT_EQ(bench.terminal(armed)->status, kFailed);

  // Someone else's SYNC at once, before the gateway's own next one.
  bench.to_drives.push_back(bench.stamp(canopen::encode_sync({})));
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(released).has_value(); }, std::chrono::seconds(1)));
  EXPECT_EQ(bench.terminal(released)->status, kDone) << bench.terminal(released)->reason;
  if (default_rpdo) {
    bench.run_for(milliseconds(100));  // the SDO write of 607Ah
    for (const std::uint8_t node : {std::uint8_t{1}, std::uint8_t{2}}) {
      uc57_driver::RpdoImage edge;
      edge.controlword = 0x1F;  // new set-point, absolute (manual §4.2.4)
      edge.mode = 1;            // profile position
      bench.to_drives.push_back(
          bench.stamp(uc57_driver::encode_rpdo1(canopen::NodeId{node}, uc57_driver::RpdoLayout::kManualDefault, edge)));
    }
    bench.to_drives.push_back(bench.stamp(canopen::encode_sync({})));
    bench.settle();
  }
  bench.run_for(milliseconds(500));
  for (const auto& [drive, from] :
       {std::pair{std::string("a-drive"), a_from}, std::pair{std::string("b-drive"), b_from}}) {
    for (const auto& r : bench.reports_of(drive, kMotionStarted))
      EXPECT_EQ(r.target, r.position) << drive << " started the released move from " << r.position << " to "
                                      << r.target;
  }
  EXPECT_EQ(position(0), a_from) << "a ran the released move";
  EXPECT_EQ(position(1), b_from) << "b ran the released move";

  // The next move runs as usual.
  move.trigger_id = 8;
  const auto again = bench.execute(move);
  ASSERT_TRUE(
      bench.run_until([&] { return bench.reply(again, gateway_reply_t::ARMED).has_value(); }, std::chrono::seconds(2)));
  bench.stack->fire(8, bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(again).has_value(); }, std::chrono::seconds(5)));
  ASSERT_EQ(bench.terminal(again)->status, kDone) << bench.terminal(again)->reason;
  EXPECT_EQ(position(0), a_from + 6400);
  EXPECT_EQ(position(1), b_from - 3200);
}

// A node that stops answering mid-move (heartbeat and TPDOs gone) may still hear: once the stack
// calls it offline, a STOP naming it still sends its halt in RPDO1 (applied by the next SYNC), the
// drive stops (ground truth), and the STOP ends FAILED saying the stop is not confirmed.
TEST(Uc57Unanswering, AStopStillReachesANodeThatHearsButDoesNotAnswer) {
  std::string yaml = kLabTemplate;
  for (auto at = yaml.find("VARIANT"); at != std::string::npos; at = yaml.find("VARIANT"))
    yaml.replace(at, 7, "honoured");
  Uc57Bench bench(yaml);
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5))) << "never ready";
  gateway_command_t enable{};
  enable.kind = gateway_command_t::ENABLE;
  enable.axes = {axis_move("a", 0)};
  const auto enabled = bench.execute(enable);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(enabled).has_value(); }, std::chrono::seconds(2)));
  const auto position = [&] { return dynamic_cast<const sim::Uc57DriveSim&>(*bench.drives[0]).position(bench.now); };
  gateway_command_t move{};
  move.kind = gateway_command_t::ARM_MOVE;
  move.axes = {axis_move("a", 64000)};  // 20 rev at 5 rev/s: 4 s
  const auto moving = bench.execute(move);
  bench.run_for(milliseconds(300));
  ASSERT_GT(position(), 0) << "the move did not start";
  bench.muted.insert("a-drive");
  ASSERT_TRUE(bench.run_until(
      [&] {
        return std::any_of(bench.out.events.begin(), bench.out.events.end(),
                           [](const auto& e) { return e.first == "a" && e.second.kind == kHeartbeatLost; });
      },
      std::chrono::seconds(2)))
      << "never called offline";
  ASSERT_TRUE(bench.terminal(moving).has_value()) << "the move did not end with its node offline";

  gateway_command_t stop{};
  stop.kind = gateway_command_t::STOP;
  stop.axes = {axis_move("a", 0)};
  const auto stopped = bench.execute(stop);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(stopped).has_value(); }, std::chrono::seconds(1)));
  EXPECT_EQ(bench.terminal(stopped)->status, kFailed);
  EXPECT_NE(bench.terminal(stopped)->reason.find("sent in RPDO1 all the same, not confirmed"), std::string::npos)
      << bench.terminal(stopped)->reason;
  bench.run_for(std::chrono::seconds(1));
  const std::int64_t rested = position();
  bench.run_for(milliseconds(200));
  EXPECT_EQ(position(), rested) << "the drive did not get its halt";
  EXPECT_LT(rested, 64000);
  std::printf("a muted mid-move, STOP: \"%s\"; at rest at %lld pulses (target 64000)\n",
              bench.terminal(stopped)->reason.c_str(), static_cast<long long>(rested));
}

INSTANTIATE_TEST_SUITE_P(Layouts, Uc57Release, ::testing::Bool(), [](const ::testing::TestParamInfo<bool>& p) {
  return p.param ? "default_rpdo1" : "remapped";
});

INSTANTIATE_TEST_SUITE_P(Variants, Uc57RpdoSync, ::testing::Values("honoured", "on_reception", "refused"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

// Polling within the bus budget: 32 nodes with synchronous TPDOs at 20 Hz would ask 125 kbit/s
// for ~1,300 frames/s. The SYNC is slowed so that the SYNCs, TPDOs and heartbeats measured on the
// wire take at most 3/4 of it, and a warning says so once at start.
TEST(Uc57PollBudget, ThirtyTwoNodesAt20HzStayWithinWhat125kbitCarries) {
  std::string yaml = "buses:\n  - {name: can0, transport: \"simcan:can0\", bitrate: 125000, poll_hz: 20}\ndrives:\n";
  for (int node = 1; node <= 32; ++node)
    yaml +=
        "  - {name: d" + std::to_string(node) + ", family: uc57, bus: can0, node_id: " + std::to_string(node) + "}\n";
  Uc57Bench bench(yaml);
  ASSERT_GT(bench.stack->sync_period(), milliseconds(50)) << "the configured 20 Hz does not fit";
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(10))) << "never ready";
  int warnings = 0;
  for (const auto& [axis, e] : bench.out.events) {
    if (axis.empty() && e.kind == event_t::CONFIG_MISMATCH) {
      ++warnings;
      EXPECT_NE(e.text.find("32 UC57 nodes with synchronous TPDOs at 20.0 Hz need"), std::string::npos) << e.text;
      EXPECT_NE(e.text.find("polls and heartbeats keep to 75% of the bus"), std::string::npos) << e.text;
    }
  }
  EXPECT_EQ(warnings, 1);
  // One second of steady state: every frame on the wire (SYNCs, TPDOs, heartbeats) counted.
  const auto frames_before = bench.frames;
  const auto busy_before = bench.wire_busy;
  bench.run_for(std::chrono::seconds(1));
  const auto frames_per_s = static_cast<double>(bench.frames - frames_before);
  const double busy_share = std::chrono::duration<double>(bench.wire_busy - busy_before).count();
  // The longest frame of the cycle (TPDO2, 8 bytes) is at least 111 bits: what the bus carries of them.
  const double capacity = 125000.0 / 111.0;
  EXPECT_LE(frames_per_s, capacity) << "frames/s asked at 125 kbit/s";
  EXPECT_LE(busy_share, 0.76) << "polls and heartbeats keep to 3/4 of the bus";
  EXPECT_GE(busy_share, 0.60) << "polling slowed more than needed";
  std::printf("32 UC57 nodes at 125 kbit/s: SYNC every %.1f ms, %.0f frames/s, wire %.0f%% busy\n",
              std::chrono::duration<double, std::milli>(bench.stack->sync_period()).count(), frames_per_s,
              100 * busy_share);
}

}  // namespace
}  // namespace motion::gateway
