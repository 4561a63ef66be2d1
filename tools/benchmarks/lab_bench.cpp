// Lab-scale benchmark (issue 17 item 6): one host, eight simulated buses, every process of a full
// lab — 122 UIM342 on one CAN bus, 127 UC57 (CANopen) on another, two RS485 lines of 32 ADAM
// drives each, and four smaller mixed buses — from a configuration generated here. Printed, each
// against a bound measured in the same run where there is one:
//   1. bring-up: seconds until each bus's axes are online (or how many came online by the deadline);
//   2. per process (motion-sim, each gateway, the coordinator): CPU (utime + stime from /proc over
//      an idle window, as a fraction of one core) and RSS (VmRSS);
//   3. per bus, while idle: position samples per second (AXIS_STATE messages with a new
//      sample_utime: a gateway may publish one sample more than once, ADAM after each of its two
//      poll reads) against the configured poll rate times the drives online, or, on an ADAM line,
//      what the line can carry when that is less (adam_polls_per_s: the wire time of one poll's two
//      transactions and the master's silences, drives answering at once); and the bus load the gateway
//      reports (bus_stats_t, a fraction of the bus's capacity);
//   4. a synchronized move of up to `--per-bus` axes of every bus together: request -> STARTED
//      against the raw LCM round trip of the same run and against the 1.5 x (wire time of
//      the move's frames + the trigger lead in force), per move: a bus's wire time is the line time
//      of arming its axes (ARM_TIMING arm_line_us each; on the first move also arm_bystander_us for
//      every other drive of the bus, which that move readies) plus its start frames (SYNC_TRIGGER2
//      lead_us), the slowest bus decides; the lead in force is the trigger's first send_utime minus
//      its utime. And the start skew from the simulated drives' ground truth (SIM_REPORT frame
//      times) against the 200 us plus the spread the coordinator's schedule predicts
//      (SYNC_TRIGGER2), with each bus's start offset from the move's median start.
// A bus that does not come up is reported as such (with what its gateway logged) and left out of
// the move; nothing is estimated. Not part of ctest: `tools/bench lab`.
//
// Usage: bench_lab [--scale F] [--bring-up-s N] [--window-s N] [--moves N] [--per-bus N] [--realtime P] [--cpu-latency US] [--sched-slice US] [--enable-all 0|1] [--serial-link pty|socket] [--sim-nice N] [--sim-realtime P]
//   --serial-link socket: motion-sim makes the serial lines Unix sockets (`simulation.serial_link`),
//     which date the gateways' bytes by their send, not by the pty's hand-over; pty, the default
//   --sim-nice N: motion-sim runs at nice N (0..19; 0, the default): the simulated drives, which on
//     a real lab take no CPU from the gateways' host, then yield it to them; their ground truth
//     is dated by the kernel's send stamps (CAN, and serial lines with --serial-link socket)
//   --sim-realtime P: motion-sim under SCHED_FIFO P (below the gateways' --realtime, so that they
//     preempt it; with --serial-link pty its lines' kernel worker is then held back, see above)
//   --scale F: every bus's drive count times F (0 < F <= 1; 1 is the full lab)
//   --sched-slice US: every bus gets `sched_slice_us: US` (0: the kernel's default slice for the
//     gateways under normal scheduling; without it, the gateways' own default)
//   --cpu-latency US: the first bus gets `cpu_latency_us: US` (its gateway asks the kernel that no
//     CPU take longer to wake from idle, for the whole host; 0: idle CPUs poll); -1, the default:
//     the host's own idle states
//   --realtime P: every bus gets `realtime_priority: P` (its gateway's loop under SCHED_FIFO);
//     motion-sim stays under normal scheduling, as in bench_e2e (a simulated serial line's bytes
//     pass the pty's kernel worker, a normal-priority thread a real-time simulator would hold
//     back); 0, the default, is normal scheduling for all
// MOTION_BIN_DIR=<another build>/bin runs the lab's programs from there (a before/after in one sitting).
//   --enable-all 1: every online axis is enabled, not only the move's (as in a lab whose idle
//     axes hold their position): the UIM342 drives of a group outside the move are then at rest
//     and enabled, so a move of part of the group starts on the group's BG (they hold PR=0)
#include <sys/stat.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <motionlcm/arm_timing_t.hpp>
#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/sim_report_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>

#include "bench_process.hpp"
#include "bench_table.hpp"
#include "host_stalls.hpp"
#include "motion/adam/rtu.hpp"
#include "motion/client/client.hpp"
#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/node.hpp"

namespace motion::bench {
namespace {

using motionlcm::reply_t;
using motionlcm::request_t;

struct Options {
  double scale = 1.0;
  int bring_up_s = 120;
  int window_s = 10;
  int moves = 6;
  int per_bus = 4;
  int realtime = 0;      // 0 or 1..99
  int cpu_latency = -1;  // -1 or 0..10000 us
  int sched_slice = -1;  // -1 (the gateways' default) or 0..100000 us
  bool enable_all = false;
  std::string serial_link = "pty";  // simulation.serial_link
  int sim_nice = 0;                 // motion-sim's nice value
  int sim_realtime = 0;             // motion-sim's SCHED_FIFO priority (0: normal scheduling)
};

// One bus of the generated lab: its drives are `count` of `family` from node id `first_id`, and
// `extra` more of `extra_family` (mixed buses).
struct BusPlan {
  std::string name;
  std::string kind;  // "can" or "serial"
  int rate = 0;      // bit/s or baud
  int poll_hz = 10;
  std::string family;
  int first_id = 1;
  int count = 0;
  std::string extra_family;
  int extra_first_id = 1;
  int extra_count = 0;
  int group_id = 0;  // UIM342 group of the first family's drives (0: none)
};

std::vector<BusPlan> lab_buses(double scale) {
  const auto scaled = [scale](int n) { return std::max(1, static_cast<int>(std::lround(n * scale))); };
  return {
      // 122 UIM342: node ids 5..126 are all taken, so no group id is left (SimpleCAN §5.1).
      {"can_uim", "can", 1000000, 10, "uim342", 5, scaled(122), "", 1, 0, 0},
      {"can_co", "can", 1000000, 10, "uc57", 1, scaled(127), "", 1, 0, 0},
      {"rs485a", "serial", 115200, 10, "adam-modbus", 1, scaled(32), "", 1, 0, 0},
      {"rs485b", "serial", 115200, 10, "adam-modbus", 1, scaled(32), "", 1, 0, 0},
      {"can_mix", "can", 500000, 20, "uim342", 5, scaled(8), "uc57", 1, scaled(8), 100},
      {"can_mix2", "can", 1000000, 20, "uim342", 5, scaled(4), "uc57", 1, scaled(4), 100},
      {"rs485c", "serial", 19200, 10, "adam-modbus", 1, scaled(8), "", 1, 0, 0},
      {"rs232", "serial", 57600, 10, "uim242", 5, scaled(4), "", 1, 0, 0},
  };
}

// Drive polls per second an ADAM line of `b` can carry: the stack's poll of one drive is two reads
// (0x0004…0x0007 position and status, 0x00A2…0x00A3 outputs and alarm; adam_stack.hpp), each the
// request's and the reply's bytes on the wire and the t3.5 of silence the master keeps after a
// reply, with a drive that answers at once (an upper bound). 8N1, as lab_yaml configures the lines.
double adam_polls_per_s(const BusPlan& b) {
  adam::rtu::SerialFormat format;
  format.baud = static_cast<std::uint32_t>(b.rate);
  const auto read = [&](std::uint16_t words) {
    const std::size_t request = 8;              // unit, 0x03, start, quantity, CRC
    const std::size_t reply = 5U + 2U * words;  // unit, 0x03, byte count, words, CRC
    return adam::rtu::transmission_time(format, request + reply) + adam::rtu::frame_timing(format).t3_5;
  };
  return 1.0 / std::chrono::duration<double>(read(4) + read(2)).count();
}

std::string setup_of(const std::string& family) {
  if (family == "uim342") return "{micro_steps: 16, current_a: 1.0, acceleration_unit: rate}";
  if (family == "uc57") return "{micro_steps: 16, current_a: 1.0, tpdo_mode: sync}";
  if (family == "adam-modbus") return "{subdivision: 16, current_a: 1.0}";
  return "{micro_steps: 16, current_a: 1.0}";
}

// The lab's YAML; `axis_bus` gets every axis's bus.
std::string lab_yaml(const std::vector<BusPlan>& buses, const Options& opt,
                     std::map<std::string, std::string>& axis_bus) {
  const int realtime = opt.realtime;
  const int cpu_latency = opt.cpu_latency;
  std::ostringstream buses_out;
  std::ostringstream drives;
  std::ostringstream axes;
  for (const auto& b : buses) {
    buses_out << "  - {name: " << b.name << ", transport: " << (b.kind == "can" ? "simcan:" : "simserial:") << b.name
              << ", " << (b.kind == "can" ? "bitrate: " : "baud: ") << b.rate
              << (b.kind == "can" ? ", bus_timing: true" : "")
              << ", request_timeout_ms: " << (b.kind == "can" ? 50 : 100) << ", retries: 2, poll_hz: " << b.poll_hz
              << (realtime > 0 ? ", realtime_priority: " + std::to_string(realtime) : "")
              << (cpu_latency >= 0 && &b == &buses.front() ? ", cpu_latency_us: " + std::to_string(cpu_latency) : "")
              << (opt.sched_slice >= 0 ? ", sched_slice_us: " + std::to_string(opt.sched_slice) : "") << "}\n";
    const auto add = [&](const std::string& family, int first, int count, int group) {
      for (int k = 0; k < count; ++k) {
        const int id = first + k;
        const std::string axis =
            b.name + "_" + (family == "uc57" && !b.extra_family.empty() ? "co" : "") + std::to_string(id);
        drives << "  - {name: " << axis << "-drive, family: " << family << ", bus: " << b.name << ", node_id: " << id
               << (group != 0 ? ", group_id: " + std::to_string(group) : "") << ", setup: " << setup_of(family)
               << "}\n";
        const double steps = family == "uc57" ? 8.888888888888889 : 640.0;  // deg (3200 counts/rev) or mm
        axes << "  - {name: " << axis << ", drive: " << axis << "-drive, steps_per_unit: " << steps
             << ", limits: {min: -720, max: 720, velocity: " << (family == "uc57" ? 360 : 20)
             << ", acceleration: " << (family == "uc57" ? 1440 : 200) << "}}\n";
        axis_bus[axis] = b.name;
      }
    };
    add(b.family, b.first_id, b.count, b.group_id);
    if (b.extra_count > 0) add(b.extra_family, b.extra_first_id, b.extra_count, 0);
  }
  return "lcm: {channel_prefix: \"MOTION_\"}\nbuses:\n" + buses_out.str() + "drives:\n" + drives.str() + "axes:\n" +
         axes.str() + "coordinator: {default_timeout_ms: 60000, progress_period_ms: 500}\n" +
         "simulation: {serial_link: " + opt.serial_link + "}\n";
}

// CPU seconds (utime + stime) of `pid`, from /proc/PID/stat; nullopt when it is gone.
std::optional<double> cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  if (!std::getline(in, text)) return std::nullopt;
  const auto close = text.rfind(')');  // the command name may hold spaces
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && fields >> field; ++i) {
    if (i == 14 || i == 15) ticks += std::stod(field);  // utime, stime (proc(5))
  }
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

// Resident set size of `pid` in MiB (VmRSS of /proc/PID/status).
double rss_mib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return NAN;
}

// The last lines of a log file, for a bus that did not come up.
std::string tail_of(const std::string& path, int lines) {
  std::ifstream in(path);
  std::vector<std::string> all;
  std::string line;
  while (std::getline(in, line)) all.push_back(line);
  std::string out;
  for (std::size_t i = all.size() > static_cast<std::size_t>(lines) ? all.size() - static_cast<std::size_t>(lines) : 0;
       i < all.size(); ++i) {
    out += "      " + all[i] + "\n";
  }
  return out;
}

int run(const Options& opt) {
  char tmpl[] = "/tmp/motion-bench-lab-XXXXXX";
  const char* made = ::mkdtemp(tmpl);
  if (made == nullptr) return 1;
  const std::string dir = made;
  const std::string sim_dir = dir + "/sim";
  const std::string config_path = dir + "/lab.yaml";
  const auto buses = lab_buses(opt.scale);
  std::map<std::string, std::string> axis_bus;
  std::ofstream(config_path) << lab_yaml(buses, opt, axis_bus);
  auto loaded = config::load_file(config_path);
  if (!loaded.ok()) {
    std::fprintf(stderr, "bench_lab: the generated configuration is refused:\n%s\n", loaded.error_text().c_str());
    return 3;
  }
  const config::Config cfg = *loaded.config;
  std::map<std::string, int> bus_axes;
  for (const auto& [axis, bus] : axis_bus) ++bus_axes[bus];

  const int port = 20000 + (static_cast<int>(::getpid()) * 17 + 3) % 40000;
  const std::string url = "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
  EventLoop loop;
  lcm::Node node(loop, {url, cfg.lcm.channel_prefix});
  if (!node.ok()) {
    std::fprintf(stderr, "LCM unavailable on %s\n", url.c_str());
    return 4;
  }
  client::Client client(loop, node, "bench-lab");
  std::map<std::string, motionlcm::health_t> health;
  node.subscribe<motionlcm::health_t>(lcm::channels::kHealth,
                                      [&](const motionlcm::health_t& h, const std::string&) { health[h.process] = h; });
  std::map<std::string, long> state_count;          // per bus, position samples (a new sample_utime)
  std::map<std::string, std::int64_t> last_sample;  // per axis
  node.subscribe<motionlcm::axis_state_t>(lcm::channels::kAxisState,
                                          [&](const motionlcm::axis_state_t& s, const std::string&) {
                                            if (std::exchange(last_sample[s.axis], s.sample_utime) != s.sample_utime)
                                              ++state_count[s.bus];
                                          });
  std::vector<motionlcm::sim_report_t> reports;
  node.subscribe<motionlcm::sim_report_t>(lcm::channels::kSimReport,
                                          [&](const motionlcm::sim_report_t& r, const std::string&) {
                                            if (r.kind == motionlcm::sim_report_t::MOTION_STARTED) reports.push_back(r);
                                          });
  std::map<std::string, motionlcm::arm_timing_t> arming;  // axis -> its ARM_TIMING
  node.subscribe<motionlcm::arm_timing_t>(
      lcm::channels::kArmTiming, [&](const motionlcm::arm_timing_t& t, const std::string&) { arming[t.axis] = t; });
  std::vector<motionlcm::sync_trigger2_t> scheduled;
  node.subscribe<motionlcm::sync_trigger2_t>(
      lcm::channels::kSyncTrigger2,
      [&](const motionlcm::sync_trigger2_t& t, const std::string&) { scheduled.push_back(t); });

  std::string bin = MOTION_LAB_BIN_DIR;
  if (const char* env = std::getenv("MOTION_BIN_DIR")) bin = env;  // other binaries, e.g. main's
  LabPrograms programs(bin, config_path, url, sim_dir, dir);
  const auto wait = [&](const std::function<bool()>& done, double seconds) {
    return client.wait_until(done, std::chrono::milliseconds(static_cast<int>(seconds * 1000)));
  };
  const auto online_on = [&](const std::string& bus) {
    int n = 0;
    for (const auto& [axis, s] : client.axes())
      n += s.online && axis_bus.contains(axis) && axis_bus.at(axis) == bus ? 1 : 0;
    return n;
  };

  int rc = 0;
  std::vector<Row> rows;
  std::vector<std::string> findings;
  do {
    const auto t_sim = Steady::now();
    // Normal scheduling even with --realtime (see the top) unless --sim-realtime; --sim-nice
    // lowers its weight.
    programs.start("sim", "motion-sim", {}, opt.sim_realtime, opt.sim_nice);
    if (!wait([&] { return health.contains("sim"); }, 60)) {
      findings.push_back("motion-sim sent no heartbeat within 60 s:\n" + tail_of(dir + "/sim.log", 8));
      rc = 1;
      break;
    }
    rows.push_back(
        {"motion-sim up (first heartbeat)", fmt("%.1f s", us_between(t_sim, Steady::now()) / 1e6), "", 0, ""});
    const auto t0 = Steady::now();
    for (const auto& b : buses) programs.start("gateway:" + b.name, "motion-gateway", {"--bus", b.name});
    programs.start("coordinator", "motion-coordinator", {});
    // 1. Bring-up, per bus.
    std::map<std::string, double> up_s;
    wait(
        [&] {
          for (const auto& b : buses) {
            if (!up_s.contains(b.name) && online_on(b.name) == bus_axes[b.name])
              up_s[b.name] = us_between(t0, Steady::now()) / 1e6;
          }
          return up_s.size() == buses.size();
        },
        opt.bring_up_s);
    for (const auto& b : buses) {
      const int online = online_on(b.name);
      const std::string what = "bring-up " + b.name + " (" + std::to_string(bus_axes[b.name]) + " axes)";
      if (up_s.contains(b.name)) {
        rows.push_back({what, fmt("%.1f s", up_s[b.name]), "", 0, "every axis online"});
      } else {
        rows.push_back({what,
                        fmt2("%.0f of %.0f online", static_cast<double>(online), static_cast<double>(bus_axes[b.name])),
                        fmt("%.0f s deadline", opt.bring_up_s), 0, "NOT all online"});
        findings.push_back("bus " + b.name + ": " + std::to_string(online) + " of " + std::to_string(bus_axes[b.name]) +
                           " axes online after " + std::to_string(opt.bring_up_s) + " s; its gateway's log ends:\n" +
                           tail_of(dir + "/gateway:" + b.name + ".log", 6));
      }
    }

    // 2 and 3. An idle window: CPU and RSS per process, status updates and bus load per bus.
    std::map<pid_t, double> cpu_before;
    for (const auto& c : programs.children()) cpu_before[c.pid] = cpu_seconds(c.pid).value_or(NAN);
    state_count.clear();
    const auto w0 = Steady::now();
    wait([] { return false; }, opt.window_s);
    const double window = us_between(w0, Steady::now()) / 1e6;
    for (const auto& c : programs.children()) {
      const auto after = cpu_seconds(c.pid);
      if (!after) {
        rows.push_back({"CPU " + c.name, "exited", "", 0, "the process is gone"});
        findings.push_back(c.name + " exited:\n" + tail_of(dir + "/" + c.name + ".log", 6));
        continue;
      }
      const double share = (*after - cpu_before[c.pid]) / window;
      rows.push_back(
          {"CPU " + c.name, fmt("%.1f %%", 100 * share), "1 core", share, fmt("RSS %.1f MiB", rss_mib(c.pid))});
    }
    for (const auto& b : buses) {
      const int online = online_on(b.name);
      const double per_s = static_cast<double>(state_count[b.name]) / window;
      const double asked = static_cast<double>(online * b.poll_hz);
      const double line = b.family == "adam-modbus" ? adam_polls_per_s(b) : asked;
      const double wanted = std::min(asked, line);
      rows.push_back({"position samples/s " + b.name, fmt("%.0f /s", per_s),
                      line < asked ? fmt("line carries %.0f polls/s", line)
                                   : fmt2("%.0f Hz x %.0f online", b.poll_hz, static_cast<double>(online)),
                      wanted > 0 ? per_s / wanted : 0,
                      line < asked ? fmt("%.2f of the asked rate", per_s / asked) : ""});
      const auto h = health.find("gateway:" + b.name);
      if (h != health.end()) {
        for (const auto& s : h->second.buses) {
          rows.push_back(
              {"bus load " + b.name + " (gateway's bus_stats)", fmt("%.1f %%", 100 * s.bus_load), "capacity 100 %",
               s.bus_load,
               fmt2("%.0f tx, %.0f timeouts", static_cast<double>(s.tx_frames), static_cast<double>(s.timeouts))});
        }
      }
    }

    // 4. A synchronized move of up to per_bus axes of every bus.
    Echo echo(url, node.channel("BENCH_PING"), node.channel("BENCH_PONG"));
    std::vector<double> rtt;
    std::optional<Steady::time_point> ping_sent;
    bool pong = false;
    node.subscribe_raw(node.channel("BENCH_PONG"), [&](const void*, int, const std::string&) {
      if (ping_sent) rtt.push_back(us_between(*ping_sent, Steady::now()));
      pong = true;
    });
    for (int i = 0; i < 60; ++i) {
      motionlcm::sync_trigger_t ping{};
      ping.utime = wall_time_us();
      pong = false;
      ping_sent = i < 10 ? std::nullopt : std::optional<Steady::time_point>(Steady::now());
      node.publish("BENCH_PING", ping);
      if (!wait([&] { return pong; }, 2)) break;
    }
    // The move's axes: up to per_bus online axes of every bus without a fault or a lost position
    // (their moves are refused), enabled; an axis that fails to enable (a finding) is left out and
    // the rest enabled again, once.
    std::vector<std::string> group;
    std::set<std::string> group_buses;
    std::set<std::string> left_out;
    bool enabled = false;
    for (int attempt = 0; attempt < 2 && !enabled; ++attempt) {
      group.clear();
      group_buses.clear();
      std::map<std::string, int> taken;
      std::vector<std::string> to_enable;
      for (const auto& [axis, s] : client.axes()) {
        if (!s.online || s.fault || s.fault_code != 0 || left_out.contains(axis) || !axis_bus.contains(axis)) continue;
        if (opt.enable_all) to_enable.push_back(axis);
        if (taken[axis_bus[axis]] >= opt.per_bus) continue;
        ++taken[axis_bus[axis]];
        group.push_back(axis);
        group_buses.insert(axis_bus[axis]);
      }
      if (group.empty()) break;
      if (!opt.enable_all) to_enable = group;
      const auto reply = client.call(client::Client::make(request_t::ENABLE, to_enable), std::chrono::seconds(60));
      enabled = reply.status == reply_t::DONE;
      if (!enabled) {
        findings.push_back("enable of " + std::to_string(to_enable.size()) + " axes: " + reply.reason);
        for (const auto& [axis, s] : client.axes()) {
          if (reply.reason.find(axis + "-drive") != std::string::npos || !s.online) left_out.insert(axis);
        }
      }
    }
    if (!enabled) {
      rc = 1;
      break;
    }
    std::vector<double> latency;
    std::vector<double> latency_ratio;  // request -> STARTED over 1.5 x (wire + lead in force)
    std::vector<double> truth;
    std::vector<double> predicted;
    std::map<std::string, std::vector<double>> bus_offset;  // per bus, each drive's start - the move's median
    const HostStallWatch host;       // the host's own stalls, to tell them from the programs' lateness
    std::vector<double> calm_truth;  // the skew of moves without a host stall in their start window
    std::size_t stalled_moves = 0;
    for (int i = 0; i < opt.moves; ++i) {
      std::map<std::string, double> targets;
      for (const auto& a : group) targets[a] = i % 2 == 0 ? 2.0 : 0.0;
      reports.clear();
      scheduled.clear();
      bool started = false;
      bool ended = false;
      reply_t last{};
      const auto m0 = Steady::now();
      client.send(client::Client::make(request_t::MOVE_ABSOLUTE, targets), [&](const reply_t& r) {
        if (r.status == reply_t::STARTED && !started) {
          started = true;
          latency.push_back(us_between(m0, Steady::now()));
        }
        if (client::is_terminal(r.status)) {
          ended = true;
          last = r;
        }
      });
      if (!wait([&] { return ended; }, 60) || last.status != reply_t::DONE) {
        findings.push_back("move " + std::to_string(i) + " of " + std::to_string(group.size()) +
                           " axes did not end DONE: " + last.reason);
        rc = 1;
        break;
      }
      if (started && !scheduled.empty()) {
        const auto& t2 = scheduled.back();
        std::map<std::string, double> wire_us;
        for (const auto& a : group) {
          if (!arming.contains(a)) continue;
          wire_us[axis_bus[a]] += arming.at(a).arm_line_us;
          if (i == 0) wire_us[axis_bus[a]] += arming.at(a).arm_bystander_us * (bus_axes[axis_bus[a]] - opt.per_bus);
        }
        double slowest = 0;
        for (std::size_t b = 0; b < t2.buses.size(); ++b)
          slowest = std::max(slowest, wire_us[t2.buses[b]] + t2.lead_us[b]);
        const double lead_us =
            static_cast<double>(*std::min_element(t2.send_utime.begin(), t2.send_utime.end()) - t2.utime);
        latency_ratio.push_back(latency.back() / (1.5 * (slowest + lead_us)));
      }
      wait([&] { return reports.size() >= group.size(); }, 2);
      if (reports.size() >= group.size()) {
        std::vector<double> starts;
        for (const auto& r : reports) starts.push_back(static_cast<double>(r.frame_utime));
        const auto [lo, hi] = std::minmax_element(starts.begin(), starts.end());
        truth.push_back(*hi - *lo);
        // The start window: from 1 ms before the first bus's send time to the last start.
        double first_send = *lo;
        if (!scheduled.empty() && !scheduled.back().send_utime.empty())
          first_send = std::min(first_send, static_cast<double>(*std::min_element(scheduled.back().send_utime.begin(),
                                                                                  scheduled.back().send_utime.end())));
        if (host.worst_in(static_cast<std::int64_t>(first_send) - 1000, static_cast<std::int64_t>(*hi)) > 0) {
          ++stalled_moves;
        } else {
          calm_truth.push_back(truth.back());
        }
        const double median = percentile(starts, 50);
        for (const auto& r : reports) bus_offset[r.bus].push_back(static_cast<double>(r.frame_utime) - median);
        if (std::getenv("BENCH_LAB_VERBOSE") != nullptr) {  // each drive's start, for a look at one move
          std::printf("move %d: predicted spread %.0f us, starts from the median:", i,
                      scheduled.empty() ? 0.0 : scheduled.back().predicted_spread_us);
          for (const auto& r : reports)
            std::printf(" %s %+.0f", r.drive.c_str(), static_cast<double>(r.frame_utime) - median);
          std::printf("\n");
        }
      }
      predicted.push_back(scheduled.empty() ? 0.0 : scheduled.back().predicted_spread_us);
    }
    const std::string move = std::to_string(group.size()) + " axes on " + std::to_string(group_buses.size()) + " buses";
    if (!latency.empty()) {
      rows.push_back({"request -> STARTED p50, " + move, fmt("%.0f us", percentile(latency, 50)),
                      fmt("%.0f us LCM RTT p50", percentile(rtt, 50)), percentile(latency, 50) / percentile(rtt, 50),
                      fmt("p99 %.0f us", percentile(latency, 99))});
    }
    if (!latency_ratio.empty()) {
      rows.push_back({"request -> STARTED / 1.5 x (wire + lead), per move",
                      fmt("p50 %.2f", percentile(latency_ratio, 50)), "issue 17 goal <= 1",
                      percentile(latency_ratio, 50),
                      fmt("p99 %.2f; the first move readies the lines' other drives", percentile(latency_ratio, 99))});
    }
    if (!truth.empty()) {
      const double bound = 200.0 + percentile(predicted, 50);
      rows.push_back({"start skew p50 (ground truth), " + move, fmt("%.0f us", percentile(truth, 50)),
                      fmt("%.0f us = 200 + predicted", bound), percentile(truth, 50) / bound,
                      fmt2("p99 %.0f us (%.2fx)", percentile(truth, 99), percentile(truth, 99) / bound)});
      rows.push_back(
          {"  moves with a host stall > " + std::to_string(host.late().count()) + " us in their start window",
           fmt("%.0f", static_cast<double>(stalled_moves)), fmt("of %.0f", static_cast<double>(truth.size())), NAN,
           std::string("watch ") + (host.realtime() ? "SCHED_FIFO" : "not real-time") +
               fmt("; p99 of the others %.0f us", percentile(calm_truth, 99))});
      for (auto& [bus, offsets] : bus_offset) {
        const auto [lo, hi] = std::minmax_element(offsets.begin(), offsets.end());
        rows.push_back({"  start - move's median start, " + bus, fmt("%+.0f us", percentile(offsets, 50)), "", NAN,
                        fmt2("min %+.0f, max %+.0f us", *lo, *hi)});
      }
    } else {
      findings.push_back("no SIM_REPORT ground truth for the moves");
    }
  } while (false);

  stop_all(programs.children());
  std::printf("lab-scale bench: %zu axes on %zu buses (scale %.2f), config %s, LCM %s\n", axis_bus.size(), buses.size(),
              opt.scale, config_path.c_str(), url.c_str());
  if (opt.realtime > 0)
    std::printf("realtime: gateways' loops SCHED_FIFO %d, motion-sim normal (refusals are in their logs)\n",
                opt.realtime);
  if (opt.sched_slice >= 0)
    std::printf("gateways' slice under normal scheduling: sched_slice_us %d\n", opt.sched_slice);
  std::printf("simulated serial lines: %s; motion-sim at nice %d, SCHED_FIFO %d (0: normal scheduling)\n",
              opt.serial_link.c_str(), opt.sim_nice, opt.sim_realtime);
  if (opt.cpu_latency >= 0)
    std::printf("cpu latency: %d us from idle, asked by %s's gateway (a refusal is in its log)\n", opt.cpu_latency,
                buses.front().name.c_str());
  print_rows(rows, "figure", "bound (same run)");
  if (!findings.empty()) {
    std::printf("\nfindings:\n");
    for (const auto& f : findings) std::printf("  - %s\n", f.c_str());
  }
  if (rc == 0 && std::getenv("BENCH_LAB_VERBOSE") == nullptr)
    std::filesystem::remove_all(dir);
  else
    std::printf("\nlogs kept in %s\n", dir.c_str());
  return rc;
}

}  // namespace
}  // namespace motion::bench

int main(int argc, char** argv) {
  motion::bench::Options opt;
  const char* const usage =
      "usage: bench_lab [--scale F] [--bring-up-s N] [--window-s N] [--moves N] [--per-bus N] [--realtime P] "
      "[--cpu-latency US] [--sched-slice US] [--enable-all 0|1] [--serial-link pty|socket] [--sim-nice N] "
      "[--sim-realtime P]\n";
  for (int i = 1; i < argc; i += 2) {
    // A flag without its value (e.g. --help) is refused, not ignored (it used to run the full lab).
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s", usage);
      return 2;
    }
    const std::string flag = argv[i];
    const double value = std::atof(argv[i + 1]);
    if (flag == "--serial-link" && (std::strcmp(argv[i + 1], "pty") == 0 || std::strcmp(argv[i + 1], "socket") == 0))
      opt.serial_link = argv[i + 1];
    else if (flag == "--sim-nice" && value >= 0 && value <= 19)
      opt.sim_nice = static_cast<int>(value);
    else if (flag == "--sim-realtime" && value >= 0 && value <= 99)
      opt.sim_realtime = static_cast<int>(value);
    else if (flag == "--scale" && value > 0 && value <= 1)
      opt.scale = value;
    else if (flag == "--bring-up-s")
      opt.bring_up_s = static_cast<int>(value);
    else if (flag == "--window-s")
      opt.window_s = static_cast<int>(value);
    else if (flag == "--moves")
      opt.moves = static_cast<int>(value);
    else if (flag == "--per-bus")
      opt.per_bus = static_cast<int>(value);
    else if (flag == "--enable-all" && (value == 0 || value == 1))
      opt.enable_all = value == 1;
    else if (flag == "--realtime" && value >= 0 && value <= 99)
      opt.realtime = static_cast<int>(value);
    else if (flag == "--cpu-latency" && value >= -1 && value <= 10000)
      opt.cpu_latency = static_cast<int>(value);
    else if (flag == "--sched-slice" && (value == 0 || (value >= 100 && value <= 100000)))
      opt.sched_slice = static_cast<int>(value);
    else {
      std::fprintf(stderr, "%s", usage);
      return 2;
    }
  }
  return motion::bench::run(opt);
}
