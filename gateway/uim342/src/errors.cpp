#include "motion/uim342/errors.hpp"

#include <fmt/format.h>

namespace motion::uim342 {
namespace {

class DriveCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "uim342"; }
  [[nodiscard]] std::string message(int code) const override {
    if (code == 0) return "no error";
    switch (static_cast<DriveErrc>(code)) {
      case DriveErrc::kSyntaxError: return "instruction syntax error (0x32)";
      case DriveErrc::kDataError: return "instruction data error (0x33)";
      case DriveErrc::kSubIndexError: return "instruction sub-index error (0x34)";
      case DriveErrc::kSdLessThanDc: return "SD value is less than DC value (0x3C)";
      case DriveErrc::kNotAllowedWhileRunning: return "instruction not allowed while the motor is running (0x3D)";
      case DriveErrc::kBgWhileDriverOff: return "BG not allowed while the motor driver is off (0x3E)";
      case DriveErrc::kBgDuringEmergencyStop: return "BG not allowed during an emergency stop (0x3F)";
      case DriveErrc::kOgWhileRunning: return "OG not allowed while the motor is running (0x41)";
    }
    return fmt::format("unknown UIM342 error code 0x{:02X}", code);
  }
};

class CodecCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "uim342-codec"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<CodecErrc>(code)) {
      case CodecErrc::kIdOutOfRange: return "SimpleCAN ID above 127";
      case CodecErrc::kNotExtendedFrame: return "SimpleCAN 3.0 needs an extended (29-bit) frame";
      case CodecErrc::kRemoteFrame: return "remote (RTR) frame carries no SimpleCAN message";
      case CodecErrc::kIdentifierOutOfRange: return "CAN identifier above 29 bits";
      case CodecErrc::kReservedBitsSet: return "reserved identifier bits (18, 13..8) not zero";
      case CodecErrc::kLengthOutOfRange: return "data length above 8";
      case CodecErrc::kUnknownFunction: return "unknown function code";
      case CodecErrc::kAckFormNotSupported: return "instruction does not exist with this ACK bit";
      case CodecErrc::kFormNotSupported: return "instruction has no such get/set form";
      case CodecErrc::kWrongLength: return "data length fits no form of the instruction";
      case CodecErrc::kBodyMismatch: return "typed body does not match the instruction form";
      case CodecErrc::kUnknownSubIndex: return "undefined sub-index";
      case CodecErrc::kUnknownNotification: return "unknown real-time notification code";
      case CodecErrc::kBadFrameSize: return "UIMessage must be exactly 16 bytes";
      case CodecErrc::kBadStartByte: return "UIMessage start byte is neither 0xAA nor 0xAD";
      case CodecErrc::kBadEndByte: return "UIMessage end byte is not 0xCC";
      case CodecErrc::kBadCrc: return "UIMessage CRC mismatch";
      case CodecErrc::kValueOutOfRange: return "value outside the range of its wire field";
      case CodecErrc::kAckBitInReply: return "drive frame with CW bit 7 set";
      case CodecErrc::kNotANotification: return "not a real-time notification (CW 0x5A)";
      case CodecErrc::kProducerNotHost:
        return "a UIMessage has no producer field: a serial gateway carries only instructions from the host (producer "
               "4)";
    }
    return "unknown uim342 codec error";
  }
};

}  // namespace

const std::error_category& drive_category() noexcept {
  static const DriveCategory category;
  return category;
}

const std::error_category& codec_category() noexcept {
  static const CodecCategory category;
  return category;
}

bool is_known_drive_error(std::uint8_t code) noexcept {
  switch (static_cast<DriveErrc>(code)) {
    case DriveErrc::kSyntaxError:
    case DriveErrc::kDataError:
    case DriveErrc::kSubIndexError:
    case DriveErrc::kSdLessThanDc:
    case DriveErrc::kNotAllowedWhileRunning:
    case DriveErrc::kBgWhileDriverOff:
    case DriveErrc::kBgDuringEmergencyStop:
    case DriveErrc::kOgWhileRunning: return true;
  }
  return false;
}

}  // namespace motion::uim342
