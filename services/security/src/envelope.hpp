// What signed_request_t, signed_gateway_command_t and signed_message_t share (internal to motion::security): the
// bytes a signature covers, sealing a message into an envelope, and the freshness checks.
// Every envelope has utime, key_id[8], counter, the signed message's bytes and signature[64];
// the message field is `payload`, `command` or `message` (payload() below).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <motionlcm/signed_gateway_command_t.hpp>
#include <motionlcm/signed_message_t.hpp>
#include <motionlcm/signed_request_t.hpp>

#include "motion/security/keys.hpp"

namespace motion::security::detail {

inline constexpr std::string_view kRequestDomain = "motionbus signed_request_t v1";
inline constexpr std::string_view kGatewayCommandDomain = "motionbus signed_gateway_command_t v1";
inline constexpr std::string_view kMessageDomain = "motionbus signed_message_t v1";

// domain NUL prefix NUL key_id counter utime payload_size payload (integers big-endian).
std::vector<std::uint8_t> covered_bytes(std::string_view domain, std::string_view prefix,
                                        const std::uint8_t (&key_id)[kKeyIdBytes], std::int64_t counter,
                                        std::int64_t utime, std::int32_t payload_size,
                                        std::span<const std::uint8_t> payload);

// The signed message's bytes and their count.
inline std::vector<std::uint8_t>& payload(motionlcm::signed_request_t& e) { return e.payload; }
inline const std::vector<std::uint8_t>& payload(const motionlcm::signed_request_t& e) { return e.payload; }
inline std::int32_t& payload_size(motionlcm::signed_request_t& e) { return e.payload_size; }
inline std::int32_t payload_size(const motionlcm::signed_request_t& e) { return e.payload_size; }
inline std::vector<std::uint8_t>& payload(motionlcm::signed_gateway_command_t& e) { return e.command; }
inline const std::vector<std::uint8_t>& payload(const motionlcm::signed_gateway_command_t& e) { return e.command; }
inline std::int32_t& payload_size(motionlcm::signed_gateway_command_t& e) { return e.command_size; }
inline std::int32_t payload_size(const motionlcm::signed_gateway_command_t& e) { return e.command_size; }
inline std::vector<std::uint8_t>& payload(motionlcm::signed_message_t& e) { return e.message; }
inline const std::vector<std::uint8_t>& payload(const motionlcm::signed_message_t& e) { return e.message; }
inline std::int32_t& payload_size(motionlcm::signed_message_t& e) { return e.message_size; }
inline std::int32_t payload_size(const motionlcm::signed_message_t& e) { return e.message_size; }

template <typename Envelope>
std::vector<std::uint8_t> covered_bytes(std::string_view domain, std::string_view prefix, const Envelope& e) {
  return covered_bytes(domain, prefix, e.key_id, e.counter, e.utime, payload_size(e), payload(e));
}

template <typename Envelope>
KeyId key_id_of(const Envelope& e) {
  KeyId id{};
  std::memcpy(id.data(), e.key_id, kKeyIdBytes);
  return id;
}

template <typename Envelope>
Signature signature_of(const Envelope& e) {
  Signature s{};
  std::memcpy(s.data(), e.signature, kSignatureBytes);
  return s;
}

// `msg` encoded, signed by `key` at `now_us` with the counter after `last_counter` (max(last + 1,
// now_us), which becomes the last).
template <typename Envelope, typename Msg>
Envelope seal(const KeyPair& key, std::string_view domain, std::string_view prefix, std::int64_t& last_counter,
              const Msg& msg, std::int64_t now_us) {
  Envelope e{};
  e.utime = now_us;
  const KeyId id = key.id();
  static_assert(sizeof e.key_id == kKeyIdBytes && sizeof e.signature == kSignatureBytes);
  std::memcpy(e.key_id, id.data(), kKeyIdBytes);
  last_counter = std::max(last_counter + 1, now_us);
  e.counter = last_counter;
  const int size = msg.getEncodedSize();
  payload(e).resize(static_cast<std::size_t>(size));
  msg.encode(payload(e).data(), 0, size);
  payload_size(e) = size;
  const Signature signature = key.sign(covered_bytes(domain, prefix, e));
  std::memcpy(e.signature, signature.data(), kSignatureBytes);
  return e;
}

// Why `utime` is not fresh at `now_us` (all µs since the epoch), e.g. "signed 2500 ms ago, outside
// the window of 2000 ms (clocks out of sync, or a replay)"; nothing when it is.
std::optional<std::string> stale(std::int64_t utime, std::int64_t now_us, std::int64_t window_us,
                                 std::int64_t not_before_us, std::string_view started);

}  // namespace motion::security::detail
