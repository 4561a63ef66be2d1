#include <cstdlib>
#include <functional>
#include <iostream>

#include <nlohmann/json.hpp>

#include "motionctl.hpp"

namespace motion::ctl {

void add_config_command(CLI::App& cli, Context& ctx) {
  auto* cmd = cli.add_subcommand("config", "Validate the configuration and print its buses, drives and axes");
  auto what = std::make_shared<std::string>("all");
  cmd->add_option(
         "what", *what,
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
    // --json: the same answers as JSON values (a list of names, a string, or the whole summary).
    const auto print = [&ctx](const nlohmann::json& value, const std::function<void()>& text) {
      if (ctx.json) {
        std::cout << value.dump(2) << "\n";
      } else {
        text();
      }
    };
    if (*what == "buses" || *what == "axes") {
      nlohmann::json names = nlohmann::json::array();
      if (*what == "buses") {
        for (const auto& b : config->buses) names.push_back(b.name);
      } else {
        for (const auto& a : config->axes) names.push_back(a.name);
      }
      print(names, [&] {
        for (const auto& n : names) std::cout << n.get<std::string>() << "\n";
      });
      return;
    }
    if (*what == "lcm-url" || *what == "channel-prefix") {
      std::string value = config->lcm.channel_prefix;
      if (*what == "lcm-url") {
        const auto options = app::lcm_options(ctx.options, *config);
        const char* env = std::getenv("LCM_DEFAULT_URL");
        value = !options.url.empty()             ? options.url
                : env != nullptr && *env != '\0' ? std::string(env)
                                                 : std::string("udpm://239.255.76.67:7667?ttl=0");
      }
      print(value, [&] { std::cout << value << "\n"; });
      return;
    }
    if (ctx.json) {
      nlohmann::json out = {{"file", config->file}, {"valid", true}, {"channel_prefix", config->lcm.channel_prefix}};
      out["buses"] = nlohmann::json::array();
      for (const auto& b : config->buses) out["buses"].push_back({{"name", b.name}, {"transport", b.transport}});
      out["axes"] = nlohmann::json::array();
      for (const auto& a : config->axes) {
        const auto* d = config->drive_of(a);
        out["axes"].push_back({{"name", a.name},
                               {"drive", d->name},
                               {"family", config::to_string(d->family)},
                               {"bus", d->bus},
                               {"node", d->node_id},
                               {"group", d->group_id},
                               {"unit", a.unit},
                               {"steps_per_unit", a.steps_per_unit},
                               {"invert", a.invert},
                               {"limits",
                                {{"min", a.limits.min_position},
                                 {"max", a.limits.max_position},
                                 {"velocity", a.limits.max_velocity},
                                 {"acceleration", a.limits.max_acceleration}}},
                               {"homing", a.homing.method_name.empty() ? nlohmann::json(nullptr)
                                                                       : nlohmann::json(a.homing.method_name)}});
      }
      std::cout << out.dump(2) << "\n";
      return;
    }
    std::cout << config->file << ": valid\n";
    for (const auto& b : config->buses) std::cout << "bus   " << b.name << "  " << b.transport << "\n";
    for (const auto& a : config->axes) {
      const auto* d = config->drive_of(a);
      std::cout << "axis  " << a.name << "  " << config::to_string(d->family) << " node " << d->node_id
                << (d->group_id != 0 ? " group " + std::to_string(d->group_id) : std::string{}) << " on " << d->bus
                << "  [" << a.limits.min_position << ", " << a.limits.max_position << "] " << a.unit << "\n";
    }
  });
}

}  // namespace motion::ctl
