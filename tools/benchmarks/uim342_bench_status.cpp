// bench_uim342, part 3: status polling throughput of N = 8, 32, 120 drives on a timed bus, and
// commands while the polls saturate it (see uim342_bench.cpp for the whole table).
#include "uim342_bench_harness.hpp"

namespace motion::uim342_bench {

using namespace std::chrono_literals;

namespace {

// Commands during saturated polling: ENABLE of one axis (one MO frame) at spread instants; when the
// MO frame started on the wire, from the command and from its hand-over, against one poll frame.
void bench_command_wait(Pump& pump, gateway::CanBusDriver& driver, Capture& out, std::vector<can::Frame>& wire,
                        bool& keeping, std::vector<std::pair<std::int64_t, can::Frame>>& handed, int axes, bool quick) {
  EventLoop& loop = pump.loop();
  const std::int64_t epoch_offset = wall_time_us() - steady_us(loop.now());  // loop time -> frame stamps
  const double poll_frame_us = us(can::frame_duration(
      *uim342::instruction_frame(uim342::kMinNodeId, uim342::request::get(uim342::MotionStatusIndex::kKinematics)),
      kBitrate));
  std::vector<double> from_command;
  std::vector<double> from_handover;
  long max_polls_ahead = 0;
  int failures = 0;
  const int commands = quick ? 20 : 100;
  for (int c = 0; c < commands; ++c) {
    pump.until([] { return false; }, std::chrono::microseconds(2000 + 173 * (c % 11)));
    wire.clear();
    handed.clear();
    keeping = true;
    const std::int64_t id = 5000 + c;
    const std::int64_t t0 = steady_us(loop.now()) + epoch_offset;
    driver.execute(command(id, k(gateway_command_t::ENABLE), {"a" + std::to_string((c * 7) % axes)}));
    const bool ended = pump.until([&] { return out.has(id, k(gateway_reply_t::DONE)) || out.failed(id); }, 1s);
    keeping = false;
    if (!ended || out.failed(id) || handed.empty()) {
      ++failures;
      continue;
    }
    const std::int64_t given = handed.front().first + epoch_offset;
    const auto mo =
        std::find_if(wire.begin(), wire.end(), [&](const can::Frame& f) { return f == handed.front().second; });
    if (mo == wire.end()) {
      ++failures;
      continue;
    }
    const double start = static_cast<double>(mo->timestamp_us) -
                         us(can::bits_duration(can::frame_bits(*mo).to_end_of_frame(), kBitrate));
    from_command.push_back(start - static_cast<double>(t0));
    from_handover.push_back(start - static_cast<double>(given));
    max_polls_ahead = std::max<long>(max_polls_ahead, std::count_if(wire.begin(), mo, [&](const can::Frame& f) {
                                       const auto m = decode(f);
                                       return m && is_function(*m, FC::kMS) &&
                                              m->address.producer == uim342::kMasterId && f.timestamp_us > given;
                                     }));
  }
  const std::string n = std::to_string(from_command.size()) + " commands" +
                        (failures ? ", " + std::to_string(failures) + " failed" : std::string{});
  const std::string label = "   N=" + std::to_string(axes) + ", polls saturating: ";
  const auto row = [&](const std::string& what, const std::vector<double>& v, double p, const std::string& note) {
    g_rows.push_back({label + what + (p < 0.9 ? " p50" : " p99"), fmt("%.0f us", nearest_rank(v, p)),
                      fmt("%.0f us one poll request frame", poll_frame_us), nearest_rank(v, p) / poll_frame_us, note});
  };
  row("command -> MO on the wire", from_command, 0.5,
      n + "; includes the node's own poll exchange in flight (one request per node, manual §2.1)");
  row("command -> MO on the wire", from_command, 0.99, "");
  row("MO handed over -> on the wire", from_handover, 0.5,
      fmt("our poll frames ended between hand-over and MO: at most %.0f", static_cast<double>(max_polls_ahead)));
  row("MO handed over -> on the wire", from_handover, 0.99, "a drive's answer already on the wire may go first");
}

}  // namespace

void bench_status(int axes, bool quick, const std::filesystem::path& dir) {
  const config::Config config =
      load(lab_config(axes, true, 0, "udpm://239.255.76.67:7667?ttl=0", "u342st" + std::to_string(axes), dir.string()));
  Pump pump(nullptr);
  EventLoop& loop = pump.loop();
  auto host = open_host(loop, config);
  auto monitor = host->hub().attach_local("monitor");
  std::uint64_t poll_frames = 0;
  std::uint64_t poll_bits = 0;
  std::uint64_t all_frames = 0;
  bool counting = false;
  std::vector<can::Frame> wire;  // every frame while commands are measured (end-of-frame stamps)
  bool keeping = false;
  loop.watch(monitor->fd(), [&] {
    while (auto f = monitor->receive()) {
      if (keeping) wire.push_back(*f);
      if (!counting) continue;
      ++all_frames;
      if (const auto m = decode(*f); m && is_function(*m, FC::kMS)) {
        ++poll_frames;
        poll_bits += can::frame_bits(*f).total;
      }
    }
  });
  Capture out;
  std::vector<std::pair<std::int64_t, can::Frame>> handed;  // MO frames handed over (steady us)
  auto tap = std::make_unique<TapTransport>(host->hub().attach_local("gateway"), [&](const can::Frame& f) {
    if (const auto m = decode(f); m && is_function(*m, FC::kMO)) handed.emplace_back(steady_us(loop.now()), f);
  });
  gateway::CanBusDriver driver(loop, "can0", std::move(tap), out);
  const gateway::Uim342Stack* stack_view = add_uim342_stack(driver, config);
  driver.start();
  await_set_up(pump, *stack_view, 120s, "status rig, N=" + std::to_string(axes));
  pump.until([] { return false; }, 500ms);  // settle into the poll rhythm
  const auto window = quick ? 1s : 4s;
  const std::uint64_t updates0 = out.status_updates;
  const auto before = stack_view->counters();
  counting = true;
  const auto t0 = Clock::now();
  pump.until([] { return false; }, window);
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  counting = false;
  const double load = host->hub().statistics().bus_load;

  const double achieved = static_cast<double>(out.status_updates - updates0) / seconds;
  const double asked = static_cast<double>(axes * kPollHz);
  const double bits_per_frame = poll_frames ? static_cast<double>(poll_bits) / static_cast<double>(poll_frames) : NAN;
  const double capacity_frames = static_cast<double>(kBitrate) / bits_per_frame;  // frames/s the bus can carry
  constexpr double kFramesPerUpdate = 4;                                          // MS[0] and MS[1]: request + ACK each
  const double needed_frames = asked * kFramesPerUpdate;
  const double bus_updates = capacity_frames / kFramesPerUpdate;
  const double bound = std::min(asked, bus_updates);
  const auto& after = stack_view->counters();
  char note[320];
  const double polled_hz = 1.0 / std::chrono::duration<double>(stack_view->poll_period()).count();
  std::snprintf(note, sizeof note,
                "asked %.0f/s (%d Hz x %d); stack estimates %.1f Hz per drive; bus carries %.0f/s "
                "(%.1f bits/poll frame); "
                "bus load %.0f%%; %lld retries, %lld timeouts, %lld unexpected",
                asked, kPollHz, axes, polled_hz, bus_updates, bits_per_frame, load * 100.0,
                static_cast<long long>(after.retries - before.retries),
                static_cast<long long>(after.timeouts - before.timeouts),
                static_cast<long long>(after.unexpected - before.unexpected));
  g_rows.push_back({"3. status N=" + std::to_string(axes) + ": axis state updates/s", fmt("%.0f /s", achieved),
                    fmt("%.0f /s min(asked, bus)", bound), achieved / bound, note});
  g_rows.push_back({"   N=" + std::to_string(axes) + ": frames/s the poll needs vs the bus carries",
                    fmt("%.0f frames/s needed", needed_frames), fmt("%.0f frames/s capacity", capacity_frames),
                    needed_frames / capacity_frames,
                    fmt2("measured on the wire: %.0f poll frames/s, %.0f frames/s in all",
                         static_cast<double>(poll_frames) / seconds, static_cast<double>(all_frames) / seconds)});
  const double poll_share = static_cast<double>(poll_bits) / seconds / kBitrate;
  const double asked_share = std::min(1.0, needed_frames / capacity_frames);
  g_rows.push_back({"   N=" + std::to_string(axes) + ": share of the bus the polls took",
                    fmt("%.1f %%", 100 * poll_share), fmt("%.1f %% min(asked, 100 %%)", 100 * asked_share),
                    poll_share / asked_share,
                    "poll frames' wire bits / bit rate; goal >= 90 % when asked for more than the bus carries"});
  if (needed_frames > capacity_frames) bench_command_wait(pump, driver, out, wire, keeping, handed, axes, quick);
  loop.unwatch(monitor->fd());
}

}  // namespace motion::uim342_bench
