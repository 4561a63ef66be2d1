#include "motion/uim242/errors.hpp"

#include <fmt/format.h>

namespace motion::uim242 {
namespace {

class DriveCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "uim242"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<ErrorCode>(code)) {
      case ErrorCode::syntax_error: return "instruction syntax error (EE 65)";
      case ErrorCode::value_error: return "instruction value error (EE 66)";
    }
    return fmt::format("unknown UIM242 error code 0x{:02X}", code);
  }
};

class CodecCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "uim242-codec"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<CodecErrc>(code)) {
      case CodecErrc::value_out_of_range: return "value outside the instruction's range";
      case CodecErrc::value_required: return "instruction form needs a value";
      case CodecErrc::value_not_allowed: return "instruction takes no value";
      case CodecErrc::hex_not_allowed: return "instruction has no hexadecimal form";
      case CodecErrc::not_global: return "instruction has no global (g...) form";
      case CodecErrc::bad_header: return "feedback frame does not start with AA, CC or EE";
      case CodecErrc::bad_terminator: return "feedback frame does not end with FF or FE";
      case CodecErrc::frame_too_short: return "feedback frame too short";
      case CodecErrc::frame_too_long: return "feedback frame longer than 16 bytes";
      case CodecErrc::not_seven_bit: return "data byte with bit 7 set";
      case CodecErrc::wrong_length: return "data length does not fit the reply layout";
      case CodecErrc::unexpected_frame: return "not the expected reply";
    }
    return "unknown uim242 codec error";
  }
};

}  // namespace

const std::error_category& error_category() noexcept {
  static const DriveCategory category;
  return category;
}

const std::error_category& codec_category() noexcept {
  static const CodecCategory category;
  return category;
}

bool is_known_error_code(std::uint8_t code) noexcept {
  return code == static_cast<std::uint8_t>(ErrorCode::syntax_error) ||
         code == static_cast<std::uint8_t>(ErrorCode::value_error);
}

}  // namespace motion::uim242
