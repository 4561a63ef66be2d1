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
  syntax_error = 0x32,               // instruction syntax error (also "#50": SP before PR/PA)
  data_error = 0x33,                 // instruction data error (value out of range / illegal)
  sub_index_error = 0x34,            // instruction sub-index error
  sd_less_than_dc = 0x3C,            // SD value is less than DC value
  not_allowed_while_running = 0x3D,  // current instruction not allowed while the motor runs
  bg_while_driver_off = 0x3E,        // BG not allowed while the motor driver is off
  bg_during_emergency_stop = 0x3F,   // BG not allowed during an emergency stop
  og_while_running = 0x41,           // OG not allowed while the motor runs
};

[[nodiscard]] const std::error_category& drive_category() noexcept;  // name() == "uim342"
[[nodiscard]] inline std::error_code make_error_code(DriveErrc e) noexcept {
  return {static_cast<int>(e), drive_category()};
}
// True for the eight codes of manual §2.3.
[[nodiscard]] bool is_known_drive_error(std::uint8_t code) noexcept;

enum class CodecErrc {
  id_out_of_range = 1,      // a producer/consumer ID above 127 (7 bits)
  not_extended_frame,       // SimpleCAN 3.0 uses 29-bit data frames only (manual §2.5)
  remote_frame,             // RTR frames carry no SimpleCAN message
  identifier_out_of_range,  // value above 29 bits
  reserved_bits_set,        // identifier bit 18 or bits 13..8 not zero
  length_out_of_range,      // DL / DLC above 8
  unknown_function,         // no instruction has this function code
  ack_form_not_supported,   // ML without ACK bit, SY with ACK bit, RT as an instruction
  form_not_supported,       // e.g. a get of BG, a set of DV
  wrong_length,             // DL fits no form of the instruction
  body_mismatch,            // the typed body does not have the layout of the form
  unknown_sub_index,        // a sub-index that selects the layout (MS) is undefined
  unknown_notification,     // RT d0 not one of the §2.4 codes
  bad_frame_size,           // UIMessage not exactly 16 bytes
  bad_start_byte,           // UIMessage SM neither 0xAA nor 0xAD
  bad_end_byte,             // UIMessage EM not 0xCC
  bad_crc,                  // UIMessage CRC matches none of the accepted coverages
  value_out_of_range,       // a unit conversion produced a value outside the wire type
  ack_bit_in_reply,         // a drive frame with CW bit 7 set (replies always clear it, §2.1)
  not_a_notification,       // CW is not 0x5A
  producer_not_host,        // an instruction for a UIMessage gateway not sent as the host (it has no producer field)
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
