// UIM342 (SimpleCAN 3.0) benchmark: the gateway's Uim342Stack inside gateway::CanBusDriver, as
// motion-gateway runs it, against simulated UIM342 drives on a simbus hub (sim::CanBusHost with
// sim::uim342_factory, as motion-sim runs them; reply latency 0), all on ONE EventLoop in this
// process. One table; every figure sits next to a bound measured or computed in the same run, and
// their ratio. Nothing is asserted.
//
//   1. Command latency, bus timing OFF (the wire takes no time, so only software remains): a
//      gateway_command_t (ENABLE of one axis: one MO=1 frame) is published on the LCM node of this
//      process (its own URL); the Gateway (lcm::Node + gateway::Gateway, as in motion-gateway)
//      receives it and its first frame goes to the transport. Measured, p50/p99 over M commands:
//        - LCM received -> first frame: from this process's own subscription to GW_COMMAND_can0
//          (registered before the Gateway's, so LCM calls it just before the Gateway's handler)
//          to the transport's send() of the MO frame;
//        - LCM publish -> first frame: the same, from the publish call.
//      Bound: a raw LCM publish -> receive of a message of the same size on the same node and loop,
//      interleaved with the commands (the hop every command pays before the gateway sees it).
//   2. Arm + trigger of N = 2, 8, 32 axes in one UIM342 group at 1 Mbit/s, bus timing ON: an
//      ARM_MOVE with a trigger id is handed to the CanBusDriver; when the stack replies ARMED the
//      bench fires the trigger; measured = from the command to the end of frame of the group BG
//      (the drives' simulated start), p50/p99 over R moves. Bound: the wire time of the frames the
//      move needs (every PA/SP/AC/DC request and ACK, then the one BG), back to back: the sum of
//      can::frame_bits() of those frames / bit rate. Also: frames per synchronized move
//      (arm + BG + the BG's ACKs) and how many other frames (status polls) shared the wire.
//      Two clocks, as bench_canopen: "wall" — the real EventLoop on the steady clock; each
//      request -> ACK hop of a node pays a loop wake-up (what a gateway and motion-sim achieve).
//      "sim" — the same code on a ManualClock advanced in 1 us steps: the protocol's own cost on
//      the wire without wake-up latency (ideal ratio ~1).
//   3. Status polling: N = 8, 32, 120 drives (node ids 5..124) polled at the bus's poll_hz (20),
//      bus timing ON, wall clock, over a window of W seconds: achieved axis state updates per
//      second (one per poll: MS[0] + MS[1], each a request and an ACK) against the rate the bus
//      can carry (bit rate / measured bits per poll frame / 4 frames per update) and the rate
//      asked for (N x poll_hz); and the frames per second the poll needs against the frames per
//      second the bus can carry; the share of the bus the poll frames took (goal >= 90% where
//      N x poll_hz does not fit). Retries, timeouts, late replies are in the note. Then, polls
//      still saturating the bus (N = 120), ENABLE commands (one MO frame) at spread instants:
//      command and hand-over -> MO's start on the wire (hub stamp minus bit time), p50/p99,
//      against one poll request frame, and our poll frames that ended in between.
//
// A plain main instead of Google Benchmark, as simbus_bench and canopen_bench: fixed end-to-end
// workloads whose meaning is the ratio to a bound from the same run.
//
// Usage: bench_uim342 [--quick]   (--quick: fewer commands and moves, shorter status windows)
#include <unistd.h>

#include "uim342_bench_harness.hpp"

namespace motion::uim342_bench {
namespace {

using namespace std::chrono_literals;

// ---- 1. LCM command -> first frame (bus timing off) ----------------------------------------------

void bench_command_latency(bool quick, const std::filesystem::path& dir) {
  const int port = 20000 + (static_cast<int>(::getpid()) * 17 + 11) % 40000;
  const std::string url = "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
  const config::Config config = load(lab_config(4, false, 0, url, "u342lat", dir.string()));
  Pump pump(nullptr);
  EventLoop& loop = pump.loop();
  auto host = open_host(loop, config);

  lcm::Node node(loop, {url, "BENCH_"});
  if (!node.ok()) die("LCM unavailable on " + url);
  // Registered before the Gateway's: called first when a command arrives.
  std::optional<Clock::time_point> received;
  node.subscribe_raw(node.channel(lcm::channels::gateway_command("can0")), [&](const void*, int, const std::string&) {
    if (!received) received = Clock::now();
  });
  std::map<std::int64_t, std::int8_t> terminal;
  node.subscribe<gateway_reply_t>(lcm::channels::kGatewayReply, [&](const gateway_reply_t& r, const std::string&) {
    if (r.status == k(gateway_reply_t::DONE) || r.status == k(gateway_reply_t::FAILED))
      terminal[r.command_id] = r.status;
  });
  std::optional<Clock::time_point> raw_received;
  node.subscribe_raw(node.channel("BENCH_RAW"),
                     [&](const void*, int, const std::string&) { raw_received = Clock::now(); });

  lcm::HealthPublisher health(loop, node, "gateway:can0", "gateway");
  gateway::Gateway gateway(loop, node, health, config, "can0");
  std::optional<Clock::time_point> first_mo;
  bool armed = false;
  auto tap = std::make_unique<TapTransport>(host->hub().attach_local("gateway"), [&](const can::Frame& f) {
    if (!armed || first_mo) return;
    if (const auto m = decode(f); m && is_function(*m, FC::kMO)) first_mo = Clock::now();
  });
  auto driver = std::make_unique<gateway::CanBusDriver>(loop, "can0", std::move(tap), gateway);
  const gateway::Uim342Stack* stack_view = add_uim342_stack(*driver, config);
  gateway.attach(std::move(driver));
  await_set_up(pump, *stack_view, 30s, "latency rig");

  const int commands = quick ? 100 : 1000;
  std::vector<double> recv_to_frame;
  std::vector<double> publish_to_frame;
  std::vector<double> raw;
  const auto probe = command(0, k(gateway_command_t::ENABLE), {"a0"});
  std::vector<std::uint8_t> raw_payload(static_cast<std::size_t>(probe.getEncodedSize()));
  probe.encode(raw_payload.data(), 0, static_cast<int>(raw_payload.size()));
  int failures = 0;
  for (int i = 0; i < commands + 20; ++i) {  // 20 warm-up rounds
    // Raw LCM publish -> receive, same size, same node and loop.
    raw_received.reset();
    const auto raw_t0 = Clock::now();
    node.publish_raw(node.channel("BENCH_RAW"), raw_payload);
    if (!pump.until([&] { return raw_received.has_value(); }, 2s)) die("LCM did not deliver the raw message");
    // The command.
    const std::int64_t id = 1000 + i;
    auto c = command(id, k(gateway_command_t::ENABLE), {"a" + std::to_string(i % 4)});
    received.reset();
    first_mo.reset();
    armed = true;
    const auto t0 = Clock::now();
    node.publish(lcm::channels::gateway_command("can0"), c);
    if (!pump.until([&] { return terminal.contains(id); }, 5s)) die("ENABLE command got no reply");
    armed = false;
    if (terminal[id] != k(gateway_reply_t::DONE) || !received || !first_mo) {
      ++failures;
      continue;
    }
    if (i < 20) continue;
    raw.push_back(us(*raw_received - raw_t0));
    recv_to_frame.push_back(us(*first_mo - *received));
    publish_to_frame.push_back(us(*first_mo - t0));
    pump.until([] { return false; }, 200us);  // let the ACK and any poll settle
  }
  const double raw50 = nearest_rank(raw, 0.5);
  const double raw99 = nearest_rank(raw, 0.99);
  const std::string n = std::to_string(recv_to_frame.size()) + " commands" +
                        (failures ? ", " + std::to_string(failures) + " failed" : "");
  g_rows.push_back({"1. LCM received -> first frame (timing off) p50", fmt("%.1f us", nearest_rank(recv_to_frame, 0.5)),
                    fmt("%.1f us raw LCM pub->recv p50", raw50), nearest_rank(recv_to_frame, 0.5) / raw50,
                    n + "; ENABLE -> MO=1 to the transport; includes waiting for a poll reply in flight"});
  g_rows.push_back({"   LCM received -> first frame p99", fmt("%.1f us", nearest_rank(recv_to_frame, 0.99)),
                    fmt("%.1f us raw LCM pub->recv p99", raw99), nearest_rank(recv_to_frame, 0.99) / raw99, ""});
  g_rows.push_back({"   LCM publish -> first frame p50", fmt("%.1f us", nearest_rank(publish_to_frame, 0.5)),
                    fmt("%.1f us raw LCM pub->recv p50", raw50), nearest_rank(publish_to_frame, 0.5) / raw50,
                    "ideal ~1 + gateway share"});
  g_rows.push_back({"   LCM publish -> first frame p99", fmt("%.1f us", nearest_rank(publish_to_frame, 0.99)),
                    fmt("%.1f us raw LCM pub->recv p99", raw99), nearest_rank(publish_to_frame, 0.99) / raw99, ""});
}

// ---- 2. arm + trigger of N grouped axes (bus timing on) -----------------------------------------

struct ArmResult {
  std::vector<double> to_bg_us;
  std::vector<double> bound_us;
  std::vector<double> frames;        // per move: arm frames + BG + BG ACKs
  std::vector<double> other_frames;  // per move: polls and others in the same window
  bool group_bg = true;              // every move started on one group BG
  int failures = 0;
};

ArmResult run_arm(int axes, bool simulated, int moves, const std::filesystem::path& dir) {
  const std::string hub = std::string("u342arm") + (simulated ? "s" : "w") + std::to_string(axes);
  const config::Config config =
      load(lab_config(axes, true, kGroupId, "udpm://239.255.76.67:7667?ttl=0", hub, dir.string()));
  ManualClock manual(TimePoint{} + std::chrono::hours(1));
  Pump pump(simulated ? &manual : nullptr);
  EventLoop& loop = pump.loop();
  auto host = open_host(loop, config);
  // The hub stamps frames with epoch_offset + steady us (set from the wall clock when it opened):
  // the same offset, taken now, maps loop time onto frame timestamps (to a few us).
  const std::int64_t epoch_offset = wall_time_us() - steady_us(loop.now());

  auto monitor = host->hub().attach_local("monitor");
  std::vector<can::Frame> seen;
  loop.watch(monitor->fd(), [&] {
    while (auto f = monitor->receive()) seen.push_back(*f);
  });
  Capture out;
  gateway::CanBusDriver driver(loop, "can0", host->hub().attach_local("gateway"), out);
  const gateway::Uim342Stack* stack_view = add_uim342_stack(driver, config);
  driver.start();
  await_set_up(pump, *stack_view, 60s, "arm rig, N=" + std::to_string(axes));
  std::vector<std::string> names;
  names.reserve(static_cast<std::size_t>(axes));
  for (int n = 0; n < axes; ++n) names.push_back("a" + std::to_string(n));
  {
    const auto enable = command(1, k(gateway_command_t::ENABLE), names);
    driver.execute(enable);
    if (!pump.until([&] { return out.has(1, k(gateway_reply_t::DONE)) || out.failed(1); }, 10s) || out.failed(1))
      die("enable failed");
  }

  ArmResult result;
  for (int m = 0; m < moves; ++m) {
    pump.until([] { return false; }, 3ms);  // the previous move's last frames go by
    const std::int64_t id = 100 + m;
    auto c = command(id, k(gateway_command_t::ARM_MOVE), names);
    c.trigger_id = id;
    for (int n = 0; n < axes; ++n) {
      auto& a = c.axes[static_cast<std::size_t>(n)];
      a.target_counts = std::int64_t{m % 2 == 0 ? 1 : 0} * (1600 + 64 * n);  // out and back
      a.velocity = 64'000;
      a.acceleration = 256'000;
      a.deceleration = 256'000;
    }
    seen.clear();
    const TimePoint t0 = loop.now();
    driver.execute(c);
    if (!pump.until([&] { return out.has(id, k(gateway_reply_t::ARMED)) || out.failed(id); }, 10s) || out.failed(id)) {
      ++result.failures;
      continue;
    }
    driver.fire(id);
    if (!pump.until([&] { return out.has(id, k(gateway_reply_t::DONE)) || out.failed(id); }, 20s) || out.failed(id)) {
      ++result.failures;
      continue;
    }
    // The frames of this move, from the monitor (end-of-frame timestamps).
    std::optional<std::int64_t> bg_eof;
    int bg_requests = 0;
    for (const auto& f : seen) {
      const auto msg = decode(f);
      if (msg && is_function(*msg, FC::kBG) && msg->address.producer == uim342::kMasterId) {
        ++bg_requests;
        if (!bg_eof) bg_eof = f.timestamp_us;
        if (msg->address.consumer != kGroupId) result.group_bg = false;
      }
    }
    if (!bg_eof || bg_requests != 1) result.group_bg = false;
    if (!bg_eof) {
      ++result.failures;
      continue;
    }
    std::uint64_t bound_bits = 0;
    int move_frames = 0;
    int bg_acks = 0;
    int others = 0;
    for (const auto& f : seen) {
      const auto msg = decode(f);
      const bool move_frame =
          msg && (is_function(*msg, FC::kPA) || is_function(*msg, FC::kSP) || is_function(*msg, FC::kAC) ||
                  is_function(*msg, FC::kDC) || is_function(*msg, FC::kBG));
      if (msg && is_function(*msg, FC::kBG) && msg->address.producer != uim342::kMasterId) {
        ++bg_acks;  // after the start: not part of the bound
        continue;
      }
      if (f.timestamp_us > *bg_eof) continue;
      if (!move_frame) {
        ++others;
        continue;
      }
      ++move_frames;
      const auto bits = can::frame_bits(f);
      bound_bits += f.timestamp_us == *bg_eof ? bits.to_end_of_frame() : bits.total;
    }
    const double to_bg = static_cast<double>(*bg_eof - (steady_us(t0) + epoch_offset));
    result.to_bg_us.push_back(to_bg);
    result.bound_us.push_back(us(can::bits_duration(bound_bits, kBitrate)));
    result.frames.push_back(move_frames + bg_acks);
    result.other_frames.push_back(others);
  }
  loop.unwatch(monitor->fd());
  return result;
}

void bench_arm(bool quick, const std::filesystem::path& dir) {
  for (const int axes : {2, 8, 32}) {
    for (const bool simulated : {false, true}) {
      const int moves = quick ? 6 : (simulated ? 20 : 40);
      const ArmResult r = run_arm(axes, simulated, moves, dir);
      const double p50 = nearest_rank(r.to_bg_us, 0.5);
      const double p99 = nearest_rank(r.to_bg_us, 0.99);
      const double bound = nearest_rank(r.bound_us, 0.5);
      char note[200];
      std::snprintf(note, sizeof note,
                    "%s; %.0f frames/move (min %d); %.0f poll/other frames on the wire meanwhile%s%s",
                    r.group_bg ? "one group BG per move" : "NOT one group BG", nearest_rank(r.frames, 0.5),
                    9 * axes + 1, nearest_rank(r.other_frames, 0.5), r.failures ? "; failures: " : "",
                    r.failures ? std::to_string(r.failures).c_str() : "");
      const std::string clock = simulated ? "sim " : "wall";
      g_rows.push_back({"2. arm+trigger N=" + std::to_string(axes) + " (" + clock + ") command -> BG p50",
                        fmt("%.2f ms", p50 / 1000.0), fmt("%.2f ms wire of the move frames", bound / 1000.0),
                        p50 / bound, note});
      g_rows.push_back({"   N=" + std::to_string(axes) + " (" + clock + ") command -> BG p99",
                        fmt("%.2f ms", p99 / 1000.0), fmt("%.2f ms", bound / 1000.0), p99 / bound,
                        std::to_string(r.to_bg_us.size()) + " moves"});
    }
  }
}

}  // namespace
}  // namespace motion::uim342_bench

int main(int argc, char** argv) {
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else {
      std::fprintf(stderr, "usage: bench_uim342 [--quick]\n");
      return 2;
    }
  }
  std::error_code error;
  const auto dir = std::filesystem::temp_directory_path() / ("uim342-bench-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir, error);
  std::printf(
      "bench_uim342: command latency (timing off), arm+trigger N=2/8/32, status N=8/32/120; %u bit/s, poll %d Hz%s\n",
      motion::uim342_bench::kBitrate, motion::uim342_bench::kPollHz, quick ? " (quick)" : "");
  std::fflush(stdout);
  motion::uim342_bench::bench_command_latency(quick, dir);
  motion::uim342_bench::bench_arm(quick, dir);
  for (const int axes : {8, 32, 120}) motion::uim342_bench::bench_status(axes, quick, dir);
  std::filesystem::remove_all(dir, error);
  motion::uim342_bench::print_table();
  return 0;
}
