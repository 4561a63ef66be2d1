// motion-coordinator: the single entry point for clients (REQUEST -> REPLY).
#include <spdlog/spdlog.h>

#include "motion/app/service.hpp"
#include "motion/coordinator/coordinator_service.hpp"
#include "motion/coordinator/move_planner.hpp"
#include "motion/core/log.hpp"

// Only the fixed option set is built outside app::run, which turns every later exception into an exit code.
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  using namespace motion;
  CLI::App cli{"motion-coordinator: validates, plans and synchronizes multi-axis moves", "motion-coordinator"};
  app::CommonOptions options;
  app::add_common_options(cli, options);
  return app::run(cli, argc, argv, [&]() -> int {
    if (!log::init("coordinator", options.log_level)) return app::kExitUsage;
    auto config = app::load_config(options);
    if (!config) return app::kExitConfig;
    auto loaded = coordinator::CoordinatorService::load_security(*config);
    if (auto* error = std::get_if<std::string>(&loaded)) {
      spdlog::error("{}: {}", config->file, *error);
      return app::kExitConfig;
    }
    auto& security = std::get<coordinator::CoordinatorService::Security>(loaded);
    spdlog::info("security: mode {}, {}, gateway commands {}", config::to_string(config->security.mode),
                 security.verifier ? std::to_string(security.verifier->keys().principals().size()) + " authorized keys"
                                   : std::string("no authorized_keys"),
                 security.command_signer ? "signed" : "not signed");
    app::Service service(*config, options, "coordinator", "coordinator");
    if (!service.ok()) return app::kExitUnavailable;
    coordinator::CoordinatorService coordinator(service.loop(), service.node(), *config,
                                                coordinator::make_move_planner(), std::move(security));
    // OK once every bus's gateway and every axis's state is heard: until then requests for those
    // axes are refused.
    auto update_health = [&] {
      std::string missing;
      for (const auto& bus : coordinator.buses_without_gateway())
        missing += (missing.empty() ? "" : ", ") + ("gateway:" + bus);
      if (!missing.empty()) {
        service.health().set_state(motionlcm::health_t::DEGRADED, "no heartbeat from " + missing);
        return;
      }
      const auto unheard = coordinator.axes_never_heard();
      if (!unheard.empty()) {
        std::string names;
        for (std::size_t i = 0; i < unheard.size() && i < 5; ++i) names += (i == 0 ? "" : ", ") + unheard[i];
        if (unheard.size() > 5) names += " and " + std::to_string(unheard.size() - 5) + " more";
        service.health().set_state(motionlcm::health_t::DEGRADED, "no state yet from axis " + names);
        return;
      }
      service.health().set_state(motionlcm::health_t::OK,
                                 std::to_string(config->axes.size()) + " axes, every gateway and axis heard");
    };
    update_health();
    service.loop().call_every(std::chrono::milliseconds(100), update_health);
    // With security.key its heartbeats also go out signed (SHEALTH), the last STOPPING one included.
    service.health().set_signed_copy([&coordinator](const motionlcm::health_t& h) { coordinator.sign_heartbeat(h); });
    const int exit_code = service.run();
    service.health().set_signed_copy({});
    return exit_code;
  });
}
