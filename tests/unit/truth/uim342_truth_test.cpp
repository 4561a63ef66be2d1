// UIM342 micro-stepping (manual §5.9, §5.7): the simulated drive's EEPROM holds 8 micro-steps, the
// configuration asks for 16 (640 counts/mm over a 5 mm lead). Under either simulated variant of
// when a written MT[0] applies (after_restart: the manual's reading; immediately), the stack
// stores it with the driver off, restarts the drive, reads it back, and a synchronized (group BG)
// move to 10 mm turns the shaft 400 full steps (2 revolutions), the simulator's ground truth; a
// HOME then searches the simulated switch and ends on its edge. A move armed and then disarmed
// leaves nothing a foreign group BG could start.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <deque>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <motionlcm/event_t.hpp>

#include "motion/config/config.hpp"
#include "motion/config/sim_variants.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/uim342/uim342.hpp"
#include "motion/uim342_driver/uim342_stack.hpp"

namespace motion::gateway {
namespace {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using std::chrono::milliseconds;

// Copies of LCM constants (never ODR-use the generated in-class constants).
constexpr std::int8_t kDone = gateway_reply_t::DONE;
constexpr std::int8_t kFailed = gateway_reply_t::FAILED;

constexpr const char* kLabTemplate = R"(
buses:
  - {name: can0, transport: "simcan:can0", bitrate: 1000000, request_timeout_ms: 50, retries: 2, poll_hz: 20}
drives:
  - {name: x-drive, family: uim342, bus: can0, node_id: 5, group_id: 20, setup: {micro_steps: 16, acceleration_unit: rate}}
  - {name: y-drive, family: uim342, bus: can0, node_id: 6, group_id: 20, setup: {micro_steps: 16, acceleration_unit: rate}}
axes:
  - {name: x, drive: x-drive, unit: mm, steps_per_unit: 640, limits: {min: -10, max: 300, velocity: 50, acceleration: 400},
     homing: {method: switch, input: 1, velocity: -10}}
  - {name: y, drive: y-drive, unit: mm, steps_per_unit: 640, limits: {min: -10, max: 200, velocity: 50, acceleration: 400}}
simulation:
  home_switches: {x-drive: -3200}
  variants:
    x-drive: {micro_steps_apply: VARIANT}
    y-drive: {micro_steps_apply: VARIANT}
)";

class Recorder final : public GatewayOutput {
 public:
  void axis_status(const std::string&, const DriveStatus&) override {}
  void axis_event(const std::string& axis, const DriveEvent& event) override { events.emplace_back(axis, event); }
  void command_reply(gateway_reply_t reply) override { replies.push_back(std::move(reply)); }
  std::vector<std::pair<std::string, DriveEvent>> events;
  std::vector<gateway_reply_t> replies;
};

motionlcm::axis_command_t axis_move(const std::string& axis, std::int64_t target) {
  motionlcm::axis_command_t a{};
  a.axis = axis;
  a.target_counts = target;
  a.velocity = 32000;  // 50 mm/s
  a.acceleration = 256000;
  a.deceleration = 256000;
  return a;
}

// The stack and its simulated drives on one zero-latency wire, time advanced by hand.
class Uim342Bench {
 public:
  explicit Uim342Bench(const std::string& variant, const char* lab = kLabTemplate) {
    std::string yaml = lab;
    for (auto at = yaml.find("VARIANT"); at != std::string::npos; at = yaml.find("VARIANT"))
      yaml.replace(at, 7, variant);
    auto loaded = config::load_string(yaml, "truth.yaml");
    EXPECT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
    CanStackContext ctx;
    ctx.out = &out;
    ctx.send = [this](const can::Frame& f) {
      to_drives.push_back(f);
      from_stack.push_back(f);
      return true;
    };
    stack = std::make_unique<Uim342Stack>(config_, "can0", ctx);
    for (const auto& d : config_.drives) {
      config::Drive stored = d;
      stored.setup["micro_steps"] = 8LL;  // what the drive's EEPROM holds at power-up
      const auto apply = config::sim_variant(config_, d, "micro_steps_apply") == "immediately"
                             ? sim::MicroStepsApply::kImmediately
                             : sim::MicroStepsApply::kAfterRestart;
      sim::SimDriveContext context;
      context.drive = d.name;
      context.bus = d.bus;
      context.send = [this, name = d.name](const can::Frame& f) {
        if (!muted.contains(name)) to_stack.push_back(f);  // a muted drive hears but is not heard
      };
      context.report = [this, name = d.name](std::int8_t kind, std::int64_t frame_utime, std::int64_t position,
                                             std::int64_t target) {
        if (kind == motionlcm::sim_report_t::POWERED_UP) ++boots[name];
        if (kind == motionlcm::sim_report_t::MOTION_STARTED) {
          starts[name].push_back(frame_utime);
          start_distances[name].push_back(target - position);
        }
        if (kind == motionlcm::sim_report_t::MOTION_FINISHED) finish_positions[name].push_back(position);
      };
      drives.push_back(std::make_unique<sim::Uim342Drive>(stored, context, sim::Uim342Identity{},
                                                          sim::uim342_home_switch(config_, d), apply));
    }
    for (auto& d : drives) d->power_up(now);
  }

  void settle() {
    while (!to_drives.empty() || !to_stack.empty()) {
      while (!to_drives.empty()) {
        auto f = to_drives.front();
        to_drives.pop_front();
        f.timestamp_us = std::chrono::duration_cast<std::chrono::microseconds>(now.time_since_epoch()).count();
        for (auto& d : drives) d->on_frame(f, now);
      }
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
  // A command of `kind` naming `axes`, for `trigger` (ARM_MOVE, DISARM).
  std::int64_t command(std::int8_t kind, std::vector<motionlcm::axis_command_t> axes, std::int64_t trigger = 0) {
    gateway_command_t c{};
    c.kind = kind;
    c.trigger_id = trigger;
    c.axes = std::move(axes);
    return execute(c);
  }
  // Someone else's BG to `group`, as another master or a stale frame would send it; then `span`.
  void foreign_bg(std::uint8_t group, Duration span) {
    const auto bg = uim342::instruction_frame(group, uim342::request::begin());
    ASSERT_TRUE(bg.ok());
    to_drives.push_back(*bg);
    settle();
    run_for(span);
  }
  // Command `id` ends DONE within `limit`; else what it ended with, or that it never did.
  ::testing::AssertionResult done(std::int64_t id, Duration limit = std::chrono::seconds(5)) {
    run_until([&] { return terminal(id).has_value(); }, limit);
    const auto r = terminal(id);
    if (!r) return ::testing::AssertionFailure() << "command " << id << " never ended";
    if (r->status != kDone) return ::testing::AssertionFailure() << "command " << id << " FAILED: " << r->reason;
    return ::testing::AssertionSuccess();
  }
  [[nodiscard]] std::optional<gateway_reply_t> terminal(std::int64_t id) const {
    for (const auto& r : out.replies) {
      if (r.command_id == id && (r.status == gateway_reply_t::DONE || r.status == gateway_reply_t::FAILED)) return r;
    }
    return std::nullopt;
  }

  config::Config config_;
  Recorder out;
  std::unique_ptr<Uim342Stack> stack;
  std::vector<std::unique_ptr<sim::Uim342Drive>> drives;
  std::map<std::string, int> boots;
  std::map<std::string, std::vector<std::int64_t>> starts;            // frame times of MOTION_STARTED
  std::map<std::string, std::vector<std::int64_t>> finish_positions;  // drive counts at MOTION_FINISHED
  std::map<std::string, std::vector<std::int64_t>> start_distances;   // target - position at MOTION_STARTED
  std::deque<can::Frame> to_drives, to_stack;
  std::vector<can::Frame> from_stack;  // every frame the stack sent, in order
  std::set<std::string> muted;         // drives whose frames never reach the stack
  TimePoint now = TimePoint{} + std::chrono::seconds(10);
  std::int64_t next_id = 0;
};

class Uim342MicroSteps : public ::testing::TestWithParam<std::string> {};

TEST_P(Uim342MicroSteps, SetUpRestartsOnceAndAMoveLandsOnThePhysicalTarget) {
  Uim342Bench bench(GetParam());
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5))) << "never ready";
  for (const auto& d : bench.drives) {
    EXPECT_EQ(d->applied_micro_steps(), 16) << "the motor does not run at the configured resolution";
    EXPECT_EQ(bench.boots[d->node_id() == 5 ? "x-drive" : "y-drive"], 2) << "power-up and exactly one restart";
  }
  gateway_command_t enable{};
  enable.kind = gateway_command_t::ENABLE;
  for (const auto* axis : {"x", "y"}) {
    motionlcm::axis_command_t a{};
    a.axis = axis;
    enable.axes.push_back(a);
  }
  const auto enabled = bench.execute(enable);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(enabled).has_value(); }, std::chrono::seconds(1)));
  ASSERT_EQ(bench.terminal(enabled)->status, kDone) << bench.terminal(enabled)->reason;

  // 10 mm and 5 mm, started by one group BG (trigger 7 fired below).
  gateway_command_t move{};
  move.kind = gateway_command_t::ARM_MOVE;
  move.trigger_id = 7;
  move.axes = {axis_move("x", 6400), axis_move("y", 3200)};
  const auto id = bench.execute(move);
  bench.run_for(milliseconds(20));
  bench.stack->fire(7, bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(id).has_value(); }, std::chrono::seconds(5)));
  const auto done = *bench.terminal(id);
  ASSERT_EQ(done.status, kDone) << done.reason;
  // What the stack reported is what the drives did: one group BG frame started both.
  std::string mechanism;
  for (const auto& r : bench.out.replies) {
    if (r.command_id == id && r.status == gateway_reply_t::STARTED) mechanism = r.start_mechanism;
  }
  EXPECT_EQ(mechanism, "group-bg");
  ASSERT_EQ(bench.starts["x-drive"].size(), 1u);
  ASSERT_EQ(bench.starts["y-drive"].size(), 1u);
  EXPECT_EQ(bench.starts["x-drive"][0], bench.starts["y-drive"][0]) << "not started by one frame";
  EXPECT_NEAR(bench.drives[0]->shaft_full_steps(bench.now), 400.0, 1e-9) << "x: 10 mm = 2 rev = 400 full steps";
  EXPECT_NEAR(bench.drives[1]->shaft_full_steps(bench.now), 200.0, 1e-9) << "y: 5 mm = 1 rev = 200 full steps";

  // HOME x (IN1 falling, toward min at 10 mm/s; the simulated switch edge at -3200 counts = -5 mm
  // = -200 full steps from power-up): the search runs from +400 full steps past the edge, the
  // origin is set there and the axis returns onto it.
  gateway_command_t home{};
  home.kind = gateway_command_t::HOME;
  motionlcm::axis_command_t x{};
  x.axis = "x";
  x.velocity = -6400;
  x.acceleration = x.deceleration = 256000;
  home.axes = {x};
  const std::size_t finished_before = bench.finish_positions["x-drive"].size();
  const auto homed = bench.execute(home);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(homed).has_value(); }, std::chrono::seconds(10)));
  ASSERT_EQ(bench.terminal(homed)->status, kDone) << bench.terminal(homed)->reason;
  const auto& finishes = bench.finish_positions["x-drive"];
  ASSERT_GE(finishes.size(), finished_before + 2) << "no search and return";
  EXPECT_LT(finishes[finished_before], 0) << "the search stopped short of the switch edge";
  EXPECT_EQ(finishes.back(), 0) << "the return did not end on the new origin";
  EXPECT_EQ(bench.drives[0]->position(bench.now), 0);
  // At the edge within what the search runs between two samples of the input (1 ms at 6400
  // counts/s: 6.4 counts = 0.4 full steps).
  EXPECT_NEAR(bench.drives[0]->shaft_full_steps(bench.now), -200.0, 0.4) << "x is not at its switch edge";
  EXPECT_LE(bench.drives[0]->shaft_full_steps(bench.now), -200.0) << "the origin was set before the edge";
  std::printf(
      "micro_steps_apply %s: HOME x from +400 full steps: search stopped at %lld counts past the edge, "
      "shaft at %.1f full steps (switch edge -200)\n",
      GetParam().c_str(), static_cast<long long>(finishes[finished_before]),
      bench.drives[0]->shaft_full_steps(bench.now));
}

// A released move (DISARM: the coordinator's, or the gateway's own at its arm expiry) leaves the
// drives nothing to start: a group BG from anyone else afterwards (manual §5.11: BG to the group
// id starts every member's loaded PA/PR) moves neither drive; the next move runs as usual.
TEST(Uim342Release, ADisarmedMoveLeavesNothingAForeignGroupBgCouldStart) {
  Uim342Bench bench("after_restart");
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5))) << "never ready";
  gateway_command_t enable{};
  enable.kind = gateway_command_t::ENABLE;
  enable.axes = {axis_move("x", 0), axis_move("y", 0)};
  const auto enabled = bench.execute(enable);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(enabled).has_value(); }, std::chrono::seconds(1)));
  ASSERT_EQ(bench.terminal(enabled)->status, kDone) << bench.terminal(enabled)->reason;

  gateway_command_t arm{};
  arm.kind = gateway_command_t::ARM_MOVE;
  arm.trigger_id = 9;
  arm.axes = {axis_move("x", 6400), axis_move("y", 3200)};
  const auto armed = bench.execute(arm);
  bench.run_for(milliseconds(50));
  gateway_command_t disarm{};
  disarm.kind = gateway_command_t::DISARM;
  disarm.trigger_id = 9;
  disarm.axes = {axis_move("x", 0), axis_move("y", 0)};
  ASSERT_TRUE(bench.done(bench.execute(disarm), std::chrono::seconds(1)));
  ASSERT_TRUE(bench.terminal(armed).has_value());
  EXPECT_EQ(bench.terminal(armed)->status, kFailed);

  // Someone else's BG to group 20 (x and y).
  bench.foreign_bg(20, milliseconds(500));
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string name = k == 0 ? "x-drive" : "y-drive";
    EXPECT_EQ(bench.drives[k]->position(bench.now), 0) << name << " ran the released move";
    for (const auto distance : bench.start_distances[name])
      EXPECT_EQ(distance, 0) << name << " started a move of " << distance << " counts on the foreign BG";
  }

  // The next move runs as usual.
  arm.trigger_id = 10;
  const auto again = bench.execute(arm);
  bench.run_for(milliseconds(50));
  bench.stack->fire(10, bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(again).has_value(); }, std::chrono::seconds(5)));
  ASSERT_EQ(bench.terminal(again)->status, kDone) << bench.terminal(again)->reason;
  EXPECT_EQ(bench.drives[0]->position(bench.now), 6400);
  EXPECT_EQ(bench.drives[1]->position(bench.now), 3200);
}

// `n` drives (x, y, z, w on nodes 5, 6, 7, 8) in group 20: a move of some of them is part of the
// group.
std::string group_lab(int n) {
  std::string drives;
  std::string axes;
  std::string variants;
  for (int k = 0; k < n; ++k) {
    const std::string a(1, "xyzw"[k]);
    drives += "  - {name: " + a + "-drive, family: uim342, bus: can0, node_id: " + std::to_string(5 + k) +
              ", group_id: 20, setup: {micro_steps: 16, acceleration_unit: rate}}\n";
    axes += "  - {name: " + a + ", drive: " + a +
            "-drive, unit: mm, steps_per_unit: 640, limits: {min: -100, max: 200, velocity: 50, acceleration: 400}}\n";
    variants += "    " + a + "-drive: {micro_steps_apply: VARIANT}\n";
  }
  return "buses:\n  - {name: can0, transport: \"simcan:can0\", bitrate: 1000000, request_timeout_ms: 50, retries: 2, "
         "poll_hz: 20}\ndrives:\n" +
         drives + "axes:\n" + axes + "simulation:\n  variants:\n" + variants;
}
const std::string kGroupOfThree = group_lab(3);

// The BG frames the stack sent from `from` on, by addressee (node or group id).
std::vector<int> bg_targets(const std::vector<can::Frame>& frames, std::size_t from = 0) {
  std::vector<int> out;
  for (std::size_t k = from; k < frames.size(); ++k) {
    const auto decoded = uim342::decode_instruction_frame(frames[k]);
    if (decoded.ok() && decoded->instruction.function == uim342::FunctionCode::kBG)
      out.push_back(decoded->address.consumer);
  }
  return out;
}

// Whether the stack sent PR=0 to `node` from `from` on.
bool pr0_sent(const std::vector<can::Frame>& frames, std::uint8_t node, std::size_t from = 0) {
  const auto pr0 = uim342::instruction_frame(node, uim342::request::set_relative_position(0));
  return std::any_of(frames.begin() + static_cast<std::ptrdiff_t>(from), frames.end(),
                     [&](const can::Frame& f) { return pr0.ok() && f == *pr0; });
}

// Ready, every axis enabled; z jogged and stopped, so that its drive is in jog mode (§5.16: a BG
// would run its jog again) and at rest.
void ready_with_z_jogged(Uim342Bench& bench) {
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5))) << "never ready";
  ASSERT_TRUE(
      bench.done(bench.command(gateway_command_t::ENABLE, {axis_move("x", 0), axis_move("y", 0), axis_move("z", 0)})));
  auto jog = axis_move("z", 0);
  jog.velocity = 3200;
  ASSERT_TRUE(bench.done(bench.command(gateway_command_t::JOG, {jog})));
  bench.run_for(milliseconds(200));
  ASSERT_TRUE(bench.drives[2]->moving(bench.now)) << "z does not jog";
  ASSERT_TRUE(bench.done(bench.command(gateway_command_t::STOP, {axis_move("z", 0)}), std::chrono::seconds(2)));
  bench.run_for(milliseconds(500));  // at rest, and polled since
  ASSERT_FALSE(bench.drives[2]->moving(bench.now));
}

std::string mechanism_of(const Uim342Bench& bench, std::int64_t id) {
  for (const auto& r : bench.out.replies) {
    if (r.command_id == id && r.status == gateway_reply_t::STARTED) return r.start_mechanism;
  }
  return "(no STARTED)";
}

// Fires `trigger`; the BG frames that went out for it, by addressee.
std::vector<int> fire(Uim342Bench& bench, std::int64_t trigger) {
  const auto from = bench.from_stack.size();
  bench.stack->fire(trigger, bench.now);
  bench.settle();
  return bg_targets(bench.from_stack, from);
}

// A move of two drives of a group of three starts with one BG to the group id (manual §5.11): the
// third, at rest, is given PR=0 while the move is armed (§5.20: relative to where it stands at
// BG), so the group BG moves it zero counts, though its drive was left in jog mode, where a BG
// alone would run the jog again.
TEST(Uim342PartialGroup, TwoOfThreeStartWithOneGroupBgAndTheThirdStaysPut) {
  Uim342Bench bench("after_restart", kGroupOfThree.c_str());
  ready_with_z_jogged(bench);
  const auto z_at = bench.drives[2]->position(bench.now);
  const auto z_starts = bench.start_distances["z-drive"].size();

  const auto from = bench.from_stack.size();
  const auto armed = bench.command(gateway_command_t::ARM_MOVE, {axis_move("x", 6400), axis_move("y", -3200)}, 7);
  bench.run_for(milliseconds(50));
  EXPECT_TRUE(pr0_sent(bench.from_stack, 7, from)) << "z was not given PR=0";
  EXPECT_EQ(fire(bench, 7), std::vector<int>{20}) << "not one BG to group 20";
  EXPECT_EQ(mechanism_of(bench, armed), "group-bg");
  ASSERT_TRUE(bench.done(armed));
  EXPECT_EQ(bench.drives[0]->position(bench.now), 6400);
  EXPECT_EQ(bench.drives[1]->position(bench.now), -3200);
  EXPECT_EQ(bench.drives[2]->position(bench.now), z_at) << "the group BG moved z";
  ASSERT_EQ(bench.start_distances["z-drive"].size(), z_starts + 1) << "z did not hear the group BG";
  EXPECT_EQ(bench.start_distances["z-drive"].back(), 0);
  // x and y started on the same frame (the simulator dates a start by its frame).
  ASSERT_FALSE(bench.starts["x-drive"].empty());
  ASSERT_FALSE(bench.starts["y-drive"].empty());
  EXPECT_EQ(bench.starts["x-drive"].back(), bench.starts["y-drive"].back());

  // z, polled again, takes a move of its own.
  ASSERT_TRUE(bench.done(bench.command(gateway_command_t::ARM_MOVE, {axis_move("z", z_at + 1600)})));
  EXPECT_EQ(bench.drives[2]->position(bench.now), z_at + 1600);
}

// A held drive taken by a command of its own before the trigger (here a move armed for another
// trigger) is not held any more: the first move starts drive by drive, and neither BG runs z's
// own move, which starts on its own trigger.
TEST(Uim342PartialGroup, ABystanderCommandedBeforeTheTriggerLeavesTheMoveToStartDriveByDrive) {
  Uim342Bench bench("after_restart", kGroupOfThree.c_str());
  ready_with_z_jogged(bench);
  const auto z_at = bench.drives[2]->position(bench.now);
  const auto first = bench.command(gateway_command_t::ARM_MOVE, {axis_move("x", 6400), axis_move("y", 3200)}, 7);
  bench.run_for(milliseconds(50));
  const auto second = bench.command(gateway_command_t::ARM_MOVE, {axis_move("z", z_at + 1600)}, 8);
  bench.run_for(milliseconds(50));
  EXPECT_EQ(fire(bench, 7), (std::vector<int>{5, 6}));
  EXPECT_EQ(mechanism_of(bench, first), "sequential");
  ASSERT_TRUE(bench.done(first));
  EXPECT_EQ(bench.drives[2]->position(bench.now), z_at) << "z's move ran on the first move's start";
  EXPECT_FALSE(bench.terminal(second).has_value());
  EXPECT_EQ(fire(bench, 8), std::vector<int>{7});
  ASSERT_TRUE(bench.done(second));
  EXPECT_EQ(bench.drives[2]->position(bench.now), z_at + 1600);
}

// A drive of the group that runs (a jog goes on after its JOG is DONE) is not held: PR=0 and a
// group BG would end its jog. The move starts drive by drive and z jogs on, untouched.
TEST(Uim342PartialGroup, ARunningDriveOfTheGroupIsNotHeld) {
  Uim342Bench bench("after_restart", kGroupOfThree.c_str());
  ready_with_z_jogged(bench);
  auto jog = axis_move("z", 0);
  jog.velocity = 3200;
  ASSERT_TRUE(bench.done(bench.command(gateway_command_t::JOG, {jog}), std::chrono::seconds(1)));
  const auto z_starts = bench.start_distances["z-drive"].size();
  // At once, before a status read shows z running.
  const auto from = bench.from_stack.size();
  const auto armed = bench.command(gateway_command_t::ARM_MOVE, {axis_move("x", 6400), axis_move("y", 3200)}, 7);
  bench.run_for(milliseconds(50));
  EXPECT_FALSE(pr0_sent(bench.from_stack, 7, from)) << "a jogging z was given PR=0";
  EXPECT_EQ(fire(bench, 7), (std::vector<int>{5, 6}));
  ASSERT_TRUE(bench.done(armed));
  EXPECT_TRUE(bench.drives[2]->moving(bench.now)) << "z's jog ended";
  EXPECT_EQ(bench.start_distances["z-drive"].size(), z_starts) << "z was started again";
}

// A drive of the group with its driver off is not held (manual §5.10: the driver on before PR or
// BG is sent, or residual actions move the motor once it is turned on): no PR=0 and no BG reaches
// it, the move starts drive by drive, and turning z's driver on later moves nothing.
TEST(Uim342PartialGroup, ADriveOfTheGroupWithItsDriverOffIsNotHeld) {
  Uim342Bench bench("after_restart", kGroupOfThree.c_str());
  ready_with_z_jogged(bench);
  ASSERT_TRUE(bench.done(bench.command(gateway_command_t::DISABLE, {axis_move("z", 0)})));
  bench.run_for(milliseconds(500));  // polled since
  const auto z_at = bench.drives[2]->position(bench.now);
  const auto z_starts = bench.start_distances["z-drive"].size();
  const auto from = bench.from_stack.size();
  const auto armed = bench.command(gateway_command_t::ARM_MOVE, {axis_move("x", 6400), axis_move("y", 3200)}, 7);
  bench.run_for(milliseconds(50));
  EXPECT_FALSE(pr0_sent(bench.from_stack, 7, from)) << "z, its driver off, was given PR=0";
  EXPECT_EQ(fire(bench, 7), (std::vector<int>{5, 6}));
  EXPECT_EQ(mechanism_of(bench, armed), "sequential");
  ASSERT_TRUE(bench.done(armed));
  EXPECT_EQ(bench.drives[0]->position(bench.now), 6400);
  EXPECT_EQ(bench.drives[1]->position(bench.now), 3200);
  EXPECT_EQ(bench.start_distances["z-drive"].size(), z_starts) << "a BG reached z";
  ASSERT_TRUE(bench.done(bench.command(gateway_command_t::ENABLE, {axis_move("z", 0)})));
  bench.run_for(milliseconds(300));
  EXPECT_FALSE(bench.drives[2]->moving(bench.now));
  EXPECT_EQ(bench.drives[2]->position(bench.now), z_at) << "z moved once its driver was turned on";
}

// A partial-group move disarmed: x and y get PR=0 as any released move, z holds its PR=0, so a
// foreign group BG moves nobody; z is polled again and takes its own move.
TEST(Uim342PartialGroup, ADisarmedPartialMoveLeavesNothingAGroupBgCouldStart) {
  Uim342Bench bench("after_restart", kGroupOfThree.c_str());
  ready_with_z_jogged(bench);
  std::vector<std::int64_t> at;
  for (const auto& d : bench.drives) at.push_back(d->position(bench.now));
  const auto armed = bench.command(gateway_command_t::ARM_MOVE, {axis_move("x", 6400), axis_move("y", 3200)}, 7);
  bench.run_for(milliseconds(50));
  ASSERT_TRUE(bench.done(bench.command(gateway_command_t::DISARM, {axis_move("x", 0), axis_move("y", 0)}, 7)));
  ASSERT_TRUE(bench.terminal(armed).has_value());
  EXPECT_EQ(bench.terminal(armed)->status, kFailed);
  bench.foreign_bg(20, milliseconds(300));
  for (std::size_t k = 0; k < bench.drives.size(); ++k)
    EXPECT_EQ(bench.drives[k]->position(bench.now), at[k]) << "drive " << k << " moved on a foreign group BG";
  ASSERT_TRUE(bench.done(bench.command(gateway_command_t::ARM_MOVE, {axis_move("z", at[2] - 800)})));
  EXPECT_EQ(bench.drives[2]->position(bench.now), at[2] - 800);
}

// Randomized against a reference rule, seeded: a group of four, moves of random parts of it to
// random targets, and before the trigger, sometimes a command of its own for a drive of the group
// outside the move (a move armed for another trigger, a jog, an ENABLE). The rule: a move of the
// whole group, or of at least two and at least half of it with nothing else commanded, starts
// on one group BG; any other starts drive by drive. Ground truth after each step: every drive of
// the move at its target, every other drive where its own commands left it (a jogging drive
// still jogging when the move starts), nothing moving once all is stopped.
TEST(Uim342PartialGroup, RandomPartsOfTheGroupMoveExactlyTheirDrives) {
  const std::string lab = group_lab(4);
  const std::array<std::string, 4> names{"x", "y", "z", "w"};
  for (unsigned seed = 1; seed <= 12; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937 rng(seed);
    const auto pick = [&rng](std::uint32_t n) { return static_cast<std::uint32_t>(rng() % n); };
    Uim342Bench bench("after_restart", lab.c_str());
    bench.stack->start(bench.now);
    bench.settle();
    ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5)));
    std::vector<motionlcm::axis_command_t> all;
    for (const auto& n : names) all.push_back(axis_move(n, 0));
    ASSERT_TRUE(bench.done(bench.command(gateway_command_t::ENABLE, all)));
    std::array<std::int64_t, 4> expected{};
    std::int64_t trigger = 100;
    for (int step = 0; step < 8; ++step) {
      const std::uint32_t mask = 1 + pick(15);
      std::vector<motionlcm::axis_command_t> axes;
      std::vector<std::size_t> inside;
      std::vector<std::size_t> outside;
      for (std::size_t k = 0; k < 4; ++k) {
        if ((mask & (1U << k)) == 0) {
          outside.push_back(k);
          continue;
        }
        inside.push_back(k);
        axes.push_back(axis_move(names[k], std::int64_t{pick(12801)} - 6400));
      }
      // 0: nothing else; 1: a move of its own for another trigger; 2: a jog; 3: an ENABLE.
      const std::uint32_t other = outside.empty() ? 0 : pick(4);
      const std::size_t b = outside.empty() ? 0 : outside[pick(static_cast<std::uint32_t>(outside.size()))];
      const std::string what = "step " + std::to_string(step) + ": mask " + std::to_string(mask) + ", other " +
                               std::to_string(other) + " on " + names[b];
      SCOPED_TRACE(what);
      const auto move = bench.command(gateway_command_t::ARM_MOVE, axes, ++trigger);
      bench.run_for(milliseconds(pick(30)));
      std::int64_t own = 0;
      auto own_target = axis_move(names[b], std::int64_t{pick(12801)} - 6400);
      if (other == 1) own = bench.command(gateway_command_t::ARM_MOVE, {own_target}, trigger + 1000);
      if (other == 2) {
        auto jog = axis_move(names[b], 0);
        jog.velocity = pick(2) == 0 ? 1600 : -1600;
        own = bench.command(gateway_command_t::JOG, {jog});
      }
      if (other == 3) own = bench.command(gateway_command_t::ENABLE, {axis_move(names[b], 0)});
      bench.run_for(milliseconds(30));
      const bool one_bg = outside.empty() || (other == 0 && axes.size() >= 2 && outside.size() <= axes.size());
      const auto bgs = fire(bench, trigger);
      EXPECT_EQ(bgs.size(), one_bg ? 1U : axes.size()) << "BG frames";
      if (one_bg && !bgs.empty()) { EXPECT_EQ(bgs.front(), 20); }
      EXPECT_EQ(mechanism_of(bench, move), one_bg ? "group-bg" : "sequential");
      if (other == 2) { EXPECT_TRUE(bench.drives[b]->moving(bench.now)) << names[b] << "'s jog was stopped"; }
      ASSERT_TRUE(bench.done(move));
      for (std::size_t j = 0; j < inside.size(); ++j) expected[inside[j]] = axes[j].target_counts;
      if (other == 1) {
        EXPECT_EQ(bench.drives[b]->position(bench.now), expected[b]) << names[b] << " ran its move on another start";
        EXPECT_EQ(fire(bench, trigger + 1000), std::vector<int>{static_cast<int>(5 + b)});
        ASSERT_TRUE(bench.done(own));
        expected[b] = own_target.target_counts;
      }
      if (other == 2) {
        ASSERT_TRUE(bench.done(bench.command(gateway_command_t::STOP, {axis_move(names[b], 0)})));
        bench.run_for(milliseconds(300));
        expected[b] = bench.drives[b]->position(bench.now);
      }
      if (other == 3) { ASSERT_TRUE(bench.done(own)); }
      bench.run_for(milliseconds(300));  // at rest, and polled since
      for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_FALSE(bench.drives[k]->moving(bench.now)) << names[k] << " still moves";
        EXPECT_EQ(bench.drives[k]->position(bench.now), expected[k]) << names[k];
      }
      if (HasFailure()) return;
    }
  }
}

// A drive that stops answering mid-move may still hear (a broken transmit path, a bad
// transceiver): once the stack calls it offline, a STOP naming it still sends its ST (without
// ACK request), the drive stops (ground truth), and the STOP ends FAILED saying the stop is not
// confirmed.
TEST(Uim342Unanswering, AStopStillReachesADriveThatHearsButDoesNotAnswer) {
  Uim342Bench bench("after_restart");
  bench.stack->start(bench.now);
  bench.settle();
  ASSERT_TRUE(bench.run_until([&] { return bench.stack->ready(); }, std::chrono::seconds(5))) << "never ready";
  gateway_command_t enable{};
  enable.kind = gateway_command_t::ENABLE;
  enable.axes = {axis_move("x", 0)};
  const auto enabled = bench.execute(enable);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(enabled).has_value(); }, std::chrono::seconds(1)));
  gateway_command_t move{};
  move.kind = gateway_command_t::ARM_MOVE;
  move.axes = {axis_move("x", 128000)};  // 200 mm at 50 mm/s: 4 s
  const auto moving = bench.execute(move);
  bench.run_for(milliseconds(300));
  ASSERT_TRUE(bench.drives[0]->moving(bench.now));
  bench.muted.insert("x-drive");
  ASSERT_TRUE(bench.run_until(
      [&] {
        return std::any_of(bench.out.events.begin(), bench.out.events.end(), [](const auto& e) {
          return e.first == "x" && e.second.kind == motionlcm::event_t::OFFLINE;
        });
      },
      std::chrono::seconds(2)))
      << "never called offline";
  ASSERT_TRUE(bench.terminal(moving).has_value()) << "the move did not end with its drive offline";
  ASSERT_TRUE(bench.drives[0]->moving(bench.now)) << "stopped by something else";

  gateway_command_t stop{};
  stop.kind = gateway_command_t::STOP;
  stop.axes = {axis_move("x", 0)};
  const auto stopped = bench.execute(stop);
  ASSERT_TRUE(bench.run_until([&] { return bench.terminal(stopped).has_value(); }, std::chrono::seconds(1)));
  EXPECT_EQ(bench.terminal(stopped)->status, kFailed);
  EXPECT_NE(bench.terminal(stopped)->reason.find("ST sent, stop not confirmed"), std::string::npos)
      << bench.terminal(stopped)->reason;
  bench.run_for(std::chrono::seconds(1));
  EXPECT_FALSE(bench.drives[0]->moving(bench.now)) << "the drive did not get its stop";
  EXPECT_LT(bench.drives[0]->position(bench.now), 128000);
  std::printf("x muted mid-move, STOP: \"%s\"; at rest at %lld counts (target 128000)\n",
              bench.terminal(stopped)->reason.c_str(), static_cast<long long>(bench.drives[0]->position(bench.now)));
}

INSTANTIATE_TEST_SUITE_P(Variants, Uim342MicroSteps, ::testing::Values("after_restart", "immediately"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

}  // namespace
}  // namespace motion::gateway
