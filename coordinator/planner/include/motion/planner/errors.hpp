// Why a plan or its quantization was refused: an enum in the "planner" std::error_category, plus
// a PlanFailure naming the axis and the offending value/limit, and a small Result<T> (C++20 has no
// std::expected). Thread contract: everything here is immutable or pure, hence thread-safe.
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <system_error>
#include <type_traits>
#include <utility>
#include <variant>

namespace motion::planner {

enum class PlanErrc {
  kNoAxes = 1,              // an empty request
  kNonFiniteInput,          // NaN or infinity where a number is needed
  kNonPositiveScale,        // counts per user unit <= 0
  kNonPositiveLimit,        // max velocity / acceleration / deceleration <= 0
  kInvalidPositionRange,    // min_position > max_position
  kInvalidSpeedScale,       // global velocity/acceleration scale outside (0, 1]
  kTargetBelowMin,          // target < min_position (user units)
  kTargetAboveMax,          // target > max_position (user units)
  kCountsOutOfRange,        // |position x scale| beyond 2^53 counts (no longer exact)
  kQuantizerCountMismatch,  // not exactly one quantizer per axis, or a null one
  kQuantizationImpossible,  // no value the drive can represent lies within the axis limits
};

[[nodiscard]] const std::error_category& planner_category() noexcept;
[[nodiscard]] inline std::error_code make_error_code(PlanErrc e) noexcept {
  return {static_cast<int>(e), planner_category()};
}

// Index used when a failure concerns the whole request rather than one axis.
inline constexpr std::size_t kNoAxis = std::numeric_limits<std::size_t>::max();

struct PlanFailure {
  PlanErrc code{};
  std::size_t axis_index = kNoAxis;
  std::string axis_name;  // AxisRequest::name, for messages the operator can act on
  double value = 0.0;     // the offending input (its unit depends on `code`, see message())
  double limit = 0.0;     // the limit it violated, same unit

  [[nodiscard]] std::error_code error_code() const noexcept { return make_error_code(code); }
  // e.g. "axis 2 'z': target above max_position (target 120 > limit 100 user units)".
  [[nodiscard]] std::string message() const;
};

// Either a T or a PlanFailure. value() on a failure throws std::bad_variant_access.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::in_place_index<0>, std::move(value)) {}                // NOLINT
  Result(PlanFailure failure) : state_(std::in_place_index<1>, std::move(failure)) {}  // NOLINT

  [[nodiscard]] bool ok() const noexcept { return state_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }
  [[nodiscard]] const T& value() const& { return std::get<0>(state_); }
  [[nodiscard]] T& value() & { return std::get<0>(state_); }
  [[nodiscard]] T&& value() && { return std::get<0>(std::move(state_)); }
  [[nodiscard]] const PlanFailure& error() const& { return std::get<1>(state_); }

 private:
  std::variant<T, PlanFailure> state_;
};

}  // namespace motion::planner

template <>
struct std::is_error_code_enum<motion::planner::PlanErrc> : std::true_type {};
