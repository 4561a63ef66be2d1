// motionctl keygen: a key pair for signed requests (README "Security"), and the --key option's
// use by every command that sends requests.
#include <cstdlib>
#include <iostream>

#include <nlohmann/json.hpp>

#include "motion/security/authorized_keys.hpp"
#include "motion/security/gateway_commands.hpp"
#include "motionctl.hpp"

namespace motion::ctl {
namespace {

std::string default_key_dir() {
  const char* home = std::getenv("HOME");
  return std::string(home != nullptr && *home != '\0' ? home : ".") + "/.motionbus";
}

std::string default_key_name() {
  const char* user = std::getenv("USER");
  return user != nullptr && security::valid_name(user) ? user : "operator";
}

}  // namespace

void Context::verify_states(client::Client& client, const config::Config& config) {
  const auto& settings = config.security;
  if (settings.mode != config::SecuritySettings::Mode::kEnforce || settings.gateway_keys_file().empty()) return;
  auto gateways = security::load_gateway_keys(settings.gateway_keys_file());
  if (auto* error = std::get_if<std::string>(&gateways)) {
    std::cerr << "motionctl: axis states are shown unverified: " << settings.gateway_keys_setting() << ": " << *error
              << "\n";
    return;
  }
  client.verify_states_with(std::move(std::get<std::vector<security::Principal>>(gateways)),
                            std::chrono::milliseconds(settings.window_ms));
}

bool Context::sign_requests(client::Client& client, const config::Config& config) {
  verify_states(client, config);
  // With security enforced and the coordinator's public key known, only its signed replies count.
  if (config.security.mode == config::SecuritySettings::Mode::kEnforce &&
      !config.security.coordinator_public_key.empty()) {
    auto coordinator = security::load_public_key(config.security.coordinator_public_key);
    if (auto* error = std::get_if<std::string>(&coordinator)) {
      std::cerr << "motionctl: security.coordinator_public_key: " << *error << "\n";
      result = app::kExitConfig;
      return false;
    }
    client.verify_with(std::get<security::PublicKey>(coordinator),
                       std::chrono::milliseconds(config.security.window_ms));
  }
  if (key_path.empty()) return true;
  auto key = security::load_private_key(key_path);
  if (auto* error = std::get_if<std::string>(&key)) {
    std::cerr << "motionctl: --key: " << *error << "\n";
    result = app::kExitConfig;
    return false;
  }
  client.sign_with(std::get<security::KeyPair>(key));
  return true;
}

void add_key_commands(CLI::App& cli, Context& ctx) {
  cli.add_option("--key", ctx.key_path, "Private key to sign requests with (motionctl keygen); default $MOTION_KEY")
      ->envname("MOTION_KEY");

  auto* cmd = cli.add_subcommand(
      "keygen",
      "Write a new Ed25519 key pair (<name>.key, mode 0600, and <name>.pub) and print its authorized_keys line");
  struct Args {
    std::string dir = default_key_dir();
    std::string name = default_key_name();
    std::string role = "operate";
    std::vector<std::string> buses;  // role gateway: the buses the key may speak for (none: every bus)
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--out", args->dir, "Folder of the key files (created with mode 0700)")->capture_default_str();
  cmd->add_option("--name", args->name, "The principal's name (1..64 of A-Z a-z 0-9 . _ -)")->capture_default_str();
  cmd->add_option("--role", args->role, "Role in the printed authorized_keys line")
      ->check(CLI::IsMember({"observe", "operate", "configure", "admin", "gateway"}))
      ->capture_default_str();
  cmd->add_option("--bus", args->buses,
                  "With --role gateway: a bus the key may speak for (repeat it, or can0,rs485a; default every bus)")
      ->delimiter(',');
  cmd->callback([&ctx, args] {
    if (!security::valid_name(args->name)) {
      std::cerr << "motionctl keygen: --name '" << args->name << "' is not 1..64 of [A-Za-z0-9._-]\n";
      ctx.result = app::kExitUsage;
      return;
    }
    if (!args->buses.empty() && args->role != "gateway") {
      std::cerr << "motionctl keygen: --bus binds a gateway's key to buses; it needs --role gateway (not " << args->role
                << ")\n";
      ctx.result = app::kExitUsage;
      return;
    }
    for (const auto& bus : args->buses) {
      if (!security::valid_name(bus)) {
        std::cerr << "motionctl keygen: --bus '" << bus << "' is not 1..64 of [A-Za-z0-9._-]\n";
        ctx.result = app::kExitUsage;
        return;
      }
    }
    if (!security::init()) {
      std::cerr << "motionctl keygen: libsodium cannot initialize (no random source?)\n";
      ctx.result = app::kExitFailure;
      return;
    }
    const auto key = security::KeyPair::generate(args->name);
    if (auto error = security::write_key_pair(key, args->dir, args->role, args->buses)) {
      std::cerr << "motionctl keygen: " << *error << "\n";
      ctx.result = app::kExitFailure;
      return;
    }
    const std::string private_path = security::private_key_path(args->dir, args->name);
    if (ctx.json) {
      std::cout << nlohmann::json{{"private_key", private_path},
                                  {"public_key", security::public_key_path(args->dir, args->name)},
                                  {"key_id", security::to_hex(key.id())},
                                  {"role", args->role},
                                  {"buses", args->buses},
                                  {"authorized_keys_line", key.authorized_line(args->role, args->buses)}}
                       .dump(2)
                << "\n";
      return;
    }
    std::cout << "wrote " << private_path << " (private, mode 0600) and "
              << security::public_key_path(args->dir, args->name) << "\n"
              << "key id " << security::to_hex(key.id())
              << "; an administrator adds this line to the coordinator's authorized_keys\n"
              << "(role observe, operate, configure or admin; gateway for a gateway's key):\n\n"
              << key.authorized_line(args->role, args->buses) << "\n\n"
              << "then sign with it: motionctl --key " << private_path << " ...  (or MOTION_KEY=" << private_path
              << ")\n";
  });
}

}  // namespace motion::ctl
