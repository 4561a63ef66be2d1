#include "motion/app/app.hpp"

#include <cstdlib>
#include <exception>
#include <iostream>

#include "motion/core/log.hpp"
#include "motion/core/version.hpp"

namespace motion::app {

void add_common_options(CLI::App& cli, CommonOptions& options) {
  cli.add_option("--config", options.config_path,
                 "Configuration file (default: the simulated lab, config/sim-lab.yaml)");
  cli.add_option("--lcm-url", options.lcm_url, "LCM URL (overrides LCM_DEFAULT_URL and the config's lcm.url)");
  cli.add_option("--log-level", options.log_level, "trace, debug, info, warn, error or off")->capture_default_str();
  cli.set_version_flag("--version", std::string(kVersion));
}

std::optional<config::Config> load_config(const CommonOptions& options) {
  const std::string path = options.config_path.empty() ? config::default_config_path() : options.config_path;
  auto result = config::load_file(path);
  if (!result.ok()) {
    std::cerr << "configuration refused (" << result.errors.size() << " error" << (result.errors.size() == 1 ? "" : "s")
              << "):\n"
              << result.error_text();
    return std::nullopt;
  }
  return std::move(result.config);
}

lcm::NodeOptions lcm_options(const CommonOptions& options, const config::Config& config) {
  lcm::NodeOptions out;
  out.prefix = config.lcm.channel_prefix;
  if (!options.lcm_url.empty()) {
    out.url = options.lcm_url;
  } else if (const char* env = std::getenv("LCM_DEFAULT_URL"); env != nullptr && *env != '\0') {
    out.url = env;
  } else {
    out.url = config.lcm.url;
  }
  return out;
}

int run(CLI::App& cli, int argc, char** argv, const std::function<int()>& body) {
  try {
    cli.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) { return cli.exit(e); } catch (const CLI::CallForVersion& e) {
    return cli.exit(e);
  } catch (const CLI::ParseError& e) {
    cli.exit(e);
    return kExitUsage;
  }
  try {
    return body();
  } catch (const std::exception& e) {
    std::cerr << cli.get_name() << ": fatal: " << e.what() << "\n";
    return kExitFailure;
  }
}

}  // namespace motion::app
