// Messages signed in one envelope by the coordinator (its own, with its key) and by gateways
// (what they publish, with a gateway key): any LCM message inside a signed_message_t
// (lcmtypes/signed_message_t.lcm) on <prefix>S<channel>, e.g. SSYNC_TRIGGER2 for the
// sync_trigger2_t of SYNC_TRIGGER2. Gateways verify triggers and ACTIVE_MOVES with them, clients
// REPLY and EVENT; the coordinator verifies gateways' AXIS_STATE, GW_REPLY, DRIVE_MODEL,
// ORPHANED_MOVES, HEALTH and events (GW_EVENT on SGW_EVENT) against the `gateway` keys of
// authorized_keys (README "Security").
//
// A MessageVerifier listens for one channel. It accepts an envelope when, in this order, its
// channel is that one, its key id is the coordinator's (or one of the signers'), the signature verifies, utime is within
// `window` of the receiver's clock and not before the verifier was made, the counter is above the
// last one it accepted (replay), and the message decodes (bounded) as the expected type; and, for
// a signer bound to buses (a gateway key with buses=... in authorized_keys), every bus the message
// speaks for is one of them. Every refusal says which of these failed.
//
// Thread contract: each object belongs to one thread; no call blocks.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <motionlcm/signed_message_t.hpp>

#include "motion/lcm/wire_bounds.hpp"
#include "motion/security/authorized_keys.hpp"
#include "motion/security/keys.hpp"

namespace motion::security {

// The channel (without prefix) a signed copy of `channel`'s messages goes on: "S" + channel.
[[nodiscard]] std::string signed_channel(std::string_view channel);

class MessageSigner {
 public:
  MessageSigner(const KeyPair& key, std::string channel_prefix);
  // `message` (any LCM type) encoded and signed for `channel` (without prefix) at `now_us` (µs
  // since the epoch), with the next counter: max(last + 1, now_us). One counter for all channels.
  template <typename Msg>
  [[nodiscard]] motionlcm::signed_message_t sign(std::string_view channel, const Msg& message, std::int64_t now_us) {
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(message.getEncodedSize()));
    message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    return sign_bytes(channel, std::move(bytes), now_us);
  }
  [[nodiscard]] motionlcm::signed_message_t sign_bytes(std::string_view channel, std::vector<std::uint8_t> message,
                                                       std::int64_t now_us);
  [[nodiscard]] const KeyPair& key() const { return key_; }

 private:
  KeyPair key_;
  std::string prefix_;
  std::int64_t last_counter_ = 0;
};

template <typename Msg>
struct Verified {
  std::optional<Msg> message;  // set when accepted
  std::string reason;          // else what was wrong
  // Whether the key is one of the signers' and the signature verified: a refusal with `authentic`
  // set is one of freshness (signed before the verifier was made, e.g. in flight when it was;
  // outside the window; a replayed counter), of decoding or of bus binding, not a forgery.
  bool authentic = false;
};

class MessageVerifier {
 public:
  // `channel`: the plain channel (without prefix) this verifier accepts envelopes for.
  MessageVerifier(PublicKey coordinator, std::string channel_prefix, std::string channel,
                  std::chrono::milliseconds window, std::int64_t not_before_us);
  // What several signers publish on one channel, e.g. gateways' AXIS_STATE: an envelope signed by
  // any of `signers` (`signers_are` names them in a refusal, e.g. "a gateway key of
  // authorized_keys"). The counter is kept per signer and per stream (see verify()); a signer
  // with buses (Principal::buses) may speak for those only.
  MessageVerifier(std::vector<Principal> signers, std::string signers_are, std::string channel_prefix,
                  std::string channel, std::chrono::milliseconds window, std::int64_t not_before_us);
  // The same for keys of every bus.
  MessageVerifier(const std::vector<PublicKey>& signers, std::string signers_are, std::string channel_prefix,
                  std::string channel, std::chrono::milliseconds window, std::int64_t not_before_us);

  // The envelope's message bytes when accepted (nullopt and `reason` otherwise).
  [[nodiscard]] std::optional<std::vector<std::uint8_t>> verify_bytes(const motionlcm::signed_message_t& envelope,
                                                                      std::int64_t now_us, std::string& reason);
  // A message that speaks for no bus (the coordinator's: one counter per signer).
  template <typename Msg>
  [[nodiscard]] Verified<Msg> verify(const motionlcm::signed_message_t& envelope, std::int64_t now_us) {
    return verify<Msg>(
        envelope, now_us, [](const Msg&) { return std::string(); },
        [](const Msg&) { return std::vector<std::string>(); });
  }
  // A message of the bus stream_of(message) (gateways': see the next one).
  template <typename Msg, typename StreamOf>
  [[nodiscard]] Verified<Msg> verify(const motionlcm::signed_message_t& envelope, std::int64_t now_us,
                                     StreamOf stream_of) {
    return verify<Msg>(envelope, now_us, stream_of,
                       [&stream_of](const Msg& m) { return std::vector<std::string>{stream_of(m)}; });
  }
  // With the counter kept per (signer, stream_of(message)): processes that share one key and sign
  // with their own clocks (gateways of several buses: stream_of gives the bus) do not take each
  // other's counters for replays; and refused when the signer is bound to buses and one of
  // buses_of(message) (what it speaks for: its bus, the bus of the axis it names, ...) is not
  // one of them. Both are read from the message once its signature verified.
  template <typename Msg, typename StreamOf, typename BusesOf>
  [[nodiscard]] Verified<Msg> verify(const motionlcm::signed_message_t& envelope, std::int64_t now_us,
                                     StreamOf stream_of, BusesOf buses_of) {
    Verified<Msg> v;
    const Principal* signer = authenticate(envelope, v.reason);
    if (signer == nullptr) return v;
    v.authentic = true;
    if (!fresh(envelope, now_us, v.reason)) return v;
    Msg msg;
    if (std::string why = lcm::wire::decode_bounded(envelope.message.data(), envelope.message.size(), msg);
        !why.empty()) {
      v.reason = "signed " + channel_ + " refused: malformed message: " + why;
      return v;
    }
    if (!speaks_for(*signer, buses_of(msg), v.reason)) return v;
    if (!take_counter(key_id(signer->key), stream_of(msg), envelope.counter, v.reason)) return v;
    v.message = std::move(msg);
    return v;
  }
  [[nodiscard]] const std::string& channel() const { return channel_; }

 private:
  // Channel, signer and signature: the signer when they pass.
  [[nodiscard]] const Principal* authenticate(const motionlcm::signed_message_t& envelope, std::string& reason) const;
  // Whether utime is within the window and not before the verifier was made.
  [[nodiscard]] bool fresh(const motionlcm::signed_message_t& envelope, std::int64_t now_us, std::string& reason) const;
  // Whether `signer` may speak for every one of `buses` (else `reason` names the key and the bus).
  [[nodiscard]] bool speaks_for(const Principal& signer, const std::vector<std::string>& buses,
                                std::string& reason) const;
  // Whether `counter` is above the last one accepted from `signer` on `stream` (then it is the last).
  [[nodiscard]] bool take_counter(const KeyId& signer, const std::string& stream, std::int64_t counter,
                                  std::string& reason);

  std::vector<Principal> signers_;
  std::string signers_are_;
  std::string prefix_;
  std::string channel_;
  std::int64_t window_us_;
  std::int64_t not_before_us_;
  std::map<std::pair<KeyId, std::string>, std::int64_t> last_counter_;
};

}  // namespace motion::security
