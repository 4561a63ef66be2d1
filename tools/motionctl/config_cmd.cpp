#include <iostream>

#include "motionctl.hpp"

namespace motion::ctl {

void add_config_command(CLI::App& cli, Context& ctx) {
  auto* cmd = cli.add_subcommand("config", "Validate the configuration and print its buses, drives and axes");
  auto what = std::make_shared<std::string>("all");
  cmd->add_option("what", *what, "all, buses (names only) or axes (names only)")
      ->check(CLI::IsMember({"all", "buses", "axes"}))
      ->capture_default_str();
  cmd->callback([&ctx, what] {
    auto config = app::load_config(ctx.options);
    if (!config) {
      ctx.result = app::kExitConfig;
      return;
    }
    if (*what == "buses") {
      for (const auto& b : config->buses) std::cout << b.name << "\n";
      return;
    }
    if (*what == "axes") {
      for (const auto& a : config->axes) std::cout << a.name << "\n";
      return;
    }
    std::cout << config->file << ": valid\n";
    for (const auto& b : config->buses) std::cout << "bus   " << b.name << "  " << b.transport << "\n";
    for (const auto& a : config->axes) {
      const auto* d = config->drive_of(a);
      std::cout << "axis  " << a.name << "  " << config::to_string(d->family) << " node " << d->node_id
                << (d->group_id != 0 ? " group " + std::to_string(d->group_id) : std::string{}) << " on " << d->bus << "  ["
                << a.limits.min_position << ", " << a.limits.max_position << "] " << a.unit << "\n";
    }
  });
}

}  // namespace motion::ctl
