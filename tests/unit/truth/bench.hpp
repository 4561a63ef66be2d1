// Test bench of test_hardware_truth: a gateway's serial line core (SerialStack) and the
// simulated far end of its line (SerialDeviceSim) joined by a zero-latency wire, time advanced by
// hand, the core's replies and events recorded, the simulator's reports kept as ground truth.
// Thread contract: single-threaded test code.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "motion/config/config.hpp"
#include "motion/gateway/bus_driver.hpp"
#include "motion/gateway/serial_stack.hpp"
#include "motion/sim/serial_device_sim.hpp"

namespace motion::truth {

// Copies of LCM constants (never ODR-use the generated in-class constants).
inline constexpr std::int8_t kDone = motionlcm::gateway_reply_t::DONE;
inline constexpr std::int8_t kFailed = motionlcm::gateway_reply_t::FAILED;
inline constexpr std::int8_t kStarted = motionlcm::sim_report_t::MOTION_STARTED;
inline constexpr std::int8_t kFinished = motionlcm::sim_report_t::MOTION_FINISHED;

class Recorder final : public gateway::GatewayOutput {
 public:
  void axis_status(const std::string&, const gateway::DriveStatus&) override {}
  void axis_event(const std::string& axis, const gateway::DriveEvent& event) override {
    events.emplace_back(axis, event);
  }
  void command_reply(motionlcm::gateway_reply_t reply) override { replies.push_back(std::move(reply)); }
  [[nodiscard]] std::optional<motionlcm::gateway_reply_t> terminal(std::int64_t id) const {
    for (const auto& r : replies) {
      if (r.command_id == id && (r.status == kDone || r.status == kFailed)) return r;
    }
    return std::nullopt;
  }
  [[nodiscard]] std::string event_text(std::int16_t kind) const {
    std::string out;
    for (const auto& e : events) {
      if (e.second.kind == kind) out += e.second.text + "\n";
    }
    return out;
  }
  std::vector<std::pair<std::string, gateway::DriveEvent>> events;
  std::vector<motionlcm::gateway_reply_t> replies;
};

struct Report {
  std::string drive;
  std::int8_t kind = 0;
  TimePoint at{};
  std::int64_t frame_utime = 0;  // the triggering frame's time, or a motion's end
  std::int64_t position = 0;
  std::int64_t target = 0;
};

class SerialBench {
 public:
  // `make_core` builds the core with the bench's send function and recorder.
  using CoreFactory = std::function<std::unique_ptr<gateway::SerialStack>(
      std::function<void(std::span<const std::uint8_t>)> send, gateway::GatewayOutput& out)>;

  SerialBench(const std::string& yaml, const std::string& bus, const sim::SerialDeviceFactory& sim_factory) {
    auto loaded = config::load_string(yaml, "truth.yaml");
    EXPECT_TRUE(loaded.ok()) << loaded.error_text();
    config = std::make_unique<config::Config>(*loaded.config);
    sim::SerialDeviceContext context;
    context.bus = bus;
    context.send = [this](std::span<const std::uint8_t> bytes, Duration delay) {
      if (mute && mute(bytes)) return;  // a muted sender hears but is not heard
      to_core.push_back({now + delay, std::vector<std::uint8_t>(bytes.begin(), bytes.end())});
    };
    context.report = [this](const std::string& drive, std::int8_t kind, std::int64_t utime, std::int64_t position,
                            std::int64_t target) {
      reports.push_back({drive, kind, now, utime, position, target});
    };
    context.utime_of = [](TimePoint t) {
      return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
    };
    device = sim_factory(*config, *config->find_bus(bus), context);
    device->power_up(now);
  }

  void attach(const CoreFactory& make_core) {
    core = make_core(
        [this](std::span<const std::uint8_t> bytes) {
          to_device.emplace_back(bytes.begin(), bytes.end());
          sent_at.push_back(now);
          sent.insert(sent.end(), bytes.begin(), bytes.end());
        },
        out);
    core->start(now);
    settle();
  }

  // Delivers what is on the wire at `now`, back and forth until nothing moves; whether anything did.
  bool settle() {
    bool any = false;
    for (int guard = 0; guard < 10000; ++guard) {
      bool moved = false;
      while (!to_device.empty()) {
        const auto bytes = std::move(to_device.front());
        to_device.pop_front();
        device->receive(bytes, now);
        moved = true;
      }
      std::stable_sort(to_core.begin(), to_core.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      while (!to_core.empty() && to_core.front().first <= now) {
        const auto bytes = std::move(to_core.front().second);
        to_core.pop_front();
        core->on_bytes(bytes, now);
        moved = true;
      }
      if (!moved) return any;
      any = true;
    }
    return any;
  }

  void run_for(Duration span) {
    const auto end = now + span;
    while (true) {
      // Bytes written by a process() reach the far end at the same `now` (a zero-latency wire).
      TimePoint next = std::min(core->process(now), device->process(now));
      for (int guard = 0; guard < 1000 && settle(); ++guard) next = std::min(core->process(now), device->process(now));
      if (!to_core.empty()) next = std::min(next, to_core.front().first);
      if (next > end) break;
      now = std::max(next, now + std::chrono::microseconds(10));
    }
    now = end;
  }
  bool run_until(const std::function<bool()>& done, Duration limit) {
    for (Duration spent{}; spent < limit; spent += std::chrono::milliseconds(5)) {
      if (done()) return true;
      run_for(std::chrono::milliseconds(5));
    }
    return done();
  }
  std::int64_t execute(motionlcm::gateway_command_t c) {
    c.command_id = ++next_id;
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    core->execute(c, now);
    settle();
    return c.command_id;
  }
  // Runs until command `id` ends; its terminal reply (FAILED with a reason when it never ended).
  motionlcm::gateway_reply_t finish(std::int64_t id, Duration limit = std::chrono::seconds(10)) {
    run_until([&] { return out.terminal(id).has_value(); }, limit);
    if (auto r = out.terminal(id)) return *r;
    motionlcm::gateway_reply_t none{};
    none.status = kFailed;
    none.reason = "no terminal reply";
    return none;
  }
  // The start_mechanism of command `id`'s STARTED reply ("" when none).
  [[nodiscard]] std::string mechanism_of(std::int64_t id) const {
    for (const auto& r : out.replies) {
      if (r.command_id == id && r.status == motionlcm::gateway_reply_t::STARTED) return r.start_mechanism;
    }
    return {};
  }
  [[nodiscard]] std::vector<Report> reports_of(const std::string& drive, std::int8_t kind) const {
    std::vector<Report> r;
    std::copy_if(reports.begin(), reports.end(), std::back_inserter(r),
                 [&](const Report& x) { return x.drive == drive && x.kind == kind; });
    return r;
  }

  std::unique_ptr<config::Config> config;  // the core keeps pointers into it
  Recorder out;
  std::unique_ptr<sim::SerialDeviceSim> device;
  std::unique_ptr<gateway::SerialStack> core;
  std::vector<Report> reports;
  std::deque<std::vector<std::uint8_t>> to_device;
  std::vector<TimePoint> sent_at;  // when the core wrote each piece
  std::vector<std::uint8_t> sent;  // every byte the core wrote, in order
  // What the far end sends and the core never gets (empty: everything arrives).
  std::function<bool(std::span<const std::uint8_t>)> mute;
  std::deque<std::pair<TimePoint, std::vector<std::uint8_t>>> to_core;
  TimePoint now = TimePoint{} + std::chrono::seconds(10);
  std::int64_t next_id = 0;
};

inline motionlcm::axis_command_t axis_move(const std::string& axis, std::int64_t target, double velocity,
                                           double acceleration) {
  motionlcm::axis_command_t a{};
  a.axis = axis;
  a.target_counts = target;
  a.velocity = velocity;
  a.acceleration = acceleration;
  a.deceleration = acceleration;
  return a;
}

inline motionlcm::gateway_command_t command(std::int8_t kind, const std::string& bus,
                                            std::vector<motionlcm::axis_command_t> axes, std::int64_t trigger_id = 0) {
  motionlcm::gateway_command_t c{};
  c.kind = kind;
  c.bus = bus;
  c.trigger_id = trigger_id;
  c.axes = std::move(axes);
  return c;
}

}  // namespace motion::truth
