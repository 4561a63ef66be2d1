// The verifier path of signed messages (services/security), as the coordinator, the gateways and
// the clients run it on what arrives on SREQUEST, GW_SCOMMAND_<bus> and S<channel>. A
// signed_message_t (told by its fingerprint) is checked by a MessageVerifier of the coordinator's
// key for its own channel when that is one the system signs (SYNC_TRIGGER, SYNC_TRIGGER2,
// ACTIVE_MOVES, REPLY, EVENT; else SYNC_TRIGGER2), and the message inside decoded as that
// channel's type; one signed for a gateway channel (AXIS_STATE, GW_REPLY) by the coordinator's
// verifier of gateway messages (any of two gateway keys, counter per key and bus). Otherwise the first byte selects the type (even:
// signed_request_t, checked by a RequestVerifier against an authorized_keys of two keys; odd:
// signed_gateway_command_t, checked by a GatewayCommandVerifier with the coordinator's public
// key) and how far the verifier's clock is from the envelope's utime (its low bits, so that
// fresh and stale are both reached); the rest is the message as it would arrive. It is decoded
// bounded (as Node::subscribe does), then verified: every input is accepted or refused with a
// reason, never a crash, and costs O(its size).
//
// The keys come from fixed seeds (32 bytes of 1, 2 and 3): the seed corpus
// (corpus/signed_messages/) holds envelopes signed with them, so the fuzzer starts past the key
// lookup and the signature, into the freshness, counter, payload, client id and role checks.
#include <array>
#include <chrono>
#include <limits>

#include <motionlcm/active_moves_t.hpp>
#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/signed_gateway_command_t.hpp>
#include <motionlcm/signed_message_t.hpp>
#include <motionlcm/signed_request_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>

#include "fuzz_targets.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/wire_bounds.hpp"
#include "motion/security/gateway_commands.hpp"
#include "motion/security/request_verifier.hpp"
#include "motion/security/signed_messages.hpp"

namespace motion::fuzz {
namespace {

constexpr const char* kPrefix = "MOTION_";
constexpr std::chrono::milliseconds kWindow{2000};

security::KeyPair key_of(std::uint8_t fill, const char* name) {
  std::array<std::uint8_t, security::kSeedBytes> seed{};
  seed.fill(fill);
  return security::KeyPair::from_seed(seed, name);
}

const security::AuthorizedKeys& authorized() {
  static const security::AuthorizedKeys keys = [] {
    const std::string text =
        key_of(1, "op").authorized_line("operate") + "\n" + key_of(2, "watch").authorized_line("observe") + "\n";
    return std::get<security::AuthorizedKeys>(security::AuthorizedKeys::parse(text, "fuzz_authorized_keys"));
  }();
  return keys;
}

const security::PublicKey& coordinator() {
  static const security::PublicKey key = key_of(3, "coordinator").public_key();
  return key;
}

// The verifier's clock: at the envelope's utime plus 0..3 s (by `selector`): within the window for
// most, beyond it for the rest.
std::int64_t now_for(std::int64_t utime, std::uint8_t selector) {
  const std::int64_t offset = static_cast<std::int64_t>(selector >> 1) * 25'000;  // 0 .. 3.175 s
  return utime > std::numeric_limits<std::int64_t>::max() - offset ? utime : utime + offset;
}

template <typename Msg>
void verify_as(const motionlcm::signed_message_t& envelope, std::string_view channel, std::uint8_t selector) {
  security::MessageVerifier verifier(coordinator(), kPrefix, std::string(channel), kWindow, 0);
  (void)verifier.verify<Msg>(envelope, now_for(envelope.utime, selector));
}

// What gateways publish, as the coordinator verifies it (the gateway keys: seeds 4 and 5).
template <typename Msg>
void verify_gateway_message(const motionlcm::signed_message_t& envelope, std::string_view channel,
                            std::uint8_t selector) {
  security::MessageVerifier verifier({key_of(4, "gateway").public_key(), key_of(5, "gateway-b").public_key()},
                                     "a gateway key", kPrefix, std::string(channel), kWindow, 0);
  (void)verifier.verify<Msg>(envelope, now_for(envelope.utime, selector), [](const Msg& m) { return m.bus; });
}

void verify_message(const motionlcm::signed_message_t& envelope, std::uint8_t selector) {
  namespace ch = lcm::channels;
  if (envelope.channel == ch::kAxisState)
    return verify_gateway_message<motionlcm::axis_state_t>(envelope, ch::kAxisState, selector);
  if (envelope.channel == ch::kGatewayReply)
    return verify_gateway_message<motionlcm::gateway_reply_t>(envelope, ch::kGatewayReply, selector);
  if (envelope.channel == ch::kSyncTrigger)
    return verify_as<motionlcm::sync_trigger_t>(envelope, ch::kSyncTrigger, selector);
  if (envelope.channel == ch::kActiveMoves)
    return verify_as<motionlcm::active_moves_t>(envelope, ch::kActiveMoves, selector);
  if (envelope.channel == ch::kReply) return verify_as<motionlcm::reply_t>(envelope, ch::kReply, selector);
  if (envelope.channel == ch::kEvent) return verify_as<motionlcm::event_t>(envelope, ch::kEvent, selector);
  verify_as<motionlcm::sync_trigger2_t>(envelope, ch::kSyncTrigger2, selector);
}

}  // namespace

int signed_messages(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t selector = data[0];
  if (motionlcm::signed_message_t message; lcm::wire::decode_bounded(data + 1, size - 1, message).empty()) {
    verify_message(message, selector);
    return 0;
  }
  if ((selector & 1) == 0) {
    motionlcm::signed_request_t envelope;
    if (!lcm::wire::decode_bounded(data + 1, size - 1, envelope).empty()) return 0;
    security::RequestVerifier verifier(authorized(), kPrefix, kWindow, 0);
    (void)verifier.verify(envelope, now_for(envelope.utime, selector));
  } else {
    motionlcm::signed_gateway_command_t envelope;
    if (!lcm::wire::decode_bounded(data + 1, size - 1, envelope).empty()) return 0;
    security::GatewayCommandVerifier verifier(coordinator(), kPrefix, kWindow, 0);
    (void)verifier.verify(envelope, now_for(envelope.utime, selector));
  }
  return 0;
}

}  // namespace motion::fuzz
