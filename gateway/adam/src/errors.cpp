#include <string>

#include "motion/adam/result.hpp"

namespace motion::adam {
namespace {

class AdamCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "adam"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<AdamErrc>(code)) {
      case AdamErrc::value_out_of_range: return "value outside the register's documented range";
      case AdamErrc::non_finite: return "non-finite value";
      case AdamErrc::invalid_subdivision: return "subdivision outside 200…1000000 pulses/rev";
      case AdamErrc::invalid_unit_address: return "node address outside 1…64";
      case AdamErrc::too_many_registers: return "more registers than one 200-byte frame carries";
      case AdamErrc::empty_table: return "no table entries";
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
