// motion-sim: the simulated buses and drives of a configuration. Every simulated CAN bus gets a
// bit-timed hub that gateways attach to by name; every simulated serial line a pty with the
// device of its drives' family (ADAM RS485 slaves, a UIM2501 with UIM242s); every drive gets the
// simulator of its family.
// With --simulate-uimessage the UIROBOT serial gateway of each uimessage: bus is simulated too
// (a pty linked at the bus's device path, a UIM2513 with the bus's UIM342s behind it).
// With --simulate-socketcan the drives of socketcan: buses are simulated on their interface too
// (a vcan in tests: the gateway then talks real SocketCAN to them).
#include <spdlog/spdlog.h>

#include "motion/app/service.hpp"
#include "motion/config/sim_variants.hpp"
#include "motion/core/log.hpp"
#include "motion/core/precise_timer.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/sim/adam_line_sim.hpp"
#include "motion/sim/can_bus_host.hpp"
#include "motion/sim/serial_line_host.hpp"
#include "motion/sim/uc57_drive.hpp"
#include "motion/sim/uim242_gateway_sim.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/sim/uimessage_gateway_sim.hpp"

// Only the fixed option set is built outside app::run, which turns every later exception into an exit code.
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  using namespace motion;
  CLI::App cli{"motion-sim: simulated buses and drives that speak the real wire protocols", "motion-sim"};
  app::CommonOptions options;
  app::add_common_options(cli, options);
  bool simulate_socketcan = false;
  cli.add_flag("--simulate-socketcan", simulate_socketcan,
               "also simulate the drives of socketcan: buses, on their interface (e.g. a vcan; one socket per drive)");
  bool simulate_uimessage = false;
  cli.add_flag("--simulate-uimessage", simulate_uimessage,
               "also simulate the UIROBOT serial gateways of uimessage: buses with their UIM342 drives: a pty linked "
               "at the bus's device path (which must not be a real port)");
  return app::run(cli, argc, argv, [&]() -> int {
    if (!log::init("sim", options.log_level)) return app::kExitUsage;
    auto config = app::load_config(options);
    if (!config) return app::kExitConfig;
    app::Service service(*config, options, "sim", "sim");
    // The simulated wires (bit-timed CAN, wire-paced serial lines) run on this loop's timers: keep
    // them to the microsecond, not to the default 50 us timer slack.
    if (!minimal_timer_slack()) spdlog::warn("could not lower the timer slack (prctl PR_SET_TIMERSLACK)");
    if (!service.ok()) return app::kExitUnavailable;

    // Simulators by family; each family's issue registers its own here.
    const std::map<config::Family, sim::CanDriveFactory> can_factories{
        {config::Family::kUim342, sim::uim342_factory(*config)},
        {config::Family::kUc57, sim::uc57_drive_factory(*config)},
    };
    const sim::SerialLineHost::Factories serial_factories{
        {config::Family::kAdamModbus, sim::adam_line_factory()},
        {config::Family::kUim242, sim::uim242_line_factory()},
    };
    // A uimessage: bus is a serial line to a UIM2513/UIM2533 with UIM342s on its CAN side.
    const sim::SerialLineHost::Factories uimessage_factories{
        {config::Family::kUim342, sim::uimessage_gateway_factory(*config)},
    };

    auto report = [&service](const motionlcm::sim_report_t& r) {
      service.node().publish(motion::lcm::channels::kSimReport, r);
    };
    std::vector<std::unique_ptr<sim::CanBusHost>> can_buses;
    std::vector<std::unique_ptr<sim::SerialLineHost>> serial_lines;
    std::vector<std::string> missing;
    for (const auto& bus : config->buses) {
      if (bus.kind == config::TransportKind::kSimCan) {
        std::error_code error;
        auto host = sim::CanBusHost::open(service.loop(), *config, bus, can_factories, report, error);
        if (!host) {
          spdlog::error("cannot open simulated CAN bus {} in {}: {}", bus.name, config::sim_runtime_dir(*config),
                        error.message());
          return app::kExitUnavailable;
        }
        missing.insert(missing.end(), host->missing().begin(), host->missing().end());
        spdlog::info("simulated CAN bus {} at {} bit/s ({}), socket {}", bus.name, bus.bitrate,
                     bus.bus_timing ? "bit-timed" : "untimed", host->hub().socket_path().string());
        can_buses.push_back(std::move(host));
      } else if (bus.kind == config::TransportKind::kSocketCan && simulate_socketcan) {
        std::error_code error;
        auto host = sim::CanBusHost::open_socketcan(service.loop(), *config, bus, can_factories, report, error);
        if (!host) {
          spdlog::error("cannot simulate the drives of bus {} on {}: {}", bus.name, bus.transport, error.message());
          return app::kExitUnavailable;
        }
        missing.insert(missing.end(), host->missing().begin(), host->missing().end());
        spdlog::info("simulated drives of CAN bus {} on SocketCAN {} ({} drives)", bus.name, bus.target,
                     host->drive_count());
        can_buses.push_back(std::move(host));
      } else if (bus.kind == config::TransportKind::kUiMessage && simulate_uimessage) {
        std::error_code error;
        auto host =
            sim::SerialLineHost::open(service.loop(), *config, bus, uimessage_factories, report, error, bus.target);
        if (!host) {
          spdlog::error("cannot simulate the serial gateway of bus {} at {}: {}", bus.name, bus.target,
                        error.message());
          return app::kExitUnavailable;
        }
        missing.insert(missing.end(), host->missing().begin(), host->missing().end());
        spdlog::info("simulated UIMessage gateway {} ({} UIM342 drives, {} baud, CRC over {} bytes) at {}", bus.name,
                     host->drive_count(), bus.baud, config::sim_bus_variant(*config, bus, "crc_bytes"),
                     host->link_path());
        serial_lines.push_back(std::move(host));
      } else if (bus.kind == config::TransportKind::kSimSerial &&
                 sim::SerialLineHost::family_for(*config, bus, serial_factories)) {
        std::error_code error;
        auto host = sim::SerialLineHost::open(service.loop(), *config, bus, serial_factories, report, error);
        if (!host) {
          spdlog::error("cannot create the simulated serial line {} in {}: {}", bus.name,
                        config::sim_runtime_dir(*config), error.message());
          return app::kExitUnavailable;
        }
        missing.insert(missing.end(), host->missing().begin(), host->missing().end());
        spdlog::info("simulated serial line {} ({} {} drives, {} baud) at {}", bus.name, host->drive_count(),
                     config::to_string(host->family()), bus.baud, host->link_path());
        serial_lines.push_back(std::move(host));
      } else if (bus.kind == config::TransportKind::kSimSerial) {
        for (const auto& d : config->drives) {
          if (d.bus == bus.name) missing.push_back(d.name + " (" + std::string(config::to_string(d.family)) + ")");
        }
      }
    }
    service.node().subscribe<motionlcm::sim_control_t>(
        motion::lcm::channels::kSimControl, [&](const motionlcm::sim_control_t& c, const std::string&) {
          for (auto& host : can_buses) {
            if (host->control(c)) return;
          }
          for (auto& host : serial_lines) {
            if (host->control(c)) return;
          }
          spdlog::warn("sim control for drive '{}' bus '{}' (action {}) matched nothing it supports", c.drive, c.bus,
                       c.action);
        });

    if (missing.empty()) {
      service.health().set_state(motionlcm::health_t::OK, std::to_string(config->drives.size()) + " drives");
    } else {
      std::string list;
      for (const auto& m : missing) list += (list.empty() ? "" : ", ") + m;
      spdlog::warn("no simulator yet for: {}", list);
      service.health().set_state(motionlcm::health_t::DEGRADED, "no simulator for " + list);
    }
    return service.run();
  });
}
