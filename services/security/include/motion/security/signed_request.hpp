// Signing requests: request_t inside a signed_request_t (lcmtypes/signed_request_t.lcm, channel
// <prefix>SREQUEST).
//
// Thread contract: signed_bytes() is a pure function; a RequestSigner belongs to one thread.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <motionlcm/request_t.hpp>
#include <motionlcm/signed_request_t.hpp>

#include "motion/security/keys.hpp"

namespace motion::security {

// What the signature of `envelope` covers (the layout is in signed_request_t.lcm): a domain
// string, the channel prefix (a request signed for one system is not valid on another sharing
// the network), key id, counter, utime, payload size and payload.
[[nodiscard]] std::vector<std::uint8_t> signed_bytes(std::string_view channel_prefix,
                                                     const motionlcm::signed_request_t& envelope);

// Signs a client's requests with one key.
class RequestSigner {
 public:
  RequestSigner(const KeyPair& key, std::string channel_prefix);

  // `client_id` as this key's own: unchanged when it is the key's name or starts with
  // "<name>/", else "<name>/<client_id>" (the coordinator refuses other ids from this key).
  [[nodiscard]] std::string own_client_id(std::string_view client_id) const;

  // The envelope of `request` (its client_id must be the key's own, see own_client_id), signed at
  // `now_us` (µs since the epoch) with the next counter: max(last + 1, now_us), so counters keep
  // increasing across runs of a program as long as the wall clock does.
  [[nodiscard]] motionlcm::signed_request_t sign(const motionlcm::request_t& request, std::int64_t now_us);

  [[nodiscard]] const KeyPair& key() const { return key_; }

 private:
  KeyPair key_;
  std::string prefix_;
  std::int64_t last_counter_ = 0;
};

}  // namespace motion::security
