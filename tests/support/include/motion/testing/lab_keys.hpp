// The key set of a lab run with `security: {mode: enforce}` (README "Security"), written next to
// its configuration: the coordinator's pair (coordinator.key/.pub), the gateways' shared key
// (gateway.key/.pub, role gateway), and authorized_keys with the test's principals and the gateway
// key; enforced_security() is the configuration's security section naming them (paths relative
// to the configuration file). Header-only: the test links motion::security.
#pragma once

#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "motion/security/keys.hpp"

namespace motion::testing {

// What went wrong writing the files, nothing on success. `principals`: authorized_keys lines
// (KeyPair::authorized_line).
[[nodiscard]] inline std::optional<std::string> write_lab_keys(const std::string& dir,
                                                               const std::vector<std::string>& principals) {
  if (auto error = security::write_key_pair(security::KeyPair::generate("coordinator"), dir, "admin")) return error;
  const auto gateway = security::KeyPair::generate("gateway");
  if (auto error = security::write_key_pair(gateway, dir, "gateway")) return error;
  std::ofstream keys(dir + "/authorized_keys");
  keys << "# the test's principals and the gateways' key\n";
  for (const auto& line : principals) keys << line << "\n";
  keys << gateway.authorized_line("gateway") << "\n";
  if (!keys.flush()) return "cannot write " + dir + "/authorized_keys";
  return std::nullopt;
}

// `authorized_keys`: the file's name; `more`: further lines of the section ("  key: value\n").
[[nodiscard]] inline std::string enforced_security(int window_ms = 2000,
                                                   const std::string& authorized_keys = "authorized_keys",
                                                   const std::string& more = {}) {
  return "\nsecurity:\n  mode: enforce\n  authorized_keys: " + authorized_keys +
         "\n  key: coordinator.key\n"
         "  coordinator_public_key: coordinator.pub\n  gateway_key: gateway.key\n  window_ms: " +
         std::to_string(window_ms) + "\n" + more;
}

}  // namespace motion::testing
