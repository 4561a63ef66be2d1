#include "motion/uim242/errors.hpp"

#include <fmt/format.h>

namespace motion::uim242 {
namespace {

class DriveCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "uim242"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<ErrorCode>(code)) {
      case ErrorCode::kSyntaxError: return "instruction syntax error (EE 65)";
      case ErrorCode::kValueError: return "instruction value error (EE 66)";
    }
    return fmt::format("unknown UIM242 error code 0x{:02X}", code);
  }
};

class CodecCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "uim242-codec"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<CodecErrc>(code)) {
      case CodecErrc::kValueOutOfRange: return "value outside the instruction's range";
      case CodecErrc::kValueRequired: return "instruction form needs a value";
      case CodecErrc::kValueNotAllowed: return "instruction takes no value";
      case CodecErrc::kHexNotAllowed: return "instruction has no hexadecimal form";
      case CodecErrc::kNotGlobal: return "instruction has no global (g...) form";
      case CodecErrc::kBadHeader: return "feedback frame does not start with AA, CC or EE";
      case CodecErrc::kBadTerminator: return "feedback frame does not end with FF or FE";
      case CodecErrc::kFrameTooShort: return "feedback frame too short";
      case CodecErrc::kFrameTooLong: return "feedback frame longer than 16 bytes";
      case CodecErrc::kNotSevenBit: return "data byte with bit 7 set";
      case CodecErrc::kWrongLength: return "data length does not fit the reply layout";
      case CodecErrc::kUnexpectedFrame: return "not the expected reply";
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
  return code == static_cast<std::uint8_t>(ErrorCode::kSyntaxError) ||
         code == static_cast<std::uint8_t>(ErrorCode::kValueError);
}

}  // namespace motion::uim242
