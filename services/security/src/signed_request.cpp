#include "motion/security/signed_request.hpp"

#include "envelope.hpp"

namespace motion::security {
namespace detail {
namespace {

// Writes the big-endian `bytes` low bytes of `value` at `at`.
void put_be(std::uint8_t* at, std::uint64_t value, std::size_t bytes) {
  for (std::size_t i = 0; i < bytes; ++i) at[i] = static_cast<std::uint8_t>(value >> (8 * (bytes - 1 - i)));
}

std::string milliseconds_text(std::uint64_t us) { return std::to_string(us / 1000) + " ms"; }

// |a - b| without overflow: utime is the sender's, any int64 (signed, so only an authorized key's
// holder can send an extreme one, but it must not be undefined behaviour either).
std::uint64_t distance(std::int64_t a, std::int64_t b) {
  const auto ua = static_cast<std::uint64_t>(a);
  const auto ub = static_cast<std::uint64_t>(b);
  return a >= b ? ua - ub : ub - ua;
}

}  // namespace

std::vector<std::uint8_t> covered_bytes(std::string_view domain, std::string_view prefix,
                                        const std::uint8_t (&key_id)[kKeyIdBytes], std::int64_t counter,
                                        std::int64_t utime, std::int32_t payload_size,
                                        std::span<const std::uint8_t> payload) {
  // Sized once and filled in place (GCC 12 misreads repeated vector inserts as overflows).
  std::vector<std::uint8_t> out(domain.size() + 1 + prefix.size() + 1 + kKeyIdBytes + 8 + 8 + 4 + payload.size());
  std::uint8_t* p = out.data();
  std::memcpy(p, domain.data(), domain.size());
  p += domain.size() + 1;  // and its NUL
  std::memcpy(p, prefix.data(), prefix.size());
  p += prefix.size() + 1;
  std::memcpy(p, key_id, kKeyIdBytes);
  p += kKeyIdBytes;
  put_be(p, static_cast<std::uint64_t>(counter), 8);
  put_be(p + 8, static_cast<std::uint64_t>(utime), 8);
  put_be(p + 16, static_cast<std::uint32_t>(payload_size), 4);
  p += 20;
  if (!payload.empty()) std::memcpy(p, payload.data(), payload.size());
  return out;
}

std::optional<std::string> stale(std::int64_t utime, std::int64_t now_us, std::int64_t window_us,
                                 std::int64_t not_before_us, std::string_view started) {
  if (utime < not_before_us) {
    return "signed " + milliseconds_text(distance(not_before_us, utime)) + " before the " + std::string(started) +
           " started (a replay?)";
  }
  const std::uint64_t age = distance(now_us, utime);
  if (age > static_cast<std::uint64_t>(window_us)) {
    return "signed " + milliseconds_text(age) + (now_us >= utime ? " ago" : " in the future") +
           ", outside the window of " + milliseconds_text(static_cast<std::uint64_t>(window_us)) +
           " (clocks out of sync, or a replay)";
  }
  return std::nullopt;
}

}  // namespace detail

std::vector<std::uint8_t> signed_bytes(std::string_view channel_prefix, const motionlcm::signed_request_t& envelope) {
  return detail::covered_bytes(detail::kRequestDomain, channel_prefix, envelope);
}

RequestSigner::RequestSigner(const KeyPair& key, std::string channel_prefix)
    : key_(key), prefix_(std::move(channel_prefix)) {}

std::string RequestSigner::own_client_id(std::string_view client_id) const {
  if (name_owns_client_id(key_.name(), client_id)) return std::string(client_id);
  return key_.name() + "/" + std::string(client_id);
}

motionlcm::signed_request_t RequestSigner::sign(const motionlcm::request_t& request, std::int64_t now_us) {
  return detail::seal<motionlcm::signed_request_t>(key_, detail::kRequestDomain, prefix_, last_counter_, request,
                                                   now_us);
}

}  // namespace motion::security
