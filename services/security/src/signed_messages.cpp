#include "motion/security/signed_messages.hpp"

#include "envelope.hpp"

namespace motion::security {
namespace {

// What the signature covers after the domain: prefix NUL channel (covered_bytes adds the NULs
// around it), so an envelope signed for one channel or system is not valid on another.
std::string scope(std::string_view prefix, std::string_view channel) {
  std::string s(prefix);
  s.push_back('\0');
  s.append(channel);
  return s;
}

}  // namespace

std::string signed_channel(std::string_view channel) { return "S" + std::string(channel); }

MessageSigner::MessageSigner(const KeyPair& key, std::string channel_prefix)
    : key_(key), prefix_(std::move(channel_prefix)) {}

motionlcm::signed_message_t MessageSigner::sign_bytes(std::string_view channel, std::vector<std::uint8_t> message,
                                                      std::int64_t now_us) {
  motionlcm::signed_message_t e{};
  e.utime = now_us;
  const KeyId id = key_.id();
  std::memcpy(e.key_id, id.data(), kKeyIdBytes);
  last_counter_ = std::max(last_counter_ + 1, now_us);
  e.counter = last_counter_;
  e.channel = std::string(channel);
  e.message_size = static_cast<std::int32_t>(message.size());
  e.message = std::move(message);
  const Signature signature = key_.sign(detail::covered_bytes(detail::kMessageDomain, scope(prefix_, e.channel), e));
  std::memcpy(e.signature, signature.data(), kSignatureBytes);
  return e;
}

MessageVerifier::MessageVerifier(PublicKey coordinator, std::string channel_prefix, std::string channel,
                                 std::chrono::milliseconds window, std::int64_t not_before_us)
    : coordinator_(coordinator),
      prefix_(std::move(channel_prefix)),
      channel_(std::move(channel)),
      window_us_(std::chrono::duration_cast<std::chrono::microseconds>(window).count()),
      not_before_us_(not_before_us) {}

std::optional<std::vector<std::uint8_t>> MessageVerifier::verify_bytes(const motionlcm::signed_message_t& envelope,
                                                                       std::int64_t now_us, std::string& reason) {
  const std::string what = "signed " + channel_ + " refused: ";
  if (envelope.channel != channel_) {
    reason = what + "it was signed for channel '" + envelope.channel.substr(0, 64) + "'";
    return std::nullopt;
  }
  const KeyId id = detail::key_id_of(envelope);
  if (id != key_id(coordinator_)) {
    reason = what + "key " + to_hex(id) + " is not the coordinator's (" + to_hex(key_id(coordinator_)) + ")";
    return std::nullopt;
  }
  if (!security::verify(coordinator_, detail::covered_bytes(detail::kMessageDomain, scope(prefix_, channel_), envelope),
                        detail::signature_of(envelope))) {
    reason = what + "bad signature (forged or altered in transit)";
    return std::nullopt;
  }
  if (auto why = detail::stale(envelope.utime, now_us, window_us_, not_before_us_, "receiver")) {
    reason = what + "stale timestamp: " + *why;
    return std::nullopt;
  }
  if (envelope.counter <= last_counter_) {
    reason = what + "replayed counter " + std::to_string(envelope.counter) + " (last accepted " +
             std::to_string(last_counter_) + ")";
    return std::nullopt;
  }
  last_counter_ = envelope.counter;
  return envelope.message;
}

}  // namespace motion::security
