// Simulated CAN bus (motion::simbus) benchmark: one table, every number next to a bound measured
// or computed in the same run, and their ratio.
//
//   1. Unix-socket path, timing model off: frames/s and one-way latency (p50/p99) from one
//      SocketEndpoint to another through a Hub running its own EventLoop in another thread, over
//      the real SOCK_SEQPACKET sockets. Bound: a bare relay thread (recv + send, no simbus) over
//      socketpairs, driven by the same client loop.
//   2. Frame length of 8-byte data frames, 11- and 29-bit ids: the bit-timing model against an
//      independent implementation of the ISO 11898-1 layout (nominal 47+8n / 67+8n bits plus the
//      stuff bits of the actual bit stream), and against the worst-case closed form
//      8n+47+floor((34+8n-1)/4) / 8n+67+floor((54+8n-1)/4) (Davis et al. 2007). Model and spec
//      must agree within 2 % (exit 1 otherwise).
//   3. Timing on at 125 k, 500 k and 1 M bit/s: back-to-back 8-byte frames, measured rate (in
//      simulated time from the frames' end-of-frame stamps, and in wall-clock time) against
//      bitrate / frame bits.
//   4. CPU cost of the model: frame_bits() and Bus::submit()+advance() per frame, against the wire
//      time of the same frame at 1 Mbit/s (the fraction of one core a full 1 Mbit/s bus costs).
//
// A plain main instead of Google Benchmark: the results are end-to-end runs with fixed workloads
// (percentiles, frames lost, rates from simulated timestamps) whose meaning is the ratio to a
// bound from the same run; Google Benchmark's repeat-until-stable per-iteration timing fits only
// the CPU-cost part, which is timed here the same way (best of 5 repetitions of a fixed loop).
//
// Usage: bench_simbus [--quick]   (--quick: ~10x fewer frames, for a smoke run)
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "motion/can_frame/bit_timing.hpp"
#include "motion/can_frame/frame.hpp"
#include "motion/core/clock.hpp"
#include "motion/simbus/bus.hpp"
#include "simbus_bench_links.hpp"

namespace motion::simbus {
namespace {

using bench::Clock;
using bench::HubThread;
using bench::one_way_latency;
using bench::Percentiles;
using bench::RawRelayLink;
using bench::SimLink;
using bench::stream;
using bench::StreamResult;

double to_us(Duration d) { return std::chrono::duration<double, std::micro>(d).count(); }

bool g_failed = false;

// ---- independent frame length (ISO 11898-1), written from the spec, not from bit_timing.cpp ----

struct SpecBits {
  std::uint32_t nominal = 0;  // fixed-form bits incl. CRC delimiter, ACK, EOF and 3-bit IFS, no stuffing
  std::uint32_t stuff = 0;    // stuff bits of this frame's actual bit stream
  std::uint32_t worst = 0;    // closed-form worst case
  [[nodiscard]] std::uint32_t actual() const { return nominal + stuff; }
};

SpecBits spec_frame_bits(const can::Frame& f) {
  const std::uint32_t n = f.rtr ? 0U : f.dlc;
  // The bit stream from SOF to the end of the CRC sequence.
  std::vector<bool> bits;
  auto put = [&bits](std::uint32_t value, int width) {
    for (int i = width - 1; i >= 0; --i) bits.push_back(((value >> static_cast<unsigned>(i)) & 1U) != 0);
  };
  put(0, 1);  // SOF, dominant
  if (f.extended) {
    put(f.id >> 18, 11);
    put(1, 1);  // SRR, recessive
    put(1, 1);  // IDE, recessive
    put(f.id & 0x3FFFF, 18);
    put(f.rtr ? 1 : 0, 1);
    put(0, 2);  // r1 r0
  } else {
    put(f.id, 11);
    put(f.rtr ? 1 : 0, 1);
    put(0, 1);  // IDE, dominant
    put(0, 1);  // r0
  }
  put(f.dlc, 4);
  for (std::uint32_t i = 0; i < n; ++i) put(f.data[i], 8);
  // CRC-15, generator x^15+x^14+x^10+x^8+x^7+x^4+x^3+1 (ISO 11898-1 10.4.2.6 pseudo-code).
  std::uint32_t crc = 0;
  for (const bool bit : bits) {
    const bool crc_next = bit != (((crc >> 14) & 1U) != 0);
    crc = (crc << 1) & 0x7FFFU;
    if (crc_next) crc ^= 0x4599U;
  }
  put(crc, 15);
  // Emit the stuffed stream: after five equal bits a complementary bit is inserted (and counts
  // towards the next run).
  std::vector<bool> stuffed;
  int run = 0;
  bool last = false;
  for (const bool bit : bits) {
    run = (!stuffed.empty() && bit == last) ? run + 1 : 1;
    stuffed.push_back(bit);
    last = bit;
    if (run == 5) {
      stuffed.push_back(!bit);
      last = !bit;
      run = 1;
    }
  }
  const std::uint32_t header = f.extended ? 67 : 47;  // all fixed bits with 0 data bytes, IFS included
  const std::uint32_t stuffable = f.extended ? 54 : 34;
  SpecBits out;
  out.nominal = header + 8 * n;
  out.stuff = static_cast<std::uint32_t>(stuffed.size() - bits.size());
  out.worst = out.nominal + (stuffable + 8 * n - 1) / 4;
  if (out.nominal - 13 != bits.size()) {  // 13 = CRC delimiter, ACK slot and delimiter, EOF, IFS
    std::printf("BUG: spec layout has %zu bits, expected %u\n", bits.size(), out.nominal - 13);
    g_failed = true;
  }
  return out;
}

can::Frame data_frame(std::uint32_t id, bool extended, std::array<std::uint8_t, 8> payload) {
  auto f = can::Frame::make(id, extended, payload);
  return *f;
}

// ---- CPU cost ----------------------------------------------------------------------------------

class CountingSink final : public BusSink {
 public:
  void deliver(EndpointId, const can::Frame& frame, bool) override { sum += frame.dlc; }
  void notify(EndpointId, const can::BusEvent&) override {}
  std::uint64_t sum = 0;
};

// Best of 5 repetitions of `body(iterations)`, in ns per iteration.
template <typename F>
double best_ns_per_op(std::uint64_t iterations, F&& body) {
  double best = 1e300;
  for (int rep = 0; rep < 5; ++rep) {
    const auto t0 = Clock::now();
    body(iterations);
    const double ns =
        std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / static_cast<double>(iterations);
    best = std::min(best, ns);
  }
  return best;
}

double bus_cost_ns(const can::Frame& frame, bool timing, std::uint64_t iterations) {
  return best_ns_per_op(iterations, [&](std::uint64_t n) {
    BusConfig config;
    config.bitrate = 1'000'000;
    config.timing = timing;
    config.max_queued = 1 << 20;
    Bus bus(config);
    const EndpointId tx = bus.attach("tx");
    bus.attach("rx");
    CountingSink sink;
    TimePoint now{};
    const Duration step = can::frame_duration(frame, config.bitrate);
    for (std::uint64_t i = 0; i < n; ++i) {
      (void)bus.submit(tx, frame, now);
      now += step;  // back-to-back: the previous frame has just left the wire
      bus.advance(now, sink);
    }
    if (sink.sum == 0) std::printf(" ");  // keeps the deliveries observable
  });
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string one;
  in >> one;
  return one.empty() ? "?" : one;
}

void check(bool ok, const char* what) {
  if (!ok) {
    std::printf("CHECK FAILED: %s\n", what);
    g_failed = true;
  }
}

int run(bool quick) {
  const double scale = quick ? 0.1 : 1.0;
  std::printf("simbus benchmark: %u CPUs, load average %s at start%s\n", std::thread::hardware_concurrency(),
              load_average().c_str(), quick ? " (--quick)" : "");

  char tmpl[] = "/tmp/bench-simbus-XXXXXX";
  const char* made = ::mkdtemp(tmpl);
  if (made == nullptr) {
    std::perror("mkdtemp");
    return 2;
  }
  const std::filesystem::path dir = made;

  const auto payload = std::array<std::uint8_t, 8>{0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE, 0xF0};
  const can::Frame std8 = data_frame(0x123, false, payload);
  const can::Frame ext8 = data_frame(0x04280095, true, payload);

  // 1. Socket path, timing off. The machine is shared, so simbus and its bound are measured in
  // turn, three times each, and the best of each is kept.
  {
    const auto frames = static_cast<std::uint64_t>(100'000 * scale);
    const int latency_samples = static_cast<int>(3000 * scale);
    constexpr std::uint64_t kWindow = 128;
    constexpr int kRounds = 3;
    double raw_fps = 0;
    double sim_fps = 0;
    Percentiles raw_latency{1e300, 1e300, 0};
    Percentiles sim_latency{1e300, 1e300, 0};
    std::uint64_t lost = 0;
    auto keep_best = [](Percentiles& best, const Percentiles& p) {
      best.p50 = std::min(best.p50, p.p50);
      best.p99 = std::min(best.p99, p.p99);
      best.samples += p.samples;
    };
    BusConfig config;
    config.timing = false;
    HubThread hub(dir, "bench-untimed", config);
    for (int round = 0; round < kRounds; ++round) {
      {
        RawRelayLink link;
        stream(link, std8, frames / 10, kWindow, std::chrono::seconds(10));  // warm-up
        const auto r = stream(link, std8, frames, kWindow, std::chrono::seconds(60));
        raw_fps = std::max(raw_fps, static_cast<double>(r.received) / r.wall_s);
        keep_best(raw_latency, one_way_latency(link, std8, latency_samples));
      }
      {
        SimLink link(dir, "bench-untimed");
        stream(link, std8, frames / 10, kWindow, std::chrono::seconds(10));
        const auto r = stream(link, std8, frames, kWindow, std::chrono::seconds(60));
        sim_fps = std::max(sim_fps, static_cast<double>(r.received) / r.wall_s);
        lost += r.sent - r.received;
        keep_best(sim_latency, one_way_latency(link, std8, latency_samples));
      }
    }
    std::printf(
        "\n== 1. Unix-socket path, timing model off: endpoint -> hub thread -> endpoint; bound: a bare relay thread\n"
        "      (recv, decode, encode, send; no bus) on socketpairs, same client loop; best of %d alternating runs ==\n",
        kRounds);
    std::printf("%-34s %14s %14s %8s\n", "", "simbus", "bound", "ratio");
    std::printf("%-34s %14.0f %14.0f %8.3f   (%llu frames per run, window %llu, lost %llu)\n", "throughput, frames/s",
                sim_fps, raw_fps, sim_fps / raw_fps, static_cast<unsigned long long>(frames),
                static_cast<unsigned long long>(kWindow), static_cast<unsigned long long>(lost));
    std::printf("%-34s %14.1f %14.1f %8.2f   (%d samples per run)\n", "one-way latency p50, us", sim_latency.p50,
                raw_latency.p50, sim_latency.p50 / raw_latency.p50, latency_samples);
    std::printf("%-34s %14.1f %14.1f %8.2f\n", "one-way latency p99, us", sim_latency.p99, raw_latency.p99,
                sim_latency.p99 / raw_latency.p99);
    check(lost == 0, "no frame lost on the untimed bus");
  }

  // 2. Frame length: model against the spec.
  std::printf("\n== 2. Frame length, 8-byte data frames, bits incl. 3-bit interframe space ==\n");
  std::printf("%-7s %-18s %6s %8s %6s %8s %10s %8s\n", "format", "payload", "model", "spec", "ratio", "stuff",
              "worst(*)", "m/worst");
  struct Case {
    const char* name;
    std::array<std::uint8_t, 8> bytes;
  };
  const Case cases[] = {{"12 34 .. F0 (run)", payload},
                        {"00 x8", {}},
                        {"FF x8", {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}},
                        {"55 x8", {0x55, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55}},
                        {"0F x8", {0x0F, 0x0F, 0x0F, 0x0F, 0x0F, 0x0F, 0x0F, 0x0F}},
                        {"3C x8", {0x3C, 0x3C, 0x3C, 0x3C, 0x3C, 0x3C, 0x3C, 0x3C}}};
  double worst_ratio = 0;
  for (const bool extended : {false, true}) {
    for (const auto& c : cases) {
      const can::Frame f = data_frame(extended ? 0x04280095U : 0x123U, extended, c.bytes);
      const can::FrameBits model = can::frame_bits(f);
      const SpecBits spec = spec_frame_bits(f);
      const double ratio = static_cast<double>(model.total) / static_cast<double>(spec.actual());
      worst_ratio = std::max(worst_ratio, std::abs(ratio - 1.0));
      std::printf("%-7s %-18s %6u %8u %6.4f %8u %10u %8.3f\n", extended ? "29-bit" : "11-bit", c.name, model.total,
                  spec.actual(), ratio, model.stuff, spec.worst,
                  static_cast<double>(model.total) / static_cast<double>(spec.worst));
      check(model.stuff == spec.stuff, "stuff bits: model == independent bit stream");
    }
    // The longest 8-byte frame the model finds over a pseudo-random search (ids and payloads).
    std::uint32_t longest = 0;
    std::uint64_t x = 0x9E3779B97F4A7C15ULL;
    for (int i = 0; i < static_cast<int>(200'000 * scale); ++i) {
      x ^= x << 13;
      x ^= x >> 7;
      x ^= x << 17;
      std::array<std::uint8_t, 8> bytes{};
      for (std::size_t b = 0; b < 8; ++b)
        bytes[b] = static_cast<std::uint8_t>((x >> (8 * b)) & (i % 2 == 0 ? 0xFFU : 0x0FU));
      const auto id = static_cast<std::uint32_t>(x >> 35) & (extended ? can::kMaxExtendedId : can::kMaxStandardId);
      const can::Frame f = data_frame(i % 3 == 0 ? 0 : id, extended, bytes);
      longest = std::max(longest, can::frame_bits(f).total);
    }
    const SpecBits spec = spec_frame_bits(data_frame(0, extended, {}));
    std::printf("%-7s %-18s %6u %8s %6s %8s %10u %8.3f\n", extended ? "29-bit" : "11-bit", "longest in search", longest,
                "-", "-", "-", spec.worst, static_cast<double>(longest) / static_cast<double>(spec.worst));
    check(longest <= spec.worst, "no frame longer than the worst-case bound");
  }
  std::printf(
      "(*) worst case 8n+47+floor((34+8n-1)/4) (11-bit), 8n+67+floor((54+8n-1)/4) (29-bit); max |model/spec - 1| = "
      "%.4f\n",
      worst_ratio);
  check(worst_ratio <= 0.02, "model and spec frame lengths agree within 2 %");

  // 3. Timing on: back-to-back frames against bitrate / frame bits.
  std::printf("\n== 3. Bit-timed wire, back-to-back 8-byte frames (payload 12 34 .. F0), ~%.1f s per row ==\n",
              1.0 * scale);
  std::printf("%-8s %-7s %5s %10s | %10s %7s | %10s %7s | %5s\n", "bit/s", "format", "bits", "max fr/s", "sim-time",
              "ratio", "wall", "ratio", "lost");
  for (const std::uint32_t bitrate : {125'000U, 500'000U, 1'000'000U}) {
    for (const bool extended : {false, true}) {
      const can::Frame& f = extended ? ext8 : std8;
      const std::uint32_t bits = can::frame_bits(f).total;
      const double max_fps = static_cast<double>(bitrate) / static_cast<double>(bits);
      const auto count = static_cast<std::uint64_t>(std::max(50.0, max_fps * scale));
      BusConfig config;
      config.bitrate = bitrate;
      config.timing = true;
      const std::string name = "bench-" + std::to_string(bitrate) + (extended ? "-ext" : "-std");
      HubThread hub(dir, name, config);
      SimLink link(dir, name);
      // A deep window (~0.1 s of wire at 1 Mbit/s) so that a descheduled sender does not let the wire run dry.
      const StreamResult r = stream(link, f, count, 1024, std::chrono::seconds(30));
      const double sim_s = static_cast<double>(r.last_ts_us - r.first_ts_us) * 1e-6;
      const double sim_fps = r.received > 1 ? static_cast<double>(r.received - 1) / sim_s : 0;
      const double wall_fps = static_cast<double>(r.received) / r.wall_s;
      std::printf("%-8u %-7s %5u %10.1f | %10.1f %7.4f | %10.1f %7.4f | %5llu\n", bitrate,
                  extended ? "29-bit" : "11-bit", bits, max_fps, sim_fps, sim_fps / max_fps, wall_fps,
                  wall_fps / max_fps, static_cast<unsigned long long>(r.sent - r.received));
      check(r.received == r.sent, "no frame lost on the timed bus");
      check(std::abs(sim_fps / max_fps - 1.0) <= 0.02, "simulated-time rate within 2 % of bitrate / frame bits");
    }
  }
  {
    // One-way latency with timing on, 1 Mbit/s: bound = the frame's time to its end of frame.
    BusConfig config;
    config.bitrate = 1'000'000;
    HubThread hub(dir, "bench-latency", config);
    SimLink link(dir, "bench-latency");
    const Percentiles p = one_way_latency(link, std8, static_cast<int>(1000 * scale));
    const double eof_us = to_us(can::bits_duration(can::frame_bits(std8).to_end_of_frame(), config.bitrate));
    std::printf(
        "one-way latency at 1 Mbit/s, 11-bit: p50 %.1f us, p99 %.1f us; wire time to end of frame %.1f us; ratio p50 "
        "%.2f, p99 %.2f "
        "(%zu samples)\n",
        p.p50, p.p99, eof_us, p.p50 / eof_us, p.p99 / eof_us, p.samples);
  }

  // 4. CPU cost of the model.
  {
    const auto iterations = static_cast<std::uint64_t>(200'000 * scale);
    std::uint64_t guard = 0;
    const double bits_ns = best_ns_per_op(iterations, [&](std::uint64_t n) {
      can::Frame f = std8;
      for (std::uint64_t i = 0; i < n; ++i) {
        f.data[0] = static_cast<std::uint8_t>(i);
        guard += can::frame_bits(f).total;
      }
    });
    const double timed_ns = bus_cost_ns(std8, true, iterations);
    const double untimed_ns = bus_cost_ns(std8, false, iterations);
    const double wire_ns = static_cast<double>(can::frame_duration(std8, 1'000'000).count());
    std::printf(
        "\n== 4. CPU cost of the model, ns per frame (best of 5 x %llu); bound: the frame's wire time at 1 Mbit/s, "
        "%.0f ns ==\n",
        static_cast<unsigned long long>(iterations), wire_ns);
    std::printf("%-44s %10.1f   ratio %.5f\n", "frame_bits() (bit-exact length, CRC, stuffing)", bits_ns,
                bits_ns / wire_ns);
    std::printf("%-44s %10.1f   ratio %.5f\n", "Bus::submit()+advance(), timing on, 1 rx", timed_ns,
                timed_ns / wire_ns);
    std::printf("%-44s %10.1f   ratio %.5f\n", "Bus::submit()+advance(), timing off, 1 rx", untimed_ns,
                untimed_ns / wire_ns);
    if (guard == 0) std::printf(" ");
  }

  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::printf("\nload average %s at end; %s\n", load_average().c_str(),
              g_failed ? "CHECKS FAILED" : "all checks passed");
  return g_failed ? 1 : 0;
}

}  // namespace
}  // namespace motion::simbus

int main(int argc, char** argv) {
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else {
      std::fprintf(stderr, "usage: %s [--quick]\n", argv[0]);
      return 2;
    }
  }
  return motion::simbus::run(quick);
}
