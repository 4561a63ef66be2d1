// ADAM Modbus RTU line benchmark: our RTU master (AdamBusDriver around AdamStack) polling N
// simulated drives (AdamLineSim, slaves 1…N) over pseudo-terminals, both on ONE EventLoop in
// this process, exactly as motion-gateway and motion-sim run them. One table; every figure sits
// next to the wire-time bound of the same frames and their ratio. Nothing is asserted.
//
//   * poll cycle: the time for every drive to be polled once (two transactions per drive:
//     0x0004 ×4 registers and 0x00A2 ×2: 8+13 and 8+9 bytes), with polling saturated (poll
//     period 1 ms, shorter than any cycle). Measured from the master's own rx frame count over a
//     window of ≥ 1 s and ≥ 3 cycles after set-up. Bound: Σ bytes × bits per character / baud,
//     plus 3.5 characters of silence before every frame (Modbus serial line v1.02 §2.5.1.1;
//     1.75 ms fixed above 19200 bit/s).
//   * two line models: "pty" — the pty delivers bytes at once, so what remains is the master's
//     own pacing (its t3.5 waits on the poll loop's timers) and CPU; "wire" — a relay
//     thread between the master's pty and the simulator's pty delivers every frame when its last
//     character would arrive on a half-duplex line at the baud rate, after t3.5 of silence (the
//     simulated drives themselves answer with 0 latency; the relay's silence stands for a real
//     drive's minimum turnaround). "wire" is the realistic figure.
//   * command latency while polling runs (wire model, polling saturated): PARAM_READ of one
//     register (0x0098) of drive i mod N, from execute() (queued) to the terminal reply (reply
//     frame complete), p50/p99 over M commands issued at random 0…2 ms after the previous one
//     ended. Bound: the command's own transaction (8 + 7 bytes, 2 × t3.5); the ratio includes the
//     wait for the poll transaction already on the line, and can dip below 1 when the line had
//     been silent for t3.5 already when the command was queued.
//
// Usage: bench_adam [--quick]   (--quick: fewer commands and shorter windows, for a smoke run)
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench_table.hpp"
#include "motion/adam/rtu.hpp"
#include "motion/adam_driver/adam_bus_driver.hpp"
#include "motion/config/config.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/gateway/serial_line.hpp"
#include "motion/serial/pty_link.hpp"
#include "motion/serial/serial_port.hpp"
#include "motion/sim/adam_line_sim.hpp"

namespace motion {
namespace {

using bench::nearest_rank;

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using Reply = motionlcm::gateway_reply_t;
namespace rtu = adam::rtu;

double ms(Duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

struct Recorder final : gateway::GatewayOutput {
  std::int64_t waiting_for = -1;
  Clock::time_point done_at{};
  bool done = false;
  bool failed = false;
  std::string reason;
  void axis_status(const std::string&, const gateway::DriveStatus&) override {}
  void axis_event(const std::string&, const gateway::DriveEvent&) override {}
  void command_reply(Reply r) override {
    if (r.command_id != waiting_for || (r.status != std::int8_t{Reply::DONE} && r.status != std::int8_t{Reply::FAILED}))
      return;
    done_at = Clock::now();
    done = true;
    failed = r.status == std::int8_t{Reply::FAILED};
    reason = r.reason;
  }
};

// A half-duplex RS485 line between two pty master fds, on its own thread (sub-millisecond
// precision, independent of the poll loop under test): every chunk read from one side is
// delivered to the other when its last character would have arrived at `baud`, a new frame
// starting no earlier than t3.5 after the previous one ended.
class WireRelay {
 public:
  WireRelay(int master_side, int drive_side, const rtu::SerialFormat& format)
      : fds_{master_side, drive_side},
        character_(rtu::transmission_time(format, 1)),
        silence_(rtu::frame_timing(format).t3_5),
        thread_([this] { run(); }) {}
  ~WireRelay() {
    stop_ = true;
    thread_.join();
  }
  WireRelay(const WireRelay&) = delete;
  WireRelay& operator=(const WireRelay&) = delete;

 private:
  struct Chunk {
    Clock::time_point at;
    int to;
    std::vector<std::uint8_t> bytes;
  };
  void run() {
    std::deque<Chunk> pending;  // delivery times are monotonic: one half-duplex line
    while (!stop_) {
      Clock::duration wait = 5ms;
      if (!pending.empty()) wait = std::max(Clock::duration::zero(), pending.front().at - Clock::now());
      const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wait).count();
      const timespec timeout{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
      pollfd pfds[2] = {{fds_[0], POLLIN, 0}, {fds_[1], POLLIN, 0}};
      ::ppoll(pfds, 2, &timeout, nullptr);
      for (int side = 0; side < 2; ++side) {
        if ((pfds[side].revents & POLLIN) == 0) continue;
        std::uint8_t buffer[512];
        ssize_t n = 0;
        while ((n = ::read(fds_[side], buffer, sizeof buffer)) > 0) {
          const auto now = Clock::now();
          const bool continuation = side == last_side_ && now < busy_until_;
          const auto start = continuation ? busy_until_ : std::max(now, busy_until_ + silence_);
          busy_until_ = start + character_ * n;
          last_side_ = side;
          pending.push_back({busy_until_, fds_[1 - side], std::vector<std::uint8_t>(buffer, buffer + n)});
        }
      }
      const auto now = Clock::now();
      while (!pending.empty() && pending.front().at <= now) {
        const Chunk& c = pending.front();
        if (::write(c.to, c.bytes.data(), c.bytes.size()) != static_cast<ssize_t>(c.bytes.size())) ++lost_;
        pending.pop_front();
      }
    }
  }

  int fds_[2];
  Duration character_;
  Duration silence_;
  std::atomic<bool> stop_{false};
  Clock::time_point busy_until_{};
  int last_side_ = -1;
  int lost_ = 0;
  std::thread thread_;
};

std::string yaml_for(const std::filesystem::path& dir, int drives, int baud) {
  std::string yaml = "buses:\n  - {name: rs485, transport: 'simserial:rs485', baud: " + std::to_string(baud) +
                     ", request_timeout_ms: 200, retries: 1, poll_hz: 1000}\ndrives:\n";
  for (int i = 1; i <= drives; ++i) {
    yaml +=
        "  - {name: d" + std::to_string(i) + ", family: adam-modbus, bus: rs485, node_id: " + std::to_string(i) + "}\n";
  }
  yaml += "axes:\n";
  for (int i = 1; i <= drives; ++i) {
    yaml += "  - {name: a" + std::to_string(i) + ", drive: d" + std::to_string(i) +
            ", unit: mm, steps_per_unit: 100, limits: {min: -100, max: 100, velocity: 10, acceleration: 100}}\n";
  }
  yaml += "simulation: {runtime_dir: '" + dir.string() + "', reply_latency_us: 0}\n";
  return yaml;
}

struct LineResult {
  double cycle_ms = 0;
  std::vector<double> latencies_ms;
  std::int64_t errors = 0, timeouts = 0, failed_commands = 0;
  bool ok = false;
  std::string failure;
};

// One line: N drives at `baud`, paced or not; the cycle, then (if commands > 0) the latencies.
LineResult run_line(int drives, int baud, bool paced, int commands, Duration window) {
  LineResult result;
  const auto dir = std::filesystem::temp_directory_path() / ("adam-bench-" + std::to_string(::getpid()) + "-" +
                                                             std::to_string(drives) + "-" + std::to_string(baud));
  std::filesystem::create_directories(dir);
  struct Cleanup {
    std::filesystem::path dir;
    ~Cleanup() {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  } cleanup{dir};
  auto loaded = config::load_string(yaml_for(dir, drives, baud));
  if (!loaded.ok()) {
    result.failure = loaded.error_text();
    return result;
  }
  const config::Config config = *loaded.config;
  const config::Bus& bus = config.buses[0];

  EventLoop loop;
  std::error_code error;
  auto host = sim::open_adam_line(loop, config, bus, {}, error);
  if (!host) {
    result.failure = "simulator: " + error.message();
    return result;
  }
  adam_driver::MasterSettings settings = adam_driver::settings_from_config(config, bus);
  settings.poll_period = 1ms;  // saturated polling
  std::string device = host->link_path();
  std::unique_ptr<serial::PtyLink> master_link;
  std::unique_ptr<serial::SerialPort> drive_port;
  std::unique_ptr<WireRelay> relay;
  if (paced) {
    master_link = serial::PtyLink::create((dir / "wire.tty").string(), gateway::serial_line_settings(bus), error);
    if (master_link)
      drive_port = serial::SerialPort::open(host->link_path(), gateway::serial_line_settings(bus), error);
    if (!master_link || !drive_port) {
      result.failure = "relay: " + error.message();
      return result;
    }
    relay = std::make_unique<WireRelay>(master_link->master_fd(), drive_port->fd(), settings.format);
    device = master_link->link_path();
  }
  Recorder out;
  adam_driver::AdamBusDriver driver(loop, settings, device, gateway::serial_line_settings(bus), out);
  driver.start();
  const auto pump_until = [&](auto done, Duration timeout) {
    const auto end = Clock::now() + timeout;
    while (!done()) {
      if (Clock::now() > end) return false;
      loop.run_once(10ms);
    }
    return true;
  };
  if (!pump_until([&] { return driver.ready(); }, 60s)) {
    result.failure = "drives not set up within 60 s";
    return result;
  }
  pump_until([] { return false; }, 200ms);  // settle into steady polling

  // Poll cycle.
  const auto before = driver.statistics().at(0);
  const auto t0 = Clock::now();
  pump_until([] { return false; }, window);
  auto after = driver.statistics().at(0);
  const std::int64_t transactions_per_cycle = 2LL * drives;
  while (after.rx_frames - before.rx_frames < 3 * transactions_per_cycle) {
    loop.run_once(10ms);
    after = driver.statistics().at(0);
  }
  const double cycles =
      static_cast<double>(after.rx_frames - before.rx_frames) / static_cast<double>(transactions_per_cycle);
  result.cycle_ms = ms(Clock::now() - t0) / cycles;

  // Command latency while polling runs.
  std::mt19937 random(42);
  std::uniform_int_distribution<int> gap_us(0, 2000);
  for (int i = 0; i < commands; ++i) {
    motionlcm::gateway_command_t read{};
    read.command_id = 1000 + i;
    read.kind = std::int8_t{motionlcm::gateway_command_t::PARAM_READ};
    read.axes.push_back(motionlcm::axis_command_t{});
    read.axes[0].axis = "a" + std::to_string(1 + i % drives);
    read.num_axes = 1;
    read.param.space = std::int8_t{motionlcm::param_t::MODBUS_REGISTER};
    read.param.index = 0x0098;
    read.param.width = 1;
    out.waiting_for = read.command_id;
    out.done = false;
    const auto queued = Clock::now();
    driver.execute(read);
    if (!pump_until([&] { return out.done; }, 10s)) {
      result.failure = "command " + std::to_string(read.command_id) + " got no reply within 10 s";
      return result;
    }
    if (out.failed) ++result.failed_commands;
    result.latencies_ms.push_back(ms(out.done_at - queued));
    const auto resume = Clock::now() + std::chrono::microseconds(gap_us(random));
    while (Clock::now() < resume) loop.run_once(std::chrono::duration_cast<Duration>(resume - Clock::now()));
  }
  const auto stats = driver.statistics().at(0);
  result.errors = stats.errors;
  result.timeouts = stats.timeouts;
  result.ok = true;
  return result;
}

int run(bool quick) {
  const int commands = quick ? 40 : 200;
  const Duration window = quick ? 300ms : 1s;
  std::printf(
      "ADAM Modbus RTU line: AdamBusDriver (our master) polling N simulated drives (AdamLineSim) on one EventLoop, "
      "over ptys\n");
  std::printf(
      "poll cycle = every drive read once (2 transactions, 38 bytes); bound = bytes x bits/char / baud + t3.5 before "
      "every frame\n");
  std::printf(
      "pty = bytes delivered at once; wire = relay pacing bytes at the baud rate with t3.5 silences (half duplex)\n");
  std::printf(
      "command = PARAM_READ of one register while polling saturates the line, queued -> reply frame complete (wire "
      "model)\n\n");
  std::printf("%4s %7s | %11s | %9s %6s | %9s %6s | %9s | %8s %6s | %8s %6s | %s\n", "N", "baud", "cycle bound",
              "pty ms", "ratio", "wire ms", "ratio", "cmd bound", "cmd p50", "ratio", "cmd p99", "ratio",
              "errors/timeouts/failed");
  std::printf("%.*s\n", 140,
              "--------------------------------------------------------------------------------------------------------"
              "--------------------------------------------");
  bool all_ok = true;
  for (const int baud : {115200, 19200}) {
    rtu::SerialFormat format;
    format.baud = static_cast<std::uint32_t>(baud);
    const Duration t35 = rtu::frame_timing(format).t3_5;
    const auto transaction = [&](std::size_t request, std::size_t reply) {
      return rtu::transmission_time(format, request + reply) + 2 * t35;
    };
    const Duration per_drive = transaction(8, 13) + transaction(8, 9);
    const Duration command = transaction(8, 7);
    for (const int drives : {1, 8, 32}) {
      const double bound = ms(per_drive) * drives;
      const LineResult raw = run_line(drives, baud, false, 0, window);
      const LineResult wire = run_line(drives, baud, true, commands, window);
      if (!raw.ok || !wire.ok) {
        std::printf("%4d %7d | failed: %s%s\n", drives, baud, raw.failure.c_str(), wire.failure.c_str());
        all_ok = false;
        continue;
      }
      const double p50 = nearest_rank(wire.latencies_ms, 0.50);
      const double p99 = nearest_rank(wire.latencies_ms, 0.99);
      std::printf(
          "%4d %7d | %8.2f ms | %9.2f %6.2f | %9.2f %6.2f | %6.2f ms | %8.2f %6.2f | %8.2f %6.2f | %lld/%lld/%lld\n",
          drives, baud, bound, raw.cycle_ms, raw.cycle_ms / bound, wire.cycle_ms, wire.cycle_ms / bound, ms(command),
          p50, p50 / ms(command), p99, p99 / ms(command),
          static_cast<long long>(raw.errors) + static_cast<long long>(wire.errors),
          static_cast<long long>(raw.timeouts) + static_cast<long long>(wire.timeouts),
          static_cast<long long>(wire.failed_commands));
      std::fflush(stdout);
    }
  }
  std::printf("\n%d commands per line; the poll loop's timers keep to the kernel's timer slack (ppoll)\n", commands);
  return all_ok ? 0 : 1;
}

}  // namespace
}  // namespace motion

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  return motion::run(quick);
}
