#include <cstdlib>
#include <iostream>

#include "motionctl.hpp"

namespace motion::ctl {

void add_config_command(CLI::App& cli, Context& ctx) {
  auto* cmd = cli.add_subcommand("config", "Validate the configuration and print its buses, drives and axes");
  auto what = std::make_shared<std::string>("all");
  cmd->add_option("what", *what,
                  "all, buses (names only), axes (names only), lcm-url (the URL the programs use: --lcm-url, $LCM_DEFAULT_URL, "
                  "lcm.url) or channel-prefix")
      ->check(CLI::IsMember({"all", "buses", "axes", "lcm-url", "channel-prefix"}))
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
    if (*what == "lcm-url") {
      const auto options = app::lcm_options(ctx.options, *config);
      const char* env = std::getenv("LCM_DEFAULT_URL");
      std::cout << (!options.url.empty() ? options.url : env != nullptr && *env != '\0' ? std::string(env) : std::string("udpm://239.255.76.67:7667?ttl=0"))
                << "\n";
      return;
    }
    if (*what == "channel-prefix") {
      std::cout << config->lcm.channel_prefix << "\n";
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
