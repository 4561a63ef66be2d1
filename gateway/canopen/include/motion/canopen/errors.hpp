// Error codes of the CANopen master core.
//  - SdoAbortCode: the CiA 301 §7.2.4.3.17 SDO abort codes (wire values), category "canopen-sdo".
//    Server aborts and client-side protocol failures (timeout, toggle error) both surface as
//    these, so a caller tests `ec == SdoAbortCode::kTimeout` whatever the origin.
//  - CanopenError: failures that have no abort code (cancelled request, mismatched reply,
//    read-back mismatch), category "canopen".
// The categories are immutable singletons: thread-safe.
#pragma once

#include <cstdint>
#include <string_view>
#include <system_error>
#include <type_traits>

namespace motion::canopen {

enum class SdoAbortCode : std::uint32_t {
  kToggleBitNotAlternated = 0x05030000,
  kTimeout = 0x05040000,
  kInvalidCommandSpecifier = 0x05040001,
  kInvalidBlockSize = 0x05040002,
  kInvalidSequenceNumber = 0x05040003,
  kCrcError = 0x05040004,
  kOutOfMemory = 0x05040005,
  kUnsupportedAccess = 0x06010000,
  kReadOfWriteOnly = 0x06010001,
  kWriteOfReadOnly = 0x06010002,
  kObjectDoesNotExist = 0x06020000,
  kObjectNotMappable = 0x06040041,
  kPdoLengthExceeded = 0x06040042,
  kParameterIncompatibility = 0x06040043,
  kInternalIncompatibility = 0x06040047,
  kHardwareError = 0x06060000,
  kLengthMismatch = 0x06070010,
  kLengthTooHigh = 0x06070012,
  kLengthTooLow = 0x06070013,
  kSubindexDoesNotExist = 0x06090011,
  kInvalidValue = 0x06090030,
  kValueTooHigh = 0x06090031,
  kValueTooLow = 0x06090032,
  kMaxLessThanMin = 0x06090036,
  kResourceNotAvailable = 0x060A0023,
  kGeneralError = 0x08000000,
  kDataNotTransferable = 0x08000020,
  kDataNotTransferableLocalControl = 0x08000021,
  kDataNotTransferableDeviceState = 0x08000022,
  kNoObjectDictionary = 0x08000023,
  kNoDataAvailable = 0x08000024,
};

// The CiA 301 text; empty for codes the standard does not define.
[[nodiscard]] std::string_view description(SdoAbortCode code);

[[nodiscard]] const std::error_category& sdo_category();
[[nodiscard]] std::error_code make_error_code(SdoAbortCode code);
// Any 32-bit abort code received on the wire, including manufacturer-specific ones.
[[nodiscard]] std::error_code sdo_abort_error(std::uint32_t code);
// The abort code to put on the wire for an error: its value for the "canopen-sdo" category,
// General error (08000000h) for anything else.
[[nodiscard]] std::uint32_t to_abort_code(std::error_code error);

enum class CanopenError : int {
  kCancelled = 1,     // request dropped by cancel() before it completed
  kMismatchedReply,   // SDO reply for another index/sub-index than requested
  kReadBackMismatch,  // verification read returned another value than was written
  kInvalidArgument,   // request the protocol cannot express (bad node-ID, oversized PDO mapping)
};

[[nodiscard]] const std::error_category& canopen_category();
[[nodiscard]] std::error_code make_error_code(CanopenError error);

}  // namespace motion::canopen

template <>
struct std::is_error_code_enum<motion::canopen::SdoAbortCode> : std::true_type {};
template <>
struct std::is_error_code_enum<motion::canopen::CanopenError> : std::true_type {};
