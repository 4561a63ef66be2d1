// motionctl: the command-line client. One subcommand per file; each registers itself here.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "motion/app/service.hpp"
#include "motion/client/client.hpp"

namespace motion::ctl {

struct Context {
  app::CommonOptions options;
  bool json = false;
  std::string key_path;  // --key / $MOTION_KEY: sign requests with it
  int result = app::kExitOk;

  // Signs `client`'s requests with --key when one is given, and has it verify the coordinator's
  // replies when `config` enforces security and names security.coordinator_public_key; false
  // (result set, error printed) when a key cannot be loaded.
  bool sign_requests(client::Client& client, const config::Config& config);
  // Has `client` take only axis states signed by a gateway key when `config` enforces security
  // and its security.gateway_public_keys, else its authorized_keys, can be read (the keys of role
  // gateway there, each for its buses= only when bound); otherwise the states are shown
  // as they come, with a note on stderr saying why they are not verified.
  static void verify_states(client::Client& client, const config::Config& config);

  // Loads the configuration, opens LCM as a client process and runs `body` with it.
  int with_node(const std::function<int(app::Service&)>& body);
};

// "; did you mean 'move'?" when one of `names` is within a small edit distance of `word` (a third
// of its length, at least 1, and less than its length; adjacent swaps count 1; the nearest, the
// first of equals), else "".
[[nodiscard]] std::string did_you_mean(const std::string& word, const std::vector<std::string>& names);

// The first subcommand word of argv when it names no subcommand of `cli` (values of the global
// options skipped), with a did_you_mean suggestion: "unknown command 'mvoe'; did you mean 'move'?".
// Empty when the command line names a known subcommand or none.
[[nodiscard]] std::string unknown_subcommand(const CLI::App& cli, int argc, const char* const* argv);

// "unknown axis 'xx'; did you mean 'x'?" (or the list of the configuration's axes) when the
// configuration has no axis `axis`, else "". unknown_axes: one line per unknown axis of `request`.
// motionctl refuses such a request itself (exit 2), like a misspelt subcommand.
[[nodiscard]] std::string unknown_axis(const config::Config& config, const std::string& axis);
[[nodiscard]] std::vector<std::string> unknown_axes(const config::Config& config, const motionlcm::request_t& request);

void add_health_command(CLI::App& cli, Context& ctx);
void add_config_command(CLI::App& cli, Context& ctx);
void add_axis_commands(CLI::App& cli, Context& ctx);
void add_can_commands(CLI::App& cli, Context& ctx);        // dump, send (can_cmds.cpp)
void add_log_command(CLI::App& cli, Context& ctx);         // log: read an lcm-logger file (log_cmds.cpp)
void add_key_commands(CLI::App& cli, Context& ctx);        // --key, keygen (key_cmds.cpp)
void add_commission_command(CLI::App& cli, Context& ctx);  // commission BUS (commission_cmd.cpp)

}  // namespace motion::ctl
