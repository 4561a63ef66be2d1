// motion-gateway --bus NAME: owns one bus of the configuration and translates between its drives'
// wire protocol and LCM.
#include <spdlog/spdlog.h>

#include "motion/app/service.hpp"
#include "motion/core/log.hpp"

int main(int argc, char** argv) {
  using namespace motion;
  CLI::App cli{"motion-gateway: one bus's drives <-> LCM (axis state, events, commands)", "motion-gateway"};
  app::CommonOptions options;
  std::string bus_name;
  app::add_common_options(cli, options);
  cli.add_option("--bus", bus_name, "Name of the bus (from the configuration's buses list) this gateway owns")->required();
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
    app::Service service(*config, options, "gateway:" + bus_name, "gateway");
    if (!service.ok()) return app::kExitUnavailable;
    service.health().set_state(motionlcm::health_t::OK, bus->transport);
    return service.run();
  });
}
