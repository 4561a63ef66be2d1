// Bounded checking of LCM-encoded messages before they are decoded.
//
// lcm-gen's C++ decode resizes a vector to the count a message claims before it finds that the
// message is too short for it: a 74-byte message claiming 20 million strings allocates 640 MB.
// The checkers generated from the .lcm files (motion/lcm/wire_bounds.hpp, made by
// services/lcm/gen/lcm_wire_bounds.py at build time) walk the bytes first, without allocating:
// every array count and string length is checked against the bytes that remain (count times
// the element's minimal encoded size), negative counts and lengths and strings without their
// NUL are refused. A message that passes decodes with allocations bounded by its own size; one
// that fails costs O(its size) and the reader says which field was wrong.
//
// LCM wire format (LCM type specification): 8-byte fingerprint, then the fields in declaration
// order, big-endian; string = int32 length including the NUL, the bytes, the NUL.
//
// Thread contract: plain values and pure functions, usable from any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace motion::lcm::wire {

class WireReader {
 public:
  WireReader(const void* data, std::size_t size) : data_(static_cast<const std::uint8_t*>(data)), size_(size) {}

  [[nodiscard]] std::size_t position() const { return pos_; }
  [[nodiscard]] std::size_t remaining() const { return size_ - pos_; }

  // Fixed-size field(s).
  bool skip(std::size_t bytes, const char* field) {
    if (bytes > remaining()) return fail(field, "needs", static_cast<std::int64_t>(bytes));
    pos_ += bytes;
    return true;
  }
  // A signed big-endian integer of `width` bytes (1, 2, 4, 8), kept because it is a count.
  bool integer(int width, const char* field, std::int64_t& value);
  // A string: int32 length >= 1 (it includes the NUL), the bytes present, the last one NUL.
  bool string(const char* field);
  // An array with dimensions `dims` (each >= 0) of elements at least `min_element_size` bytes
  // each: the product must fit in what remains. `count` = the number of elements.
  template <std::size_t N>
  bool array(const char* field, const std::int64_t (&dims)[N], std::size_t min_element_size, std::int64_t& count) {
    return array(field, dims, N, min_element_size, count);
  }
  bool array(const char* field, const std::int64_t* dims, std::size_t num_dims, std::size_t min_element_size,
             std::int64_t& count);

  bool fail(const char* field, const char* problem, std::int64_t value);

  // Empty while every check passed; else e.g.
  // "request_t.axes: count 20000000 needs at least 100000000 bytes, 16 remain (at byte 58)".
  [[nodiscard]] const std::string& error() const { return error_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::string error_;
};

// Specialised for every LCM type by the generated motion/lcm/wire_bounds.hpp:
//   kName (package.type), kMinSize (smallest encoding incl. fingerprint), check_body(WireReader&).
template <typename Msg>
struct Bounds;

// Checks fingerprint, body and that nothing trails it. Returns "" when `data` is a well-formed
// encoding of Msg, else the reason.
template <typename Msg>
std::string check_message(const void* data, std::size_t size);

// Decodes only what check_message accepted. Returns "" on success, else the reason.
template <typename Msg>
std::string decode_bounded(const void* data, std::size_t size, Msg& out);

// lcm-gen's encoding of a default-constructed Msg (every count 0, every string empty).
template <typename Msg>
std::vector<std::uint8_t> encode_default();

// One entry per type of the .lcm files (generated: all_types()).
struct CountField {
  const char* path;    // e.g. "num_axes", "param.mnemonic" (nested)
  std::size_t offset;  // in encode_default()'s bytes
  int width;           // bytes of the count's integer type
  bool string_length;  // the int32 length of a string rather than an array count
};
struct TypeInfo {
  const char* name;      // package.type
  const char* lcm_file;  // e.g. "request_t.lcm"
  std::string (*check)(const void* data, std::size_t size);
  // decode_bounded into a temporary of the type (what Node::subscribe does).
  std::string (*decode)(const void* data, std::size_t size);
  // lcm-gen's decode alone, no check (allocates what the message claims): for the tests and the
  // fuzz target that show the hazard. Returns its result; may throw std::length_error.
  int (*decode_unchecked)(const void* data, std::size_t size);
  std::vector<std::uint8_t> (*encode_default)();
  std::vector<CountField> count_fields;
};

// ---- implementation of the templates ----

std::string describe_fingerprint_mismatch(const char* type_name, std::size_t size, std::int64_t got, std::int64_t want);

template <typename Msg>
std::string check_message(const void* data, std::size_t size) {
  WireReader r(data, size);
  std::int64_t hash = 0;
  if (!r.integer(8, "fingerprint", hash)) return r.error();
  if (hash != Msg::getHash()) return describe_fingerprint_mismatch(Bounds<Msg>::kName, size, hash, Msg::getHash());
  if (!Bounds<Msg>::check_body(r)) return r.error();
  if (r.remaining() != 0) {
    r.fail(Bounds<Msg>::kName, "has trailing bytes:", static_cast<std::int64_t>(r.remaining()));
    return r.error();
  }
  return {};
}

template <typename Msg>
std::string decode_bounded(const void* data, std::size_t size, Msg& out) {
  std::string why = check_message<Msg>(data, size);
  if (!why.empty()) return why;
  const int n = static_cast<int>(size);
  if (out.decode(data, 0, n) != n) return std::string(Bounds<Msg>::kName) + ": lcm decode refused a checked message";
  return {};
}

template <typename Msg>
std::string decode_to_temporary(const void* data, std::size_t size) {
  Msg msg;
  return decode_bounded(data, size, msg);
}

template <typename Msg>
int decode_unchecked(const void* data, std::size_t size) {
  Msg msg;
  return msg.decode(data, 0, static_cast<int>(size));
}

template <typename Msg>
std::vector<std::uint8_t> encode_default() {
  const Msg msg{};
  const int size = msg.getEncodedSize();
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  msg.encode(bytes.data(), 0, size);
  return bytes;
}

}  // namespace motion::lcm::wire
