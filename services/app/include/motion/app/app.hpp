// What every motion-* program shares: common flags, loading the configuration before anything
// else, the LCM URL precedence, logging set-up and exit codes.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <optional>
#include <string>

#include "motion/config/config.hpp"
#include "motion/lcm/node.hpp"

namespace motion::app {

// Exit codes of every program (documented in the README).
enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,      // the operation failed (request rejected/aborted/failed, runtime error)
  kExitUsage = 2,        // bad command line
  kExitConfig = 3,       // the configuration file was refused
  kExitUnavailable = 4,  // LCM could not be opened, or a needed process did not answer
};

struct CommonOptions {
  std::string config_path;  // empty: the embedded default (config/sim-lab.yaml)
  std::string lcm_url;      // overrides LCM_DEFAULT_URL and the config's lcm.url
  std::string log_level = "info";
};

// Adds --config, --lcm-url, --log-level and --version.
void add_common_options(CLI::App& cli, CommonOptions& options);

// Loads and validates the configuration; on failure prints every error (file:line:col: key:
// reason) to stderr and returns nullopt.
std::optional<config::Config> load_config(const CommonOptions& options);

// LCM URL precedence: --lcm-url, then $LCM_DEFAULT_URL, then the config's lcm.url, then LCM's
// default.
lcm::NodeOptions lcm_options(const CommonOptions& options, const config::Config& config);

// Parses the command line and runs `body`, mapping CLI errors to kExitUsage and escaping
// exceptions to kExitFailure with a message (they never terminate the process uncaught).
int run(CLI::App& cli, int argc, char** argv, const std::function<int()>& body);

}  // namespace motion::app
