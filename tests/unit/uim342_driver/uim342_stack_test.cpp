// Uim342Stack driven with explicit `now` values: a fake send sink records every frame, fake
// drives answer with codec-encoded replies, a fake GatewayOutput records replies, status and
// events. Every test checks that each command ended in exactly one terminal reply.
#include "motion/uim342_driver/uim342_stack.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <motionlcm/event_t.hpp>

#include "fake_drive.hpp"
#include "motion/can_frame/bit_timing.hpp"

namespace motion::gateway {
namespace {

using motionlcm::event_t;
using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using std::chrono::milliseconds;
using FC = uim342::FunctionCode;

// x and y share group 20, z has none (as in config/sim-lab.yaml).
constexpr const char* kLab = R"(
buses:
  - {name: can0, transport: "simcan:can0", bitrate: 1000000, request_timeout_ms: 50, retries: 2, poll_hz: 20}
drives:
  - {name: x-drive, family: uim342, bus: can0, node_id: 5, group_id: 20,
     setup: {micro_steps: 16, current_a: 2.0, acceleration_unit: rate, closed_loop: false}}
  - {name: y-drive, family: uim342, bus: can0, node_id: 6, group_id: 20, setup: {micro_steps: 16}}
  - {name: z-drive, family: uim342, bus: can0, node_id: 7, setup: {current_a: 1.5}}
axes:
  - {name: x, drive: x-drive, unit: mm, steps_per_unit: 640, limits: {min: -10, max: 300, velocity: 50, acceleration: 400}}
  - {name: y, drive: y-drive, unit: mm, steps_per_unit: 640, limits: {min: -10, max: 200, velocity: 50, acceleration: 400}}
  - {name: z, drive: z-drive, unit: mm, steps_per_unit: 640, limits: {min: -50, max: 50, velocity: 20, acceleration: 200}}
)";

constexpr std::int64_t kEpochUs = 1'700'000'000'000'000;

class RecordingOutput final : public GatewayOutput {
 public:
  void axis_status(const std::string& axis, const DriveStatus& status) override { statuses.emplace_back(axis, status); }
  void axis_event(const std::string& axis, const DriveEvent& event) override { events.emplace_back(axis, event); }
  void command_reply(gateway_reply_t reply) override { replies.push_back(std::move(reply)); }

  std::vector<std::pair<std::string, DriveStatus>> statuses;
  std::vector<std::pair<std::string, DriveEvent>> events;
  std::vector<gateway_reply_t> replies;
};

class Uim342StackTest : public ::testing::Test {
 protected:
  void SetUp() override { build(kLab); }

  void build(const std::string& yaml) {
    auto loaded = config::load_string(yaml, "test.yaml");
    ASSERT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
    auto stack_config = Uim342StackConfig::from(config_, "can0");
    CanStackContext ctx;
    ctx.out = &out;
    ctx.send = [this](const can::Frame& f) {
      sent.push_back(f);
      wire.push_back(f);
      return true;
    };
    stack = std::make_unique<Uim342Stack>(stack_config, ctx, [](TimePoint t) {
      return kEpochUs + std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
    });
    drives.clear();
    drives.emplace(5, test::FakeDrive{5, 20});
    drives.emplace(6, test::FakeDrive{6, 20});
    drives.emplace(7, test::FakeDrive{7, 0});
  }

  void TearDown() override {
    // Every command ends in exactly one terminal reply.
    for (const auto id : commands_) {
      const auto terminal = std::count_if(out.replies.begin(), out.replies.end(), [id](const gateway_reply_t& r) {
        return r.command_id == id && (r.status == gateway_reply_t::DONE || r.status == gateway_reply_t::FAILED);
      });
      EXPECT_EQ(terminal, 1) << "command " << id;
    }
  }

  // Frames on the wire reach every drive; their answers go to the stack (vcan semantics).
  void settle() {
    while (!wire.empty()) {
      const auto frame = wire.front();
      wire.pop_front();
      for (auto& [id, d] : drives) {
        for (const auto& answer : d.handle(frame)) deliver(answer);
      }
    }
  }
  void deliver(const can::Frame& f) {
    stack->on_frame(f, now);
    settle();
  }
  void deliver(const std::vector<can::Frame>& frames) {
    for (const auto& f : frames) deliver(f);
  }
  // Runs the stack's deadlines until `span` has passed.
  void run_for(Duration span) {
    const auto end = now + span;
    while (true) {
      const auto next = stack->process(now);
      settle();
      if (next > end) break;
      now = std::max(next, now + std::chrono::microseconds(1));
    }
    now = end;
    stack->process(now);
    settle();
  }
  void start_and_set_up() {
    stack->start(now);
    settle();
    run_for(milliseconds(1));
    ASSERT_TRUE(stack->ready());
    clear_records();
  }
  void clear_records() {
    sent.clear();
    out.replies.clear();
    out.events.clear();
    out.statuses.clear();
  }

  gateway_command_t command(std::int8_t kind, std::vector<std::string> axes, std::int64_t trigger_id = 0) {
    gateway_command_t c{};
    c.bus = "can0";
    c.command_id = ++next_id_;
    c.kind = kind;
    c.trigger_id = trigger_id;
    for (const auto& a : axes) {
      motionlcm::axis_command_t ac{};
      ac.axis = a;
      ac.velocity = 3200;
      ac.acceleration = 10000;
      ac.deceleration = 10000;
      c.axes.push_back(ac);
    }
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    return c;
  }
  std::int64_t execute(const gateway_command_t& c) {
    commands_.push_back(c.command_id);
    stack->execute(c, now);
    settle();
    return c.command_id;
  }
  std::int64_t enable(std::vector<std::string> axes) {
    return execute(command(gateway_command_t::ENABLE, std::move(axes)));
  }

  std::vector<gateway_reply_t> replies_of(std::int64_t id) const {
    std::vector<gateway_reply_t> r;
    std::copy_if(out.replies.begin(), out.replies.end(), std::back_inserter(r),
                 [id](const auto& x) { return x.command_id == id; });
    return r;
  }
  gateway_reply_t last_reply(std::int64_t id) const {
    const auto r = replies_of(id);
    return r.empty() ? gateway_reply_t{} : r.back();
  }
  std::vector<std::int8_t> statuses_of(std::int64_t id) const {
    std::vector<std::int8_t> s;
    for (const auto& r : replies_of(id)) s.push_back(r.status);
    return s;
  }
  // Frames sent with this CW to this consumer (node, group or global id).
  std::size_t count_sent(std::uint8_t consumer, FC f) const {
    return static_cast<std::size_t>(std::count_if(sent.begin(), sent.end(), [&](const can::Frame& fr) {
      const auto d = uim342::decode_instruction_frame(fr);
      return d && d->address.consumer == consumer && d->instruction.function == f;
    }));
  }
  std::vector<uim342::Instruction> sent_to(std::uint8_t consumer) const {
    std::vector<uim342::Instruction> out_list;
    for (const auto& fr : sent) {
      const auto d = uim342::decode_instruction_frame(fr);
      if (d && d->address.consumer == consumer) out_list.push_back(d->instruction);
    }
    return out_list;
  }
  bool has_event(std::int16_t kind, const std::string& axis = {}) const {
    return std::any_of(out.events.begin(), out.events.end(),
                       [&](const auto& e) { return e.second.kind == kind && (axis.empty() || e.first == axis); });
  }
  const DriveEvent* find_event(std::int16_t kind) const {
    for (const auto& e : out.events) {
      if (e.second.kind == kind) return &e.second;
    }
    return nullptr;
  }

  // Copies of LCM constants (never ODR-use the generated in-class constants).
  static constexpr std::int8_t kArmed = gateway_reply_t::ARMED;
  static constexpr std::int8_t kStarted = gateway_reply_t::STARTED;
  static constexpr std::int8_t kDone = gateway_reply_t::DONE;
  static constexpr std::int8_t kFailed = gateway_reply_t::FAILED;
  static constexpr std::int8_t kError = event_t::ERROR;
  static constexpr std::int8_t kWarning = event_t::WARNING;

  config::Config config_;
  RecordingOutput out;
  std::vector<can::Frame> sent;
  std::deque<can::Frame> wire;
  std::map<std::uint8_t, test::FakeDrive> drives;
  std::unique_ptr<Uim342Stack> stack;
  TimePoint now = TimePoint{} + std::chrono::seconds(10);
  std::int64_t next_id_ = 100;
  std::vector<std::int64_t> commands_;
};

// ---- start-up -------------------------------------------------------------------------------

TEST_F(Uim342StackTest, StartIdentifiesAppliesSetupAndBecomesReady) {
  EXPECT_FALSE(stack->ready());
  EXPECT_EQ(stack->axes(), (std::vector<std::string>{"x", "y", "z"}));
  stack->start(now);
  settle();
  EXPECT_TRUE(stack->ready());
  const auto x = sent_to(5);
  ASSERT_FALSE(x.empty());
  EXPECT_EQ(x.front(), uim342::request::get(FC::kML));  // §5.4 identification first
  const auto has = [&](const uim342::Instruction& i) { return std::find(x.begin(), x.end(), i) != x.end(); };
  EXPECT_TRUE(has(uim342::request::get(uim342::ProtocolParameter::kGroupId)));
  // MT[0] / QE[4] already at the configured 16 / 3200: read, not rewritten (no restart).
  EXPECT_TRUE(has(uim342::request::get(uim342::MotorDriver::kMicrostepping)));
  EXPECT_TRUE(has(uim342::request::get(uim342::QuadratureEncoder::kCountsPerRevolution)));
  EXPECT_FALSE(has(uim342::request::set(uim342::MotorDriver::kMicrostepping, 16)));
  EXPECT_EQ(count_sent(5, FC::kSY), 0u);
  EXPECT_TRUE(has(uim342::request::set(uim342::MotorDriver::kWorkingCurrent, 20)));
  EXPECT_TRUE(has(uim342::request::set(uim342::InitialConfig::kAccelerationUnit, 0)));
  EXPECT_TRUE(has(uim342::request::set(uim342::InitialConfig::kClosedLoop, 0)));
  EXPECT_TRUE(has(uim342::request::set(uim342::InformationEnable::kPositionReached, true)));
  EXPECT_TRUE(has(uim342::request::set(uim342::InformationEnable::kIn1Change, true)));
  EXPECT_EQ(drives.at(7).word(FC::kMT, 1), 15);  // z: 1.5 A
  EXPECT_EQ(count_sent(7, FC::kPP), 0u);         // z has no group id
  EXPECT_TRUE(has_event(event_t::ONLINE, "x"));

  motionlcm::bus_stats_t stats{};
  stack->add_statistics(stats);
  EXPECT_EQ(stats.drives_online, 3);
  EXPECT_EQ(stats.drives_total, 3);

  // Polling at the bus's poll rate (20 Hz): MS[0] and MS[1] per node, status published.
  clear_records();
  run_for(milliseconds(50));
  EXPECT_EQ(count_sent(5, FC::kMS), 2u);
  EXPECT_EQ(count_sent(7, FC::kMS), 2u);
  ASSERT_FALSE(out.statuses.empty());
  EXPECT_TRUE(out.statuses.back().second.online);
  EXPECT_EQ(out.statuses.back().second.sample_utime, kEpochUs + 10'050'000);
  run_for(milliseconds(100));
  EXPECT_EQ(count_sent(5, FC::kMS), 6u);
}

// §5.9, §5.7: micro-steps apply only when stored with the driver off and the drive restarted.
// A drive at 8 gets MO=0, MT[0]=16, QE[4]=3200, SY[1], in that order, and is ready only after the
// read-back following the restart agrees.
TEST_F(Uim342StackTest, MicroStepsAreStoredWithTheDriverOffAndTheDriveRestartedBeforeReady) {
  drives.erase(5);
  drives.emplace(5, test::FakeDrive{5, 20, 8});
  stack->start(now);
  settle();
  EXPECT_FALSE(stack->ready());
  const auto x = sent_to(5);
  const auto index_of = [&](const uim342::Instruction& i) { return std::find(x.begin(), x.end(), i) - x.begin(); };
  const auto off = index_of(uim342::request::driver_on(false));
  const auto mt = index_of(uim342::request::set(uim342::MotorDriver::kMicrostepping, 16));
  const auto qe = index_of(uim342::request::set(uim342::QuadratureEncoder::kCountsPerRevolution, 3200));
  const auto sy = index_of(uim342::request::system(uim342::SystemOperation::kReboot));
  ASSERT_LT(sy, static_cast<std::ptrdiff_t>(x.size()));
  EXPECT_LT(off, mt);
  EXPECT_LT(mt, qe);
  EXPECT_LT(qe, sy);
  EXPECT_TRUE(has_event(event_t::REBOOT, "x"));
  run_for(milliseconds(1100));  // reboot_wait, then identified, set up and read back
  EXPECT_TRUE(stack->ready());
  EXPECT_EQ(drives.at(5).reboots, 1);
  EXPECT_EQ(drives.at(5).word(FC::kMT, 0), 16);
}

// A drive that does not keep MT[0] over the restart: CONFIG_MISMATCH naming drive and value,
// never ready, and no second restart (no EEPROM write loop).
TEST_F(Uim342StackTest, MicroStepsNotKeptOverTheRestartAreAnErrorNotALoop) {
  drives.erase(5);
  drives.emplace(5, test::FakeDrive{5, 20, 8});
  drives.at(5).keeps_micro_steps = false;
  stack->start(now);
  settle();
  run_for(milliseconds(5000));
  EXPECT_FALSE(stack->ready());
  EXPECT_EQ(drives.at(5).reboots, 1);
  const auto* mismatch = find_event(event_t::CONFIG_MISMATCH);
  ASSERT_NE(mismatch, nullptr);
  EXPECT_NE(mismatch->text.find("x-drive (node 5) reads MT[0] 0 / QE[4] 3200"), std::string::npos) << mismatch->text;
  EXPECT_NE(mismatch->text.find("configured micro_steps 16"), std::string::npos) << mismatch->text;
}

// §5.24 polling that fills the bus. 120 drives x (MS[0] + MS[1]) at 20 Hz need ~1.1 s of wire
// per second at 1 Mbit/s: more than the bus carries. Each drive is then polled as often as the
// bus allows (one poll of every drive back to back), and the stack says so once at start. How
// full the bus really gets is measured on a bit-timed wire in uim342_poll_test.cpp.
TEST_F(Uim342StackTest, PollingIsSlowedToWhatTheBusCarriesAndSaysSo) {
  std::string yaml = "buses:\n  - {name: can0, transport: \"simcan:can0\", bitrate: 1000000, poll_hz: 20}\ndrives:\n";
  for (int node = 5; node < 125; ++node)
    yaml += fmt::format("  - {{name: d{0}, family: uim342, bus: can0, node_id: {0}}}\n", node);
  build(yaml.c_str());
  const auto cycle = [](std::size_t polled) {
    // One poll of a drive: two requests and two ACKs, the longest ACK 8 bytes (MS[1]).
    const auto request = uim342::instruction_frame(5, uim342::request::get(uim342::MotionStatusIndex::kKinematics));
    const auto ack = uim342::reply_frame(5, uim342::Reply{FC::kMS, uim342::MotionKinematics{-1, -1}});
    return 2 * (can::frame_duration(*request, 1'000'000) + can::frame_duration(*ack, 1'000'000)) *
           static_cast<std::int64_t>(polled);
  };
  ASSERT_GT(cycle(120), milliseconds(50));  // more than the configured 50 ms period
  // The whole bus, not 3/4 of it: node ids differ in stuff bits by a few per frame.
  EXPECT_GE(stack->poll_period(), cycle(120) * 97 / 100);
  EXPECT_LT(stack->poll_period(), cycle(120) * 103 / 100);
  stack->start(now);
  const auto* warning = find_event(event_t::CONFIG_MISMATCH);
  ASSERT_NE(warning, nullptr);
  EXPECT_EQ(warning->severity, kWarning);
  EXPECT_NE(warning->text.find("bus can0: polling 120 UIM342 drives at 20.0 Hz needs"), std::string::npos)
      << warning->text;
  EXPECT_NE(warning->text.find("polls fill the bus, commands go first"), std::string::npos) << warning->text;
  EXPECT_EQ(std::count_if(out.events.begin(), out.events.end(), [](const auto& e) { return e.first.empty(); }), 1);

  // Three drives fit: the configured rate, nothing said.
  build(kLab);
  clear_records();
  EXPECT_EQ(stack->poll_period(), milliseconds(50));
  stack->start(now);
  settle();
  EXPECT_EQ(find_event(event_t::CONFIG_MISMATCH), nullptr);
}

// A request's timeout counts from when it was handed to the transport plus the wire time of
// the requests in flight ahead of it (each with its ACK): a queue on a busy bus is not a silent
// drive. Three requests in flight at 1 Mbit/s: ~0.2 ms of wire each.
TEST_F(Uim342StackTest, RequestTimeoutAllowsForTheRequestsAheadOnTheWire) {
  start_and_set_up();
  for (auto& [id, d] : drives) d.silent = true;
  execute(command(gateway_command_t::ENABLE, {"x", "y", "z"}));
  ASSERT_EQ(count_sent(5, FC::kMO) + count_sent(6, FC::kMO) + count_sent(7, FC::kMO), 3u);
  run_for(milliseconds(50) + std::chrono::microseconds(150));
  EXPECT_EQ(stack->counters().retries, 0);  // at exactly request_timeout_ms they would all be retried
  run_for(milliseconds(2));
  EXPECT_EQ(stack->counters().retries, 3);
  for (auto& [id, d] : drives) d.silent = false;
  run_for(milliseconds(60));  // the second retries are answered: the command ends DONE
}

TEST_F(Uim342StackTest, WrongGroupIdIsWrittenAndTheDriveRebooted) {
  drives.erase(6);
  drives.emplace(6, test::FakeDrive{6, 10});  // factory group 10
  stack->start(now);
  settle();
  EXPECT_FALSE(stack->ready());
  EXPECT_EQ(count_sent(6, FC::kSY), 1u);
  EXPECT_TRUE(has_event(event_t::REBOOT, "y"));
  run_for(milliseconds(1001));  // reboot_wait, then identified and set up again
  EXPECT_EQ(drives.at(6).group(), 20);
  EXPECT_TRUE(stack->ready());
  EXPECT_EQ(count_sent(6, FC::kML), 2u);
}

TEST_F(Uim342StackTest, SilentNodeIsOfflineRetriedWithBackOffAndRecovers) {
  drives.at(7).silent = true;
  stack->start(now);
  settle();
  run_for(milliseconds(160));  // 3 tries of 50 ms
  EXPECT_EQ(count_sent(7, FC::kML), 3u);
  EXPECT_FALSE(stack->ready());
  const auto* offline = find_event(event_t::OFFLINE);
  ASSERT_NE(offline, nullptr);
  EXPECT_EQ(offline->text,
            "z-drive (node 7) offline: z-drive (node 7) did not answer ML after 3 tries; retrying in 500 ms");
  ASSERT_TRUE(stack->status("z").has_value());
  EXPECT_FALSE(stack->status("z")->online);
  motionlcm::bus_stats_t stats{};
  stack->add_statistics(stats);
  EXPECT_EQ(stats.drives_online, 2);
  EXPECT_EQ(stats.timeouts, 1);
  EXPECT_EQ(stats.retries, 2);

  // Back-off: 500 ms, then 1000 ms; one OFFLINE event only.
  sent.clear();
  run_for(milliseconds(600));
  EXPECT_EQ(count_sent(7, FC::kML), 3u);
  run_for(milliseconds(600));
  EXPECT_EQ(count_sent(7, FC::kML), 3u);
  run_for(milliseconds(600));
  EXPECT_EQ(count_sent(7, FC::kML), 6u);
  EXPECT_EQ(std::count_if(out.events.begin(), out.events.end(),
                          [](const auto& e) { return e.second.kind == event_t::OFFLINE; }),
            1);

  const auto refused = execute(command(gateway_command_t::ENABLE, {"z"}));
  EXPECT_EQ(last_reply(refused).error_code, error_code(ReplyError::kAxisOffline));

  drives.at(7).silent = false;
  run_for(milliseconds(2100));
  EXPECT_TRUE(stack->ready());
  EXPECT_TRUE(stack->status("z")->online);
}

// ---- commands -------------------------------------------------------------------------------

TEST_F(Uim342StackTest, EnableAndDisable) {
  start_and_set_up();
  const auto on = enable({"x", "z"});
  EXPECT_EQ(statuses_of(on), (std::vector<std::int8_t>{kDone}));
  EXPECT_TRUE(drives.at(5).enabled());
  EXPECT_TRUE(drives.at(7).enabled());
  EXPECT_TRUE(stack->status("x")->enabled);
  EXPECT_EQ(sent_to(5).back(), uim342::request::driver_on(true));
  const auto off = execute(command(gateway_command_t::DISABLE, {"x"}));
  EXPECT_EQ(statuses_of(off), (std::vector<std::int8_t>{kDone}));
  EXPECT_FALSE(drives.at(5).enabled());
}

TEST_F(Uim342StackTest, ArmedGroupMoveStartsWithOneBgToTheGroupId) {
  start_and_set_up();
  enable({"x", "y"});
  auto move = command(gateway_command_t::ARM_MOVE, {"x", "y"}, 77);
  move.axes[0].target_counts = 6400;
  move.axes[1].target_counts = -3200;
  const auto id = execute(move);
  EXPECT_EQ(statuses_of(id), (std::vector<std::int8_t>{kArmed}));
  // PA first, then SP (§5.19 ordering rule), then AC and DC.
  const auto x = sent_to(5);
  const auto pa = std::find(x.begin(), x.end(), uim342::request::set_absolute_position(6400));
  ASSERT_NE(pa, x.end());
  ASSERT_LT(pa + 3, x.end());
  EXPECT_EQ(*(pa + 1), uim342::request::set_ptp_speed(3200));
  EXPECT_EQ(*(pa + 2), uim342::request::set_acceleration(10000));
  EXPECT_EQ(*(pa + 3), uim342::request::set_deceleration(10000));
  EXPECT_FALSE(drives.at(5).moving());

  // Armed nodes are not polled (the trigger goes out at once), and no deadline is due for them.
  sent.clear();
  run_for(milliseconds(200));
  EXPECT_EQ(count_sent(5, FC::kMS), 0u);
  EXPECT_EQ(count_sent(7, FC::kMS), 8u);  // z is still polled
  EXPECT_GT(stack->process(now), now);
  stack->fire(77, now);
  settle();
  EXPECT_EQ(count_sent(20, FC::kBG), 1u);
  EXPECT_EQ(count_sent(5, FC::kBG) + count_sent(6, FC::kBG), 0u);
  EXPECT_TRUE(drives.at(5).moving());
  EXPECT_TRUE(drives.at(6).moving());
  ASSERT_EQ(replies_of(id).size(), 2u);
  const auto started = replies_of(id)[1];
  EXPECT_EQ(started.status, kStarted);
  EXPECT_EQ(started.start_mechanism, "group-bg");
  EXPECT_EQ(started.predicted_skew_us, 0.0);
  EXPECT_EQ(started.trigger_utime, kEpochUs + 10'201'000);

  deliver(drives.at(5).finish_move());
  EXPECT_EQ(replies_of(id).size(), 2u);  // y still moving
  deliver(drives.at(6).finish_move());
  EXPECT_EQ(last_reply(id).status, kDone);
  EXPECT_EQ(stack->status("x")->position_counts, 6400);
  EXPECT_EQ(stack->status("y")->position_counts, -3200);
  EXPECT_TRUE(has_event(event_t::MOTION_COMPLETE, "y"));
}

TEST_F(Uim342StackTest, MoveOfAxesWithoutACommonGroupStartsSequentiallyAndEndsByPolling) {
  start_and_set_up();
  enable({"x", "z"});
  drives.at(5).notify_in_position = false;
  drives.at(7).notify_in_position = false;
  auto move = command(gateway_command_t::ARM_MOVE, {"x", "z"});  // trigger 0: start at once
  move.axes[0].target_counts = 100;
  move.axes[1].target_counts = 200;
  const auto id = execute(move);
  EXPECT_EQ(statuses_of(id), (std::vector<std::int8_t>{kArmed, kStarted}));
  EXPECT_EQ(count_sent(5, FC::kBG), 1u);
  EXPECT_EQ(count_sent(7, FC::kBG), 1u);
  const auto started = replies_of(id)[1];
  EXPECT_EQ(started.start_mechanism, "sequential");
  const auto bg = *uim342::instruction_frame(5, uim342::request::begin());
  const double frame_us = std::chrono::duration<double, std::micro>(can::frame_duration(bg, 1'000'000)).count();
  EXPECT_DOUBLE_EQ(started.predicted_skew_us, frame_us);
  run_for(milliseconds(60));
  EXPECT_EQ(last_reply(id).status, kStarted);  // polled while moving
  drives.at(5).finish_move();
  drives.at(7).finish_move();
  run_for(milliseconds(60));
  EXPECT_EQ(last_reply(id).status, kDone);
}

TEST_F(Uim342StackTest, GroupIsNotUsedWhenAGroupMemberIsNotPartOfTheMove) {
  start_and_set_up();
  enable({"x"});
  const auto id = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
  EXPECT_EQ(count_sent(20, FC::kBG), 0u);  // y is in group 20 too and must not start
  EXPECT_EQ(count_sent(5, FC::kBG), 1u);
  EXPECT_EQ(replies_of(id).at(1).start_mechanism, "sequential");
  EXPECT_EQ(replies_of(id).at(1).predicted_skew_us, 0.0);
  EXPECT_FALSE(drives.at(6).moving());
  deliver(drives.at(5).finish_move());
  EXPECT_EQ(last_reply(id).status, kDone);
}

TEST_F(Uim342StackTest, TimeoutAfterTheLastRetryFailsWithTheDriveNodeAndInstruction) {
  start_and_set_up();
  drives.at(5).silent = true;
  auto move = command(gateway_command_t::ARM_MOVE, {"x"});
  const auto id = execute(move);
  run_for(milliseconds(200));
  const auto r = last_reply(id);
  EXPECT_EQ(r.status, kFailed);
  EXPECT_EQ(r.reason, "x-drive (node 5) did not answer PA after 3 tries");
  EXPECT_EQ(r.error_code, error_code(ReplyError::kTimeout));
  EXPECT_EQ(count_sent(5, FC::kPA), 3u);
  EXPECT_EQ(count_sent(5, FC::kSP), 0u);  // nothing else of the command went out
  EXPECT_TRUE(has_event(event_t::TIMEOUT, "x"));
  EXPECT_TRUE(has_event(event_t::OFFLINE, "x"));
  EXPECT_EQ(stack->counters().retries, 2);
  EXPECT_EQ(stack->counters().timeouts, 1);
  EXPECT_FALSE(stack->ready());
}

TEST_F(Uim342StackTest, ErrorReportFailsTheCommandWithTheDriveError) {
  start_and_set_up();
  enable({"x"});
  drives.at(5).refuse[FC::kPA] = uim342::DriveErrc::kDataError;
  const auto id = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
  const auto r = last_reply(id);
  EXPECT_EQ(r.status, kFailed);
  EXPECT_EQ(r.error_code, error_code(ReplyError::kDriveError));
  EXPECT_EQ(r.reason, "x-drive (node 5) refused PA=0: instruction data error (0x33)");
  const auto* e = find_event(event_t::ERROR_REPORT);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->code, 0x33);
  EXPECT_EQ(count_sent(5, FC::kSP), 0u);
}

TEST_F(Uim342StackTest, BgWhileDriverOffIsReportedAsDriveError) {
  start_and_set_up();
  const auto id = execute(command(gateway_command_t::ARM_MOVE, {"z"}));
  EXPECT_EQ(last_reply(id).status, kFailed);
  EXPECT_EQ(last_reply(id).reason, "z-drive (node 7) refused BG: BG not allowed while the motor driver is off (0x3E)");
}

TEST_F(Uim342StackTest, StallNotificationFailsTheMoveAndRaisesAStallEvent) {
  start_and_set_up();
  enable({"x", "y"});
  const auto id = execute(command(gateway_command_t::ARM_MOVE, {"x", "y"}));
  ASSERT_EQ(last_reply(id).status, kStarted);
  deliver(drives.at(6).alarm(uim342::AlarmCode::kStall));
  const auto r = last_reply(id);
  EXPECT_EQ(r.status, kFailed);
  EXPECT_EQ(r.error_code, error_code(ReplyError::kAxisFault));
  EXPECT_EQ(r.reason, "y-drive (node 6): motor stall detected (alarm 0x1D)");
  const auto* e = find_event(event_t::STALL);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->severity, kError);
  EXPECT_TRUE(stack->status("y")->fault);
  EXPECT_EQ(stack->status("y")->fault_code, 0x1D);
  // A later in-position of x does not produce a second terminal reply (TearDown checks).
  deliver(drives.at(5).finish_move());

  // FAULT_RESET clears the flags (MS[0]=0).
  const auto reset = execute(command(gateway_command_t::FAULT_RESET, {"y"}));
  EXPECT_EQ(last_reply(reset).status, kDone);
  EXPECT_FALSE(stack->status("y")->fault);
}

TEST_F(Uim342StackTest, FaultResetOfALockedDriveFails) {
  start_and_set_up();
  drives.at(5).locked = true;
  const auto id = execute(command(gateway_command_t::FAULT_RESET, {"x"}));
  EXPECT_EQ(last_reply(id).status, kFailed);
  EXPECT_NE(last_reply(id).reason.find("locked down"), std::string::npos);
}

TEST_F(Uim342StackTest, StopEndsTheMoveAndSendsSt) {
  start_and_set_up();
  enable({"x"});
  const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
  const auto stop = execute(command(gateway_command_t::STOP, {"x"}));
  EXPECT_EQ(last_reply(move).status, kFailed);
  EXPECT_EQ(last_reply(move).error_code, error_code(ReplyError::kStopped));
  EXPECT_EQ(last_reply(stop).status, kDone);
  EXPECT_EQ(count_sent(5, FC::kST), 1u);
  EXPECT_FALSE(drives.at(5).moving());
}

// The coordinator aborts a group whose drive fell silent with one stop naming every axis: the
// offline drive must not keep the others running; the reply fails naming it.
TEST_F(Uim342StackTest, StopNamingAnOfflineDriveStillStopsTheOthers) {
  start_and_set_up();
  enable({"x"});
  drives.at(7).silent = true;
  run_for(milliseconds(400));  // its polls run out of retries
  ASSERT_FALSE(stack->status("z")->online);
  for (const std::int8_t kind : {gateway_command_t::STOP, gateway_command_t::ESTOP}) {
    const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
    run_for(milliseconds(20));
    ASSERT_TRUE(drives.at(5).moving());
    sent.clear();
    const auto stop = execute(command(kind, {"x", "z"}));
    run_for(milliseconds(60));
    EXPECT_EQ(count_sent(5, FC::kST), 1u);
    EXPECT_FALSE(drives.at(5).moving());
    EXPECT_EQ(last_reply(move).status, kFailed);
    EXPECT_EQ(last_reply(stop).status, kFailed);
    EXPECT_EQ(last_reply(stop).error_code, error_code(ReplyError::kAxisOffline));
    EXPECT_EQ(last_reply(stop).reason, "z-drive (node 7) is offline");
  }
}

TEST_F(Uim342StackTest, EstopGoesAheadOfQueuedWorkAndFailsIt) {
  start_and_set_up();
  enable({"x"});
  drives.at(5).silent = true;  // keep the first request outstanding
  const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x"}));
  const auto estop = execute(command(gateway_command_t::ESTOP, {"x"}));
  EXPECT_EQ(last_reply(move).status, kFailed);
  EXPECT_EQ(last_reply(move).reason, "x-drive (node 5) stopped by ESTOP command " + std::to_string(estop));
  drives.at(5).silent = false;
  run_for(milliseconds(60));  // PA is retried, then ST goes out
  EXPECT_EQ(last_reply(estop).status, kDone);
  EXPECT_EQ(count_sent(5, FC::kSP), 0u);
  EXPECT_EQ(count_sent(5, FC::kST), 1u);
  // Like every family after an e-stop, the drive ends with its power stage off: ST, then MO=0.
  const auto x = sent_to(5);
  const auto st = std::find(x.begin(), x.end(), uim342::request::stop());
  ASSERT_NE(st, x.end());
  EXPECT_NE(std::find(st, x.end(), uim342::request::driver_on(false)), x.end()) << "no MO=0 after the ST";
  EXPECT_FALSE(stack->status("x")->enabled);
}

TEST_F(Uim342StackTest, JogLoadsJvAndBegins) {
  start_and_set_up();
  enable({"z"});
  auto jog = command(gateway_command_t::JOG, {"z"});
  jog.axes[0].velocity = -1000;
  jog.axes[0].acceleration = 0;  // keep the drive's AC/DC
  jog.axes[0].deceleration = 0;
  const auto id = execute(jog);
  EXPECT_EQ(statuses_of(id), (std::vector<std::int8_t>{kDone}));
  const auto z = sent_to(7);
  ASSERT_GE(z.size(), 2u);
  EXPECT_EQ(z[z.size() - 2], uim342::request::set_jog_velocity(-1000));
  EXPECT_EQ(z.back(), uim342::request::begin());
}

TEST_F(Uim342StackTest, HomeSetsTheOriginAndSetPositionKeepsAnOffset) {
  start_and_set_up();
  enable({"x"});
  const auto home = execute(command(gateway_command_t::HOME, {"x"}));
  EXPECT_EQ(last_reply(home).status, kDone);
  EXPECT_EQ(count_sent(5, FC::kOG), 1u);
  EXPECT_TRUE(stack->status("x")->homed);
  // x has no `homing:`: zero in place, and the reply says that no switch was searched.
  EXPECT_NE(last_reply(home).reason.find("no switch search"), std::string::npos) << last_reply(home).reason;
  EXPECT_EQ(count_sent(5, FC::kJV), 0u);

  auto set = command(gateway_command_t::SET_POSITION, {"x"});
  set.axes[0].target_counts = 1000;
  const auto id = execute(set);
  EXPECT_EQ(last_reply(id).status, kDone);
  EXPECT_EQ(stack->status("x")->position_counts, 1000);
  auto move = command(gateway_command_t::ARM_MOVE, {"x"});
  move.axes[0].target_counts = 1500;
  const auto m = execute(move);
  EXPECT_EQ(drives.at(5).target(), 500);  // drive counter = position - offset
  deliver(drives.at(5).finish_move());
  EXPECT_EQ(last_reply(m).status, kDone);
  EXPECT_EQ(stack->status("x")->position_counts, 1500);
}

TEST_F(Uim342StackTest, SetOutputsWritesOp1AndRefusesOtherBits) {
  start_and_set_up();
  auto set = command(gateway_command_t::SET_OUTPUTS, {"x"});
  set.axes[0].output_mask = 1;
  set.axes[0].output_value = 1;
  const auto id = execute(set);
  EXPECT_EQ(last_reply(id).status, kDone);
  EXPECT_EQ(sent_to(5).back(), uim342::request::set_outputs(1));
  EXPECT_EQ(stack->status("x")->outputs, 1);
  set = command(gateway_command_t::SET_OUTPUTS, {"x"});
  set.axes[0].output_mask = 2;
  const auto bad = execute(set);
  EXPECT_EQ(last_reply(bad).error_code, error_code(ReplyError::kUnsupported));
}

TEST_F(Uim342StackTest, ParameterReadAndWriteInInstructionTerms) {
  start_and_set_up();
  auto read = command(gateway_command_t::PARAM_READ, {"x"});
  read.param.space = motionlcm::param_t::UIM342_INSTRUCTION;
  read.param.index = 0x10;  // MT
  read.param.subindex = 1;  // working current
  const auto r = execute(read);
  EXPECT_EQ(last_reply(r).status, kDone);
  EXPECT_EQ(last_reply(r).param.value, 20);

  auto write = command(gateway_command_t::PARAM_WRITE, {"x"});
  write.param.space = motionlcm::param_t::UIM342_INSTRUCTION;
  write.param.index = 0x1B;  // SS
  write.param.subindex = -1;
  write.param.value = 1000;
  const auto w = execute(write);
  EXPECT_EQ(last_reply(w).status, kDone);
  EXPECT_EQ(last_reply(w).param.value, 1000);
  EXPECT_EQ(sent_to(5).back(), uim342::request::set_cut_in_speed(1000));

  write = command(gateway_command_t::PARAM_WRITE, {"x"});
  write.param.space = motionlcm::param_t::UIM342_INSTRUCTION;
  write.param.index = 0x10;  // MT[0] = 12: no such micro-step resolution
  write.param.subindex = 0;
  write.param.value = 12;
  const auto bad = execute(write);
  EXPECT_EQ(last_reply(bad).error_code, error_code(ReplyError::kOutsideLimits));

  read.command_id = ++next_id_;
  read.param.space = motionlcm::param_t::CANOPEN_OBJECT;
  const auto wrong_space = execute(read);
  EXPECT_EQ(last_reply(wrong_space).error_code, error_code(ReplyError::kUnsupported));
}

TEST_F(Uim342StackTest, DisarmEndsAnArmedMove) {
  start_and_set_up();
  enable({"x", "y"});
  const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x", "y"}, 5));
  ASSERT_EQ(last_reply(move).status, kArmed);
  const auto disarm = execute(command(gateway_command_t::DISARM, {"x", "y"}, 5));
  EXPECT_EQ(last_reply(move).status, kFailed);
  EXPECT_EQ(last_reply(disarm).status, kDone);
  stack->fire(5, now);
  settle();
  EXPECT_EQ(count_sent(20, FC::kBG), 0u);
}

TEST_F(Uim342StackTest, RefusesUnknownAxesBusyAxesAndEmptyCommands) {
  start_and_set_up();
  enable({"x"});
  EXPECT_EQ(last_reply(execute(command(gateway_command_t::ENABLE, {"q"}))).error_code,
            error_code(ReplyError::kUnknownAxis));
  EXPECT_EQ(last_reply(execute(command(gateway_command_t::ENABLE, {}))).error_code,
            error_code(ReplyError::kMalformedRequest));
  const auto move = execute(command(gateway_command_t::ARM_MOVE, {"x"}, 9));
  EXPECT_EQ(last_reply(execute(command(gateway_command_t::JOG, {"x"}))).error_code, error_code(ReplyError::kAxisBusy));
  EXPECT_EQ(last_reply(execute(command(13 + 50, {"x"}))).error_code, error_code(ReplyError::kUnsupported));
  execute(command(gateway_command_t::DISARM, {"x"}));
  EXPECT_EQ(last_reply(move).status, kFailed);
}

TEST_F(Uim342StackTest, MalformedForeignAndUnexpectedFramesAreIgnoredAndCounted) {
  start_and_set_up();
  // From node 5, an MO ACK with a trailing byte: refused by the codec, consumed, counted.
  EXPECT_TRUE(stack->on_frame(*can::Frame::make(0x05200015, true, std::vector<std::uint8_t>{1, 0}), now));
  EXPECT_EQ(stack->counters().malformed, 1);
  // From node 99 (not configured) and a standard frame: left to other stacks.
  EXPECT_FALSE(stack->on_frame(*uim342::reply_frame(99, {FC::kMO, uim342::Byte{1}}), now));
  EXPECT_EQ(stack->counters().foreign, 1);
  EXPECT_FALSE(stack->on_frame(*can::Frame::make(0x181, false, std::vector<std::uint8_t>{1}), now));
  // A well-formed ACK nobody waited for.
  EXPECT_TRUE(stack->on_frame(*uim342::reply_frame(5, {FC::kMO, uim342::Byte{1}}), now));
  EXPECT_EQ(stack->counters().unexpected, 1);
  motionlcm::bus_stats_t stats{};
  stack->add_statistics(stats);
  EXPECT_EQ(stats.errors, 1);
  EXPECT_TRUE(stack->ready());
}

TEST_F(Uim342StackTest, InputEdgesAndAlarmsBecomeEvents) {
  start_and_set_up();
  deliver(
      *uim342::notification_frame(5, uim342::InputEdgeNotification{uim342::InputPort::kIn2, uim342::Edge::kRising}));
  const auto* edge = find_event(event_t::INPUT_EDGE);
  ASSERT_NE(edge, nullptr);
  EXPECT_EQ(edge->text, "x-drive (node 5): IN2 rising edge");
  EXPECT_EQ(stack->status("x")->inputs, 2);
  deliver(*uim342::notification_frame(7, uim342::AlarmNotification{uim342::AlarmCode::kAboveUpperLimit}));
  EXPECT_TRUE(has_event(event_t::LIMIT, "z"));
  deliver(*uim342::notification_frame(6, uim342::AlarmNotification{uim342::AlarmCode::kEncoderBatteryLow}));
  const auto* battery = find_event(event_t::ALARM);
  ASSERT_NE(battery, nullptr);
  EXPECT_EQ(battery->severity, kWarning);
  EXPECT_FALSE(stack->status("y")->fault);
}

TEST_F(Uim342StackTest, RefusedSetupValueIsAConfigMismatchAndNotReady) {
  drives.at(7).refuse[FC::kMT] = uim342::DriveErrc::kDataError;
  stack->start(now);
  settle();
  EXPECT_FALSE(stack->ready());
  const auto* e = find_event(event_t::CONFIG_MISMATCH);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->text, "z-drive (node 7) refused MT[1]=15: instruction data error (0x33)");
  EXPECT_TRUE(stack->status("z")->online);
}

}  // namespace
}  // namespace motion::gateway

namespace motion::gateway {
namespace {

// x homes on a switch at IN2 (falling edge) toward min; travel 310 mm = 198400 counts.
std::string homing_lab() {
  std::string yaml = kLab;
  const std::string x_axis = "limits: {min: -10, max: 300, velocity: 50, acceleration: 400}}";
  yaml.replace(yaml.find(x_axis), x_axis.size(),
               "limits: {min: -10, max: 300, velocity: 50, acceleration: 400}, homing: {method: switch, input: 2, "
               "velocity: -5}}");
  return yaml;
}

std::vector<uim342::Instruction> without_polls(std::vector<uim342::Instruction> list) {
  std::erase_if(list, [](const uim342::Instruction& i) {
    return i.function == FC::kMS && i.operation == uim342::Operation::kGet &&
           std::get<uim342::Index>(i.body).index == 1;
  });
  return list;
}

TEST_F(Uim342StackTest, HomeOnASwitchArmsTheOriginActionJogsRestoresAndReturnsToTheEdge) {
  build(homing_lab());
  start_and_set_up();
  enable({"x"});
  drives.at(5).inputs = 0x02;  // IN2 high: off the switch
  // The drive's IL[1] before homing (§5.26 example bytes): restored afterwards.
  drives.at(5).handle(*uim342::instruction_frame(
      5, uim342::request::set_input_logic(uim342::InputPort::kIn2,
                                          uim342::EdgeAction{uim342::InputAction::kDecelerateStop, false},
                                          uim342::EdgeAction{})));
  sent.clear();
  auto cmd = command(gateway_command_t::HOME, {"x"});
  cmd.axes[0].velocity = -3200;
  cmd.axes[0].target_counts = 640;  // homing offset 1 mm
  const auto home = execute(cmd);
  run_for(milliseconds(10));
  ASSERT_TRUE(statuses_of(home).empty()) << "HOME must not end before the switch is found";
  ASSERT_TRUE(drives.at(5).moving());
  namespace rq = uim342::request;
  using uim342::EdgeAction;
  using uim342::InputAction;
  const EdgeAction origin{InputAction::kOriginThenDecelerateStop, true};  // 0x86: FG = 1, action 0x06
  const EdgeAction nothing{InputAction::kNone, true};                     // 0x80
  auto x = without_polls(sent_to(5));
  const std::vector<uim342::Instruction> search{rq::get(uim342::MotionStatusIndex::kStatus),
                                                rq::get_input_logic(1),
                                                rq::select_group(uim342::ParameterGroup::kIn2Falling),
                                                rq::set_deceleration(10000),
                                                rq::set_input_logic(uim342::InputPort::kIn2, origin, nothing),
                                                rq::set_jog_velocity(-3200),
                                                rq::set_acceleration(10000),
                                                rq::set_deceleration(10000),
                                                rq::begin()};
  ASSERT_GE(x.size(), search.size());
  EXPECT_EQ(std::vector<uim342::Instruction>(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(search.size())),
            search);
  EXPECT_EQ(count_sent(5, FC::kOG), 0u);  // the origin comes from the switch, not from OG

  // The switch is reached: IN2 falls, the drive zeroes its counter there and stops 12 counts on.
  sent.clear();
  deliver(drives.at(5).origin_action(uim342::InputPort::kIn2, false, -12));
  run_for(milliseconds(100));  // the next MS[0] poll sees it stopped on the switch
  x = without_polls(sent_to(5));
  std::erase_if(x, [](const uim342::Instruction& i) { return i.function == FC::kMS; });
  const std::vector<uim342::Instruction> back{
      rq::set_input_logic(uim342::InputPort::kIn2, EdgeAction{InputAction::kDecelerateStop, false}, EdgeAction{}),
      rq::set_absolute_position(0), rq::set_ptp_speed(3200), rq::begin()};
  EXPECT_EQ(x, back);
  EXPECT_TRUE(statuses_of(home).empty());
  deliver(drives.at(5).finish_move());
  EXPECT_EQ(statuses_of(home), (std::vector<std::int8_t>{kDone}));
  EXPECT_NE(last_reply(home).reason.find("IN2 falling edge"), std::string::npos) << last_reply(home).reason;
  EXPECT_TRUE(stack->status("x")->homed);
  EXPECT_EQ(stack->status("x")->position_counts, 640);
}

TEST_F(Uim342StackTest, HomeStartingOnTheSwitchLeavesItTheOtherWay) {
  build(homing_lab());
  start_and_set_up();
  enable({"x"});
  drives.at(5).inputs = 0x00;  // IN2 low: on the switch
  sent.clear();
  auto cmd = command(gateway_command_t::HOME, {"x"});
  cmd.axes[0].velocity = -3200;
  const auto home = execute(cmd);
  run_for(milliseconds(10));
  const auto x = sent_to(5);
  const uim342::EdgeAction origin{uim342::InputAction::kOriginThenDecelerateStop, true};
  const uim342::EdgeAction nothing{uim342::InputAction::kNone, true};
  EXPECT_NE(std::find(x.begin(), x.end(), uim342::request::set_input_logic(uim342::InputPort::kIn2, nothing, origin)),
            x.end());
  EXPECT_NE(std::find(x.begin(), x.end(), uim342::request::set_jog_velocity(3200)), x.end());
  deliver(drives.at(5).origin_action(uim342::InputPort::kIn2, true, 5));
  run_for(milliseconds(100));
  deliver(drives.at(5).finish_move());
  EXPECT_EQ(last_reply(home).status, kDone);
}

TEST_F(Uim342StackTest, HomeWithoutTheSwitchStopsAndFailsNamingTheInputWithinItsBound) {
  build(homing_lab());
  start_and_set_up();
  enable({"x"});
  drives.at(5).inputs = 0x02;
  auto cmd = command(gateway_command_t::HOME, {"x"});
  cmd.axes[0].velocity = -3200;
  const auto home = execute(cmd);
  // Bound: 198400 counts / 3200 counts/s + 2 x 3200/10000 s of ramps + 2 s = 64.64 s.
  run_for(std::chrono::seconds(64));
  EXPECT_TRUE(statuses_of(home).empty());
  EXPECT_TRUE(drives.at(5).moving());
  sent.clear();
  run_for(std::chrono::seconds(1));
  ASSERT_EQ(statuses_of(home), (std::vector<std::int8_t>{kFailed}));
  const auto reason = last_reply(home).reason;
  EXPECT_NE(reason.find("IN2"), std::string::npos) << reason;
  EXPECT_NE(reason.find("not found"), std::string::npos) << reason;
  EXPECT_FALSE(drives.at(5).moving());  // ST
  EXPECT_EQ(count_sent(5, FC::kST), 1u);
  // IL[1] disarmed: the drive's earlier (factory) value again.
  EXPECT_EQ(drives.at(5).word(FC::kIL, 1), 0);
  EXPECT_FALSE(stack->status("x")->homed);
}

TEST_F(Uim342StackTest, HomeOnASwitchNeedsTheDriverOn) {
  build(homing_lab());
  start_and_set_up();
  const auto home = execute(command(gateway_command_t::HOME, {"x"}));
  EXPECT_EQ(last_reply(home).status, kFailed);
  EXPECT_NE(last_reply(home).reason.find("disabled"), std::string::npos);
  EXPECT_EQ(count_sent(5, FC::kIL), 0u);  // IL with the driver off would go to EEPROM (§5.26)
}

}  // namespace
}  // namespace motion::gateway
