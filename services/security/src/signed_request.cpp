#include "motion/security/signed_request.hpp"

#include <algorithm>
#include <cstring>

namespace motion::security {
namespace {

constexpr std::string_view kDomain = "motionbus signed_request_t v1";

// Writes the big-endian `bytes` low bytes of `value` at `at`.
void put_be(std::uint8_t* at, std::uint64_t value, std::size_t bytes) {
  for (std::size_t i = 0; i < bytes; ++i) at[i] = static_cast<std::uint8_t>(value >> (8 * (bytes - 1 - i)));
}

}  // namespace

std::vector<std::uint8_t> signed_bytes(std::string_view channel_prefix, const motionlcm::signed_request_t& envelope) {
  // Sized once and filled in place (GCC 12 misreads repeated vector inserts as overflows).
  const std::size_t payload = envelope.payload.size();
  std::vector<std::uint8_t> out(kDomain.size() + 1 + channel_prefix.size() + 1 + kKeyIdBytes + 8 + 8 + 4 + payload);
  std::uint8_t* p = out.data();
  std::memcpy(p, kDomain.data(), kDomain.size());
  p += kDomain.size() + 1;  // and its NUL
  std::memcpy(p, channel_prefix.data(), channel_prefix.size());
  p += channel_prefix.size() + 1;
  std::memcpy(p, envelope.key_id, kKeyIdBytes);
  p += kKeyIdBytes;
  put_be(p, static_cast<std::uint64_t>(envelope.counter), 8);
  put_be(p + 8, static_cast<std::uint64_t>(envelope.utime), 8);
  put_be(p + 16, static_cast<std::uint32_t>(envelope.payload_size), 4);
  p += 20;
  if (payload != 0) std::memcpy(p, envelope.payload.data(), payload);
  return out;
}

RequestSigner::RequestSigner(KeyPair key, std::string channel_prefix) : key_(std::move(key)), prefix_(std::move(channel_prefix)) {}

std::string RequestSigner::own_client_id(std::string_view client_id) const {
  if (name_owns_client_id(key_.name(), client_id)) return std::string(client_id);
  return key_.name() + "/" + std::string(client_id);
}

motionlcm::signed_request_t RequestSigner::sign(const motionlcm::request_t& request, std::int64_t now_us) {
  motionlcm::signed_request_t envelope{};
  envelope.utime = now_us;
  const KeyId id = key_.id();
  static_assert(sizeof envelope.key_id == kKeyIdBytes && sizeof envelope.signature == kSignatureBytes);
  std::memcpy(envelope.key_id, id.data(), kKeyIdBytes);
  last_counter_ = std::max(last_counter_ + 1, now_us);
  envelope.counter = last_counter_;
  const int size = request.getEncodedSize();
  envelope.payload.resize(static_cast<std::size_t>(size));
  request.encode(envelope.payload.data(), 0, size);
  envelope.payload_size = size;
  const Signature signature = key_.sign(signed_bytes(prefix_, envelope));
  std::memcpy(envelope.signature, signature.data(), kSignatureBytes);
  return envelope;
}

}  // namespace motion::security
