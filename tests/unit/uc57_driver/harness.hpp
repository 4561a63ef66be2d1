// Test bench for Uc57Stack: a configuration with two UC57 drives (a-drive node 1, b-drive node 2)
// and a UIM342 drive on one CAN bus, fake nodes, a virtual clock, and everything the stack reports.
// Frames travel through queues (never re-entrantly) as on a real bus.
// Thread contract: single-threaded test code.
#pragma once

#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>

#include "fake_uc57.hpp"
#include "motion/config/config.hpp"
#include "motion/uc57_driver/uc57_stack.hpp"

namespace motion::uc57_driver::testing {

inline constexpr const char* kLabYaml = R"(
buses:
  - {name: can0, transport: simcan:can0, bitrate: 1000000, request_timeout_ms: 50, retries: 2, poll_hz: 20}
drives:
  - {name: x-drive, family: uim342, bus: can0, node_id: 5}
  - {name: a-drive, family: uc57, bus: can0, node_id: 1, setup: {micro_steps: 16, current_a: 2.0, tpdo_mode: sync}}
  - {name: b-drive, family: uc57, bus: can0, node_id: 2, setup: {micro_steps: 16, current_a: 2.0, tpdo_mode: sync}}
axes:
  - {name: x, drive: x-drive, steps_per_unit: 640, limits: {min: -10, max: 300, velocity: 50, acceleration: 400}}
  - {name: a, drive: a-drive, unit: deg, steps_per_unit: 8.888888888888889,
     limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}, homing: {method: switch, input: 2, velocity: 20}}
  - {name: b, drive: b-drive, unit: deg, steps_per_unit: 8.888888888888889,
     limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}}
)";

inline constexpr std::int64_t kWallOffsetUs = 1'700'000'000'000'000;

class Bench : public gateway::GatewayOutput {
 public:
  // `edit` changes the loaded configuration before the stack is built (e.g. a set-up value the
  // loader would refuse, to test the stack's own check).
  // `kernel_sync`: the context offers a cyclic sender (start_cyclic...), simulated below.
  explicit Bench(const std::string& yaml = kLabYaml, const std::function<void(config::Config&)>& edit = {},
                 bool kernel_sync = false) {
    auto loaded = config::load_string(yaml, "bench.yaml");
    if (!loaded.ok()) throw std::runtime_error(loaded.error_text());
    config_ = *loaded.config;
    if (edit) edit(config_);
    nodes.push_back(std::make_unique<FakeUc57>(1));
    nodes.push_back(std::make_unique<FakeUc57>(2));
    gateway::CanStackContext context;
    context.out = this;
    context.send = [this](const can::Frame& frame) {
      sent.push_back(frame);
      wire.push_back(frame);
      wire_log.push_back(can::to_cansend(frame));
      return true;
    };
    if (kernel_sync) {
      context.start_cyclic = [this](const can::Frame& frame, Duration interval) {
        kernel_job = KernelJob{frame, interval, now + interval};
        wire_log.emplace_back("BCM start");
        kernel_send(frame);  // TX_ANNOUNCE: the first frame at once
        return true;
      };
      context.stop_cyclic = [this](const can::Frame&) {
        kernel_job.reset();
        wire_log.emplace_back("BCM stop");
      };
      context.retime_cyclic = [this](const can::Frame&, Duration interval) {
        if (!kernel_job) return false;
        kernel_job->interval = interval;
        return true;
      };
    }
    Uc57Stack::Options options;
    options.wall_clock_us = [](TimePoint t) {
      return kWallOffsetUs + std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
    };
    stack = std::make_unique<Uc57Stack>(config_, config_.buses.front(), context, options);
  }

  FakeUc57& node(int id) { return *nodes.at(static_cast<std::size_t>(id - 1)); }

  // Frames from the fakes to the stack (a real bus delivers them later than they were caused).
  void deliver(const std::vector<can::Frame>& frames) {
    for (const auto& frame : frames) {
      if (!stack->on_frame(frame, now)) ++unclaimed;
    }
  }

  void settle() {
    while (!wire.empty() || !kernel_echoes.empty()) {
      if (!wire.empty()) {
        const can::Frame frame = wire.front();
        wire.pop_front();
        for (auto& fake : nodes) deliver(fake->on_frame(frame, now));
        continue;
      }
      const can::Frame echo = kernel_echoes.front();
      kernel_echoes.pop_front();
      stack->on_cyclic_sent(echo, now);
    }
  }

  // Advances virtual time to `now + span`, serving every deadline of the stack and the fakes.
  void run_for(Duration span) {
    const TimePoint end = now + span;
    for (;;) {
      if (kernel_job && kernel_job->next <= now) {
        kernel_send(kernel_job->frame);
        kernel_job->next += kernel_job->interval;
      }
      settle();
      TimePoint next = stack->process(now);
      settle();
      for (auto& fake : nodes) {
        deliver(fake->tick(now));
        next = std::min(next, fake->next_tick());
      }
      settle();
      if (kernel_job) next = std::min(next, kernel_job->next);
      if (now >= end) break;
      next = std::min(std::max(next, now + std::chrono::microseconds(100)), end);
      now = next;
    }
  }

  void start() {
    stack->start(now);
    run_for(std::chrono::milliseconds(1));
  }
  void start_ready() {
    start();
    run_for(std::chrono::seconds(1));
    ASSERT_TRUE(stack->ready());
  }

  motionlcm::gateway_command_t command(std::int8_t kind, const std::vector<std::string>& axes,
                                       std::int64_t trigger_id = 0) {
    motionlcm::gateway_command_t c{};
    c.command_id = ++last_command_id;
    c.kind = kind;
    c.trigger_id = trigger_id;
    for (auto& name : axes) {
      motionlcm::axis_command_t a{};
      a.axis = name;
      c.axes.push_back(a);
    }
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    return c;
  }
  void execute(const motionlcm::gateway_command_t& c) {
    stack->execute(c, now);
    settle();
  }

  // Replies of one command.
  std::vector<motionlcm::gateway_reply_t> replies_of(std::int64_t id) const {
    std::vector<motionlcm::gateway_reply_t> out;
    for (const auto& r : replies) {
      if (r.command_id == id) out.push_back(r);
    }
    return out;
  }
  std::size_t terminal_count(std::int64_t id) const {
    std::size_t count = 0;
    for (const auto& r : replies_of(id)) {
      if (r.status == motionlcm::gateway_reply_t::DONE || r.status == motionlcm::gateway_reply_t::FAILED) ++count;
    }
    return count;
  }
  bool has_event(std::int16_t kind) const {
    return std::any_of(events.begin(), events.end(), [kind](const auto& e) { return e.second.kind == kind; });
  }

  // GatewayOutput
  void axis_status(const std::string& axis, const gateway::DriveStatus& status) override {
    statuses[axis] = status;
    status_log.emplace_back(axis, status);
  }
  void axis_event(const std::string& axis, const gateway::DriveEvent& event) override {
    events.emplace_back(axis, event);
  }
  void command_reply(motionlcm::gateway_reply_t reply) override {
    replies.push_back(std::move(reply));
    replied_after.push_back(status_log.size());
  }

  // The kernel's cyclic job (kernel_sync benches): a CAN_BCM job without latency. Its frames go
  // on the wire and come back to the stack (on_cyclic_sent) as the kernel loops them back.
  struct KernelJob {
    can::Frame frame;
    Duration interval{};
    TimePoint next = kNever;
  };
  void kernel_send(const can::Frame& frame) {
    sent.push_back(frame);
    wire.push_back(frame);
    kernel_echoes.push_back(frame);
    wire_log.push_back("BCM " + can::to_cansend(frame));
  }
  std::optional<KernelJob> kernel_job;
  std::deque<can::Frame> kernel_echoes;
  // Every frame sent, in order, as cansend text; the kernel's as "BCM 080#", with "BCM start" /
  // "BCM stop" where its job started and stopped.
  std::vector<std::string> wire_log;

  config::Config config_;
  std::vector<std::unique_ptr<FakeUc57>> nodes;
  std::unique_ptr<Uc57Stack> stack;
  TimePoint now = TimePoint{} + std::chrono::seconds(10);
  std::vector<can::Frame> sent;
  std::deque<can::Frame> wire;
  std::size_t unclaimed = 0;
  std::map<std::string, gateway::DriveStatus> statuses;                  // the latest per axis
  std::vector<std::pair<std::string, gateway::DriveStatus>> status_log;  // every one, in order
  std::vector<std::pair<std::string, gateway::DriveEvent>> events;
  std::vector<motionlcm::gateway_reply_t> replies;
  std::vector<std::size_t> replied_after;  // per reply: how many statuses had gone out before it
  std::int64_t last_command_id = 100;
};

}  // namespace motion::uc57_driver::testing
