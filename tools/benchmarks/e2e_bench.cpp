// End-to-end benchmark on the simulated lab (config/sim-lab.yaml): one table, every figure next to
// a bound measured in the same run, and their ratio.
//
//   1. Raw LCM round trip: publish -> an echo thread (its own LCM instance on the same URL) ->
//      back, p50/p99 over `pings`. The floor of any request/reply over LCM.
//   2. Client request -> STARTED reply latency of a synchronized x+y move (UIM342 group, can0,
//      one BG frame), p50/p99 over `moves` moves, against (i) the raw round trip (a move needs
//      about three: request/reply, arm/armed, trigger/started) and (ii) the wire time at the bus
//      bitrate of the 29-bit (UIM342) CAN frames seen on can0 between the request and STARTED,
//      read from an endpoint of our own on the simulated bus (includes the status polls that fall
//      into the window).
//   2b. Client request -> STARTED of a move across two buses, x+y (can0, one BG) + c (rs485, ADAM
//      broadcast), p50/p99 over `moves` moves after 10 warm-up moves (the coordinator's trigger lead
//      adapts once each bus has 8 TRIGGER_HEARD samples), against the issue 17 bound
//      1.5 x (wire time of the move's frames + the trigger lead in force), per move: the wire time is
//      the slower bus's, can0's 29-bit frames as in 2, rs485's the line time of arming c
//      (ARM_TIMING arm_line_us, from its gateway's frames) plus its start frame (SYNC_TRIGGER2
//      lead_us); the lead in force is the trigger's first send_utime minus its utime.
//   3. Start skew: the coordinator's measured_start_skew_us on one bus (x, y, a, b on can0: BG +
//      SYNC), across two buses (+ c on rs485) and across three (+ u on rs232), against the ground
//      truth of the simulated drives (spread of the SIM_REPORT MOTION_STARTED frame times). Bounds:
//      one bus, (k - 1) frame times + 50 us for its k = 2 start frames (the SYNC's wire time after
//      the BG, can::frame_duration at the bus's bit rate); across buses, the 200 us goal
//      plus the spread the coordinator's schedule predicts (SYNC_TRIGGER2, 0 when absent).
//      MOTION_BIN_DIR=<another build>/bin runs the same measurement against other binaries (e.g.
//      main's, for a before/after in one sitting); BENCH_E2E_CONFIG=<file> against a variant of
//      the lab's configuration (the same buses, drives and axis names; e.g. other bus keys);
//      --set BUS.KEY=VALUE changes one key of one bus of it (e.g. --set rs485.baud=19200
//      --set can0.bitrate=500000, the baud and bit-rate matrix) without a file of its own.
//      Across buses the bench also prints the moves over the bound and the worst one: with N
//      moves the p99 is interpolated between the two worst of every hundred, so a p99 goal holds
//      when fewer than N / 100 moves exceed it (--moves 300 gives a p99 that one host hiccup does
//      not decide). BENCH_E2E_VERBOSE=1 prints each move's starts against x's
//      and keeps the programs' logs. --realtime P: every bus gets `realtime_priority: P` (its
//      gateway's loop under SCHED_FIFO); motion-sim stays under normal scheduling: a simulated
//      serial line's bytes reach its reading thread through the pty's kernel worker, a thread of
//      normal priority that a real-time simulator would hold back (bench_line_hop's real-time
//      sitting), while the simulated CAN bus dates frames by the kernel's send stamp. 0, the
//      default, is normal scheduling for all.
//
// The processes run on their own LCM URL and simulation directory and are killed at the end (also
// when this process dies: PR_SET_PDEATHSIG). A plain main, not Google Benchmark: fixed end-to-end
// workloads whose meaning is the ratio to bounds from the same run.
//
// Usage: bench_e2e [--quick] [--skew-only] [--moves N] [--realtime P] [--set BUS.KEY=VALUE ...]
//        (--quick: 10 moves instead of 50, 4 skew moves instead of 12; --skew-only: part 3 only,
//        30 skew moves per group unless --quick; --moves N: N skew moves per group)
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <motionlcm/arm_timing_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/sim_report_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>
#include <motionlcm/trigger_heard_t.hpp>

#include "bench_process.hpp"
#include "config_edit.hpp"
#include "host_stalls.hpp"
#include "motion/can_frame/bit_timing.hpp"
#include "motion/canopen/sync.hpp"
#include "motion/client/client.hpp"
#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/node.hpp"
#include "motion/simbus/endpoint.hpp"

namespace motion::bench {
namespace {

using motionlcm::reply_t;
using motionlcm::request_t;
using Values = std::map<std::string, double>;

struct Row {
  std::string what;
  double p50 = NAN;
  double p99 = NAN;
  std::string bound;
  double bound_p50 = NAN;
  bool p99_ratio = false;  // print p50 and p99 each over the bound
};

// The load average over the last minute, as /proc/loadavg gives it (NAN when unreadable).
double load_average() {
  std::FILE* f = std::fopen("/proc/loadavg", "r");
  double load = NAN;
  if (f != nullptr) {
    if (std::fscanf(f, "%lf", &load) != 1) load = NAN;
    std::fclose(f);
  }
  return load;
}

// `serial_link`: simulation.serial_link for the run (empty: the configuration's).
int run(bool quick, bool skew_only, int skew_moves, int realtime, std::vector<std::string> sets,
        const std::string& serial_link) {
  std::string config_path = MOTION_E2E_CONFIG;
  if (const char* env = std::getenv("BENCH_E2E_CONFIG")) config_path = env;
  std::string yaml;
  {
    std::ifstream in(config_path);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in) {
      std::fprintf(stderr, "bench_e2e: cannot read %s\n", config_path.c_str());
      return 3;
    }
    yaml = text.str();
  }
  if (realtime > 0) {  // every bus of the configuration, before any --set of the command line
    auto plain = config::load_string(yaml, config_path);
    if (!plain.ok()) {
      std::fprintf(stderr, "%s\n", plain.error_text().c_str());
      return 3;
    }
    std::vector<std::string> rt;
    for (const auto& bus : plain.config->buses)
      rt.push_back(bus.name + ".realtime_priority=" + std::to_string(realtime));
    sets.insert(sets.begin(), rt.begin(), rt.end());
  }
  for (const auto& spec : sets) {
    if (const auto why = set_bus_key(yaml, spec); !why.empty()) {
      std::fprintf(stderr, "bench_e2e: %s\n", why.c_str());
      return 2;
    }
  }
  const bool changed = !sets.empty() || !serial_link.empty();
  if (!serial_link.empty()) set_simulation_key(yaml, "serial_link", serial_link);
  auto loaded = config::load_string(yaml, config_path);
  if (!loaded.ok()) {
    std::fprintf(stderr, "%s\n", loaded.error_text().c_str());
    return 3;
  }
  const config::Config cfg = *loaded.config;
  const int port = 20000 + (static_cast<int>(::getpid()) * 13 + 5) % 40000;
  const std::string url = "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
  char tmpl[] = "/tmp/motion-bench-e2e-XXXXXX";
  const char* made = ::mkdtemp(tmpl);
  if (made == nullptr) return 1;
  const std::string dir = made;
  const std::string sim_dir = dir + "/sim";
  if (changed) {  // the programs read the changed configuration from the run's directory
    config_path = dir + "/lab.yaml";
    std::ofstream(config_path) << yaml;
  }
  std::string bin = MOTION_E2E_BIN_DIR;
  if (const char* env = std::getenv("MOTION_BIN_DIR")) bin = env;

  EventLoop loop;
  lcm::Node node(loop, {url, cfg.lcm.channel_prefix});
  if (!node.ok()) {
    std::fprintf(stderr, "LCM unavailable on %s\n", url.c_str());
    return 4;
  }
  client::Client client(loop, node, "bench-e2e");
  std::map<std::string, motionlcm::health_t> health;
  node.subscribe<motionlcm::health_t>(lcm::channels::kHealth,
                                      [&](const motionlcm::health_t& h, const std::string&) { health[h.process] = h; });
  std::vector<motionlcm::sim_report_t> reports;
  node.subscribe<motionlcm::sim_report_t>(lcm::channels::kSimReport,
                                          [&](const motionlcm::sim_report_t& r, const std::string&) {
                                            if (r.kind == motionlcm::sim_report_t::MOTION_STARTED) reports.push_back(r);
                                          });
  std::vector<motionlcm::sync_trigger2_t> scheduled;
  std::map<std::string, motionlcm::arm_timing_t> arming;  // axis -> its ARM_TIMING
  // TRIGGER_HEARD of triggers of several buses (gateways that publish it): how long each took to be
  // heard, and how many were heard after their bus's send time (fired late).
  std::map<std::int64_t, int> trigger_buses;  // trigger id -> its number of buses
  std::vector<double> heard_delay;
  int heard_late = 0;
  node.subscribe<motionlcm::trigger_heard_t>(lcm::channels::kTriggerHeard,
                                             [&](const motionlcm::trigger_heard_t& h, const std::string&) {
                                               const auto it = trigger_buses.find(h.trigger_id);
                                               if (it == trigger_buses.end() || it->second < 2) return;
                                               heard_delay.push_back(static_cast<double>(h.utime - h.trigger_utime));
                                               if (h.utime > h.send_utime) ++heard_late;
                                             });
  node.subscribe<motionlcm::arm_timing_t>(
      lcm::channels::kArmTiming, [&](const motionlcm::arm_timing_t& t, const std::string&) { arming[t.axis] = t; });
  node.subscribe<motionlcm::sync_trigger2_t>(lcm::channels::kSyncTrigger2,
                                             [&](const motionlcm::sync_trigger2_t& t, const std::string&) {
                                               scheduled.push_back(t);
                                               trigger_buses[t.trigger_id] = t.num_buses;
                                             });

  LabPrograms programs(bin, config_path, url, sim_dir, dir);
  programs.start("sim", "motion-sim", {}, 0);  // normal scheduling even with --realtime (see the top)
  const auto wait = [&](const std::function<bool()>& done, int seconds) {
    return client.wait_until(done, std::chrono::seconds(seconds));
  };
  int rc = 0;
  std::vector<Row> rows;
  const auto fail = [&](const std::string& why) {
    std::fprintf(stderr, "bench_e2e: %s (logs in %s)\n", why.c_str(), dir.c_str());
    rc = 1;
  };
  do {
    if (!wait([&] { return health.contains("sim"); }, 20)) {
      fail("no heartbeat from motion-sim");
      break;
    }
    for (const auto& bus : cfg.buses) programs.start("gateway:" + bus.name, "motion-gateway", {"--bus", bus.name});
    programs.start("coordinator", "motion-coordinator", {});
    const auto ok = [&](const std::string& p) {
      const auto it = health.find(p);
      return it != health.end() && it->second.state == motionlcm::health_t::OK;
    };
    const std::vector<std::string> axes{"x", "y", "z", "a", "b", "c", "u"};
    const bool ready = wait(
        [&] {
          if (!ok("coordinator")) return false;
          for (const auto& a : axes) {
            const auto it = client.axes().find(a);
            if (it == client.axes().end() || !it->second.online) return false;
          }
          return true;
        },
        30);
    if (!ready) {
      fail("the lab did not come up (coordinator OK and x,y,z,a,b,c,u online)");
      break;
    }
    const auto enabled = client.call(client::Client::make(request_t::ENABLE, axes), std::chrono::seconds(20));
    if (enabled.status != reply_t::DONE) {
      fail("enable failed: " + enabled.reason);
      break;
    }

    const std::uint32_t bitrate = static_cast<std::uint32_t>(cfg.find_bus("can0")->bitrate);
    if (!skew_only) {
      // 1. Raw LCM round trip.
      Echo echo(url, node.channel("BENCH_PING"), node.channel("BENCH_PONG"));
      std::vector<double> rtt;
      std::optional<Steady::time_point> ping_sent;
      bool pong = false;
      node.subscribe_raw(node.channel("BENCH_PONG"), [&](const void*, int, const std::string&) {
        if (ping_sent) rtt.push_back(us_between(*ping_sent, Steady::now()));
        pong = true;
      });
      const int pings = quick ? 50 : 300;
      for (int i = 0; i < pings + 10; ++i) {
        motionlcm::sync_trigger_t ping{};
        ping.utime = wall_time_us();
        pong = false;
        ping_sent = i < 10 ? std::nullopt : std::optional<Steady::time_point>(Steady::now());  // 10 warm-up
        node.publish("BENCH_PING", ping);
        if (!wait([&] { return pong; }, 2)) break;
      }
      if (rtt.size() < static_cast<std::size_t>(pings) / 2) {
        fail("the LCM echo did not answer");
        break;
      }
      rows.push_back(
          {"raw LCM round trip (publish -> echo -> back)", percentile(rtt, 50), percentile(rtt, 99), "", NAN});

      // CAN frames seen on can0, from our own endpoint on the simulated bus.
      std::error_code ec;
      auto can0 = simbus::SocketEndpoint::connect("can0", {sim_dir, "bench-e2e", false}, ec);
      if (!can0) {
        fail("cannot attach to the simulated can0: " + ec.message());
        break;
      }
      std::vector<can::Frame> frames;
      loop.watch(can0->fd(), [&] {
        while (auto f = can0->receive()) frames.push_back(*f);
      });

      // 2. request -> STARTED of x+y moves.
      const int moves = quick ? 10 : 50;
      std::vector<double> latency;
      std::vector<double> wire;
      std::vector<double> frame_counts;
      for (int i = 0; i < moves && rc == 0; ++i) {
        const double to = i % 2 == 0 ? 2.0 : 0.0;
        bool started = false;
        bool ended = false;
        reply_t last{};
        Steady::time_point t_started{};
        frames.clear();
        const std::int64_t from_utime = wall_time_us();
        const auto t0 = Steady::now();
        std::int64_t started_utime = 0;
        client.send(client::Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", to}, {"y", to / 2}}),
                    [&](const reply_t& r) {
                      if (r.status == reply_t::STARTED && !started) {
                        started = true;
                        t_started = Steady::now();
                        started_utime = wall_time_us();
                      }
                      if (client::is_terminal(r.status)) {
                        ended = true;
                        last = r;
                      }
                    });
        if (!wait([&] { return ended; }, 20) || last.status != reply_t::DONE || !started) {
          fail("move " + std::to_string(i) + " did not end DONE: " + last.reason);
          break;
        }
        latency.push_back(us_between(t0, t_started));
        double bits_us = 0;
        int count = 0;
        for (const auto& f : frames) {
          if (!f.extended || f.timestamp_us < from_utime || f.timestamp_us > started_utime) continue;
          bits_us += std::chrono::duration<double, std::micro>(can::frame_duration(f, bitrate)).count();
          ++count;
        }
        wire.push_back(bits_us);
        frame_counts.push_back(count);
      }
      if (rc != 0) {
        loop.unwatch(can0->fd());
        break;
      }
      rows.push_back({"request -> STARTED, x+y (can0, one BG)", percentile(latency, 50), percentile(latency, 99),
                      "raw LCM round trip p50", percentile(rtt, 50)});
      char what[160];
      std::snprintf(what, sizeof what, "CAN wire time of its 29-bit frames (%.0f frames p50, at %u bit/s)",
                    percentile(frame_counts, 50), bitrate);
      rows.push_back({what, percentile(wire, 50), percentile(wire, 99), "", NAN});
      rows.push_back({"request -> STARTED, x+y", percentile(latency, 50), percentile(latency, 99),
                      "its CAN wire time p50", percentile(wire, 50)});

      // 2b. request -> STARTED of x+y+c (can0 + rs485), against 1.5 x (wire + trigger lead).
      std::vector<double> latency2;
      std::vector<double> bound2;
      std::vector<double> ratio2;
      std::vector<double> lead2;
      std::vector<double> wire2;
      const int warm_up = 10;
      for (int i = 0; i < warm_up + moves && rc == 0; ++i) {
        const double to = i % 2 == 0 ? 2.0 : 0.0;
        bool started = false;
        bool ended = false;
        reply_t last{};
        Steady::time_point t_started{};
        frames.clear();
        scheduled.clear();
        const std::int64_t from_utime = wall_time_us();
        const auto t0 = Steady::now();
        std::int64_t started_utime = 0;
        client.send(client::Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", to}, {"y", to / 2}, {"c", to}}),
                    [&](const reply_t& r) {
                      if (r.status == reply_t::STARTED && !started) {
                        started = true;
                        t_started = Steady::now();
                        started_utime = wall_time_us();
                      }
                      if (client::is_terminal(r.status)) {
                        ended = true;
                        last = r;
                      }
                    });
        if (!wait([&] { return ended; }, 20) || last.status != reply_t::DONE || !started) {
          fail("two-bus move " + std::to_string(i) + " did not end DONE: " + last.reason);
          break;
        }
        if (i < warm_up) continue;
        double can0_us = 0;
        for (const auto& f : frames) {
          if (f.extended && f.timestamp_us >= from_utime && f.timestamp_us <= started_utime)
            can0_us += std::chrono::duration<double, std::micro>(can::frame_duration(f, bitrate)).count();
        }
        const auto t2 = std::find_if(scheduled.begin(), scheduled.end(),
                                     [](const motionlcm::sync_trigger2_t& t) { return t.num_buses == 2; });
        if (t2 == scheduled.end() || !arming.contains("c")) {
          fail("no SYNC_TRIGGER2 of two buses or no ARM_TIMING of c heard");
          break;
        }
        double rs485_us = arming.at("c").arm_line_us;
        for (std::size_t b = 0; b < t2->buses.size(); ++b)
          if (t2->buses[b] == "rs485") rs485_us += t2->lead_us[b];
        const double lead_us =
            static_cast<double>(*std::min_element(t2->send_utime.begin(), t2->send_utime.end()) - t2->utime);
        const double bound = 1.5 * (std::max(can0_us, rs485_us) + lead_us);
        latency2.push_back(us_between(t0, t_started));
        bound2.push_back(bound);
        ratio2.push_back(latency2.back() / bound);
        lead2.push_back(lead_us);
        wire2.push_back(std::max(can0_us, rs485_us));
      }
      if (rc != 0) {
        loop.unwatch(can0->fd());
        break;
      }
      rows.push_back({"request -> STARTED, x+y+c (can0 + rs485)", percentile(latency2, 50), percentile(latency2, 99),
                      "raw LCM round trip p50", percentile(rtt, 50)});
      rows.push_back({"  wire time of its frames, slower bus", percentile(wire2, 50), percentile(wire2, 99), "", NAN});
      rows.push_back({"  trigger lead in force", percentile(lead2, 50), percentile(lead2, 99), "", NAN});
      rows.push_back({"  1.5 x (wire + lead), per move", percentile(bound2, 50), percentile(bound2, 99), "", NAN});
      rows.push_back({"  request -> STARTED over 1.5 x (wire + lead), per move: ratio", percentile(ratio2, 50),
                      percentile(ratio2, 99), "issue 17 goal <= 1", 1.0, true});
      loop.unwatch(can0->fd());
    }  // !skew_only

    // 3. Start skew, one bus and two buses.
    const double sync_us =
        std::chrono::duration<double, std::micro>(can::frame_duration(canopen::encode_sync({}), bitrate)).count();
    const HostStallWatch host;  // the host's own stalls, to tell them from the programs' lateness
    // BENCH_E2E_VERBOSE: can0's frames, to show what was on the wire before a late start.
    const bool verbose = std::getenv("BENCH_E2E_VERBOSE") != nullptr;
    std::unique_ptr<simbus::SocketEndpoint> tap;
    if (verbose) {
      std::error_code ec;
      tap = simbus::SocketEndpoint::connect("can0", {sim_dir, "bench-e2e-tap", false}, ec);
    }
    const auto drain_tap = [&tap] {
      std::vector<can::Frame> out;
      if (tap)
        while (auto f = tap->receive()) out.push_back(*f);
      return out;
    };
    const auto skew_run = [&](const std::vector<std::string>& group, const std::string& label, bool one_bus) {
      std::vector<double> measured;
      std::vector<double> truth;
      std::vector<double> predicted;
      std::vector<std::int64_t> stall;                    // per move: the longest host stall in its start window (µs)
      std::map<std::string, std::vector<double>> offset;  // drive -> start minus the first CAN start (x-drive)
      const int n = skew_moves > 0 ? skew_moves : quick ? 4 : skew_only ? 30 : 12;
      for (int i = 0; i < n && rc == 0; ++i) {
        Values targets;
        for (const auto& a : group) {
          const double span = a == "a" || a == "b" ? 90.0 : 4.0;
          targets[a] = (i % 2 == 0 ? span : 0.0) * (a == "b" ? -1.0 : 1.0);
        }
        reports.clear();
        scheduled.clear();
        drain_tap();
        const auto r = client.call(client::Client::make(request_t::MOVE_ABSOLUTE, targets), std::chrono::seconds(30));
        if (r.status != reply_t::DONE) {
          fail(label + " move did not end DONE: " + r.reason);
          return;
        }
        measured.push_back(r.measured_start_skew_us);
        wait([&] { return reports.size() >= group.size(); }, 2);
        if (reports.size() >= group.size()) {
          std::int64_t lo = reports.front().frame_utime;
          std::int64_t hi = lo;
          for (const auto& s : reports) {
            lo = std::min(lo, s.frame_utime);
            hi = std::max(hi, s.frame_utime);
          }
          truth.push_back(static_cast<double>(hi - lo));
          // The start window: from 1 ms before the first bus's send time to the last start.
          std::int64_t first_send = lo;
          if (!scheduled.empty() && !scheduled.back().send_utime.empty())
            first_send = std::min(
                first_send, *std::min_element(scheduled.back().send_utime.begin(), scheduled.back().send_utime.end()));
          stall.push_back(host.worst_in(first_send - 1000, hi));
          const auto x = std::find_if(reports.begin(), reports.end(),
                                      [](const motionlcm::sim_report_t& s) { return s.drive == "x-drive"; });
          if (x != reports.end()) {
            if (verbose) std::fprintf(stderr, "%s move %d:", label.c_str(), i);
            for (const auto& s : reports) {
              offset[s.drive].push_back(static_cast<double>(s.frame_utime - x->frame_utime));
              if (verbose)
                std::fprintf(stderr, " %s %+lld", s.drive.c_str(), static_cast<long long>(offset[s.drive].back()));
            }
            if (verbose)
              std::fprintf(stderr, " (measured %.0f us; host stall %lld us)\n", r.measured_start_skew_us,
                           static_cast<long long>(stall.back()));
            if (verbose && !one_bus && !scheduled.empty() &&
                truth.back() > 200.0 + scheduled.back().predicted_spread_us) {
              // Over the bound: each drive's start after its bus's send time (its start frame's
              // wire time when on time), then can0's frames from 3 ms before the first send time
              // to the last start.
              const auto& t2 = scheduled.back();
              for (const auto& rep : reports) {
                for (std::size_t b = 0; b < t2.buses.size() && b < t2.send_utime.size(); ++b) {
                  if (t2.buses[b] == rep.bus)
                    std::fprintf(stderr, "    %s: %lld us after %s's send time\n", rep.drive.c_str(),
                                 static_cast<long long>(rep.frame_utime - t2.send_utime[b]), rep.bus.c_str());
                }
              }
              for (const auto& f : drain_tap()) {
                if (f.timestamp_us < first_send - 3000 || f.timestamp_us > hi) continue;
                std::fprintf(stderr, "    can0 %+lld us: %s\n", static_cast<long long>(f.timestamp_us - x->frame_utime),
                             can::to_cansend(f).c_str());
              }
            }
          }
        }
        predicted.push_back(scheduled.empty() ? 0.0 : scheduled.back().predicted_spread_us);
      }
      rows.push_back({"start skew " + label + ", ground truth (sim frames)", percentile(truth, 50),
                      percentile(truth, 99), "", NAN});
      if (one_bus) {
        // k = 2 distinct start frames (BG, SYNC): the SYNC's wire time after the BG, + 50 us.
        rows.push_back({"  same, against (k-1) frame times + 50 us", percentile(truth, 50), percentile(truth, 99),
                        "1 SYNC frame + 50 us", sync_us + 50.0, true});
      } else {
        const double bound = 200.0 + percentile(predicted, 50);
        rows.push_back({"  same, against 200 us + predicted spread", percentile(truth, 50), percentile(truth, 99),
                        "goal + SYNC_TRIGGER2 spread", bound, true});
        std::size_t over = 0;
        std::size_t over_stalled = 0;
        std::size_t within_stalled = 0;
        double longest = 0;
        for (std::size_t m = 0; m < truth.size() && m < stall.size(); ++m) {
          const bool stalled = stall[m] > 0;
          if (truth[m] > bound) {
            ++over;
            over_stalled += stalled ? 1 : 0;
            longest = std::max(longest, static_cast<double>(stall[m]));
          } else {
            within_stalled += stalled ? 1 : 0;
          }
        }
        rows.push_back({"  moves over it: " + std::to_string(over) + " of " + std::to_string(truth.size()) +
                            "; the worst move (as p50 and p99)",
                        percentile(truth, 100), percentile(truth, 100), "", NAN});
        // A late move is the host's when the watch itself was held back in its start window.
        rows.push_back({"  of them with a host stall > " + std::to_string(host.late().count()) +
                            " us in the start window: " + std::to_string(over_stalled) + " (moves within: " +
                            std::to_string(within_stalled) + " of " + std::to_string(truth.size() - over) +
                            "); watch " + (host.realtime() ? "SCHED_FIFO" : "not real-time") + ", " +
                            std::to_string(host.count()) + " stalls in all; the longest in a move over",
                        longest, longest, "", NAN});
      }
      rows.push_back({"start skew " + label + ", coordinator measured", percentile(measured, 50),
                      percentile(measured, 99), "ground truth p50", percentile(truth, 50)});
      for (const auto& [drive, values] : offset) {
        if (drive != "x-drive")
          rows.push_back({"  " + drive + " start - x-drive start (ground truth)", percentile(values, 50),
                          percentile(values, 99), "", NAN});
      }
    };
    skew_run({"x", "y", "a", "b"}, "one bus (x,y,a,b: BG+SYNC)", true);
    skew_run({"x", "y", "a", "b", "c"}, "two buses (+c rs485)", false);
    skew_run({"x", "y", "a", "b", "c", "u"}, "three buses (+c rs485 +u rs232)", false);
  } while (false);

  if (!heard_delay.empty()) {
    rows.push_back({"TRIGGER_HEARD delay, triggers of 2-3 buses (" + std::to_string(heard_delay.size()) +
                        " hearings, " + std::to_string(heard_late) + " after their send time)",
                    percentile(heard_delay, 50), percentile(heard_delay, 99), "", NAN});
  }
  stop_all(programs.children());
  std::printf("end to end on the simulated lab (%s, serial lines: %s), binaries %s, LCM %s, load average %.2f\n\n",
              config_path.c_str(),
              cfg.simulation.serial_link == config::SimulationSettings::SerialLink::kSocket ? "socket" : "pty",
              bin.c_str(), url.c_str(), load_average());
  std::printf("%-62s %11s %11s   %-24s %8s\n", "measure", "p50 us", "p99 us", "bound (same run)", "ratio");
  for (const auto& r : rows) {
    std::printf("%-62s %11.1f %11.1f   %-24s", r.what.c_str(), r.p50, r.p99, r.bound.c_str());
    if (std::isfinite(r.bound_p50) && r.bound_p50 > 0 && r.p99_ratio) {
      std::printf(" %7.2fx / %.2fx (p50 / p99 over %.1f us)\n", r.p50 / r.bound_p50, r.p99 / r.bound_p50, r.bound_p50);
    } else if (std::isfinite(r.bound_p50) && r.bound_p50 > 0) {
      std::printf(" %7.2fx\n", r.p50 / r.bound_p50);
    } else {
      std::printf(" %8s\n", "");
    }
  }
  if (rc == 0 && std::getenv("BENCH_E2E_VERBOSE") == nullptr) std::filesystem::remove_all(dir);
  if (rc == 0 && std::getenv("BENCH_E2E_VERBOSE") != nullptr) std::printf("\nlogs kept in %s\n", dir.c_str());
  return rc;
}

}  // namespace
}  // namespace motion::bench

int main(int argc, char** argv) {
  bool quick = false;
  bool skew_only = false;
  int skew_moves = 0;
  int realtime = 0;
  std::vector<std::string> sets;
  std::string serial_link;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else if (std::strcmp(argv[i], "--skew-only") == 0) {
      skew_only = true;
    } else if (std::strcmp(argv[i], "--moves") == 0 && i + 1 < argc) {
      skew_moves = std::atoi(argv[++i]);
      if (skew_moves < 1) {
        std::fprintf(stderr, "bench_e2e: --moves wants a count of at least 1, got '%s'\n", argv[i]);
        return 2;
      }
    } else if (std::strcmp(argv[i], "--realtime") == 0 && i + 1 < argc) {
      realtime = std::atoi(argv[++i]);
      if (realtime < 0 || realtime > 99) {
        std::fprintf(stderr, "bench_e2e: --realtime wants 0 or a priority of 1 to 99, got '%s'\n", argv[i]);
        return 2;
      }
    } else if (std::strcmp(argv[i], "--set") == 0 && i + 1 < argc) {
      sets.emplace_back(argv[++i]);
    } else if (std::strcmp(argv[i], "--serial-link") == 0 && i + 1 < argc) {
      serial_link = argv[++i];
      if (serial_link != "pty" && serial_link != "socket") {
        std::fprintf(stderr, "bench_e2e: --serial-link wants pty or socket, got '%s'\n", argv[i]);
        return 2;
      }
    } else {
      std::fprintf(stderr,
                   "usage: bench_e2e [--quick] [--skew-only] [--moves N] [--realtime P] [--set BUS.KEY=VALUE ...] "
                   "[--serial-link pty|socket]\n"
                   "unknown or incomplete argument: %s\n",
                   argv[i]);
      return 2;
    }
  }
  return motion::bench::run(quick, skew_only, skew_moves, realtime, std::move(sets), serial_link);
}
