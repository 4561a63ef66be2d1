// CANopen (motion::canopen, the UC57 stack and simulator) benchmark on the bit-timed simulated
// bus at 1 Mbit/s. One table; every figure sits next to a bound computed in the same run from the
// very frames that went over the wire (can::frame_bits(), the simulated bus's own frame-length
// function, divided by the bit rate), and their ratio. Nothing is asserted.
//
//   1. SDO (CiA 301 §7.2.4): canopen::SdoClient on one LocalEndpoint, the simulator's SDO server on
//      another, both on ONE EventLoop with a simbus::Hub, exactly as motion-sim and a gateway run
//      them (but in one process).
//        - expedited round trip (upload of 6064h and download of 6081h, 4 bytes) against the
//          simulated UC57 (sim::Uc57DriveSim, its whole SDO/object-dictionary path): p50/p99 over M
//          transfers. Bound: request frame + response frame to its end of frame, back to back.
//        - segmented upload and download of a 4 KiB domain object, canopen::SdoServer (the server
//          the simulator embeds; the UC57 dictionary itself holds only 1..4-byte objects):
//          throughput, median of R transfers. Bound: the summed wire time of every frame of the
//          transfer (initiate, segments, responses).
//      Two clocks: "wall" — the real EventLoop on the steady clock: the hub hands a frame to its
//      receivers from a loop timer (ppoll: within the kernel's timer slack), so every
//      request/response hop pays a loop wake-up; this is what a gateway and motion-sim achieve.
//      "sim" — the same code on an EventLoop driven by a ManualClock advanced in 1 us steps: the
//      protocol's own cost on the wire without wake-up latency (the ideal ratio is ~1).
//   2. SYNC producer (canopen::SyncProducer) at 1 kHz on the wall-clock EventLoop, sending on the
//      simulated bus; a second endpoint records the end-of-frame timestamps receivers see. Jitter
//      = |interval - 1 ms| over N periods (10 000 by default): p50/p99/max, and SYNCs skipped by the
//      producer (a whole period missed). Bound: one 8-byte frame at 1 Mbit/s, the jitter CAN
//      itself imposes on a SYNC (a SYNC ready while another frame is on the wire waits for it).
//      Twice in one run: (a) on the loop's own timer (ppoll timeout, the default 50 us timer
//      slack), as before; (b) on a PreciseTimer (timerfd, TFD_TIMER_ABSTIME) with the thread's
//      timer slack at 1 ns, as CanBusDriver runs its stacks' deadlines now; (c) the same under
//      SCHED_FIFO (priority 50) where the process is permitted (not used by the gateway yet).
//   3. Boot and configure: Uc57Stack (inside gateway::CanBusDriver, as motion-gateway runs it)
//      against 1, 8 and 32 simulated UC57s (sim::CanBusHost, as motion-sim runs them; reply
//      latency 0), from start() until ready() (every node configured, NMT started and its
//      heartbeat seen Operational). Bound: the wire time of the configuration frames (every SDO
//      request/response and NMT command in that window, as if sent back to back). The wait for the
//      first Operational heartbeat (1017h = 100 ms) is inherent to the start-up and shown apart.
//
// A plain main instead of Google Benchmark, as simbus_bench: fixed end-to-end workloads whose
// meaning is the ratio to a bound from the same run.
//
//   4. UC57 status polling, TPDOs at every SYNC against staggered TPDOs (canopen_poll_bench.cpp).
//
// Usage: bench_canopen [--quick] [--sync-only | --polls]   (--quick: ~10x fewer transfers and SYNC
//        periods; --sync-only: part 2 only; --polls: part 4 only)
#include <unistd.h>

#include <algorithm>
#include <chrono>
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

#include <motionlcm/sim_report_t.hpp>

#include "bench_pump.hpp"
#include "bench_table.hpp"
#include "motion/can_frame/bit_timing.hpp"
#include "motion/can_frame/frame.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/sdo_client.hpp"
#include "motion/canopen/sdo_server.hpp"
#include "motion/canopen/sync.hpp"
#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/core/precise_timer.hpp"
#include "motion/gateway/can_bus_driver.hpp"
#include "motion/sim/can_bus_host.hpp"
#include "motion/sim/uc57_drive.hpp"
#include "motion/simbus/hub.hpp"
#include "motion/uc57_driver/uc57_stack.hpp"

namespace motion {
namespace bench {
// Part 4 (canopen_poll_bench.cpp): UC57 polling, TPDOs at every SYNC against staggered.
void bench_polls(bool quick, const std::filesystem::path& dir, std::vector<Row>& rows);
}  // namespace bench
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr std::uint32_t kBitrate = 1'000'000;
constexpr canopen::NodeId kNode = 1;
constexpr canopen::ObjectAddress kDomain{0x2F00, 0};  // the bench's domain object (segmented transfers)
constexpr std::size_t kDomainSize = 4096;

double us(Duration d) { return std::chrono::duration<double, std::micro>(d).count(); }
double ms(Duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

Duration wire(const can::Frame& f) { return can::frame_duration(f, kBitrate); }
Duration to_end_of_frame(const can::Frame& f) {
  return can::bits_duration(can::frame_bits(f).to_end_of_frame(), kBitrate);
}

// ---- the table ---------------------------------------------------------------------------------

using bench::fmt;
using bench::fmt2;
using bench::nearest_rank;
using bench::Row;
std::vector<Row> g_rows;

void print_table() { bench::print_rows(g_rows, "figure (1 Mbit/s, bus timing on)", "bound"); }

// ---- driving one EventLoop on the wall clock or on a manual clock ------------------------------

using bench::Pump;

std::unique_ptr<simbus::Hub> open_hub(EventLoop& loop, const std::string& name) {
  simbus::HubOptions options;
  options.bus_name = name;
  options.listen = false;
  options.bus.bitrate = kBitrate;
  options.bus.timing = true;
  std::error_code error;
  auto hub = simbus::Hub::open(loop, options, error);
  if (!hub) {
    std::fprintf(stderr, "bench_canopen: cannot open a hub: %s\n", error.message().c_str());
    std::exit(2);
  }
  return hub;
}

// ---- 1. SDO ------------------------------------------------------------------------------------

// SdoClient and a server on two endpoints of one hub; every frame either side sends is recorded.
class SdoRig {
 public:
  enum class Server { kUc57Sim, kDomainObject };

  SdoRig(ManualClock* manual, Server kind) : pump_(manual), hub_(open_hub(pump_.loop(), "bench")) {
    client_ep_ = hub_->attach_local("client");
    server_ep_ = hub_->attach_local("server");
    client_ = std::make_unique<canopen::SdoClient>(
        [this](const can::Frame& f) {
          sent_.push_back(f);
          client_ep_->send(f);
        },
        canopen::SdoClientConfig{2s, 0, std::size_t{64} * 1024});
    const auto server_send = [this](const can::Frame& f) {
      sent_.push_back(f);
      server_ep_->send(f);
    };
    if (kind == Server::kUc57Sim) {
      sim::SimDriveContext ctx;
      ctx.drive = "bench-drive";
      ctx.bus = "bench";
      ctx.send = server_send;
      ctx.report = [](std::int8_t, std::int64_t, std::int64_t, std::int64_t) {};
      drive_ = std::make_unique<sim::Uc57DriveSim>(kNode, std::move(ctx));
      drive_->power_up(pump_.loop().now());
    } else {
      domain_.resize(kDomainSize);
      for (std::size_t i = 0; i < domain_.size(); ++i) domain_[i] = static_cast<std::uint8_t>(i * 7 + 3);
      canopen::SdoServerHandlers handlers;
      handlers.read = [this](canopen::ObjectAddress object) {
        canopen::SdoReadResult r;
        if (object == kDomain) {
          r.data = domain_;
        } else {
          r.abort = canopen::SdoAbortCode::kObjectDoesNotExist;
        }
        return r;
      };
      handlers.write = [this](const canopen::SdoWrite& w) -> std::optional<canopen::SdoAbortCode> {
        if (!(w.object == kDomain)) return canopen::SdoAbortCode::kObjectDoesNotExist;
        domain_.assign(w.data.begin(), w.data.end());
        return std::nullopt;
      };
      server_ = std::make_unique<canopen::SdoServer>(kNode, server_send, std::move(handlers));
    }
    pump_.loop().watch(client_ep_->fd(), [this] {
      while (auto f = client_ep_->receive()) { client_->on_frame(*f, pump_.loop().now()); }
    });
    pump_.loop().watch(server_ep_->fd(), [this] {
      while (auto f = server_ep_->receive()) {
        if (drive_) {
          drive_->on_frame(*f, pump_.loop().now());
        } else {
          server_->on_request(*f, pump_.loop().now());
        }
      }
    });
    pump_.until([] { return false; }, 5ms);  // the boot-up frame goes by
  }
  ~SdoRig() {
    pump_.loop().unwatch(client_ep_->fd());
    pump_.loop().unwatch(server_ep_->fd());
  }
  SdoRig(const SdoRig&) = delete;
  SdoRig& operator=(const SdoRig&) = delete;

  struct Result {
    bool ok = false;
    Duration elapsed{};  // this clock, from the request to the completion callback
    Duration bound{};    // every frame of the transfer, back to back
    std::size_t frames = 0;
  };

  // One transfer: `start` issues it on the client with a completion callback.
  Result run(const std::function<void(canopen::SdoCallback)>& start) {
    sent_.clear();
    bool done = false;
    std::error_code error;
    const TimePoint t0 = pump_.loop().now();
    const auto wall0 = Clock::now();
    start([&](std::error_code ec, std::span<const std::uint8_t>) {
      error = ec;
      done = true;
    });
    client_->process(pump_.loop().now());
    Result r;
    const bool finished = pump_.until([&] { return done; });
    r.ok = finished && !error;
    r.elapsed =
        pump_.simulated() ? pump_.loop().now() - t0 : std::chrono::duration_cast<Duration>(Clock::now() - wall0);
    r.frames = sent_.size();
    for (std::size_t i = 0; i < sent_.size(); ++i) {
      r.bound += i + 1 == sent_.size() ? to_end_of_frame(sent_[i]) : wire(sent_[i]);
    }
    if (!r.ok) std::fprintf(stderr, "bench_canopen: SDO transfer failed: %s\n", error.message().c_str());
    return r;
  }

  canopen::SdoClient& client() { return *client_; }

 private:
  Pump pump_;
  std::unique_ptr<simbus::Hub> hub_;
  std::unique_ptr<simbus::LocalEndpoint> client_ep_;
  std::unique_ptr<simbus::LocalEndpoint> server_ep_;
  std::unique_ptr<canopen::SdoClient> client_;
  std::unique_ptr<canopen::SdoServer> server_;
  std::unique_ptr<sim::Uc57DriveSim> drive_;
  std::vector<std::uint8_t> domain_;
  std::vector<can::Frame> sent_;
};

void bench_sdo(bool quick) {
  const int expedited = quick ? 100 : 1000;
  const int segmented = quick ? 3 : 15;
  for (const bool simulated : {false, true}) {
    ManualClock manual(Clock::now());
    const char* clock = simulated ? "sim" : "wall";
    {
      SdoRig rig(simulated ? &manual : nullptr, SdoRig::Server::kUc57Sim);
      for (const bool upload : {true, false}) {
        std::vector<double> rtt;
        Duration bound{};
        for (int i = 0; i < expedited; ++i) {
          const auto r = rig.run([&](canopen::SdoCallback cb) {
            if (upload) {
              rig.client().upload(kNode, {0x6064, 0}, std::move(cb));
            } else {
              rig.client().download(kNode, {0x6081, 0},
                                    canopen::encode_value<std::uint32_t>(static_cast<std::uint32_t>(60 + i % 100)),
                                    std::move(cb));
            }
          });
          if (!r.ok) return;
          rtt.push_back(us(r.elapsed));
          bound = r.bound;
        }
        const double p50 = nearest_rank(rtt, 0.5);
        g_rows.push_back(
            {std::string("SDO expedited ") + (upload ? "upload 6064h" : "download 6081h") + " RTT [" + clock + "]",
             fmt2("p50 %.0f us, p99 %.0f us", p50, nearest_rank(rtt, 0.99)), fmt("%.0f us (2 frames)", us(bound)),
             p50 / us(bound),
             simulated ? "Uc57DriveSim, 1 us clock steps" : "Uc57DriveSim; hub delivery from loop timers"});
      }
    }
    {
      SdoRig rig(simulated ? &manual : nullptr, SdoRig::Server::kDomainObject);
      for (const bool upload : {true, false}) {
        std::vector<double> rate;
        std::vector<double> ratio;
        double bound_rate = 0;
        std::size_t frames = 0;
        for (int i = 0; i < segmented; ++i) {
          const auto r = rig.run([&](canopen::SdoCallback cb) {
            if (upload) {
              rig.client().upload(kNode, kDomain, std::move(cb));
            } else {
              std::vector<std::uint8_t> data(kDomainSize, static_cast<std::uint8_t>(i));
              rig.client().download(kNode, kDomain, std::move(data), std::move(cb),
                                    canopen::SdoDownloadMode::kSegmented);
            }
          });
          if (!r.ok) return;
          const double seconds = std::chrono::duration<double>(r.elapsed).count();
          rate.push_back(static_cast<double>(kDomainSize) / seconds / 1024.0);
          ratio.push_back(us(r.elapsed) / us(r.bound));
          bound_rate = static_cast<double>(kDomainSize) / std::chrono::duration<double>(r.bound).count() / 1024.0;
          frames = r.frames;
        }
        g_rows.push_back({std::string("SDO segmented ") + (upload ? "upload" : "download") + " 4 KiB [" + clock + "]",
                          fmt("%.1f KiB/s", nearest_rank(rate, 0.5)), fmt("%.1f KiB/s", bound_rate),
                          nearest_rank(ratio, 0.5),
                          std::to_string(frames) + " frames/transfer, median of " + std::to_string(segmented) +
                              (simulated ? "" : "; a loop wake-up per hop")});
      }
    }
  }
}

// ---- 2. SYNC jitter ----------------------------------------------------------------------------

void bench_sync(bool quick, bool precise, bool fifo = false) {
  const std::size_t periods = quick ? 1000 : 10000;
  const Duration period = 1ms;
  if (precise) minimal_timer_slack();  // this thread from here on (part 3 runs after it)
  const bool realtime = fifo && fifo_scheduling(50);
  if (fifo && !realtime) {
    g_rows.push_back(
        {"SYNC 1 kHz period jitter [+ SCHED_FIFO]", "-", "-", 0.0, "SCHED_FIFO not permitted here: not measured"});
    return;
  }
  Pump pump(nullptr);
  auto hub = open_hub(pump.loop(), precise ? "syncbench2" : "syncbench");
  auto producer_ep = hub->attach_local("producer");
  auto receiver_ep = hub->attach_local("receiver");
  canopen::SyncProducer producer([&](const can::Frame& f) { producer_ep->send(f); }, {period, 0, canopen::kSyncCobId});
  std::vector<std::int64_t> stamps;
  stamps.reserve(periods + 1);
  pump.loop().watch(receiver_ep->fd(), [&] {
    while (auto f = receiver_ep->receive()) {
      if (f->id == canopen::kSyncCobId && !f->extended) stamps.push_back(f->timestamp_us);
    }
  });
  EventLoop::TimerId timer = 0;
  PreciseTimer precise_timer(pump.loop());
  std::function<void()> tick = [&] {
    const TimePoint next = producer.process(pump.loop().now());
    if (precise) {
      precise_timer.arm(next, tick);
    } else {
      timer = pump.loop().call_at(next, tick);
    }
  };
  const TimePoint first = producer.start(pump.loop().now());
  if (precise) {
    precise_timer.arm(first, tick);
  } else {
    timer = pump.loop().call_at(first, tick);
  }
  pump.until([&] { return stamps.size() > periods; }, std::chrono::seconds(periods / 500 + 10));
  pump.loop().cancel(timer);
  precise_timer.cancel();
  pump.loop().unwatch(receiver_ep->fd());
  if (realtime) normal_scheduling();

  std::vector<double> jitter;
  for (std::size_t i = 1; i < stamps.size(); ++i) {
    jitter.push_back(std::abs(static_cast<double>(stamps[i] - stamps[i - 1]) - us(period)));
  }
  const auto eight = can::Frame::make(0x181, false, std::vector<std::uint8_t>(8, 0x55));
  const double frame_us = us(wire(*eight));
  const double p50 = nearest_rank(jitter, 0.5);
  const double p99 = nearest_rank(jitter, 0.99);
  const double max = jitter.empty() ? 0 : *std::max_element(jitter.begin(), jitter.end());
  const std::string how = realtime  ? " [timerfd, slack 1 ns, FIFO]"
                          : precise ? " [timerfd abs, slack 1 ns]"
                                    : " [loop timer, default slack]";
  const std::string note = std::to_string(jitter.size()) + " periods, " + std::to_string(producer.skipped()) +
                           " skipped by the producer" +
                           (precise && !precise_timer.absolute() ? "; NO timerfd: loop timer fallback" : "");
  g_rows.push_back({"SYNC 1 kHz period jitter p50" + how, fmt("%.1f us", p50), fmt("%.0f us (8-byte frame)", frame_us),
                    p50 / frame_us, note});
  g_rows.push_back({"SYNC 1 kHz period jitter p99" + how, fmt("%.1f us", p99), fmt("%.0f us (8-byte frame)", frame_us),
                    p99 / frame_us, ""});
  g_rows.push_back({"SYNC 1 kHz period jitter max" + how, fmt("%.1f us", max), fmt("%.0f us (8-byte frame)", frame_us),
                    max / frame_us, ""});
}

// ---- 3. boot and configure ---------------------------------------------------------------------

struct NullOutput final : gateway::GatewayOutput {
  void axis_status(const std::string&, const gateway::DriveStatus&) override {}
  void axis_event(const std::string&, const gateway::DriveEvent&) override {}
  void command_reply(motionlcm::gateway_reply_t) override {}
};

std::string boot_config(int nodes, const std::string& dir) {
  std::string y = "lcm: {url: \"udpm://239.255.76.67:7667?ttl=0\", channel_prefix: \"BENCH_\"}\n";
  y += "buses:\n  - {name: can0, transport: \"simcan:canopenbench\", bitrate: 1000000, bus_timing: true, "
       "request_timeout_ms: 50, "
       "retries: 2, poll_hz: 20}\n";
  y += "drives:\n";
  for (int n = 1; n <= nodes; ++n) {
    y += "  - {name: d" + std::to_string(n) + ", family: uc57, bus: can0, node_id: " + std::to_string(n) +
         ", setup: {micro_steps: 16, current_a: 2.0, tpdo_mode: sync}}\n";
  }
  y += "axes:\n";
  for (int n = 1; n <= nodes; ++n) {
    y += "  - {name: a" + std::to_string(n) + ", drive: d" + std::to_string(n) +
         ", unit: deg, steps_per_unit: 8.888888888888889, limits: {min: -720, max: 720, velocity: 360, acceleration: "
         "1440}}\n";
  }
  y += "simulation: {runtime_dir: \"" + dir + "\", reply_latency_us: 0}\n";
  return y;
}

void bench_boot(int nodes, const std::filesystem::path& dir) {
  const auto loaded = config::load_string(boot_config(nodes, dir.string()), "canopen_bench");
  if (!loaded.ok()) {
    std::fprintf(stderr, "bench_canopen: configuration refused: %s\n", loaded.error_text().c_str());
    std::exit(2);
  }
  const config::Config config = *loaded.config;
  const config::Bus& bus = config.buses.front();
  Pump pump(nullptr);
  std::error_code error;
  auto host = sim::CanBusHost::open(
      pump.loop(), config, bus, {{config::Family::kUc57, sim::uc57_drive_factory()}},
      [](const motionlcm::sim_report_t&) {}, error);
  if (!host) {
    std::fprintf(stderr, "bench_canopen: cannot open the simulated bus: %s\n", error.message().c_str());
    std::exit(2);
  }
  auto monitor = host->hub().attach_local("monitor");
  std::vector<can::Frame> seen;
  pump.loop().watch(monitor->fd(), [&] {
    while (auto f = monitor->receive()) seen.push_back(*f);
  });
  pump.until([] { return false; }, 20ms);  // the drives' boot-up frames go by
  seen.clear();

  NullOutput out;
  gateway::CanBusDriver driver(pump.loop(), bus.name, host->hub().attach_local("gateway"), out);
  driver.add_stack(std::make_unique<uc57_driver::Uc57Stack>(config, bus, driver.context()));
  const auto t0 = Clock::now();
  driver.start();
  const bool ready = pump.until([&] { return driver.ready(); }, 60s);
  const Duration elapsed = Clock::now() - t0;
  pump.until([] { return false; }, 2ms);  // the last frames reach the monitor
  pump.loop().unwatch(monitor->fd());

  Duration config_wire{};
  Duration all_wire{};
  std::size_t config_frames = 0;
  std::int64_t last_config_us = 0;
  std::int64_t first_us = seen.empty() ? 0 : seen.front().timestamp_us;
  for (const auto& f : seen) {
    all_wire += wire(f);
    const auto info = canopen::classify_cob_id(f.id);
    if (f.extended || !info) continue;
    if (info->kind == canopen::MessageKind::kSdoRequest || info->kind == canopen::MessageKind::kSdoResponse ||
        info->kind == canopen::MessageKind::kNmt) {
      config_wire += wire(f);
      ++config_frames;
      last_config_us = f.timestamp_us;
    }
  }
  const double until_last_config_ms = static_cast<double>(last_config_us - first_us) / 1000.0;
  char note[160];
  std::snprintf(note, sizeof note, "%s; %zu config frames; last config frame at %.1f ms; all traffic %.1f ms wire",
                ready ? "ready" : "NOT READY within 60 s", config_frames, until_last_config_ms, ms(all_wire));
  g_rows.push_back(
      {"boot + configure " + std::to_string(nodes) + " UC57 node" + (nodes == 1 ? "" : "s") + " (start -> ready)",
       fmt("%.1f ms", ms(elapsed)), fmt("%.2f ms config wire", ms(config_wire)), ms(elapsed) / ms(config_wire), note});
  g_rows.push_back({"  same, to the last configuration frame", fmt("%.1f ms", until_last_config_ms),
                    fmt("%.2f ms config wire", ms(config_wire)), until_last_config_ms / ms(config_wire),
                    "excludes the wait for the first Operational heartbeat"});
}

}  // namespace
}  // namespace motion

int main(int argc, char** argv) {
  bool quick = false;
  bool sync_only = false;
  bool polls_only = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else if (std::strcmp(argv[i], "--sync-only") == 0) {
      sync_only = true;
    } else if (std::strcmp(argv[i], "--polls") == 0) {
      polls_only = true;
    } else {
      std::fprintf(stderr, "usage: bench_canopen [--quick] [--sync-only | --polls]\n");
      return 2;
    }
  }
  std::error_code error;
  const auto dir = std::filesystem::temp_directory_path() / ("canopen-bench-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir, error);
  std::printf("bench_canopen: SDO (wall and simulated clock), SYNC jitter, boot + configure; bit rate %u bit/s%s\n",
              motion::kBitrate, quick ? " (quick)" : "");
  std::fflush(stdout);
  if (!sync_only && !polls_only) motion::bench_sdo(quick);
  if (!polls_only) {
    motion::bench_sync(quick, false);
    motion::bench_sync(quick, true);
    motion::bench_sync(quick, true, true);
  }
  if (!sync_only && !polls_only) {
    for (const int nodes : {1, 8, 32}) motion::bench_boot(nodes, dir);
  }
  if (!sync_only) motion::bench::bench_polls(quick, dir, motion::g_rows);
  std::filesystem::remove_all(dir, error);
  motion::print_table();
  return 0;
}
