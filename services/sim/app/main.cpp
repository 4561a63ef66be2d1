// motion-sim: the simulated buses and drives of a configuration.
#include <spdlog/spdlog.h>

#include "motion/app/service.hpp"
#include "motion/core/log.hpp"

int main(int argc, char** argv) {
  using namespace motion;
  CLI::App cli{"motion-sim: simulated buses and drives that speak the real wire protocols", "motion-sim"};
  app::CommonOptions options;
  app::add_common_options(cli, options);
  return app::run(cli, argc, argv, [&]() -> int {
    if (!log::init("sim", options.log_level)) return app::kExitUsage;
    auto config = app::load_config(options);
    if (!config) return app::kExitConfig;
    app::Service service(*config, options, "sim", "sim");
    if (!service.ok()) return app::kExitUnavailable;
    service.health().set_state(motionlcm::health_t::OK, std::to_string(config->drives.size()) + " drives");
    return service.run();
  });
}
