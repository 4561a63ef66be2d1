// The bench of the AdamStack tests (adam_stack_test.cpp, adam_sync_test.cpp, adam_power_test.cpp):
// AdamStack (the ADAM Modbus RTU master, passive) whose every frame is recorded, replies scripted
// bytes or from motion::adam::serve() over fake register banks (or other banks, e.g. simulated
// drives), and time that only moves when the test says so. Single-threaded test code.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <motionlcm/event_t.hpp>

#include "motion/adam/commands.hpp"
#include "motion/adam/slave.hpp"
#include "motion/adam/status.hpp"
#include "motion/adam_driver/adam_stack.hpp"

namespace motion::adam_driver::test {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;
using Command = motionlcm::gateway_command_t;
using Reply = motionlcm::gateway_reply_t;

// LCM constants wrapped so that no test ODR-uses them.
constexpr std::int8_t kDone = std::int8_t{Reply::DONE};
constexpr std::int8_t kFailed = std::int8_t{Reply::FAILED};
constexpr std::int8_t kArmed = std::int8_t{Reply::ARMED};
constexpr std::int8_t kStarted = std::int8_t{Reply::STARTED};

inline std::string hex(const Bytes& b) {
  std::string s;
  char part[4];
  for (const auto byte : b) {
    std::snprintf(part, sizeof part, "%02X ", byte);
    s += part;
  }
  if (!s.empty()) s.pop_back();
  return s;
}
inline Bytes with_crc(Bytes b) {
  adam::rtu::append_crc(b);
  return b;
}

struct Recorder final : gateway::GatewayOutput {
  std::vector<std::pair<std::string, gateway::DriveStatus>> statuses;
  std::vector<gateway::DriveEvent> events;
  std::vector<Reply> replies;
  std::vector<std::string> lost;  // position_lost: why
  void position_lost(const std::string&, const std::string& why) override { lost.push_back(why); }
  void axis_status(const std::string& axis, const gateway::DriveStatus& s) override { statuses.emplace_back(axis, s); }
  void axis_event(const std::string&, const gateway::DriveEvent& e) override { events.push_back(e); }
  void command_reply(Reply r) override { replies.push_back(std::move(r)); }
  [[nodiscard]] std::vector<Reply> of(std::int64_t id) const {
    std::vector<Reply> out;
    std::copy_if(replies.begin(), replies.end(), std::back_inserter(out),
                 [id](const Reply& r) { return r.command_id == id; });
    return out;
  }
  [[nodiscard]] int terminal(std::int64_t id) const {
    const auto all = of(id);
    return static_cast<int>(
        std::count_if(all.begin(), all.end(), [](const Reply& r) { return r.status == kDone || r.status == kFailed; }));
  }
  [[nodiscard]] bool has_event(std::int16_t kind) const {
    return std::any_of(events.begin(), events.end(), [kind](const auto& e) { return e.kind == kind; });
  }
};

// A drive for the fake line: registers, and instant motion on the commands the driver uses.
struct FakeDrive final : adam::RegisterBank {
  std::vector<std::uint16_t> regs = std::vector<std::uint16_t>(0x10000, 0);
  bool completes_moves = true;
  FakeDrive() {
    regs[0x0024] = 4000;    // subdivision 4000 pulses/rev
    regs[0x0006] = 0x1000;  // X12 in position, idle
  }
  void set_position(std::int32_t p) {
    const auto w = adam::encode32(p);
    regs[4] = w[0];
    regs[5] = w[1];
  }
  [[nodiscard]] std::int32_t position() const { return adam::decode32_signed(regs[4], regs[5]); }
  void set_moving(bool moving) { regs[6] = moving ? 0x0300 : 0x1000; }
  std::optional<adam::rtu::ExceptionCode> read(std::uint16_t start, std::span<std::uint16_t> out) override {
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = regs[start + i];
    return std::nullopt;
  }
  std::optional<adam::rtu::ExceptionCode> write(std::uint16_t start, std::span<const std::uint16_t> values) override {
    for (std::size_t i = 0; i < values.size(); ++i) regs[start + i] = values[i];
    const auto move_to = [&](std::int32_t target) {
      if (completes_moves)
        set_position(target);
      else
        set_moving(true);
    };
    if (start == 0x00DD) {  // execute table entry 0 (absolute) at 300 + 0x00AC
      const std::uint32_t at = 300U + regs[0x00AC];
      move_to(adam::decode32_signed(regs[at], regs[at + 1]));
    }
    if (start == 0x00D0) move_to(adam::decode32_signed(regs[0xD0], regs[0xD1]));
    if (start == 0x00C8) set_moving(false);  // stop
    return std::nullopt;
  }
};

inline DriveSettings drive(const std::string& name, const std::string& axis, std::uint8_t unit) {
  DriveSettings d;
  d.drive = name;
  d.axis = axis;
  d.unit = unit;
  d.request_timeout = 100ms;
  d.retries = 1;
  d.homing_method = config::HomingMethod::kSwitch;
  return d;
}

class AdamStackTest : public ::testing::Test {
 protected:
  // `egress`: the line's egress latency (bus key egress_latency_us).
  explicit AdamStackTest(std::vector<DriveSettings> drives = {drive("c-drive", "c", 1)}, Duration egress = {}) {
    MasterSettings s;
    s.bus = "rs485";
    s.transport = "simserial:rs485";
    s.poll_period = 100ms;
    s.egress_latency = egress;
    s.drives = std::move(drives);
    core = std::make_unique<AdamStack>(
        s,
        [this](std::span<const std::uint8_t> b) {
          sent.emplace_back(b.begin(), b.end());
          return true;
        },
        out, [](TimePoint t) {  // wall clock = the steady time's microseconds
          return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
        });
  }
  void advance(Duration dt) {
    now += dt;
    core->process(now);
  }
  void reply(const Bytes& bytes) {
    now += 1ms;
    core->on_bytes(bytes, now);
    core->process(now);
  }
  // Answers every frame sent so far (and those the answers cause) from the fake drives.
  void serve_pending() {
    while (answered < sent.size()) {
      const Bytes frame = sent[answered++];
      for (auto& [unit, bank] : banks) {
        const auto result = adam::serve(frame, adam::SlaveConfig{unit, {}, adam::ExceptionMode::kStandard}, bank);
        if (!result.reply.empty()) reply(result.reply);
      }
      for (auto& [unit, bank] : other_banks) {
        if (silent.contains(unit)) continue;
        if (before_serving) before_serving();
        const auto result = adam::serve(frame, adam::SlaveConfig{unit, {}, adam::ExceptionMode::kStandard}, *bank);
        if (!result.reply.empty()) reply(result.reply);
      }
    }
  }
  // Lets `total` pass in 1 ms steps, the fake drives answering everything.
  void run_for(Duration total) {
    for (Duration t{}; t < total; t += 1ms) {
      serve_pending();
      advance(1ms);
    }
    serve_pending();
  }
  [[nodiscard]] bool was_sent(const std::string& frame) const {
    return std::any_of(sent.begin(), sent.end(), [&](const Bytes& b) { return hex(b) == frame; });
  }
  static Command command(std::int64_t id, std::int8_t kind, const std::vector<std::string>& axes) {
    Command c{};
    c.command_id = id;
    c.kind = kind;
    for (auto& a : axes) {
      motionlcm::axis_command_t ac{};
      ac.axis = a;
      c.axes.push_back(ac);
    }
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    return c;
  }

  static Command arm(std::int64_t id, std::int64_t trigger, std::vector<std::pair<std::string, std::int64_t>> targets) {
    std::vector<std::string> names;
    names.reserve(targets.size());
    for (auto& [axis, target] : targets) names.push_back(axis);
    Command c = command(id, std::int8_t{Command::ARM_MOVE}, names);
    c.trigger_id = trigger;
    for (std::size_t i = 0; i < targets.size(); ++i) {
      c.axes[i].target_counts = targets[i].second;
      c.axes[i].velocity = 8000;  // 120 rpm at 4000 pulses/rev
      c.axes[i].acceleration = 16000;
      c.axes[i].deceleration = 16000;
    }
    return c;
  }

  TimePoint now = TimePoint{} + 10s;
  Recorder out;
  std::vector<Bytes> sent;
  std::size_t answered = 0;
  std::map<std::uint8_t, FakeDrive> banks;
  std::map<std::uint8_t, adam::RegisterBank*> other_banks;  // served too, unless their unit is silent
  std::set<std::uint8_t> silent;
  std::function<void()> before_serving;  // called before one of other_banks serves a frame
  std::unique_ptr<AdamStack> core;
};

}  // namespace motion::adam_driver::test
