// Error vocabulary of the UIM242 string-protocol codec.
//
// * ErrorCode — the codes a UIM242 (or the gateway in front of it) returns in an error frame
//   `EE code FF` (EN/CN §6.2), in the std::error_category "uim242". The manuals write
//   them as `65` / `66` in the same hex notation as every other byte row, so the wire bytes are
//   0x65 and 0x66 (not stated in the manuals: assumed).
// * CodecErrc — why this library refused to encode or decode something, category "uim242-codec".
// * Result<T> — a T or a std::error_code (C++20 has no std::expected).
// Thread contract: pure functions and immutable singletons, thread-safe.
#pragma once

#include <cstdint>
#include <string>
#include <system_error>
#include <type_traits>
#include <utility>
#include <variant>

#include "motion/core/result.hpp"

namespace motion::uim242 {

// EN/CN §6.2, CN #6 (`CUR 81;` -> `EE 66 FF`). Values are the wire bytes.
enum class ErrorCode : std::uint8_t {
  kSyntaxError = 0x65,  // unknown mnemonic, malformed number, odd hex digit count, > 20 characters, non-ASCII
  kValueError = 0x66,   // value outside the instruction's documented set or range
};

[[nodiscard]] const std::error_category& error_category() noexcept;  // name() == "uim242"
[[nodiscard]] inline std::error_code make_error_code(ErrorCode e) noexcept {
  return {static_cast<int>(e), error_category()};
}
[[nodiscard]] bool is_known_error_code(std::uint8_t code) noexcept;

enum class CodecErrc {
  kValueOutOfRange = 1,  // encode: value outside the instruction's range (would earn EE 66)
  kValueRequired,        // encode: the instruction form needs a value
  kValueNotAllowed,      // encode: the instruction has no value form
  kHexNotAllowed,        // encode: no hex form documented for this instruction (EN/CN §12.3)
  kNotGlobal,            // encode: no g... form of this instruction
  kBadHeader,            // decode: frame does not start with AA, CC or EE
  kBadTerminator,        // decode: frame does not end with FF or FE
  kFrameTooShort,
  kFrameTooLong,     // framer: more than kMaxFrameBytes without a terminator
  kNotSevenBit,      // decode: a data byte with bit 7 set
  kWrongLength,      // decode: data length does not fit the expected layout
  kUnexpectedFrame,  // decode: header/message id is not the expected reply
};

[[nodiscard]] const std::error_category& codec_category() noexcept;  // name() == "uim242-codec"
[[nodiscard]] inline std::error_code make_error_code(CodecErrc e) noexcept {
  return {static_cast<int>(e), codec_category()};
}

// The shared Result<T> (motion/core/result.hpp).
using motion::Result;

}  // namespace motion::uim242

template <>
struct std::is_error_code_enum<motion::uim242::ErrorCode> : std::true_type {};
template <>
struct std::is_error_code_enum<motion::uim242::CodecErrc> : std::true_type {};
