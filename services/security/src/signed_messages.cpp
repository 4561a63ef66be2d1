#include "motion/security/signed_messages.hpp"

#include <algorithm>

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

namespace {

std::vector<Principal> of_every_bus(const std::vector<PublicKey>& keys) {
  std::vector<Principal> out(keys.size());
  for (std::size_t i = 0; i < keys.size(); ++i) out[i].key = keys[i];
  return out;
}

}  // namespace

MessageVerifier::MessageVerifier(PublicKey coordinator, std::string channel_prefix, std::string channel,
                                 std::chrono::milliseconds window, std::int64_t not_before_us)
    : MessageVerifier(std::vector<PublicKey>{coordinator}, "the coordinator's (" + to_hex(key_id(coordinator)) + ")",
                      std::move(channel_prefix), std::move(channel), window, not_before_us) {}

MessageVerifier::MessageVerifier(const std::vector<PublicKey>& signers, std::string signers_are,
                                 std::string channel_prefix, std::string channel, std::chrono::milliseconds window,
                                 std::int64_t not_before_us)
    : MessageVerifier(of_every_bus(signers), std::move(signers_are), std::move(channel_prefix), std::move(channel),
                      window, not_before_us) {}

MessageVerifier::MessageVerifier(std::vector<Principal> signers, std::string signers_are, std::string channel_prefix,
                                 std::string channel, std::chrono::milliseconds window, std::int64_t not_before_us)
    : signers_(std::move(signers)),
      signers_are_(std::move(signers_are)),
      prefix_(std::move(channel_prefix)),
      channel_(std::move(channel)),
      window_us_(std::chrono::duration_cast<std::chrono::microseconds>(window).count()),
      not_before_us_(not_before_us) {}

const Principal* MessageVerifier::authenticate(const motionlcm::signed_message_t& envelope, std::string& reason) const {
  const std::string what = "signed " + channel_ + " refused: ";
  if (envelope.channel != channel_) {
    reason = what + "it was signed for channel '" + envelope.channel.substr(0, 64) + "'";
    return nullptr;
  }
  const KeyId id = detail::key_id_of(envelope);
  const auto signer =
      std::find_if(signers_.begin(), signers_.end(), [&](const Principal& p) { return key_id(p.key) == id; });
  if (signer == signers_.end()) {
    reason = what + "key " + to_hex(id) + " is not " + signers_are_;
    return nullptr;
  }
  if (!security::verify(signer->key, detail::covered_bytes(detail::kMessageDomain, scope(prefix_, channel_), envelope),
                        detail::signature_of(envelope))) {
    reason = what + "bad signature (forged or altered in transit)";
    return nullptr;
  }
  return &*signer;
}

bool MessageVerifier::fresh(const motionlcm::signed_message_t& envelope, std::int64_t now_us,
                            std::string& reason) const {
  if (auto why = detail::stale(envelope.utime, now_us, window_us_, not_before_us_, "receiver")) {
    reason = "signed " + channel_ + " refused: stale timestamp: " + *why;
    return false;
  }
  return true;
}

bool MessageVerifier::speaks_for(const Principal& signer, const std::vector<std::string>& buses,
                                 std::string& reason) const {
  for (const auto& bus : buses) {
    if (signer.may_speak_for(bus)) continue;
    std::string allowed;
    for (const auto& b : signer.buses) allowed += (allowed.empty() ? "" : ",") + b;
    reason = "signed " + channel_ + " refused: key '" + signer.name + "' (" + to_hex(key_id(signer.key)) +
             ") may speak for " + (signer.buses.size() == 1 ? "bus " : "buses ") + allowed +
             " only (buses= of its authorized_keys line " + std::to_string(signer.line) + "), not for bus '" +
             bus.substr(0, 64) + "'";
    return false;
  }
  return true;
}

bool MessageVerifier::take_counter(const KeyId& signer, const std::string& stream, std::int64_t counter,
                                   std::string& reason) {
  std::int64_t& last = last_counter_[{signer, stream}];
  if (counter <= last) {
    reason = "signed " + channel_ + " refused: replayed counter " + std::to_string(counter) + " (last accepted " +
             std::to_string(last) + (stream.empty() ? "" : " for " + stream.substr(0, 64)) + ")";
    return false;
  }
  last = counter;
  return true;
}

std::optional<std::vector<std::uint8_t>> MessageVerifier::verify_bytes(const motionlcm::signed_message_t& envelope,
                                                                       std::int64_t now_us, std::string& reason) {
  const Principal* signer = authenticate(envelope, reason);
  if (signer == nullptr || !fresh(envelope, now_us, reason) ||
      !take_counter(key_id(signer->key), std::string(), envelope.counter, reason))
    return std::nullopt;
  return envelope.message;
}

}  // namespace motion::security
