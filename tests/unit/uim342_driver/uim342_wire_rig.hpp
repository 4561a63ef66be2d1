// The wire rig of the Uim342Stack tests on a bit-timed wire (uim342_poll_test.cpp,
// uim342_power_test.cpp): the shared bit-timed loop (../common/can_wire_loop.hpp) between the
// stack and simulated UIM342 drives (sim::Uim342Drive, answering at once), on a simulated clock.
// Thread contract: single-threaded test code.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "../common/can_wire_loop.hpp"
#include "motion/can_frame/bit_timing.hpp"
#include "motion/config/config.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/simbus/bus.hpp"
#include "motion/uim342/uim342.hpp"
#include "motion/uim342_driver/uim342_stack.hpp"

namespace motion::gateway::test {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using std::chrono::microseconds;
using std::chrono::milliseconds;
using FC = uim342::FunctionCode;

constexpr std::uint32_t kBitrate = 1'000'000;
// Copies of LCM constants (never ODR-use the generated in-class constants).
constexpr std::int8_t kDone = gateway_reply_t::DONE;
constexpr std::int8_t kFailed = gateway_reply_t::FAILED;
constexpr std::int8_t kEnable = gateway_command_t::ENABLE;

class Recorder final : public GatewayOutput {
 public:
  void axis_status(const std::string& axis, const DriveStatus&) override { ++updates[axis]; }
  void axis_event(const std::string& axis, const DriveEvent& event) override { events.emplace_back(axis, event); }
  void position_lost(const std::string& axis, const std::string& why) override { lost.emplace_back(axis, why); }
  void command_reply(gateway_reply_t reply) override { replies.push_back(std::move(reply)); }
  [[nodiscard]] std::int64_t total_updates() const {
    std::int64_t n = 0;
    for (const auto& [axis, count] : updates) n += count;
    return n;
  }
  std::map<std::string, std::int64_t> updates;
  std::vector<gateway_reply_t> replies;
  std::vector<std::pair<std::string, DriveEvent>> events;
  std::vector<std::pair<std::string, std::string>> lost;  // position_lost(axis, why)
};

// A frame as it went over the wire.
struct OnWire {
  can::Frame frame;
  TimePoint end_of_frame;
  bool ours = false;  // sent by the stack
  std::uint32_t bitrate = kBitrate;
  [[nodiscard]] bool is_poll() const {
    const auto m = uim342::decode_can(frame);
    return m && m->message.function_code() == uim342::code(FC::kMS);
  }
  [[nodiscard]] TimePoint start() const {
    return end_of_frame - can::bits_duration(can::frame_bits(frame).to_end_of_frame(), bitrate);
  }
};

// The stack and `drives` simulated UIM342 (node ids 5...) on one bit-timed 1 Mbit/s wire.
class WireRig final : public motion::testing::CanWireLoop<Uim342Stack, OnWire> {
 public:
  WireRig(int drives, int poll_hz) : CanWireLoop(kBitrate, 4096) {
    std::string yaml = fmt::format(
        "buses:\n  - {{name: can0, transport: \"simcan:can0\", bitrate: {}, request_timeout_ms: 50, retries: 2, "
        "poll_hz: {}}}\ndrives:\n",
        kBitrate, poll_hz);
    for (int n = 0; n < drives; ++n)
      yaml += fmt::format("  - {{name: d{0}, family: uim342, bus: can0, node_id: {1}}}\n", n, 5 + n);
    yaml += "axes:\n";
    for (int n = 0; n < drives; ++n)
      yaml += fmt::format(
          "  - {{name: a{0}, drive: d{0}, unit: mm, steps_per_unit: 640, limits: {{min: -10, max: 10, velocity: 5, "
          "acceleration: 50}}}}\n",
          n);
    auto loaded = config::load_string(yaml, "poll.yaml");
    EXPECT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
    CanStackContext ctx;
    ctx.out = &out;
    ctx.send = [this](const can::Frame& f) { return send(f); };
    stack = std::make_unique<Uim342Stack>(config_, "can0", ctx);
    const auto factory = sim::uim342_factory(config_);
    for (const auto& d : config_.drives) {
      endpoints_[d.node_id] = attach_drive(d.name, [&](simbus::EndpointId endpoint) {
        sim::SimDriveContext context;
        context.drive = d.name;
        context.bus = d.bus;
        context.send = [this, endpoint, name = d.name](const can::Frame& f) {
          if (silent.contains(name)) return;
          EXPECT_FALSE(bus_.submit(endpoint, f, now));
        };
        context.report = [](std::int8_t, std::int64_t, std::int64_t, std::int64_t) {};
        return factory(d, context);
      });
    }
    power_up_drives();
  }

  void start() {
    stack->start(now);
    ASSERT_TRUE(run_until([&] { return stack->ready(); }, std::chrono::seconds(10))) << "never ready";
  }
  std::int64_t execute(std::int8_t kind, const std::string& axis) {
    gateway_command_t c{};
    c.bus = "can0";
    c.command_id = ++next_id_;
    c.kind = kind;
    motionlcm::axis_command_t a{};
    a.axis = axis;
    c.axes.push_back(a);
    c.num_axes = 1;
    stack->execute(c, now);
    return c.command_id;
  }
  [[nodiscard]] std::optional<gateway_reply_t> terminal(std::int64_t id) const {
    for (const auto& r : out.replies) {
      if (r.command_id == id && (r.status == kDone || r.status == kFailed)) return r;
    }
    return std::nullopt;
  }

  // Cuts and restores the power of drive `node` (sim_control_t::POWER_CYCLE): what the simulated
  // drive does at power-up.
  void power_cycle(int node) { drives_.at(endpoints_.at(node))->power_up(now); }

  Recorder out;
  std::set<std::string> silent;  // drives whose frames never reach the wire

 private:
  void stuck() override { ADD_FAILURE() << "the rig does not advance"; }
  config::Config config_;
  std::map<int, simbus::EndpointId> endpoints_;  // by node id
  std::int64_t next_id_ = 0;
};

}  // namespace motion::gateway::test
