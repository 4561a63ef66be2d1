// motionctl dump / send: raw CAN frames on a configured bus, in can-utils' notation.
//
//   motionctl dump BUS [--count N] [--for SECONDS]   every frame on the bus as `candump -L` lines
//   motionctl send BUS ID#DATA [ID#DATA...]           frames in `cansend` syntax
//
// Both reach the bus through gateway::open_can_transport() (simcan:, socketcan: or uimessage:,
// where "seen on the bus" means written to the gateway's serial port), like the gateways, and
// need no LCM. dump writes only log lines to stdout (one flushed line per frame, so
// `> file` and pipes see each frame at once); diagnostics go to stderr, starting with
// "listening on BUS" once the bus delivers to it (for scripts: frames sent after that line are
// dumped). send returns when every frame has been seen on the bus (own echo), so exit status 0
// means every frame has been on the wire, not merely queued. Exit codes: 0 done, 1 the bus
// refused a frame / disconnected / no echo in time, 2 bad command line (syntax, unknown or
// non-CAN bus), 3 configuration refused, 4 the bus cannot be opened (no motion-sim, no interface).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include "motion/can_frame/frame.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/core/log.hpp"
#include "motion/gateway/can_transport_factory.hpp"
#include "motion/simbus/endpoint.hpp"
#include "motionctl.hpp"

namespace motion::ctl {
namespace {

struct DumpOptions {
  std::string bus;
  std::uint64_t count = 0;  // 0: no limit
  double seconds = 0;       // 0: no limit
};

struct SendOptions {
  std::string bus;
  std::vector<std::string> frames;
};

// Why `text` is not cansend syntax (empty when it is).
std::string cansend_problem(const std::string& text) {
  if (can::parse_cansend(text)) return {};
  constexpr const char* kHex = "0123456789abcdefABCDEF";
  const auto hash = text.find('#');
  std::string why;
  if (hash == std::string::npos) {
    why = "no '#' between id and data";
  } else if (hash != 3 && hash != 8) {
    why = "the id needs 3 hex digits (11-bit) or 8 (29-bit), not " + std::to_string(hash);
  } else if (text.find_first_not_of(kHex) < hash) {
    why = "the id is not hexadecimal";
  } else if (hash == 3 && std::stoul(text.substr(0, 3), nullptr, 16) > can::kMaxStandardId) {
    why = "an 11-bit id is at most 7FF";
  } else if (hash == 8 && std::stoul(text.substr(0, 8), nullptr, 16) > can::kMaxExtendedId) {
    why = "a 29-bit id is at most 1FFFFFFF";
  } else {
    why = "the data must be up to 8 bytes as hex pairs (optionally '.'-separated), or R / R0..R8 for a remote frame";
  }
  return "'" + text + "' is not cansend syntax ID#DATA: " + why + " (e.g. 123#DEADBEEF, 04280095#01, 123#R)";
}

// The configured CAN bus named `name`; nullptr after printing why not.
const config::Bus* find_can_bus(const config::Config& config, const std::string& name, const char* command) {
  const config::Bus* bus = config.find_bus(name);
  if (bus == nullptr) {
    std::string names;
    for (const auto& b : config.buses) {
      if (config::is_can(b.kind)) names += (names.empty() ? "" : ", ") + b.name;
    }
    std::cerr << "motionctl " << command << ": bus '" << name << "' is not in " << config.file
              << " (CAN buses: " << (names.empty() ? "none" : names) << ")\n";
    return nullptr;
  }
  if (!config::is_can(bus->kind)) {
    std::cerr << "motionctl " << command << ": bus " << bus->name << " (" << bus->transport
              << ") is not a CAN bus (CAN transports: simcan:NAME, socketcan:IFACE, uimessage:DEVICE)\n";
    return nullptr;
  }
  return bus;
}

// Whether frames sent on the bus now reach this transport: a simulated-bus endpoint is attached
// once the hub's Welcome has arrived; a SocketCAN socket is bound when it is open.
bool attached(const can::Transport& transport) {
  if (const auto* sim = dynamic_cast<const simbus::SocketEndpoint*>(&transport)) return sim->endpoint_id() != 0;
  return transport.fd() >= 0;
}

Duration seconds_to_duration(double seconds) {
  return std::chrono::duration_cast<Duration>(std::chrono::duration<double>(seconds));
}

struct OpenBus {
  std::optional<config::Config> config;
  const config::Bus* bus = nullptr;
  std::unique_ptr<can::Transport> transport;
};

// Loads the configuration, finds the bus and opens it; an exit code on failure (message printed).
int open_bus(Context& ctx, const std::string& bus_name, const char* command, OpenBus& out) {
  if (!log::init("motionctl", ctx.options.log_level)) return app::kExitUsage;
  out.config = app::load_config(ctx.options);
  if (!out.config) return app::kExitConfig;
  out.bus = find_can_bus(*out.config, bus_name, command);
  if (out.bus == nullptr) return app::kExitUsage;
  std::error_code error;
  out.transport = gateway::open_can_transport(
      *out.config, *out.bus, "motionctl " + std::string(command) + " (pid " + std::to_string(::getpid()) + ")", error);
  if (!out.transport) {
    std::cerr << "motionctl " << command << ": " << gateway::open_error_message(*out.config, *out.bus, error) << "\n";
    return app::kExitUnavailable;
  }
  return app::kExitOk;
}

constexpr auto kAttachTimeout = std::chrono::seconds(3);

int run_dump(Context& ctx, const DumpOptions& options) {
  OpenBus open;
  if (const int rc = open_bus(ctx, options.bus, "dump", open); rc != app::kExitOk) return rc;
  can::Transport& transport = *open.transport;
  const std::string& interface = open.bus->name;

  EventLoop loop;
  loop.stop_on_signals();
  int rc = app::kExitOk;
  std::uint64_t dumped = 0;
  bool announced = false;
  auto announce = [&] {
    if (announced || !attached(transport)) return;
    announced = true;
    std::cerr << "motionctl dump: listening on " << interface << " (" << open.bus->transport << ")" << std::endl;
  };
  transport.on_bus_event([&](const can::BusEvent& e) {
    std::cerr << "motionctl dump: bus " << interface << ": " << can::to_string(e.state)
              << (e.text.empty() ? "" : ": " + e.text) << std::endl;
    if (e.state == can::BusState::kDisconnected) {
      rc = app::kExitFailure;
      loop.stop();
    }
  });
  const int fd = transport.fd();
  loop.watch(fd, [&] {
    while (!loop.stopping()) {
      auto frame = transport.receive();
      if (!frame) break;
      if (frame->timestamp_us == 0) frame->timestamp_us = wall_time_us();
      const std::string line = can::to_candump_line(*frame, interface) + "\n";
      if (std::fwrite(line.data(), 1, line.size(), stdout) != line.size() || std::fflush(stdout) != 0) {
        rc = app::kExitFailure;  // stdout closed: nobody is listening any more
        loop.stop();
        return;
      }
      if (options.count != 0 && ++dumped >= options.count) loop.stop();
    }
    announce();
  });
  announce();
  loop.call_after(kAttachTimeout, [&] {
    if (announced) return;
    std::cerr << "motionctl dump: bus " << interface << ": no answer from the bus within "
              << std::chrono::duration_cast<std::chrono::seconds>(kAttachTimeout).count() << " s\n";
    rc = app::kExitUnavailable;
    loop.stop();
  });
  if (options.seconds > 0) loop.call_after(seconds_to_duration(options.seconds), [&] { loop.stop(); });
  if (!loop.stopping()) loop.run();
  loop.unwatch(fd);
  return rc;
}

int run_send(Context& ctx, const SendOptions& options) {
  std::vector<can::Frame> frames;
  for (const auto& text : options.frames) {
    auto frame = can::parse_cansend(text);
    if (!frame) {  // the CLI validator already refused it; kept for callers that bypass it
      std::cerr << "motionctl send: " << cansend_problem(text) << "\n";
      return app::kExitUsage;
    }
    frames.push_back(*frame);
  }
  OpenBus open;
  if (const int rc = open_bus(ctx, options.bus, "send", open); rc != app::kExitOk) return rc;
  can::Transport& transport = *open.transport;
  const std::string& name = open.bus->name;
  // Our own frames come back when they have been on the wire: that is the confirmation.
  if (const auto error = transport.set_own_echo(true)) {
    std::cerr << "motionctl send: bus " << name << ": cannot enable own echo: " << error.message() << "\n";
    return app::kExitFailure;
  }

  EventLoop loop;
  loop.stop_on_signals();
  std::string failure;
  std::size_t next = 0;
  std::vector<can::Frame> unconfirmed;  // sent, echo not seen yet
  std::uint64_t refused_by_us = 0;      // send() failures we retry (counted in tx_dropped too)
  auto fail = [&](std::string why) {
    if (failure.empty()) failure = std::move(why);
    loop.stop();
  };
  transport.on_bus_event([&](const can::BusEvent& e) {
    if (e.state == can::BusState::kBusOff || e.state == can::BusState::kDisconnected) {
      fail(std::string(can::to_string(e.state)) + (e.text.empty() ? "" : ": " + e.text));
    }
  });
  auto pump = [&] {
    while (auto frame = transport.receive()) {
      const auto it = std::find(unconfirmed.begin(), unconfirmed.end(), *frame);
      if (it != unconfirmed.end()) unconfirmed.erase(it);
    }
    if (loop.stopping()) return;
    if (transport.statistics().tx_dropped > refused_by_us) {
      fail("the bus refused a frame (bus-off?)");
      return;
    }
    while (next < frames.size()) {
      const std::error_code error = transport.send(frames[next]);
      if (error == std::errc::no_buffer_space || error == std::errc::resource_unavailable_try_again) {
        ++refused_by_us;  // transmit queue full: retried by the timer below
        break;
      }
      if (error) {
        fail("cannot send " + can::to_cansend(frames[next]) + ": " + error.message());
        return;
      }
      unconfirmed.push_back(frames[next++]);
    }
    if (next == frames.size() && unconfirmed.empty()) loop.stop();
  };
  const int fd = transport.fd();
  loop.watch(fd, pump);
  loop.call_every(std::chrono::milliseconds(5), [&] {
    if (next < frames.size()) pump();  // only while the transmit queue pushed back
  });
  // Generous: the slowest bus (10 kbit/s) needs ~16 ms per frame.
  const auto timeout = std::chrono::seconds(3) + std::chrono::milliseconds(20) * frames.size();
  loop.call_after(timeout, [&] {
    fail(std::to_string(unconfirmed.size() + (frames.size() - next)) + " of " + std::to_string(frames.size()) +
         " frames not seen on the bus within " +
         std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(timeout).count()) + " ms");
  });
  pump();
  if (!loop.stopping()) loop.run();
  if (transport.fd() >= 0) loop.unwatch(fd);
  if (!failure.empty()) {
    std::cerr << "motionctl send: bus " << name << " (" << open.bus->transport << "): " << failure << "\n";
    return app::kExitFailure;
  }
  if (loop.stop_signal() != 0) return app::kExitFailure;  // interrupted before every frame was confirmed
  return app::kExitOk;
}

}  // namespace

void add_can_commands(CLI::App& cli, Context& ctx) {
  auto* dump = cli.add_subcommand(
      "dump", "Print every frame on a CAN bus as candump -L log lines: (SECONDS.MICROS) BUS ID#DATA");
  auto d = std::make_shared<DumpOptions>();
  dump->add_option("bus", d->bus, "Bus name from the configuration (printed as the interface)")->required();
  const CLI::Validator non_negative(
      [](std::string& text) {
        try {
          std::size_t used = 0;
          const double v = std::stod(text, &used);
          if (used == text.size() && v >= 0 && std::isfinite(v)) return std::string{};
        } catch (const std::exception&) {}
        return "'" + text + "' is not a number >= 0";
      },
      "NUMBER>=0", "non-negative");
  dump->add_option("--count", d->count, "Stop after N frames (0: no limit)")
      ->check(non_negative)
      ->capture_default_str();
  dump->add_option("--for", d->seconds, "Stop after SECONDS (0: no limit)")->check(non_negative)->capture_default_str();
  // dump writes candump log lines and send reads cansend syntax: the can-utils formats, which
  // other tools parse; no JSON form.
  const auto no_json = [&ctx](const char* command) {
    if (!ctx.json) return false;
    std::cerr << "motionctl " << command
              << ": --json is not supported (it speaks the can-utils formats: candump -L lines, cansend frames)\n";
    ctx.result = app::kExitUsage;
    return true;
  };
  dump->callback([&ctx, d, no_json] {
    if (!no_json("dump")) ctx.result = run_dump(ctx, *d);
  });

  auto* send = cli.add_subcommand("send", "Send CAN frames in cansend syntax; returns once each has been on the bus");
  auto s = std::make_shared<SendOptions>();
  send->add_option("bus", s->bus, "Bus name from the configuration")->required();
  send->add_option("frames", s->frames,
                   "ID#DATA: 3 hex digits = 11-bit id, 8 = 29-bit id; data as hex pairs (up to 8 bytes); ID#R or "
                   "ID#R<dlc> = remote frame")
      ->required()
      ->check(CLI::Validator([](std::string& text) { return cansend_problem(text); }, "ID#DATA", "cansend"));
  send->callback([&ctx, s, no_json] {
    if (!no_json("send")) ctx.result = run_send(ctx, *s);
  });
}

}  // namespace motion::ctl
