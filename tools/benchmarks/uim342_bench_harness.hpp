// What the three parts of bench_uim342 share (uim342_bench.cpp: command latency, arm + trigger,
// and main; uim342_bench_status.cpp: status polling): the lab configuration, the simulated bus,
// the transport tap, the reply capture and the table. See uim342_bench.cpp for what is measured.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "bench_pump.hpp"
#include "bench_table.hpp"
#include "motion/can/transport.hpp"
#include "motion/can_frame/bit_timing.hpp"
#include "motion/can_frame/frame.hpp"
#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/gateway/can_bus_driver.hpp"
#include "motion/gateway/gateway.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/health.hpp"
#include "motion/lcm/node.hpp"
#include "motion/sim/can_bus_host.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/simbus/hub.hpp"
#include "motion/uim342/message.hpp"
#include "motion/uim342_driver/uim342_stack.hpp"

namespace motion::uim342_bench {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using Clock = std::chrono::steady_clock;
using FC = uim342::FunctionCode;

inline constexpr std::uint32_t kBitrate = 1'000'000;
inline constexpr int kPollHz = 20;
inline constexpr int kGroupId = 126;  // node and group ids share 5..126 (§5.1): above every node id used here

inline double us(Duration d) { return std::chrono::duration<double, std::micro>(d).count(); }
inline std::int64_t steady_us(TimePoint t) {
  return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
}

[[noreturn]] inline void die(const std::string& why) {
  std::fprintf(stderr, "bench_uim342: %s\n", why.c_str());
  std::exit(2);
}

// LCM in-class constants are never ODR-used: copies.
inline std::int8_t k(std::int8_t v) { return v; }

// ---- the table ---------------------------------------------------------------------------------

using bench::fmt;
using bench::fmt2;
using bench::nearest_rank;
using bench::Row;
inline std::vector<Row> g_rows;

inline void print_table() { bench::print_rows(g_rows, "figure", "bound (same run)"); }

// ---- infrastructure ----------------------------------------------------------------------------

// Runs one EventLoop on the wall clock or on a manual clock advanced in 1 us steps.
using bench::Pump;

// The gateway's transport with a tap: the time of every send() (the frame goes to the wire).
class TapTransport final : public can::Transport {
 public:
  using Tap = std::function<void(const can::Frame&)>;
  TapTransport(std::unique_ptr<can::Transport> inner, Tap tap) : inner_(std::move(inner)), tap_(std::move(tap)) {
    inner_->on_bus_event([this](const can::BusEvent& e) { emit_bus_event(e); });
  }
  [[nodiscard]] std::string name() const override { return inner_->name(); }
  [[nodiscard]] int fd() const override { return inner_->fd(); }
  std::error_code send(const can::Frame& frame) override {
    tap_(frame);
    return inner_->send(frame);
  }
  std::optional<can::Frame> receive() override { return inner_->receive(); }
  std::error_code set_filters(const std::vector<can::Filter>& filters) override { return inner_->set_filters(filters); }
  std::error_code set_own_echo(bool enabled) override { return inner_->set_own_echo(enabled); }
  [[nodiscard]] can::BusState state() const override { return inner_->state(); }
  [[nodiscard]] can::Statistics statistics() const override { return inner_->statistics(); }

 private:
  std::unique_ptr<can::Transport> inner_;
  Tap tap_;
};

// Collects the stack's replies and counts status updates.
struct Capture final : gateway::GatewayOutput {
  void axis_status(const std::string&, const gateway::DriveStatus&) override { ++status_updates; }
  void axis_event(const std::string&, const gateway::DriveEvent&) override {}
  void command_reply(gateway_reply_t r) override { replies[r.command_id].push_back(r.status); }
  [[nodiscard]] bool has(std::int64_t id, std::int8_t status) const {
    const auto it = replies.find(id);
    return it != replies.end() && std::find(it->second.begin(), it->second.end(), status) != it->second.end();
  }
  [[nodiscard]] bool failed(std::int64_t id) const { return has(id, k(gateway_reply_t::FAILED)); }
  std::map<std::int64_t, std::vector<std::int8_t>> replies;
  std::uint64_t status_updates = 0;
};

inline std::string lab_config(int drives, bool timing, int group_id, const std::string& url, const std::string& hub,
                              const std::string& dir) {
  std::string y = "lcm: {url: \"" + url + "\", channel_prefix: \"BENCH_\"}\n";
  y += "buses:\n  - {name: can0, transport: \"simcan:" + hub + "\", bitrate: " + std::to_string(kBitrate) +
       ", bus_timing: " + (timing ? "true" : "false") +
       ", request_timeout_ms: 50, retries: 2, poll_hz: " + std::to_string(kPollHz) + "}\n";
  y += "drives:\n";
  for (int n = 0; n < drives; ++n) {
    y += "  - {name: d" + std::to_string(n) +
         ", family: uim342, bus: can0, node_id: " + std::to_string(uim342::kMinNodeId + n) +
         (group_id != 0 ? ", group_id: " + std::to_string(group_id) : std::string{}) +
         ", setup: {micro_steps: 16, current_a: 2.0, acceleration_unit: rate}}\n";
  }
  y += "axes:\n";
  for (int n = 0; n < drives; ++n) {
    y += "  - {name: a" + std::to_string(n) + ", drive: d" + std::to_string(n) +
         ", unit: mm, steps_per_unit: 640, limits: {min: -300, max: 300, velocity: 100, acceleration: 400}}\n";
  }
  y += "simulation: {runtime_dir: \"" + dir + "\", reply_latency_us: 0}\n";
  return y;
}

inline config::Config load(const std::string& yaml) {
  const auto loaded = config::load_string(yaml, "uim342_bench");
  if (!loaded.ok()) die("configuration refused: " + loaded.error_text());
  return *loaded.config;
}

inline std::unique_ptr<sim::CanBusHost> open_host(EventLoop& loop, const config::Config& config) {
  std::error_code error;
  auto host = sim::CanBusHost::open(
      loop, config, config.buses.front(), {{config::Family::kUim342, sim::uim342_factory(config)}},
      [](const motionlcm::sim_report_t&) {}, error);
  if (!host) die("cannot open the simulated bus: " + error.message());
  return host;
}

inline std::optional<uim342::CanMessage> decode(const can::Frame& f) {
  auto m = uim342::decode_can(f);
  if (!m) return std::nullopt;
  return *m;
}
inline bool is_function(const uim342::CanMessage& m, FC f) { return m.message.function_code() == uim342::code(f); }

// Puts a Uim342Stack for can0 on `driver`; the stack, to watch.
inline const gateway::Uim342Stack* add_uim342_stack(gateway::CanBusDriver& driver, const config::Config& config) {
  auto stack = std::make_unique<gateway::Uim342Stack>(config, "can0", driver.context());
  const gateway::Uim342Stack* view = stack.get();
  driver.add_stack(std::move(stack));
  return view;
}

// Runs the loop until `stack` has set its drives up; ends the benchmark when `within` passes first.
inline void await_set_up(Pump& pump, const gateway::Uim342Stack& stack, Duration within, const std::string& rig) {
  if (!pump.until([&] { return stack.ready(); }, within)) {
    die("the UIM342 drives were not set up within " +
        std::to_string(std::chrono::duration_cast<std::chrono::seconds>(within).count()) + " s (" + rig + ")");
  }
}

inline gateway_command_t command(std::int64_t id, std::int8_t kind, const std::vector<std::string>& axes) {
  gateway_command_t c{};
  c.utime = wall_time_us();
  c.bus = "can0";
  c.command_id = id;
  c.kind = kind;
  for (const auto& a : axes) {
    motionlcm::axis_command_t ac{};
    ac.axis = a;
    c.axes.push_back(ac);
  }
  c.num_axes = static_cast<std::int32_t>(c.axes.size());
  return c;
}

// ---- 3. status polling throughput (uim342_bench_status.cpp) ------------------------------------

// N drives polled at poll_hz on a timed bus: updates/s and frames/s against what the bus carries,
// then commands while the polls saturate it.
void bench_status(int axes, bool quick, const std::filesystem::path& dir);

}  // namespace motion::uim342_bench
