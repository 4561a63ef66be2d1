// motionctl: the command-line client. One subcommand per file; each registers itself here.
#pragma once

#include <functional>

#include "motion/app/service.hpp"
#include "motion/client/client.hpp"

namespace motion::ctl {

struct Context {
  app::CommonOptions options;
  bool json = false;
  std::string key_path;  // --key / $MOTION_KEY: sign requests with it
  int result = app::kExitOk;

  // Signs `client`'s requests with --key when one is given; false (result set, error printed)
  // when the key cannot be loaded.
  bool sign_requests(client::Client& client);

  // Loads the configuration, opens LCM as a client process and runs `body` with it.
  int with_node(const std::function<int(app::Service&)>& body);
};

void add_health_command(CLI::App& cli, Context& ctx);
void add_config_command(CLI::App& cli, Context& ctx);
void add_axis_commands(CLI::App& cli, Context& ctx);
void add_can_commands(CLI::App& cli, Context& ctx);  // dump, send (can_cmds.cpp)
void add_log_command(CLI::App& cli, Context& ctx);   // log: read an lcm-logger file (log_cmds.cpp)
void add_key_commands(CLI::App& cli, Context& ctx);  // --key, keygen (key_cmds.cpp)

}  // namespace motion::ctl
