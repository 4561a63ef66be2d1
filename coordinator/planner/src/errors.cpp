#include "motion/planner/errors.hpp"

#include <fmt/format.h>

namespace motion::planner {
namespace {

class PlannerCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "planner"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<PlanErrc>(code)) {
      case PlanErrc::no_axes: return "no axes to plan";
      case PlanErrc::non_finite_input: return "non-finite input";
      case PlanErrc::non_positive_scale: return "counts per user unit must be > 0";
      case PlanErrc::non_positive_limit: return "velocity/acceleration/deceleration limits must be > 0";
      case PlanErrc::invalid_position_range: return "min_position above max_position";
      case PlanErrc::invalid_speed_scale: return "velocity/acceleration scale outside (0, 1]";
      case PlanErrc::target_below_min: return "target below min_position";
      case PlanErrc::target_above_max: return "target above max_position";
      case PlanErrc::counts_out_of_range: return "position beyond 2^53 drive counts";
      case PlanErrc::quantizer_count_mismatch: return "need exactly one non-null quantizer per axis";
      case PlanErrc::quantization_impossible: return "no drive-representable value within the axis limits";
    }
    return "unknown planner error";
  }
};

// What value/limit mean for each code, for PlanFailure::message().
std::string detail(const PlanFailure& f) {
  switch (f.code) {
    case PlanErrc::target_below_min: return fmt::format("target {} < min_position {} user units", f.value, f.limit);
    case PlanErrc::target_above_max: return fmt::format("target {} > max_position {} user units", f.value, f.limit);
    case PlanErrc::invalid_position_range:
      return fmt::format("min_position {} > max_position {} user units", f.value, f.limit);
    case PlanErrc::invalid_speed_scale: return fmt::format("scale {}", f.value);
    case PlanErrc::counts_out_of_range: return fmt::format("{} counts", f.value);
    case PlanErrc::non_finite_input:
    case PlanErrc::non_positive_scale:
    case PlanErrc::non_positive_limit: return fmt::format("value {}", f.value);
    case PlanErrc::quantization_impossible:
      return fmt::format("desired {} counts/s, velocity limit {} counts/s", f.value, f.limit);
    case PlanErrc::no_axes:
    case PlanErrc::quantizer_count_mismatch: break;
  }
  return {};
}

}  // namespace

const std::error_category& planner_category() noexcept {
  static const PlannerCategory category;
  return category;
}

std::string PlanFailure::message() const {
  std::string out;
  if (axis_index != kNoAxis) out = fmt::format("axis {} '{}': ", axis_index, axis_name);
  out += planner_category().message(static_cast<int>(code));
  if (const std::string more = detail(*this); !more.empty()) out += fmt::format(" ({})", more);
  return out;
}

}  // namespace motion::planner
