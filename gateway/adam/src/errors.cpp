#include <string>

#include "motion/adam/result.hpp"

namespace motion::adam {
namespace {

class AdamCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "adam"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<AdamErrc>(code)) {
      case AdamErrc::kValueOutOfRange: return "value outside the register's documented range";
      case AdamErrc::kNonFinite: return "non-finite value";
      case AdamErrc::kInvalidSubdivision: return "subdivision outside 200…1000000 pulses/rev";
      case AdamErrc::kInvalidUnitAddress: return "node address outside 1…64";
      case AdamErrc::kTooManyRegisters: return "more registers than one 200-byte frame carries";
      case AdamErrc::kEmptyTable: return "no table entries";
    }
    return "unknown adam error " + std::to_string(code);
  }
};

}  // namespace

const std::error_category& adam_category() noexcept {
  static const AdamCategory category;
  return category;
}

}  // namespace motion::adam
