// The bench of the Uim342Stack tests (uim342_startup_test.cpp, uim342_commands_test.cpp,
// uim342_homing_test.cpp): Uim342Stack driven with explicit `now` values, a fake send sink that
// records every frame, fake drives that answer with codec-encoded replies, a fake GatewayOutput
// that records replies, status and events. Every test checks that each command ended in exactly
// one terminal reply. Thread contract: single-threaded test code.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <motionlcm/event_t.hpp>

#include "fake_drive.hpp"
#include "motion/uim342_driver/uim342_stack.hpp"

namespace motion::gateway::test {

using motionlcm::event_t;
using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using std::chrono::milliseconds;
using FC = uim342::FunctionCode;

// x and y share group 20, z has none (as in config/sim-lab.yaml).
inline constexpr const char* kLab = R"(
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

inline constexpr std::int64_t kEpochUs = 1'700'000'000'000'000;

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

  gateway_command_t command(std::int8_t kind, const std::vector<std::string>& axes, std::int64_t trigger_id = 0) {
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
  std::int64_t enable(const std::vector<std::string>& axes) {
    return execute(command(gateway_command_t::ENABLE, axes));
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

}  // namespace motion::gateway::test
