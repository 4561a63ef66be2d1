// The coordinator's gate for signed requests: an envelope and the wall-clock `now` in, a verdict
// out. Passive (no clock, no I/O), so its tests run on a manual clock.
//
// A signed_request_t is accepted when, in this order:
//   1. its key id is in authorized_keys                         else "unknown key"
//   2. the signature verifies over signed_bytes()               else "bad signature"
//   3. utime is within `window` of now, and not before the
//      verifier was made (not_before_us: a message signed before
//      this coordinator ran cannot be a fresh one)              else "stale timestamp"
//   4. the counter is above the last one accepted from the key  else "replayed counter"
//   5. the payload decodes as a request_t (bounded)             else "malformed payload"
//   6. its client_id is the key's own (name or "<name>/...")    else "client id of another key"
//   7. the key's role allows the request's kind                 else "role too low"
// Counters are kept per key in memory only; after a restart, (3)'s not_before refuses whatever
// was signed before, so a replay needs no persisted state to be caught.
//
// Every refusal names the key (id and, when known, name), what was wrong, and the request as it
// claims to be (lcm::request_label: kind, request id, client id). Only a refusal at
// step 7 is `answerable`: the request is authentic, fresh and under its signer's own ids, so a
// REJECTED reply to its (client_id, request_id) cannot land on somebody else's request. At
// steps 1-6 the ids cannot be trusted (forged, replayed, or another key's), and nothing may be
// answered under them.
//
// Thread contract: single-threaded (the caller's loop thread); verify() never blocks.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include <motionlcm/request_t.hpp>
#include <motionlcm/signed_request_t.hpp>

#include "motion/security/authorized_keys.hpp"

namespace motion::security {

struct Verdict {
  // Accepted: the request to execute. Refused and answerable: the request, for the reply.
  std::optional<motionlcm::request_t> request;
  bool accepted = false;
  bool answerable = false;
  std::string reason;  // refused: what was wrong, naming the key
  std::string signer;  // "<name> (<key id>)", or "<key id>" for an unknown key
};

class RequestVerifier {
 public:
  // `channel_prefix` must be the one the signers signed for. `not_before_us`: the wall time the
  // verifier starts at (µs since the epoch).
  RequestVerifier(AuthorizedKeys keys, std::string channel_prefix, std::chrono::milliseconds window,
                  std::int64_t not_before_us);

  [[nodiscard]] Verdict verify(const motionlcm::signed_request_t& envelope, std::int64_t now_us);

  [[nodiscard]] const AuthorizedKeys& keys() const { return keys_; }

 private:
  AuthorizedKeys keys_;
  std::string prefix_;
  std::int64_t window_us_;
  std::int64_t not_before_us_;
  std::map<KeyId, std::int64_t> last_counter_;
};

}  // namespace motion::security
