// The gateway's command handling on a CAN bus fed command sequences: the UIM342 and UC57 stacks
// (their execute(), fire(), frames and timers) with simulated drives on one bus, on a manual
// clock; the three UIM342 share group 20, so moves of two of them hold the third at PR=0. Each command passes the gateway's own check against the axis limits first
// (check_axis_command), as in the gateway; then commands of every kind with edge values (zero,
// one count, beyond the limits, huge), triggers, DISARMs, stops, and faults of the wire (frames
// lost, a drive that falls silent for a while), in any order.
//
// Checked while it runs: a command never gets a second terminal reply, a reply never names a
// command that was not given, and the stacks' ledgers never refuse a transition (a refused one is
// a stack asking for a lifecycle step the ledger's table does not have). Checked at the end, with
// the wire healthy again, every trigger fired, every axis stopped and time run out: every command
// has had its one terminal reply and no simulated drive is still moving. A violation aborts.
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "fuzz_targets.hpp"
#include "motion/config/config.hpp"
#include "motion/core/log.hpp"
#include "motion/gateway/axis_limits.hpp"
#include "motion/gateway/can_bus_driver.hpp"
#include "motion/sim/uc57_drive.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/uc57_driver/uc57_stack.hpp"
#include "motion/uim342_driver/uim342_stack.hpp"

namespace motion::fuzz {
namespace {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;

constexpr const char* kBus = R"(
buses:
  - {name: can0, transport: simcan:can0, bitrate: 1000000, request_timeout_ms: 50, retries: 2, poll_hz: 20}
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5, group_id: 20}
  - {name: yd, family: uim342, bus: can0, node_id: 6, group_id: 20}
  - {name: zd, family: uim342, bus: can0, node_id: 7, group_id: 20}
  - {name: ad, family: uc57, bus: can0, node_id: 1, setup: {micro_steps: 16, current_a: 2.0, tpdo_mode: sync}}
axes:
  - {name: x, drive: xd, steps_per_unit: 100, limits: {min: -100, max: 100, velocity: 50, acceleration: 500},
     homing: {method: switch, input: 1, velocity: 5}}
  - {name: y, drive: yd, steps_per_unit: 100, limits: {min: -100, max: 100, velocity: 50, acceleration: 500}}
  - {name: z, drive: zd, steps_per_unit: 100, limits: {min: -100, max: 100, velocity: 50, acceleration: 500}}
  - {name: a, drive: ad, unit: deg, steps_per_unit: 8.888888888888889,
     limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}, homing: {method: switch, input: 2, velocity: 20}}
simulation:
  home_switches: {xd: 50, ad: -89}
)";
constexpr std::int64_t kWallStartUs = 1'700'000'000'000'000;
constexpr TimePoint kStart = TimePoint{} + std::chrono::hours(1000);

const config::Config& bus_config() {
  static const bool logging = motion::log::init("can_bus_sequences", std::getenv("FUZZ_VERBOSE") ? "info" : "off");
  (void)logging;
  static const config::Config config = *config::load_string(kBus, "can_bus_sequences").config;
  return config;
}

[[noreturn]] void violated(const std::string& what) {
  std::fprintf(stderr, "can_bus_sequences: %s\n", what.c_str());
  std::abort();
}

bool is_terminal(std::int8_t status) { return status == gateway_reply_t::DONE || status == gateway_reply_t::FAILED; }

// Counts that matter for a move, a jog speed or a ramp: zero, one, typical, at and beyond limits.
std::int64_t edge_counts(Input& in) {
  static constexpr std::array<std::int64_t, 12> kCounts{0,    1,      -1,      2,      100,  -100,
                                                        3200, 10'000, -10'000, 10'001, 6400, 64};
  const std::uint8_t b = in.byte();
  if (b < 230) return kCounts[b % kCounts.size()];
  return static_cast<std::int64_t>(static_cast<std::int16_t>(in.u16())) * (b % 2 == 0 ? 1 : 7);
}
double edge_rate(Input& in) {
  static constexpr std::array<double, 10> kRates{0.0,      1.0,      0.5, 100.0,  5000.0,
                                                 12'800.0, 50'000.0, 1e6, -100.0, -5000.0};
  return kRates[in.byte() % kRates.size()];
}

class Bench final : public gateway::GatewayOutput {
 public:
  Bench() {
    const config::Config& config = bus_config();
    const gateway::WallClock wall = [](TimePoint t) { return wall_of(t); };
    stacks_.push_back(std::make_unique<gateway::Uim342Stack>(config, "can0", context(), wall));
    uc57_driver::Uc57Stack::Options uc57;
    uc57.wall_clock_us = wall;
    stacks_.push_back(std::make_unique<uc57_driver::Uc57Stack>(config, config.buses.front(), context(), uc57));
    for (const config::Drive& d : config.drives) {
      sim::SimDriveContext ctx;
      ctx.drive = d.name;
      ctx.bus = d.bus;
      const std::size_t index = drives_.size();
      ctx.send = [this, index](const can::Frame& f) { put(static_cast<int>(index), f); };
      ctx.report = [](std::int8_t, std::int64_t, std::int64_t, std::int64_t) {};
      if (d.family == config::Family::kUim342) {
        drives_.push_back(std::make_unique<sim::Uim342Drive>(d, ctx, sim::uim342_identity(d, 1'000'000),
                                                             sim::uim342_home_switch(config, d)));
      } else {
        drives_.push_back(sim::uc57_drive_factory(config)(d, ctx));
      }
    }
    for (const config::Axis& a : config.axes) limits_.emplace(a.name, gateway::CountLimits::of(a));
    for (auto& d : drives_) d->power_up(now_);
    for (auto& s : stacks_) s->start(now_);
    advance(std::chrono::seconds(3));  // identified and set up
  }

  void step(Input& in) {
    const std::uint8_t op = in.byte();
    switch (op % 8) {
      case 0:
      case 1:
      case 2: command(in); break;
      case 3: stacks_[in.byte() % stacks_.size()]->fire(1 + in.byte() % 3, now_); break;
      case 4: drop_ = in.byte() % 40; break;
      case 5: silent_ = in.byte() % (drives_.size() + 1); break;  // drives_.size(): none
      default: {
        static constexpr std::array<int, 8> kSteps{0, 1, 5, 20, 100, 500, 2000, 10000};
        advance(std::chrono::milliseconds(kSteps[in.byte() % kSteps.size()]));
        break;
      }
    }
    settle();
  }

  // The wire heals, every trigger fires, every axis is stopped; time runs out.
  void finish() {
    drop_ = 0;
    silent_ = drives_.size();
    advance(std::chrono::seconds(2));
    for (auto& s : stacks_) {
      for (std::int64_t trigger = 1; trigger <= 3; ++trigger) s->fire(trigger, now_);
    }
    settle();
    for (auto& s : stacks_) {
      gateway_command_t stop{};
      stop.command_id = ++next_id_;
      stop.kind = gateway_command_t::STOP;
      for (const auto& axis : s->axes()) stop.axes.push_back(motionlcm::axis_command_t{axis, 0, 0, 0, 0, 0, 0});
      stop.num_axes = static_cast<std::int32_t>(stop.axes.size());
      given_[stop.command_id];
      s->execute(stop, now_);
      settle();
    }
    advance(std::chrono::seconds(60));
    for (const auto& [id, seen] : given_) {
      if (!seen.terminal)
        violated("command " + std::to_string(id) + " never ended (last status " + std::to_string(seen.last) + ")");
    }
    for (std::size_t i = 0; i < drives_.size(); ++i) {
      if (moving(i)) violated("drive " + bus_config().drives[i].name + " still moves after every axis was stopped");
    }
    check_ledgers();
  }

  // ---- GatewayOutput
  void axis_status(const std::string&, const gateway::DriveStatus& status) override { (void)status; }
  void axis_event(const std::string&, const gateway::DriveEvent&) override {}
  void command_reply(gateway_reply_t reply) override {
    const auto it = given_.find(reply.command_id);
    if (it == given_.end()) violated("a reply names command " + std::to_string(reply.command_id) + ", never given");
    if (verbose())
      std::fprintf(stderr, "  command %lld: status %d %s\n", static_cast<long long>(reply.command_id), reply.status,
                   reply.reason.c_str());
    if (is_terminal(reply.status)) {
      if (it->second.terminal) {
        violated("command " + std::to_string(reply.command_id) + " ended twice (" + reply.reason + ")");
      }
      it->second.terminal = true;
    }
    it->second.last = reply.status;
  }

 private:
  struct Given {
    bool terminal = false;
    std::int8_t last = 0;
  };
  struct OnWire {
    int from;  // -1: the gateway's stacks; else the drive's index
    can::Frame frame;
  };

  static bool verbose() {
    static const bool on = std::getenv("FUZZ_VERBOSE") != nullptr;
    return on;
  }
  static std::int64_t wall_of(TimePoint t) {
    return kWallStartUs + std::chrono::duration_cast<std::chrono::microseconds>(t - kStart).count();
  }
  gateway::CanStackContext context() {
    gateway::CanStackContext c;
    c.out = this;
    c.send = [this](const can::Frame& f) {
      put(-1, f);
      return true;
    };
    return c;
  }
  void put(int from, can::Frame f) {
    if (drop_ > 0) {
      --drop_;
      return;
    }
    if (from >= 0 && static_cast<std::size_t>(from) == silent_) return;
    if (wire_.size() > 100'000) violated("more than 100000 frames queued: a stack or drive floods the bus");
    f.timestamp_us = wall_of(now_);
    wire_.push_back({from, f});
  }
  [[nodiscard]] bool moving(std::size_t i) const {
    if (auto* u = dynamic_cast<const sim::Uim342Drive*>(drives_[i].get())) return u->moving(now_);
    if (auto* c = dynamic_cast<const sim::Uc57DriveSim*>(drives_[i].get())) {
      return c->physical_position(now_) != c->physical_position(now_ + std::chrono::milliseconds(50));
    }
    return false;
  }

  void command(Input& in) {
    gateway::CanStack& stack = *stacks_[in.byte() % stacks_.size()];
    gateway_command_t c{};
    c.command_id = ++next_id_;
    c.kind = static_cast<std::int8_t>(1 + in.byte() % 13);
    c.trigger_id = c.kind == gateway_command_t::ARM_MOVE || c.kind == gateway_command_t::DISARM ? in.byte() % 4 : 0;
    const auto axes = stack.axes();
    const std::uint8_t mask = in.byte();
    for (std::size_t i = 0; i < axes.size(); ++i) {
      if ((mask & (1U << i)) == 0 && !(i == 0 && (mask & 0x0F) == 0)) continue;
      motionlcm::axis_command_t a{};
      a.axis = axes[i];
      a.target_counts = edge_counts(in);
      a.velocity = edge_rate(in);
      a.acceleration = edge_rate(in);
      a.deceleration = edge_rate(in);
      a.output_mask = in.byte() & 3;
      a.output_value = in.byte() & 3;
      c.axes.push_back(a);
    }
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    c.param.space = static_cast<std::int8_t>(in.byte() % 4);
    c.param.index = in.u16() % 0x7000;
    c.param.subindex = in.byte() % 4;
    c.param.width = static_cast<std::int8_t>(in.byte() % 5);
    c.param.value = static_cast<std::int16_t>(in.u16());
    // The gateway's own check first (gateway.cpp): a refused command never reaches the stack.
    for (const auto& a : c.axes) {
      if (gateway::check_axis_command(c.kind, a, limits_.at(a.axis), std::nullopt)) return;
    }
    // PARAM_WRITE of identity or bit rate would take a drive off this bus for good: not a command
    // sequence the checks here are about.
    if (c.kind == gateway_command_t::PARAM_WRITE) return;
    given_[c.command_id];
    if (verbose())
      std::fprintf(stderr, "execute %lld kind %d axes %d trigger %lld\n", static_cast<long long>(c.command_id), c.kind,
                   c.num_axes, static_cast<long long>(c.trigger_id));
    stack.execute(c, now_);
  }

  // Delivers what is on the wire and runs what is due, until nothing is.
  void settle() {
    for (int round = 0;; ++round) {
      if (round == 100'000) violated("the bus never settles: " + busy_parties());
      bool busy = false;
      for (int n = 0; !wire_.empty() && n < 10'000; ++n) {
        const OnWire w = wire_.front();
        wire_.pop_front();
        busy = true;
        for (std::size_t i = 0; i < drives_.size(); ++i) {
          if (static_cast<int>(i) != w.from) drives_[i]->on_frame(w.frame, now_);
        }
        if (w.from >= 0) {
          for (auto& s : stacks_) {
            if (s->on_frame(w.frame, now_)) break;  // the first stack that claims it (CanBusDriver)
          }
        } else {
          for (auto& s : stacks_) s->on_transmitted(w.frame, now_);  // the own echo
        }
      }
      for (auto& s : stacks_) {
        if (s->process(now_) <= now_) busy = true;
      }
      for (auto& d : drives_) {
        if (d->process(now_) <= now_) busy = true;
      }
      check_ledgers();
      if (!busy && wire_.empty()) return;
    }
  }
  void advance(Duration d) {
    const TimePoint end = now_ + d;
    while (true) {
      settle();
      TimePoint next = end;
      for (auto& s : stacks_) next = std::min(next, s->process(now_));
      for (auto& dr : drives_) next = std::min(next, dr->process(now_));
      if (next >= end) break;
      now_ = std::max(next, now_ + std::chrono::microseconds(1));
    }
    now_ = end;
    settle();
  }
  // Who keeps the bus busy (for the violation's message).
  std::string busy_parties() {
    std::string out = std::to_string(wire_.size()) + " frames queued";
    for (auto& s : stacks_) {
      if (s->process(now_) <= now_) out += ", the " + s->family() + " stack stays due";
    }
    for (std::size_t i = 0; i < drives_.size(); ++i) {
      if (drives_[i]->process(now_) <= now_) out += ", drive " + bus_config().drives[i].name + " stays due";
    }
    if (!wire_.empty()) {
      const can::Frame& f = wire_.front().frame;
      out += "; next frame id " + std::to_string(f.id) + " from " + std::to_string(wire_.front().from);
    }
    return out;
  }

  // A transition the ledger's table does not have, or a command id added twice, is a stack asking
  // for a step its lifecycle has no row for. (A second terminal for an ended command is absorbed by
  // the ledger by design, counted, never sent: the replies above check what goes out.)
  void check_ledgers() const {
    for (const auto& s : stacks_) {
      const auto counters = s->ledger_counters();
      if (counters.refused_transitions != 0 || counters.refused_adds != 0) {
        violated(s->family() + " ledger refused " + std::to_string(counters.refused_transitions) + " transitions and " +
                 std::to_string(counters.refused_adds) + " adds");
      }
    }
  }

  TimePoint now_ = kStart;
  std::vector<std::unique_ptr<gateway::CanStack>> stacks_;
  std::vector<std::unique_ptr<sim::CanDriveSim>> drives_;
  std::map<std::string, gateway::CountLimits> limits_;
  std::deque<OnWire> wire_;
  std::map<std::int64_t, Given> given_;
  std::int64_t next_id_ = 0;
  int drop_ = 0;
  std::size_t silent_ = 99;
};

}  // namespace

int can_bus_sequences(const std::uint8_t* data, std::size_t size) {
  Input in(data, size);
  Bench bench;
  for (int steps = 0; !in.empty() && steps < 200; ++steps) bench.step(in);
  bench.finish();
  return 0;
}

}  // namespace motion::fuzz
