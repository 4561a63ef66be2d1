#include "motion/lcm/wire_reader.hpp"

#include <limits>

namespace motion::lcm::wire {

bool WireReader::integer(int width, const char* field, std::int64_t& value) {
  const auto bytes = static_cast<std::size_t>(width);
  if (!skip(bytes, field)) return false;
  std::uint64_t v = 0;
  for (std::size_t i = pos_ - bytes; i < pos_; ++i) v = (v << 8) | data_[i];
  const unsigned shift = 64U - 8U * static_cast<unsigned>(width);
  // Sign-extend from `width` bytes (two's complement).
  value = shift == 0 ? static_cast<std::int64_t>(v) : static_cast<std::int64_t>(v << shift) >> shift;
  return true;
}

bool WireReader::string(const char* field) {
  std::int64_t length = 0;
  if (!integer(4, field, length)) return false;
  if (length < 1) return fail(field, "string length (must be >= 1, it includes the NUL) is", length);
  if (static_cast<std::uint64_t>(length) > remaining())
    return fail(field, "string length exceeds what remains:", length);
  pos_ += static_cast<std::size_t>(length);
  if (data_[pos_ - 1] != 0) return fail(field, "string does not end with NUL; length", length);
  return true;
}

bool WireReader::array(const char* field, const std::int64_t* dims, std::size_t num_dims, std::size_t min_element_size,
                       std::int64_t& count) {
  // min_element_size >= 1, so a count that fits is at most remaining() <= size: no overflow.
  const auto limit = static_cast<std::int64_t>(remaining() / min_element_size);
  std::int64_t total = 1;
  for (std::size_t i = 0; i < num_dims; ++i) {
    if (dims[i] < 0) return fail(field, "negative count", dims[i]);
    if (dims[i] == 0) {
      total = 0;
      break;
    }
    if (dims[i] > limit || total > limit / dims[i]) {
      error_ = std::string(field) + ": count " + std::to_string(dims[i]) + " needs at least " +
               (dims[i] > std::numeric_limits<std::int64_t>::max() / static_cast<std::int64_t>(min_element_size)
                    ? std::string("more than 2^63")
                    : std::to_string(dims[i] * static_cast<std::int64_t>(min_element_size))) +
               " bytes, " + std::to_string(remaining()) + " remain (at byte " + std::to_string(pos_) + ")";
      return false;
    }
    total *= dims[i];
  }
  count = total;
  return true;
}

bool WireReader::fail(const char* field, const char* problem, std::int64_t value) {
  error_ = std::string(field) + ": " + problem + " " + std::to_string(value) + " (at byte " + std::to_string(pos_) +
           " of " + std::to_string(size_) + ")";
  return false;
}

std::string describe_fingerprint_mismatch(const char* type_name, std::size_t size, std::int64_t got,
                                          std::int64_t want) {
  (void)want;
  return std::to_string(size) + " bytes are not a " + std::string(type_name) + " (fingerprint " + std::to_string(got) +
         ")";
}

}  // namespace motion::lcm::wire
