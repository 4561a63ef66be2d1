// bench_canopen, part 4 (--polls): UC57 status polling with TPDOs at every SYNC (tpdo_mode sync)
// against staggered TPDOs (tpdo_mode staggered), N = 8 / 32 / 127 nodes at 1 Mbit/s and 32 at the
// UC57's default 125 kbit/s, at a poll rate no bus carries (1000 Hz per node), each against a bound
// of the same run:
//   - status updates/s: bound = what the bus carries of TPDO1 + TPDO2 pairs alone (1 s / their
//     wire time, no SYNC, no heartbeat): how much of the wire each scheme turns into samples;
//   - bus share of the polls (SYNCs + TPDOs) and of everything: bound = the whole bus;
//   - an SDO read's request (PARAM_READ 6064h) issued at 100 moments spread over the poll rhythm:
//     from its hand-over to its frame's start on the wire, p50 / p99 in TPDO frame times (bound:
//     one TPDO2 frame), and the most TPDOs that ended on the wire in between.
// Two clocks: "sim" — the stack and simulated drives on a bit-timed simbus wire on a simulated
// clock (the rig of tests/unit/uc57_driver/uc57_wire_rig.hpp: exact, no host latency); "wall" —
// the stack inside gateway::CanBusDriver against sim::CanBusHost on the wall-clock EventLoop, as
// motion-gateway and motion-sim run them (updates/s and bus share; the SDO read's round trip,
// execute -> DONE, p50 / p99 in TPDO frame times, bound: its request + response frames).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <motionlcm/param_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "bench_pump.hpp"
#include "bench_table.hpp"
#include "motion/gateway/can_bus_driver.hpp"
#include "motion/sim/can_bus_host.hpp"
#include "uc57_wire_rig.hpp"

namespace motion::bench {
namespace {

using std::chrono::milliseconds;
constexpr double kPollHz = 1000;

double frames_of(Duration d, Duration frame) { return std::chrono::duration<double>(d) / frame; }

struct Figures {
  double updates = 0;   // status updates/s
  double polls = 0;     // bus share of SYNCs + TPDOs
  double all = 0;       // bus share of every frame
  double wait_p50 = 0;  // TPDO frames
  double wait_p99 = 0;
  std::size_t ahead = 0;  // most TPDOs ahead of a request (sim only)
  double ready_s = 0;     // start -> every node operational
  bool ok = false;
  std::string why = "the rig did not come up";  // when not ok
};

Duration tpdo_pair(std::uint32_t bitrate) {  // TPDO1 + TPDO2 on the wire
  return can::frame_duration(uc57_driver::encode_tpdo1(1, {}), bitrate) +
         can::frame_duration(uc57_driver::encode_tpdo2(1, {}), bitrate);
}

Figures on_simulated_wire(int nodes, std::uint32_t bitrate, const std::string& mode, bool quick) {
  uc57_driver::wire::RigOptions o;
  o.nodes = nodes;
  o.poll_hz = kPollHz;
  o.bitrate = bitrate;
  o.tpdo_mode = mode;
  uc57_driver::wire::WireRig rig(o);
  Figures f;
  const TimePoint started = rig.now;
  if (!rig.start()) return f;
  f.ready_s = std::chrono::duration<double>(rig.now - started).count();
  if (!rig.run_for(milliseconds(300))) return f;
  const TimePoint from = rig.now;
  const auto before = rig.total_updates();
  if (!rig.run_for(std::chrono::seconds(1))) return f;
  f.updates = static_cast<double>(rig.total_updates() - before);
  f.polls = rig.busy_share(from, rig.now, true);
  f.all = rig.busy_share(from, rig.now, false);
  const Duration frame = can::frame_duration(uc57_driver::encode_tpdo2(1, {}), bitrate);
  std::vector<double> waits;
  const int reads = quick ? 30 : 100;
  for (int k = 0; k < reads; ++k) {
    if (!rig.run_for(std::chrono::microseconds(1013 + 97 * k))) return f;
    const auto r = rig.sdo_read_wait(1 + k % nodes);
    if (!r.ok) {
      f.why = "SDO read " + std::to_string(k) + " not answered";
      return f;
    }
    waits.push_back(frames_of(r.wait, frame));
    f.ahead = std::max(f.ahead, r.polls_ahead);
  }
  f.wait_p50 = nearest_rank(waits, 0.5);
  f.wait_p99 = nearest_rank(waits, 0.99);
  f.ok = true;
  return f;
}

struct CountingOutput final : gateway::GatewayOutput {
  void axis_status(const std::string&, const gateway::DriveStatus&) override { ++updates; }
  void axis_event(const std::string&, const gateway::DriveEvent&) override {}
  void command_reply(motionlcm::gateway_reply_t reply) override { replies.push_back(std::move(reply)); }
  std::int64_t updates = 0;
  std::vector<motionlcm::gateway_reply_t> replies;
};

std::string wall_config(int nodes, std::uint32_t bitrate, const std::string& mode, const std::string& dir) {
  std::string y = "lcm: {url: \"udpm://239.255.76.67:7667?ttl=0\", channel_prefix: \"BENCH_\"}\n";
  y += "buses:\n  - {name: can0, transport: \"simcan:canopenpolls\", bitrate: " + std::to_string(bitrate) +
       ", bus_timing: true, request_timeout_ms: 50, retries: 2, poll_hz: 1000}\ndrives:\n";
  for (int n = 1; n <= nodes; ++n) {
    y += "  - {name: d" + std::to_string(n) + ", family: uc57, bus: can0, node_id: " + std::to_string(n) +
         ", setup: {heartbeat_ms: 100, tpdo_mode: " + mode + "}}\n";
  }
  y += "axes:\n";
  for (int n = 1; n <= nodes; ++n) {
    y += "  - {name: a" + std::to_string(n) + ", drive: d" + std::to_string(n) +
         ", unit: rev, steps_per_unit: 3200, limits: {min: -100, max: 100, velocity: 10, acceleration: 100}}\n";
  }
  y += "simulation: {runtime_dir: \"" + dir + "\", reply_latency_us: 0}\n";
  return y;
}

Figures on_wall_clock(int nodes, std::uint32_t bitrate, const std::string& mode, bool quick,
                      const std::filesystem::path& dir) {
  Figures f;
  const auto loaded = config::load_string(wall_config(nodes, bitrate, mode, dir.string()), "canopen_poll_bench");
  if (!loaded.ok()) {
    std::fprintf(stderr, "bench_canopen: configuration refused: %s\n", loaded.error_text().c_str());
    return f;
  }
  const config::Config config = *loaded.config;
  const config::Bus& bus = config.buses.front();
  Pump pump(nullptr);
  std::error_code error;
  auto host = sim::CanBusHost::open(
      pump.loop(), config, bus, {{config::Family::kUc57, sim::uc57_drive_factory()}},
      [](const motionlcm::sim_report_t&) {}, error);
  if (!host) return f;
  auto monitor = host->hub().attach_local("monitor");
  Duration busy{};
  Duration polls{};
  pump.loop().watch(monitor->fd(), [&] {
    while (auto frame = monitor->receive()) {
      const Duration d = can::frame_duration(*frame, bitrate);
      busy += d;
      const auto info = canopen::classify_cob_id(frame->id);
      if (!frame->extended && info &&
          (info->kind == canopen::MessageKind::kTpdo || info->kind == canopen::MessageKind::kSync))
        polls += d;
    }
  });
  pump.until([] { return false; }, milliseconds(20));  // the drives' boot-up frames go by
  CountingOutput out;
  gateway::CanBusDriver driver(pump.loop(), bus.name, host->hub().attach_local("gateway"), out);
  driver.add_stack(std::make_unique<uc57_driver::Uc57Stack>(config, bus, driver.context()));
  const auto started = SteadyClock::now();
  driver.start();
  if (!pump.until([&] { return driver.ready(); }, std::chrono::seconds(60))) {
    pump.loop().unwatch(monitor->fd());
    f.why = "not ready within 60 s";
    return f;
  }
  f.ready_s = std::chrono::duration<double>(SteadyClock::now() - started).count();
  pump.until([] { return false; }, milliseconds(300));
  const auto updates0 = out.updates;
  busy = polls = Duration{};
  const auto t0 = SteadyClock::now();
  pump.until([] { return false; }, std::chrono::seconds(1));
  const double seconds = std::chrono::duration<double>(SteadyClock::now() - t0).count();
  f.updates = static_cast<double>(out.updates - updates0) / seconds;
  f.polls = std::chrono::duration<double>(polls).count() / seconds;
  f.all = std::chrono::duration<double>(busy).count() / seconds;
  const Duration frame = can::frame_duration(uc57_driver::encode_tpdo2(1, {}), bitrate);
  std::vector<double> trips;
  const int reads = quick ? 20 : 50;
  for (int k = 0; k < reads; ++k) {
    pump.until([] { return false; }, std::chrono::microseconds(1013 + 97 * k));
    motionlcm::gateway_command_t read{};
    read.bus = bus.name;
    read.command_id = 1000 + k;
    read.kind = motionlcm::gateway_command_t::PARAM_READ;
    motionlcm::axis_command_t axis{};
    axis.axis = "a" + std::to_string(1 + k % nodes);
    read.axes = {axis};
    read.num_axes = 1;
    read.param.space = motionlcm::param_t::CANOPEN_OBJECT;
    read.param.index = 0x6064;
    const auto sent = SteadyClock::now();
    driver.execute(read);
    const auto answered = [&] {
      return std::any_of(out.replies.begin(), out.replies.end(), [&](const auto& r) {
        return r.command_id == read.command_id && r.status == motionlcm::gateway_reply_t::DONE;
      });
    };
    if (!pump.until(answered, std::chrono::seconds(2))) {
      f.why = "SDO read " + std::to_string(k) + " not answered within 2 s";
      break;
    }
    trips.push_back(frames_of(std::chrono::duration_cast<Duration>(SteadyClock::now() - sent), frame));
  }
  pump.loop().unwatch(monitor->fd());
  if (trips.size() < static_cast<std::size_t>(reads)) return f;
  f.wait_p50 = nearest_rank(trips, 0.5);
  f.wait_p99 = nearest_rank(trips, 0.99);
  f.ok = true;
  return f;
}

}  // namespace

void bench_polls(bool quick, const std::filesystem::path& dir, std::vector<Row>& rows) {
  const std::vector<std::pair<int, std::uint32_t>> runs = {
      {8, 1'000'000}, {32, 1'000'000}, {127, 1'000'000}, {32, 125'000}};
  for (const auto& [nodes, bitrate] : runs) {
    const Duration pair = tpdo_pair(bitrate);
    const double carried = 1.0 / std::chrono::duration<double>(pair).count();
    const Duration tpdo = can::frame_duration(uc57_driver::encode_tpdo2(1, {}), bitrate);
    for (const char* mode : {"sync", "staggered"}) {
      for (const bool wall : {false, true}) {
        const Figures f =
            wall ? on_wall_clock(nodes, bitrate, mode, quick, dir) : on_simulated_wire(nodes, bitrate, mode, quick);
        const std::string what = "4. UC57 polls N=" + std::to_string(nodes) + (bitrate == 125'000 ? " 125k " : " ") +
                                 mode + " (" + (wall ? "wall" : "sim") + "): ";
        if (!f.ok) {
          rows.push_back({what + "FAILED", "-", "-", 0, f.why});
          continue;
        }
        rows.push_back({what + "bring-up, every node operational", fmt("%.2f s", f.ready_s), "", NAN,
                        wall ? "wall clock" : "simulated clock"});
        rows.push_back({what + "status updates/s", fmt("%.0f /s", f.updates), fmt("%.0f /s TPDO pairs alone", carried),
                        f.updates / carried,
                        fmt2("asked %.0f /s; polls %.0f%% of the bus", nodes * kPollHz, 100 * f.polls)});
        rows.push_back({what + "bus share polls / all", fmt2("%.1f / %.1f %%", 100 * f.polls, 100 * f.all),
                        "the whole bus", f.all, "heartbeats 100 ms, SDO reads"});
        if (wall) {
          rows.push_back(
              {what + "SDO read execute -> DONE p50 / p99", fmt2("%.1f / %.1f frames", f.wait_p50, f.wait_p99),
               fmt("%.0f us per TPDO frame; bound 2 frames", std::chrono::duration<double, std::micro>(tpdo).count()),
               f.wait_p99 / 2, "request + response on the wire at the least"});
        } else {
          rows.push_back({what + "SDO request handed -> on the wire p50 / p99",
                          fmt2("%.2f / %.2f frames", f.wait_p50, f.wait_p99),
                          fmt("one TPDO frame %.0f us", std::chrono::duration<double, std::micro>(tpdo).count()),
                          f.wait_p99, "most TPDOs ahead: " + std::to_string(f.ahead)});
        }
        std::fflush(stdout);
      }
    }
  }
}

}  // namespace motion::bench
