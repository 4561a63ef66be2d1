// motionctl: command-line client of the motion system.
#include <unistd.h>

#include <iostream>

#include "motion/core/log.hpp"
#include "motionctl.hpp"

namespace motion::ctl {

int Context::with_node(const std::function<int(app::Service&)>& body) {
  if (!log::init("motionctl", options.log_level)) return app::kExitUsage;
  auto config = app::load_config(options);
  if (!config) return app::kExitConfig;
  app::Service service(*config, options, "motionctl:" + std::to_string(::getpid()), "client");
  if (!service.ok()) return app::kExitUnavailable;
  return body(service);
}

}  // namespace motion::ctl

// Only the fixed option set is built outside app::run, which turns every later exception into an exit code.
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  using namespace motion;
  CLI::App cli{"motionctl: command and watch the motion system", "motionctl"};
  ctl::Context ctx;
  app::add_common_options(cli, ctx.options);
  cli.add_flag("--json", ctx.json, "Machine-readable output");
  cli.require_subcommand(1);
  cli.fallthrough();  // global options (--lcm-url, --config, ...) may also follow the subcommand
  ctl::add_health_command(cli, ctx);
  ctl::add_config_command(cli, ctx);
  ctl::add_axis_commands(cli, ctx);
  ctl::add_can_commands(cli, ctx);
  ctl::add_log_command(cli, ctx);
  ctl::add_key_commands(cli, ctx);
  ctl::add_commission_command(cli, ctx);
  if (const auto unknown = ctl::unknown_subcommand(cli, argc, argv); !unknown.empty()) {
    std::cerr << "motionctl: " << unknown << " (motionctl --help lists the commands)\n";
    return app::kExitUsage;
  }
  const int rc = app::run(cli, argc, argv, [&] { return app::kExitOk; });
  return rc != app::kExitOk ? rc : ctx.result;
}
