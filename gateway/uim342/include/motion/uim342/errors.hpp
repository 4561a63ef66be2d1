// Error vocabulary of the UIM342 SimpleCAN 3.0 codec.
//
// * DriveErrc — the error codes a drive reports in d1 of an error report / ER ACK (CW 0x0F),
//   manual §2.3, in the std::error_category "uim342". A value of 0 (an empty ER history slot) is
//   "no error" and therefore maps to a default (false) std::error_code.
// * CodecErrc — why this library refused to encode or decode something (malformed frame, wrong
//   length, unknown control word, bad CRC ...), in the category "uim342-codec".
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

namespace motion::uim342 {

// Manual §2.3 "Error Code for UIM342". Values are the wire bytes.
enum class DriveErrc : std::uint8_t {
  kSyntaxError = 0x32,             // instruction syntax error (also "#50": SP before PR/PA)
  kDataError = 0x33,               // instruction data error (value out of range / illegal)
  kSubIndexError = 0x34,           // instruction sub-index error
  kSdLessThanDc = 0x3C,            // SD value is less than DC value
  kNotAllowedWhileRunning = 0x3D,  // current instruction not allowed while the motor runs
  kBgWhileDriverOff = 0x3E,        // BG not allowed while the motor driver is off
  kBgDuringEmergencyStop = 0x3F,   // BG not allowed during an emergency stop
  kOgWhileRunning = 0x41,          // OG not allowed while the motor runs
};

[[nodiscard]] const std::error_category& drive_category() noexcept;  // name() == "uim342"
[[nodiscard]] inline std::error_code make_error_code(DriveErrc e) noexcept {
  return {static_cast<int>(e), drive_category()};
}
// True for the eight codes of manual §2.3.
[[nodiscard]] bool is_known_drive_error(std::uint8_t code) noexcept;

enum class CodecErrc {
  kIdOutOfRange = 1,      // a producer/consumer ID above 127 (7 bits)
  kNotExtendedFrame,      // SimpleCAN 3.0 uses 29-bit data frames only (manual §2.5)
  kRemoteFrame,           // RTR frames carry no SimpleCAN message
  kIdentifierOutOfRange,  // value above 29 bits
  kReservedBitsSet,       // identifier bit 18 or bits 13..8 not zero
  kLengthOutOfRange,      // DL / DLC above 8
  kUnknownFunction,       // no instruction has this function code
  kAckFormNotSupported,   // ML without ACK bit, SY with ACK bit, RT as an instruction
  kFormNotSupported,      // e.g. a get of BG, a set of DV
  kWrongLength,           // DL fits no form of the instruction
  kBodyMismatch,          // the typed body does not have the layout of the form
  kUnknownSubIndex,       // a sub-index that selects the layout (MS) is undefined
  kUnknownNotification,   // RT d0 not one of the §2.4 codes
  kBadFrameSize,          // UIMessage not exactly 16 bytes
  kBadStartByte,          // UIMessage SM neither 0xAA nor 0xAD
  kBadEndByte,            // UIMessage EM not 0xCC
  kBadCrc,                // UIMessage CRC matches none of the accepted coverages
  kValueOutOfRange,       // a unit conversion produced a value outside the wire type
  kAckBitInReply,         // a drive frame with CW bit 7 set (replies always clear it, §2.1)
  kNotANotification,      // CW is not 0x5A
  kProducerNotHost,       // an instruction for a UIMessage gateway not sent as the host (it has no producer field)
};

[[nodiscard]] const std::error_category& codec_category() noexcept;  // name() == "uim342-codec"
[[nodiscard]] inline std::error_code make_error_code(CodecErrc e) noexcept {
  return {static_cast<int>(e), codec_category()};
}

// The shared Result<T> (motion/core/result.hpp).
using motion::Result;

}  // namespace motion::uim342

template <>
struct std::is_error_code_enum<motion::uim342::DriveErrc> : std::true_type {};
template <>
struct std::is_error_code_enum<motion::uim342::CodecErrc> : std::true_type {};
