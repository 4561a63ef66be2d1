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
      case DriveErrc::syntax_error: return "instruction syntax error (0x32)";
      case DriveErrc::data_error: return "instruction data error (0x33)";
      case DriveErrc::sub_index_error: return "instruction sub-index error (0x34)";
      case DriveErrc::sd_less_than_dc: return "SD value is less than DC value (0x3C)";
      case DriveErrc::not_allowed_while_running: return "instruction not allowed while the motor is running (0x3D)";
      case DriveErrc::bg_while_driver_off: return "BG not allowed while the motor driver is off (0x3E)";
      case DriveErrc::bg_during_emergency_stop: return "BG not allowed during an emergency stop (0x3F)";
      case DriveErrc::og_while_running: return "OG not allowed while the motor is running (0x41)";
    }
    return fmt::format("unknown UIM342 error code 0x{:02X}", code);
  }
};

class CodecCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "uim342-codec"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<CodecErrc>(code)) {
      case CodecErrc::id_out_of_range: return "SimpleCAN ID above 127";
      case CodecErrc::not_extended_frame: return "SimpleCAN 3.0 needs an extended (29-bit) frame";
      case CodecErrc::remote_frame: return "remote (RTR) frame carries no SimpleCAN message";
      case CodecErrc::identifier_out_of_range: return "CAN identifier above 29 bits";
      case CodecErrc::reserved_bits_set: return "reserved identifier bits (18, 13..8) not zero";
      case CodecErrc::length_out_of_range: return "data length above 8";
      case CodecErrc::unknown_function: return "unknown function code";
      case CodecErrc::ack_form_not_supported: return "instruction does not exist with this ACK bit";
      case CodecErrc::form_not_supported: return "instruction has no such get/set form";
      case CodecErrc::wrong_length: return "data length fits no form of the instruction";
      case CodecErrc::body_mismatch: return "typed body does not match the instruction form";
      case CodecErrc::unknown_sub_index: return "undefined sub-index";
      case CodecErrc::unknown_notification: return "unknown real-time notification code";
      case CodecErrc::bad_frame_size: return "UIMessage must be exactly 16 bytes";
      case CodecErrc::bad_start_byte: return "UIMessage start byte is neither 0xAA nor 0xAD";
      case CodecErrc::bad_end_byte: return "UIMessage end byte is not 0xCC";
      case CodecErrc::bad_crc: return "UIMessage CRC mismatch";
      case CodecErrc::value_out_of_range: return "value outside the range of its wire field";
      case CodecErrc::ack_bit_in_reply: return "drive frame with CW bit 7 set";
      case CodecErrc::not_a_notification: return "not a real-time notification (CW 0x5A)";
      case CodecErrc::producer_not_host:
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
    case DriveErrc::syntax_error:
    case DriveErrc::data_error:
    case DriveErrc::sub_index_error:
    case DriveErrc::sd_less_than_dc:
    case DriveErrc::not_allowed_while_running:
    case DriveErrc::bg_while_driver_off:
    case DriveErrc::bg_during_emergency_stop:
    case DriveErrc::og_while_running: return true;
  }
  return false;
}

}  // namespace motion::uim342
