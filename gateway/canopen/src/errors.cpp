#include "motion/canopen/errors.hpp"

#include <cstdio>
#include <string>

namespace motion::canopen {
namespace {

class SdoCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "canopen-sdo"; }
  [[nodiscard]] std::string message(int value) const override {
    const auto code = static_cast<std::uint32_t>(value);
    char hex[16];
    std::snprintf(hex, sizeof hex, "%08X", code);
    const std::string_view text = description(static_cast<SdoAbortCode>(code));
    if (text.empty()) return "SDO abort " + std::string(hex);
    return std::string(text) + " (SDO abort " + hex + ")";
  }
};

class CanopenCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "canopen"; }
  [[nodiscard]] std::string message(int value) const override {
    switch (static_cast<CanopenError>(value)) {
      case CanopenError::kCancelled: return "request cancelled";
      case CanopenError::kMismatchedReply: return "SDO reply for another object than requested";
      case CanopenError::kReadBackMismatch: return "read-back value differs from the value written";
      case CanopenError::kInvalidArgument: return "request not expressible in CANopen";
    }
    return "unknown canopen error";
  }
};

}  // namespace

std::string_view description(SdoAbortCode code) {
  switch (code) {
    case SdoAbortCode::kToggleBitNotAlternated: return "Toggle bit not alternated";
    case SdoAbortCode::kTimeout: return "SDO protocol timed out";
    case SdoAbortCode::kInvalidCommandSpecifier: return "Client/server command specifier not valid or unknown";
    case SdoAbortCode::kInvalidBlockSize: return "Invalid block size (block mode only)";
    case SdoAbortCode::kInvalidSequenceNumber: return "Invalid sequence number (block mode only)";
    case SdoAbortCode::kCrcError: return "CRC error (block mode only)";
    case SdoAbortCode::kOutOfMemory: return "Out of memory";
    case SdoAbortCode::kUnsupportedAccess: return "Unsupported access to an object";
    case SdoAbortCode::kReadOfWriteOnly: return "Attempt to read a write only object";
    case SdoAbortCode::kWriteOfReadOnly: return "Attempt to write a read only object";
    case SdoAbortCode::kObjectDoesNotExist: return "Object does not exist in the object dictionary";
    case SdoAbortCode::kObjectNotMappable: return "Object cannot be mapped to the PDO";
    case SdoAbortCode::kPdoLengthExceeded:
      return "The number and length of the objects to be mapped would exceed PDO length";
    case SdoAbortCode::kParameterIncompatibility: return "General parameter incompatibility reason";
    case SdoAbortCode::kInternalIncompatibility: return "General internal incompatibility in the device";
    case SdoAbortCode::kHardwareError: return "Access failed due to an hardware error";
    case SdoAbortCode::kLengthMismatch: return "Data type does not match, length of service parameter does not match";
    case SdoAbortCode::kLengthTooHigh: return "Data type does not match, length of service parameter too high";
    case SdoAbortCode::kLengthTooLow: return "Data type does not match, length of service parameter too low";
    case SdoAbortCode::kSubindexDoesNotExist: return "Sub-index does not exist";
    case SdoAbortCode::kInvalidValue: return "Invalid value for parameter (download only)";
    case SdoAbortCode::kValueTooHigh: return "Value of parameter written too high (download only)";
    case SdoAbortCode::kValueTooLow: return "Value of parameter written too low (download only)";
    case SdoAbortCode::kMaxLessThanMin: return "Maximum value is less than minimum value";
    case SdoAbortCode::kResourceNotAvailable: return "Resource not available: SDO connection";
    case SdoAbortCode::kGeneralError: return "General error";
    case SdoAbortCode::kDataNotTransferable: return "Data cannot be transferred or stored to the application";
    case SdoAbortCode::kDataNotTransferableLocalControl:
      return "Data cannot be transferred or stored to the application because of local control";
    case SdoAbortCode::kDataNotTransferableDeviceState:
      return "Data cannot be transferred or stored to the application because of the present device state";
    case SdoAbortCode::kNoObjectDictionary:
      return "Object dictionary dynamic generation fails or no object dictionary is present";
    case SdoAbortCode::kNoDataAvailable: return "No data available";
  }
  return {};
}

const std::error_category& sdo_category() {
  static const SdoCategory category;
  return category;
}

std::error_code make_error_code(SdoAbortCode code) { return sdo_abort_error(static_cast<std::uint32_t>(code)); }

// Abort codes use all 32 bits; the int value round-trips through the same bit pattern.
std::error_code sdo_abort_error(std::uint32_t code) { return {static_cast<int>(code), sdo_category()}; }

std::uint32_t to_abort_code(std::error_code error) {
  if (error.category() == sdo_category()) return static_cast<std::uint32_t>(error.value());
  return static_cast<std::uint32_t>(SdoAbortCode::kGeneralError);
}

const std::error_category& canopen_category() {
  static const CanopenCategory category;
  return category;
}

std::error_code make_error_code(CanopenError error) { return {static_cast<int>(error), canopen_category()}; }

}  // namespace motion::canopen
