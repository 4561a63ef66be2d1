// Signed gateway commands: the coordinator signs every gateway_command_t with its own key into a
// signed_gateway_command_t (lcmtypes/signed_gateway_command_t.lcm, channel
// <prefix>GW_SCOMMAND_<bus>); a gateway verifies it with the coordinator's public key.
//
// A command is accepted when its key id is the coordinator's, the signature verifies, utime is
// within `window` of the gateway's clock and not before the verifier was made, the counter is above
// the last one accepted, and the payload decodes as a gateway_command_t or a gateway_command2_t
// (told apart by its LCM fingerprint). Every refusal says which of these failed.
//
// Thread contract: each object belongs to one thread; no call blocks.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include <motionlcm/gateway_command2_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/signed_gateway_command_t.hpp>

#include "motion/security/keys.hpp"

namespace motion::security {

class GatewayCommandSigner {
 public:
  GatewayCommandSigner(const KeyPair& key, std::string channel_prefix);
  // Signed at `now_us` (µs since the epoch) with the next counter, max(last + 1, now_us).
  [[nodiscard]] motionlcm::signed_gateway_command_t sign(const motionlcm::gateway_command_t& command,
                                                         std::int64_t now_us);
  [[nodiscard]] motionlcm::signed_gateway_command_t sign(const motionlcm::gateway_command2_t& command,
                                                         std::int64_t now_us);
  [[nodiscard]] const KeyPair& key() const { return key_; }

 private:
  KeyPair key_;
  std::string prefix_;
  std::int64_t last_counter_ = 0;
};

struct CommandVerdict {
  std::optional<motionlcm::gateway_command_t> command;    // set when accepted, the payload being one
  std::optional<motionlcm::gateway_command2_t> command2;  // set when accepted, the payload being one
  std::string reason;                                     // else what was wrong
  [[nodiscard]] bool accepted() const { return command || command2; }
};

class GatewayCommandVerifier {
 public:
  GatewayCommandVerifier(PublicKey coordinator, std::string channel_prefix, std::chrono::milliseconds window,
                         std::int64_t not_before_us);
  [[nodiscard]] CommandVerdict verify(const motionlcm::signed_gateway_command_t& envelope, std::int64_t now_us);

 private:
  PublicKey coordinator_;
  std::string prefix_;
  std::int64_t window_us_;
  std::int64_t not_before_us_;
  std::int64_t last_counter_ = 0;
};

// Reads a public key file (one "<base64 public key> <name> [<role>]" line, as motionctl keygen
// writes <name>.pub); errors name file:line.
[[nodiscard]] Loaded<PublicKey> load_public_key(const std::string& path);

}  // namespace motion::security
