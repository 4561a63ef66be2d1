#include "motion/security/request_verifier.hpp"

#include <algorithm>

#include "envelope.hpp"
#include "motion/lcm/request_kinds.hpp"
#include "motion/lcm/wire_bounds.hpp"
#include "motion/security/signed_request.hpp"

namespace motion::security {

RequestVerifier::RequestVerifier(AuthorizedKeys keys, std::string channel_prefix, std::chrono::milliseconds window,
                                 std::int64_t not_before_us)
    : keys_(std::move(keys)),
      prefix_(std::move(channel_prefix)),
      window_us_(std::chrono::duration_cast<std::chrono::microseconds>(window).count()),
      not_before_us_(not_before_us) {}

Verdict RequestVerifier::verify(const motionlcm::signed_request_t& envelope, std::int64_t now_us) {
  Verdict v;
  // Decoded first (bounded, O(its size)) so that every refusal can say which request it claims to
  // be; nothing of it is trusted before step 7.
  motionlcm::request_t request;
  const std::string malformed = lcm::wire::decode_bounded(envelope.payload.data(), envelope.payload.size(), request);
  const std::string claimed = malformed.empty() ? ": " + lcm::request_label(request) : std::string();
  const KeyId id = detail::key_id_of(envelope);
  const Principal* p = keys_.find(id);
  if (p == nullptr) {
    v.signer = to_hex(id);
    v.reason = "unknown key " + v.signer + " (not in authorized_keys)" + claimed;
    return v;
  }
  v.signer = "'" + p->name + "' (" + to_hex(id) + ")";
  if (!security::verify(p->key, signed_bytes(prefix_, envelope), detail::signature_of(envelope))) {
    v.reason = "bad signature from key " + v.signer + " (forged or altered in transit)" + claimed;
    return v;
  }
  if (auto why = detail::stale(envelope.utime, now_us, window_us_, not_before_us_, "coordinator")) {
    v.reason = "stale timestamp from key " + v.signer + ": " + *why + claimed;
    return v;
  }
  auto [last, first] = last_counter_.try_emplace(id, 0);
  if (!first && envelope.counter <= last->second) {
    v.reason = "replayed counter " + std::to_string(envelope.counter) + " from key " + v.signer + " (last accepted " +
               std::to_string(last->second) + ")" + claimed;
    return v;
  }
  last->second = envelope.counter;
  if (!malformed.empty()) {
    v.reason = "malformed payload from key " + v.signer + ": " + malformed;
    return v;
  }
  if (!p->owns_client_id(request.client_id)) {
    v.reason = "client id '" + request.client_id + "' is not key " + v.signer + "'s own (it must be '" + p->name +
               "' or start with '" + p->name + "/')" + claimed;
    return v;
  }
  if (!allows(p->role, request.kind)) {
    v.reason =
        p->role == Role::kGateway
            ? "key " + v.signer + " has role gateway: a gateway's key signs what gateways publish, no request" + claimed
            : "role too low: key " + v.signer + " has role " + to_string(p->role) + ", a " +
                  lcm::request_kind_words(request.kind) + " needs " + to_string(required_role(request.kind)) + claimed;
    v.answerable = true;
    v.request = std::move(request);
    return v;
  }
  v.accepted = true;
  v.request = std::move(request);
  return v;
}

}  // namespace motion::security
