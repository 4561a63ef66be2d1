// The gateway's side of security (README "Security"): verifying what the coordinator signs
// (commands, triggers, ACTIVE_MOVES) and signing what the gateway publishes with its own key.
#include "motion/gateway/gateway.hpp"

#include "motion/lcm/channels.hpp"
#include "motion/lcm/gateway_commands.hpp"

namespace motion::gateway {

security::Loaded<std::optional<security::PublicKey>> Gateway::load_coordinator_key(const config::Config& config) {
  if (config.security.coordinator_public_key.empty()) return std::optional<security::PublicKey>{};
  auto key = security::load_public_key(config.security.coordinator_public_key);
  if (auto* error = std::get_if<std::string>(&key)) return "security.coordinator_public_key: " + *error;
  return std::optional<security::PublicKey>{std::get<security::PublicKey>(key)};
}

security::Loaded<std::optional<security::KeyPair>> Gateway::load_gateway_key(const config::Config& config,
                                                                             const std::string& bus) {
  std::string path = config.security.gateway_key;
  if (path.empty()) return std::optional<security::KeyPair>{};
  static constexpr std::string_view kBus = "{bus}";
  for (auto at = path.find(kBus); at != std::string::npos; at = path.find(kBus, at + bus.size()))
    path.replace(at, kBus.size(), bus);
  auto key = security::load_private_key(path);
  if (auto* error = std::get_if<std::string>(&key)) return "security.gateway_key: " + *error;
  return std::optional<security::KeyPair>{std::get<security::KeyPair>(key)};
}

void Gateway::set_coordinator_key(const std::optional<security::PublicKey>& coordinator) {
  const std::int64_t now = wall_time_us();
  const std::chrono::milliseconds window(config_.security.window_ms);
  const std::string prefix = node_.prefix();  // what the coordinator signed for: the channels this gateway hears
  auto verifier = [&](std::string_view channel) {
    return coordinator ? std::optional<security::MessageVerifier>{std::in_place,        *coordinator, prefix,
                                                                  std::string(channel), window,       now}
                       : std::nullopt;
  };
  verifier_ = coordinator
                  ? std::optional<security::GatewayCommandVerifier>{std::in_place, *coordinator, prefix, window, now}
                  : std::nullopt;
  trigger_verifier_ = verifier(lcm::channels::kSyncTrigger);
  trigger2_verifier_ = verifier(lcm::channels::kSyncTrigger2);
  moves_verifier_ = verifier(lcm::channels::kActiveMoves);
}

void Gateway::on_signed_command(const motionlcm::signed_gateway_command_t& envelope) {
  if (verifier_) {
    auto verdict = verifier_->verify(envelope, wall_time_us());
    if (verdict.command2) return on_command2(*verdict.command2);
    if (!verdict.command) return refuse(verdict.reason);
    return on_command(*verdict.command);
  }
  // No coordinator key configured (mode off): taken as a plain command would be (either type, told
  // apart by its fingerprint).
  auto decoded = lcm::decode_gateway_command(envelope.command);
  if (auto* why = std::get_if<std::string>(&decoded)) {
    return refuse("signed command with a malformed payload refused: " + *why);
  }
  if (auto* command2 = std::get_if<motionlcm::gateway_command2_t>(&decoded)) return on_command2(*command2);
  on_command(std::get<motionlcm::gateway_command_t>(decoded));
}

void Gateway::refuse(const std::string& reason) {
  // A flood of forged messages must not become a flood of events: 5 a second, then a count.
  const TimePoint now = loop_.now();
  const std::uint64_t suppressed = security_events_.take_summary(now);
  if (!security_events_.admit(now)) return;
  DriveEvent e;
  e.kind = motionlcm::event_t::SECURITY;
  e.severity = motionlcm::event_t::WARNING;
  e.text = suppressed == 0
               ? reason
               : reason + " (and " + std::to_string(suppressed) + " more refusals not reported, at most 5 a second)";
  axis_event("", e);
}

void Gateway::subscribe_coordinator_messages() {
  const auto unsigned_refusal = [this](std::string_view channel, const std::string& what) {
    refuse("unsigned " + std::string(channel) + " (" + what +
           ") refused: security is enforced, it must be signed by the coordinator (" +
           node_.channel(security::signed_channel(channel)) + ")");
  };
  node_.subscribe<motionlcm::sync_trigger_t>(
      lcm::channels::kSyncTrigger, [this, unsigned_refusal](const motionlcm::sync_trigger_t& t, const std::string&) {
        if (enforce_) return unsigned_refusal(lcm::channels::kSyncTrigger, "trigger " + std::to_string(t.trigger_id));
        on_trigger(t);
      });
  node_.subscribe<motionlcm::sync_trigger2_t>(
      lcm::channels::kSyncTrigger2, [this, unsigned_refusal](const motionlcm::sync_trigger2_t& t, const std::string&) {
        if (enforce_) return unsigned_refusal(lcm::channels::kSyncTrigger2, "trigger " + std::to_string(t.trigger_id));
        on_trigger2(t);
      });
  node_.subscribe<motionlcm::active_moves_t>(
      lcm::channels::kActiveMoves, [this, unsigned_refusal](const motionlcm::active_moves_t& m, const std::string&) {
        if (enforce_) return unsigned_refusal(lcm::channels::kActiveMoves, std::to_string(m.num_axes) + " rows");
        on_active_moves(m);
      });
  const auto malformed = [this](const void*, int, const std::string& why) {
    refuse("malformed signed message refused: " + why);
  };
  node_.subscribe<motionlcm::signed_message_t>(
      security::signed_channel(lcm::channels::kSyncTrigger),
      [this](const motionlcm::signed_message_t& m, const std::string&) {
        on_signed_message(trigger_verifier_, m, &Gateway::on_trigger);
      },
      malformed);
  node_.subscribe<motionlcm::signed_message_t>(
      security::signed_channel(lcm::channels::kSyncTrigger2),
      [this](const motionlcm::signed_message_t& m, const std::string&) {
        on_signed_message(trigger2_verifier_, m, &Gateway::on_trigger2);
      },
      malformed);
  node_.subscribe<motionlcm::signed_message_t>(
      security::signed_channel(lcm::channels::kActiveMoves),
      [this](const motionlcm::signed_message_t& m, const std::string&) {
        on_signed_message(moves_verifier_, m, &Gateway::on_active_moves);
      },
      malformed);
}

template <typename Msg>
void Gateway::on_signed_message(std::optional<security::MessageVerifier>& verifier,
                                const motionlcm::signed_message_t& envelope, void (Gateway::*handler)(const Msg&)) {
  if (verifier) {
    auto verified = verifier->verify<Msg>(envelope, wall_time_us());
    if (!verified.message) return refuse(verified.reason);
    return (this->*handler)(*verified.message);
  }
  // No coordinator key configured (mode off): taken as the plain message would be.
  Msg msg;
  if (std::string why = lcm::wire::decode_bounded(envelope.message.data(), envelope.message.size(), msg);
      !why.empty()) {
    return refuse("signed " + envelope.channel.substr(0, 64) + " with a malformed message refused: " + why);
  }
  (this->*handler)(msg);
}

void Gateway::set_gateway_key(const std::optional<security::KeyPair>& key) {
  signer_.reset();
  health_.set_signed_copy({});
  if (!key) return;
  signer_.emplace(*key, node_.prefix());
  // Heartbeats too: under enforce the coordinator takes a gateway's liveness only from these.
  health_.set_signed_copy([this](const motionlcm::health_t& health) {
    node_.publish(security::signed_channel(lcm::channels::kHealth),
                  signer_->sign(lcm::channels::kHealth, health, wall_time_us()));
  });
}

template <typename Msg>
void Gateway::publish_own(std::string_view channel, const Msg& message, bool plain_under_enforce) {
  // The signed copy first: an observer that acts on the plain one (e.g. a lab that enables the axes
  // it sees online) must not reach the coordinator before the copy the coordinator takes.
  if (signer_) node_.publish(security::signed_channel(channel), signer_->sign(channel, message, wall_time_us()));
  if (!signer_ || !enforce_ || plain_under_enforce) node_.publish(channel, message);
}

void Gateway::publish_event(const motionlcm::event_t& event) {
  // Signed as GW_EVENT on SGW_EVENT (not SEVENT: that is the coordinator's own), signed first; the
  // plain EVENT always, for observers.
  if (signer_) {
    node_.publish(security::signed_channel(lcm::channels::kGatewayEvent),
                  signer_->sign(lcm::channels::kGatewayEvent, event, wall_time_us()));
  }
  node_.publish(lcm::channels::kEvent, event);
}

template void Gateway::publish_own(std::string_view, const motionlcm::axis_state_t&, bool);
template void Gateway::publish_own(std::string_view, const motionlcm::gateway_reply_t&, bool);
template void Gateway::publish_own(std::string_view, const motionlcm::drive_model_t&, bool);
template void Gateway::publish_own(std::string_view, const motionlcm::arm_timing_t&, bool);
template void Gateway::publish_own(std::string_view, const motionlcm::line_timing_t&, bool);
template void Gateway::publish_own(std::string_view, const motionlcm::trigger_heard_t&, bool);
template void Gateway::publish_own(std::string_view, const motionlcm::active_moves_t&, bool);

}  // namespace motion::gateway
