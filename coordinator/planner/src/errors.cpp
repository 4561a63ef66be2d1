#include "motion/planner/errors.hpp"

#include <fmt/format.h>

namespace motion::planner {
namespace {

class PlannerCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "planner"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<PlanErrc>(code)) {
      case PlanErrc::kNoAxes: return "no axes to plan";
      case PlanErrc::kNonFiniteInput: return "non-finite input";
      case PlanErrc::kNonPositiveScale: return "counts per user unit must be > 0";
      case PlanErrc::kNonPositiveLimit: return "velocity/acceleration/deceleration limits must be > 0";
      case PlanErrc::kInvalidPositionRange: return "min_position above max_position";
      case PlanErrc::kInvalidSpeedScale: return "velocity/acceleration scale outside (0, 1]";
      case PlanErrc::kTargetBelowMin: return "target below min_position";
      case PlanErrc::kTargetAboveMax: return "target above max_position";
      case PlanErrc::kCountsOutOfRange: return "position beyond 2^53 drive counts";
      case PlanErrc::kQuantizerCountMismatch: return "need exactly one non-null quantizer per axis";
      case PlanErrc::kQuantizationImpossible: return "no drive-representable value within the axis limits";
    }
    return "unknown planner error";
  }
};

// What value/limit mean for each code, for PlanFailure::message().
std::string detail(const PlanFailure& f) {
  switch (f.code) {
    case PlanErrc::kTargetBelowMin: return fmt::format("target {} < min_position {} user units", f.value, f.limit);
    case PlanErrc::kTargetAboveMax: return fmt::format("target {} > max_position {} user units", f.value, f.limit);
    case PlanErrc::kInvalidPositionRange:
      return fmt::format("min_position {} > max_position {} user units", f.value, f.limit);
    case PlanErrc::kInvalidSpeedScale: return fmt::format("scale {}", f.value);
    case PlanErrc::kCountsOutOfRange: return fmt::format("{} counts", f.value);
    case PlanErrc::kNonFiniteInput:
    case PlanErrc::kNonPositiveScale:
    case PlanErrc::kNonPositiveLimit: return fmt::format("value {}", f.value);
    case PlanErrc::kQuantizationImpossible:
      return fmt::format("desired {} counts/s, velocity limit {} counts/s", f.value, f.limit);
    case PlanErrc::kNoAxes:
    case PlanErrc::kQuantizerCountMismatch: break;
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
