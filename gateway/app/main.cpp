// motion-gateway --bus NAME: owns one bus of the configuration and translates between its drives'
// wire protocol and LCM.
#include <spdlog/spdlog.h>

#include <cerrno>
#include <cstring>
#include <optional>

#include "bus_assembly.hpp"
#include "bus_lock.hpp"
#include "motion/app/service.hpp"
#include "motion/core/cpu_latency.hpp"
#include "motion/core/log.hpp"
#include "motion/core/precise_timer.hpp"
#include "motion/drive_model/drive_model.hpp"
#include "motion/gateway/gateway.hpp"

// Only the fixed option set is built outside app::run, which turns every later exception into an exit code.
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  using namespace motion;
  CLI::App cli{"motion-gateway: one bus's drives <-> LCM (axis state, events, commands)", "motion-gateway"};
  app::CommonOptions options;
  std::string bus_name;
  app::add_common_options(cli, options);
  cli.add_option("--bus", bus_name, "Name of the bus (from the configuration's buses list) this gateway owns")
      ->required();
  return app::run(cli, argc, argv, [&]() -> int {
    if (!log::init("gateway:" + bus_name, options.log_level)) return app::kExitUsage;
    auto config = app::load_config(options);
    if (!config) return app::kExitConfig;
    const config::Bus* bus = config->find_bus(bus_name);
    if (bus == nullptr) {
      std::string names;
      for (const auto& b : config->buses) names += (names.empty() ? "" : ", ") + b.name;
      spdlog::error("bus '{}' is not in {} (buses: {})", bus_name, config->file, names);
      return app::kExitConfig;
    }
    auto lock = gateway::lock_bus(*config, *bus);
    if (const auto* refused = std::get_if<std::string>(&lock)) {
      spdlog::error("{}", *refused);
      return app::kExitUnavailable;
    }
    auto verifier = gateway::Gateway::load_coordinator_key(*config);
    if (auto* error = std::get_if<std::string>(&verifier)) {
      spdlog::error("{}: {}", config->file, *error);
      return app::kExitConfig;
    }
    auto gateway_key = gateway::Gateway::load_gateway_key(*config, bus_name);
    if (auto* error = std::get_if<std::string>(&gateway_key)) {
      spdlog::error("{}: {}", config->file, *error);
      return app::kExitConfig;
    }
    app::Service service(*config, options, "gateway:" + bus_name, "gateway");
    if (!service.ok()) return app::kExitUnavailable;
    // Scheduled starts and SYNC periods keep to microseconds (PreciseTimer), not to the default
    // 50 us timer slack of this (the loop's) thread.
    if (!minimal_timer_slack()) spdlog::warn("could not lower the timer slack (prctl PR_SET_TIMERSLACK)");
    // Optional: the loop (it blocks in ppoll between frames, so it cannot starve the CPU) ahead of
    // every normal process, for SYNC periods and start frames that keep their time on a busy host.
    bool fifo = false;
    if (const int priority = bus->realtime_priority; priority > 0) {
      fifo = fifo_scheduling(priority);
      const int error = errno;
      if (fifo) {
        spdlog::info("bus {}: running under SCHED_FIFO at priority {}", bus_name, priority);
      } else {
        spdlog::warn(
            "bus {}: realtime_priority {} refused ({}): running under normal scheduling (needs "
            "CAP_SYS_NICE or an RLIMIT_RTPRIO of at least {}, e.g. LimitRTPRIO= in its systemd unit)",
            bus_name, priority, std::strerror(error), priority);
      }
    }
    // Optional, under normal scheduling: short turns, so that the loop woken for a start or a SYNC
    // preempts a busy process at once instead of waiting out that one's slice (up to milliseconds);
    // a loop whose bursts are longer than its slice is preempted inside them (README).
    if (!fifo && bus->sched_slice_us > 0) {
      const auto slice = fair_slice(std::chrono::microseconds(bus->sched_slice_us));
      const int error = errno;
      if (!slice) {
        spdlog::warn("bus {}: sched_slice_us {} refused ({}): the kernel's default slice stays", bus_name,
                     bus->sched_slice_us, std::strerror(error));
      } else if (*slice == Duration::zero()) {
        spdlog::info("bus {}: this kernel takes no slice of a thread's own (Linux 6.12 and later do)", bus_name);
      } else {
        spdlog::info("bus {}: the loop's slice is {} us", bus_name,
                     std::chrono::duration_cast<std::chrono::microseconds>(*slice).count());
      }
    }
    // Optional: no CPU of the host slower to wake from idle than cpu_latency_us while this process
    // runs (in a virtual machine, waking a halted virtual CPU costs tens of microseconds more).
    std::optional<CpuLatencyRequest> cpu_latency;
    if (bus->cpu_latency_us >= 0) {
      cpu_latency.emplace(std::chrono::microseconds(bus->cpu_latency_us));
      if (cpu_latency->held()) {
        spdlog::info("bus {}: the host's CPUs wake from idle within {} us while this gateway runs", bus_name,
                     bus->cpu_latency_us);
      } else {
        spdlog::warn(
            "bus {}: cpu_latency_us {} refused ({}): the host's own idle states stay (needs write access to "
            "/dev/cpu_dma_latency: root, or a udev rule granting the gateway's group)",
            bus_name, bus->cpu_latency_us, cpu_latency->error().message());
      }
    }
    gateway::Gateway gateway(service.loop(), service.node(), service.health(), *config, bus_name);
    // Where the axes were, whether homed: a drive that lost power while no gateway ran is caught.
    gateway.set_position_record(gateway::position_record_path(*config, *bus));
    gateway.set_coordinator_key(std::get<std::optional<security::PublicKey>>(verifier));
    gateway.set_gateway_key(std::get<std::optional<security::KeyPair>>(gateway_key));
    gateway.set_model_builder([&config = *config](const config::Axis& axis, const gateway::DriveFacts& facts) {
      return drive_model::build(config, axis, facts);
    });
    gateway.set_arming_builder(
        [&config = *config](const config::Axis& axis) { return drive_model::arming(config, axis); });

    // The bus may not exist yet (motion-sim starting, adapter unplugged): keep trying, and say
    // why in the health meanwhile.
    constexpr auto kRetryPeriod = std::chrono::seconds(1);
    EventLoop::TimerId retry = 0;
    std::string last_error;
    auto try_open = [&] {
      auto assembly = gateway::assemble_bus(service.loop(), *config, *bus, gateway);
      gateway.set_unsupported(assembly.unsupported);
      if (assembly.driver) {
        service.loop().cancel(retry);
        gateway.set_waiting({});
        spdlog::info("bus {} open ({})", bus_name, bus->transport);
        gateway.attach(std::move(assembly.driver));
        return;
      }
      if (assembly.error) {
        if (assembly.error_text != last_error)
          spdlog::warn("{}; retrying every {} s", assembly.error_text, kRetryPeriod.count());
        last_error = assembly.error_text;
        gateway.set_waiting(assembly.error_text);
      } else {
        service.loop().cancel(retry);  // nothing to open: no driver serves this bus's families yet
      }
    };
    retry = service.loop().call_every(kRetryPeriod, try_open);
    try_open();
    return service.run();
  });
}
