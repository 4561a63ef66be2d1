#include "motion/security/gateway_commands.hpp"

#include <fstream>
#include <sstream>

#include "envelope.hpp"
#include "motion/lcm/gateway_commands.hpp"

namespace motion::security {

GatewayCommandSigner::GatewayCommandSigner(const KeyPair& key, std::string channel_prefix)
    : key_(key), prefix_(std::move(channel_prefix)) {}

motionlcm::signed_gateway_command_t GatewayCommandSigner::sign(const motionlcm::gateway_command_t& command,
                                                               std::int64_t now_us) {
  return detail::seal<motionlcm::signed_gateway_command_t>(key_, detail::kGatewayCommandDomain, prefix_, last_counter_,
                                                           command, now_us);
}

motionlcm::signed_gateway_command_t GatewayCommandSigner::sign(const motionlcm::gateway_command2_t& command,
                                                               std::int64_t now_us) {
  return detail::seal<motionlcm::signed_gateway_command_t>(key_, detail::kGatewayCommandDomain, prefix_, last_counter_,
                                                           command, now_us);
}

GatewayCommandVerifier::GatewayCommandVerifier(PublicKey coordinator, std::string channel_prefix,
                                               std::chrono::milliseconds window, std::int64_t not_before_us)
    : coordinator_(coordinator),
      prefix_(std::move(channel_prefix)),
      window_us_(std::chrono::duration_cast<std::chrono::microseconds>(window).count()),
      not_before_us_(not_before_us) {}

CommandVerdict GatewayCommandVerifier::verify(const motionlcm::signed_gateway_command_t& envelope,
                                              std::int64_t now_us) {
  CommandVerdict v;
  const KeyId id = detail::key_id_of(envelope);
  if (id != key_id(coordinator_)) {
    v.reason = "signed command refused: key " + to_hex(id) + " is not the coordinator's (" +
               to_hex(key_id(coordinator_)) + ")";
    return v;
  }
  if (!security::verify(coordinator_, detail::covered_bytes(detail::kGatewayCommandDomain, prefix_, envelope),
                        detail::signature_of(envelope))) {
    v.reason = "signed command refused: bad signature (forged or altered in transit)";
    return v;
  }
  if (auto why = detail::stale(envelope.utime, now_us, window_us_, not_before_us_, "gateway")) {
    v.reason = "signed command refused: stale timestamp: " + *why;
    return v;
  }
  if (envelope.counter <= last_counter_) {
    v.reason = "signed command refused: replayed counter " + std::to_string(envelope.counter) + " (last accepted " +
               std::to_string(last_counter_) + ")";
    return v;
  }
  last_counter_ = envelope.counter;
  auto decoded = lcm::decode_gateway_command(envelope.command);
  if (auto* why = std::get_if<std::string>(&decoded)) {
    v.reason = "signed command refused: malformed payload: " + *why;
  } else if (auto* command2 = std::get_if<motionlcm::gateway_command2_t>(&decoded)) {
    v.command2 = std::move(*command2);
  } else {
    v.command = std::get<motionlcm::gateway_command_t>(std::move(decoded));
  }
  return v;
}

Loaded<PublicKey> load_public_key(const std::string& path) {
  std::ifstream in(path);
  if (!in) return "cannot read public key file " + path;
  int number = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    std::istringstream fields_in(line);
    std::string text;
    if (!(fields_in >> text) || text[0] == '#') continue;
    const auto key = base64_decode(text);
    if (!key || key->size() != kPublicKeyBytes) {
      return path + ":" + std::to_string(number) +
             ": expected '<base64 public key> <name> [<role>]' (is this a .pub file?)";
    }
    PublicKey out{};
    std::copy(key->begin(), key->end(), out.begin());
    return out;
  }
  return "public key file " + path + " holds no key line";
}

}  // namespace motion::security
