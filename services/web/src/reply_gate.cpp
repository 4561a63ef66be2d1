#include "motion/web/reply_gate.hpp"

#include <chrono>

#include "motion/lcm/channels.hpp"
#include "motion/security/gateway_commands.hpp"

namespace motion::web {

std::variant<ReplyGate, std::string> ReplyGate::from_config(const config::Config& config, std::int64_t now_us) {
  ReplyGate gate;
  const auto& security = config.security;
  if (security.mode != config::SecuritySettings::Mode::kEnforce || security.coordinator_public_key.empty()) return gate;
  auto key = security::load_public_key(security.coordinator_public_key);
  if (const auto* error = std::get_if<std::string>(&key)) return "security.coordinator_public_key: " + *error;
  gate.verifier_.emplace(std::get<security::PublicKey>(key), config.lcm.channel_prefix,
                         std::string(lcm::channels::kReply), std::chrono::milliseconds(security.window_ms), now_us);
  return gate;
}

std::vector<Outgoing> ReplyGate::on_plain(LabView& view, const motionlcm::reply_t& reply) const {
  if (verifier_) return {};  // only the signed twin counts
  return view.on_reply(reply);
}

std::vector<Outgoing> ReplyGate::on_signed(LabView& view, const motionlcm::signed_message_t& envelope,
                                           std::int64_t now_us) {
  if (!verifier_) return {};  // the plain twin is shown
  auto verified = verifier_->verify<motionlcm::reply_t>(envelope, now_us);
  if (!verified.message) {
    ++refused_;
    last_refusal_ = std::move(verified.reason);
    return {};
  }
  return view.on_reply(*verified.message);
}

}  // namespace motion::web
