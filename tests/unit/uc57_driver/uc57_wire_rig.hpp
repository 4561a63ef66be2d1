// The wire rig of the Uc57Stack polling tests (uc57_stagger_test.cpp) and of bench_canopen's
// --staggered mode: the shared bit-timed loop (../common/can_wire_loop.hpp) between the stack and
// simulated UC57 drives (sim::Uc57DriveSim, answering at once), on a simulated clock. Every frame
// is recorded as it went over the wire, so tests judge what the bus carried.
// Thread contract: single-threaded test code.
#pragma once

#include <algorithm>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/param_t.hpp>

#include "../common/can_wire_loop.hpp"
#include "motion/can_frame/bit_timing.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/nmt.hpp"
#include "motion/config/config.hpp"
#include "motion/sim/uc57_drive.hpp"
#include "motion/simbus/bus.hpp"
#include "motion/uc57_driver/process_data.hpp"
#include "motion/uc57_driver/uc57_stack.hpp"

namespace motion::uc57_driver::wire {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;

class Recorder final : public gateway::GatewayOutput {
 public:
  void axis_status(const std::string& axis, const gateway::DriveStatus& status) override {
    ++updates[axis];
    positions[axis] = status.position_counts;
  }
  void axis_event(const std::string& axis, const gateway::DriveEvent& event) override {
    events.emplace_back(axis, event);
  }
  void command_reply(gateway_reply_t reply) override { replies.push_back(std::move(reply)); }
  std::map<std::string, std::int64_t> updates;
  std::map<std::string, std::int64_t> positions;  // the last status of each axis
  std::vector<gateway_reply_t> replies;
  std::vector<std::pair<std::string, gateway::DriveEvent>> events;
};

// A frame as it went over the wire.
struct OnWire {
  can::Frame frame;
  TimePoint end_of_frame;
  bool ours = false;  // sent by the stack
  std::uint32_t bitrate = 125000;
  [[nodiscard]] bool is_sync() const { return !frame.extended && frame.id == canopen::kSyncCobId; }
  [[nodiscard]] bool is_poll() const {  // a TPDO (status answer)
    const auto info = canopen::classify_cob_id(frame.id);
    return !frame.extended && info && info->kind == canopen::MessageKind::kTpdo;
  }
  [[nodiscard]] TimePoint start() const {
    return end_of_frame - can::bits_duration(can::frame_bits(frame).to_end_of_frame(), bitrate);
  }
};

struct RigOptions {
  int nodes = 32;
  double poll_hz = 20;
  std::uint32_t bitrate = 125000;
  std::string tpdo_mode = "staggered";
  // Per node id: the simulated drive's options (a drive refusing type G, one counting differently).
  std::function<void(int node, sim::Uc57SimOptions&)> sim;
  // The stack's options beyond the configuration (its timeouts).
  std::function<void(Uc57Stack::Options&)> stack;
};

// The stack and `nodes` simulated UC57 (node ids 1...) on one bit-timed wire.
class WireRig final : public motion::testing::CanWireLoop<Uc57Stack, OnWire> {
 public:
  explicit WireRig(const RigOptions& o) : CanWireLoop(o.bitrate, 8192), bitrate(o.bitrate) {
    std::string yaml = "buses:\n  - {name: can0, transport: \"simcan:can0\", bitrate: " + std::to_string(o.bitrate) +
                       ", request_timeout_ms: 50, retries: 2, poll_hz: " + std::to_string(o.poll_hz) + "}\ndrives:\n";
    for (int n = 1; n <= o.nodes; ++n)
      yaml += "  - {name: d" + std::to_string(n) + ", family: uc57, bus: can0, node_id: " + std::to_string(n) +
              ", setup: {heartbeat_ms: 100, tpdo_mode: " + o.tpdo_mode + "}}\n";
    yaml += "axes:\n";
    for (int n = 1; n <= o.nodes; ++n)
      yaml += "  - {name: a" + std::to_string(n) + ", drive: d" + std::to_string(n) +
              ", unit: rev, steps_per_unit: 3200, limits: {min: -100, max: 100, velocity: 10, acceleration: 100}}\n";
    auto loaded = config::load_string(yaml, "stagger.yaml");
    if (!loaded.ok()) throw std::runtime_error(loaded.error_text());
    config_ = *loaded.config;
    gateway::CanStackContext ctx;
    ctx.out = &out;
    ctx.send = [this](const can::Frame& f) { return send(f); };
    Uc57Stack::Options options;
    options.wall_clock_us = [](TimePoint t) {
      return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
    };
    if (o.stack) o.stack(options);
    stack = std::make_unique<Uc57Stack>(config_, *config_.find_bus("can0"), ctx, options);
    for (const auto& d : config_.drives) {
      attach_drive(d.name, [&](simbus::EndpointId endpoint) {
        sim::SimDriveContext context;
        context.drive = d.name;
        context.bus = d.bus;
        context.send = [this, endpoint](const can::Frame& f) { (void)bus_.submit(endpoint, f, now); };
        context.report = [](std::int8_t, std::int64_t, std::int64_t, std::int64_t) {};
        sim::Uc57SimOptions sim_options;
        if (o.sim) o.sim(d.node_id, sim_options);
        return std::make_unique<sim::Uc57DriveSim>(static_cast<canopen::NodeId>(d.node_id), context, sim_options);
      });
    }
    power_up_drives();
    other_ = bus_.attach("other-master");
  }

  // A frame from another master on the bus (e.g. an NMT command).
  void inject(const can::Frame& frame) { (void)bus_.submit(other_, frame, now); }

  bool start() {
    stack->start(now);
    if (run_until([&] { return stack->ready(); }, std::chrono::seconds(20))) return true;
    for (const auto& [axis, e] : out.events) std::fprintf(stderr, "event %s: %s\n", axis.c_str(), e.text.c_str());
    return false;
  }
  std::int64_t execute(gateway_command_t c) {
    c.bus = "can0";
    c.command_id = ++next_id_;
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    stack->execute(c, now);
    return c.command_id;
  }
  [[nodiscard]] std::optional<gateway_reply_t> terminal(std::int64_t id) const {
    for (const auto& r : out.replies) {
      if (r.command_id == id && (r.status == gateway_reply_t::DONE || r.status == gateway_reply_t::FAILED)) return r;
    }
    return std::nullopt;
  }
  // Wire bits of the frames that ended within [from, to) (all, or the polls: SYNCs and TPDOs).
  [[nodiscard]] double busy_share(TimePoint from, TimePoint to, bool polls_only) const {
    std::uint64_t bits = 0;
    for (const auto& w : wire) {
      if (w.end_of_frame >= from && w.end_of_frame < to && (!polls_only || w.is_poll() || w.is_sync()))
        bits += can::frame_bits(w.frame).total;
    }
    return static_cast<double>(bits) / bitrate / std::chrono::duration<double>(to - from).count();
  }
  // A PARAM_READ of 6064h on node `node` executed now, run to its reply: how long its SDO request
  // (600h + node) waited from its hand-over to the start of its frame on the wire, and the TPDOs
  // and SYNCs that ended on the wire in between (ok false: no reply, or the frame not found).
  struct CommandWait {
    bool ok = false;
    bool done = false;  // the reply was DONE
    Duration wait{};
    std::size_t polls_ahead = 0;
    std::size_t syncs_ahead = 0;
  };
  CommandWait sdo_read_wait(int node) {
    gateway_command_t read{};
    read.kind = gateway_command_t::PARAM_READ;
    motionlcm::axis_command_t axis{};
    axis.axis = "a" + std::to_string(node);
    read.axes = {axis};
    read.param.space = motionlcm::param_t::CANOPEN_OBJECT;
    read.param.index = 0x6064;
    read.param.subindex = 0;
    const auto handed_before = handed.size();
    const auto id = execute(read);
    CommandWait r;
    if (!run_until([&] { return terminal(id).has_value(); }, std::chrono::milliseconds(500))) return r;
    r.done = terminal(id)->status == gateway_reply_t::DONE;
    const auto request = canopen::sdo_request_cob_id(static_cast<canopen::NodeId>(node));
    const auto from = std::find_if(handed.begin() + static_cast<std::ptrdiff_t>(handed_before), handed.end(),
                                   [&](const auto& h) { return h.second.id == request; });
    if (from == handed.end()) return r;
    const auto on_wire = std::find_if(wire.begin(), wire.end(), [&](const OnWire& w) {
      return w.ours && w.frame.id == request && w.end_of_frame > from->first;
    });
    if (on_wire == wire.end()) return r;
    for (auto it = wire.begin(); it != on_wire; ++it) {
      if (it->end_of_frame <= from->first) continue;
      r.polls_ahead += it->is_poll() ? 1U : 0U;
      r.syncs_ahead += it->is_sync() ? 1U : 0U;
    }
    r.wait = on_wire->start() - from->first;
    r.ok = true;
    return r;
  }

  [[nodiscard]] std::int64_t total_updates() const {
    std::int64_t n = 0;
    for (const auto& [axis, count] : out.updates) n += count;
    return n;
  }

  std::uint32_t bitrate;
  Recorder out;

 private:
  // What the stack and the wire were waiting for.
  void stuck() override {
    std::fprintf(
        stderr, "stuck at %lld us: stack %lld bus %lld errors %lld handed %zu wire %zu\n",
        static_cast<long long>(std::chrono::duration_cast<std::chrono::microseconds>(now.time_since_epoch()).count()),
        static_cast<long long>(
            std::chrono::duration_cast<std::chrono::microseconds>(stack->process(now).time_since_epoch()).count()),
        static_cast<long long>(
            std::chrono::duration_cast<std::chrono::microseconds>(bus_.next_deadline().time_since_epoch()).count()),
        static_cast<long long>(stack->counters().protocol_errors), handed.size(), wire.size());
  }

  config::Config config_;
  simbus::EndpointId other_ = 0;
  std::int64_t next_id_ = 0;
};

}  // namespace motion::uc57_driver::wire
