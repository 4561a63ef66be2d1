#include "motion/uim342/parameters.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace motion::uim342 {
namespace {

using FC = FunctionCode;
constexpr std::int64_t kU16Max = std::numeric_limits<std::uint16_t>::max();
constexpr std::int64_t kU32Max = std::numeric_limits<std::uint32_t>::max();
constexpr std::int64_t kS32Min = std::numeric_limits<std::int32_t>::min();
constexpr std::int64_t kS32Max = std::numeric_limits<std::int32_t>::max();

// Sub-indices first..last of `function` take values in `range` (manual §5.1-§5.28).
struct IndexedRange {
  FunctionCode function;
  std::uint8_t first;
  std::uint8_t last;
  ValueRange range;
};
constexpr std::array kIndexedRanges{
    IndexedRange{FC::kPP, 5, 5, {0, 4}},  // bit rate code
    IndexedRange{FC::kPP, 7, 8, {kMinNodeId, kMaxNodeId}},
    IndexedRange{FC::kIC, 0, 7, {0, 1}},
    IndexedRange{FC::kIE, 0, 2, {0, 1}},
    IndexedRange{FC::kIE, 8, 8, {0, 1}},
    IndexedRange{FC::kQE, 0, 0, {1, kU16Max}},   // lines per revolution
    IndexedRange{FC::kQE, 1, 1, {10, kU16Max}},  // stall tolerance
    IndexedRange{FC::kQE, 2, 2, {17, 20}},       // 17 or 20 bits
    IndexedRange{FC::kQE, 3, 3, {0, 1}},         // battery status
    IndexedRange{FC::kQE, 4, 4, {200, 25600}},   // counts per revolution
    IndexedRange{FC::kMT, 0, 0, {1, 64}},        // micro-steps, powers of two
    IndexedRange{FC::kMT, 1, 1, {5, 80}},        // 0.1 A
    IndexedRange{FC::kMT, 2, 2, {0, 100}},       // %
    IndexedRange{FC::kMT, 3, 3, {0, 60000}},     // ms
    IndexedRange{FC::kTG, 0, 2, {0, kTriggerOneTime}},
    IndexedRange{FC::kIL, 0, 2, {0, kU16Max}},  // two action bytes, checked separately
    IndexedRange{FC::kIL, kInputLogicStallBehaviourAlias, kInputLogicStallBehaviourAlias, {0, 1}},
    IndexedRange{FC::kIL, kInputLogicStallBehaviour, kInputLogicStallBehaviour, {0, 1}},
    IndexedRange{FC::kER, kErrorSlotLatest, kErrorSlotLatest, {0, 0}},  // only "=0" (clear)
    IndexedRange{FC::kER, kErrorSlotPowerOn, kErrorSlotPowerOn, {0, 0}},
    IndexedRange{FC::kER, kErrorSlotHistoryFirst, kErrorSlotHistoryLast, {0, 0}},
    IndexedRange{FC::kMS, 0, 0, {0, 0}},  // MS[0]=0 clears the flags
    IndexedRange{FC::kMS, 1, 1, {1, 0}},  // readable, never writable (empty range)
    IndexedRange{FC::kDV, 0, 4, {1, 0}},
    IndexedRange{FC::kSY, 1, 2, {0, 0}},
};

const IndexedRange* find_indexed(FunctionCode function, std::uint8_t index) {
  const auto* it = std::find_if(kIndexedRanges.begin(), kIndexedRanges.end(), [&](const IndexedRange& r) {
    return r.function == function && index >= r.first && index <= r.last;
  });
  return it == kIndexedRanges.end() ? nullptr : &*it;
}

bool has_sub_index(FunctionCode function) {
  return std::any_of(kIndexedRanges.begin(), kIndexedRanges.end(),
                     [function](const IndexedRange& r) { return r.function == function; });
}

// The numeric value a set body writes (nullopt for bodies checked otherwise).
std::optional<std::int64_t> set_value(const Body& body) {
  if (const auto* b = std::get_if<Byte>(&body)) return b->value;
  if (const auto* b = std::get_if<IndexedByte>(&body)) return b->value;
  if (const auto* b = std::get_if<IndexedWord>(&body)) return b->value;
  if (const auto* b = std::get_if<Unsigned>(&body)) return b->value;
  if (const auto* b = std::get_if<Signed>(&body)) return b->value;
  return std::nullopt;
}

bool is_known_action(EdgeAction a) {
  return static_cast<std::uint8_t>(a.action) <= static_cast<std::uint8_t>(InputAction::kAbsolute);
}

// Values the range admits but the enumeration does not.
bool excluded(FunctionCode function, std::uint8_t index, std::int64_t value) {
  const bool power_of_two = value > 0 && (value & (value - 1)) == 0;
  if (function == FC::kMT && index == static_cast<std::uint8_t>(MotorDriver::kMicrostepping)) return !power_of_two;
  if (function == FC::kQE && index == static_cast<std::uint8_t>(QuadratureEncoder::kAbsoluteResolutionBits)) {
    return value != 17 && value != 20;
  }
  if (function == FC::kMF) return value == static_cast<std::uint8_t>(ParameterGroup::kReserved);
  return false;
}

Result<std::uint32_t> rounded_in(double value, ValueRange range) {
  if (!std::isfinite(value)) return DriveErrc::kDataError;
  const double r = std::round(value);
  if (r < static_cast<double>(range.min) || r > static_cast<double>(range.max)) return DriveErrc::kDataError;
  return static_cast<std::uint32_t>(r);
}

}  // namespace

bool is_defined_sub_index(FunctionCode function, std::uint8_t index) noexcept {
  return find_indexed(function, index) != nullptr;
}

std::optional<ValueRange> value_range(FunctionCode function, std::uint8_t index, AccelerationUnit unit) noexcept {
  switch (function) {
    case FC::kMO: return ValueRange{0, 1};
    case FC::kMF: return ValueRange{0, static_cast<std::uint8_t>(ParameterGroup::kIn3Falling)};
    case FC::kAC:
    case FC::kDC:
      return unit == AccelerationUnit::kPulsesPerS2 ? ValueRange{1, kAccelerationRateMax}
                                                    : ValueRange{1, kAccelerationTimeMaxMs};
    case FC::kSS:
    case FC::kSD: return ValueRange{0, kU32Max};
    case FC::kBL: return ValueRange{0, kBacklashMax};
    case FC::kJV:
    case FC::kSP:
    case FC::kPR:
    case FC::kPA: return ValueRange{kS32Min, kS32Max};
    default: break;
  }
  const auto* row = find_indexed(function, index);
  if (!row || row->range.min > row->range.max) return std::nullopt;
  return row->range;
}

std::error_code check_instruction(const Instruction& instruction, AccelerationUnit unit) {
  if (!find_forms(instruction.function)) return DriveErrc::kSyntaxError;
  const auto index = instruction.sub_index();
  if (index && has_sub_index(instruction.function) && !is_defined_sub_index(instruction.function, *index)) {
    return DriveErrc::kSubIndexError;
  }
  if (instruction.operation == Operation::kGet) return {};

  if (const auto* actions = std::get_if<InputActions>(&instruction.body)) {
    return is_known_action(actions->falling) && is_known_action(actions->rising)
               ? std::error_code{}
               : make_error_code(DriveErrc::kDataError);
  }
  const auto value = set_value(instruction.body);
  if (!value) return {};  // BG, ST, OG, SY, DI: nothing numeric to check
  const std::uint8_t i = index.value_or(0);
  const auto range = value_range(instruction.function, i, unit);
  if (!range || !range->contains(*value) || excluded(instruction.function, i, *value)) return DriveErrc::kDataError;
  return {};
}

Result<std::int32_t> speed_to_pps(double pulses_per_s) {
  if (!std::isfinite(pulses_per_s)) return DriveErrc::kDataError;
  const double r = std::round(pulses_per_s);
  if (r < static_cast<double>(kS32Min) || r > static_cast<double>(kS32Max)) return DriveErrc::kDataError;
  return static_cast<std::int32_t>(r);
}

Result<std::int32_t> rpm_to_pps(double rpm, std::uint32_t counts_per_rev) {
  return speed_to_pps(rpm * static_cast<double>(counts_per_rev) / 60.0);
}

double pps_to_rpm(std::int32_t pps, std::uint32_t counts_per_rev) noexcept {
  return counts_per_rev == 0 ? 0.0 : static_cast<double>(pps) * 60.0 / static_cast<double>(counts_per_rev);
}

Result<std::uint32_t> acceleration_to_wire(double rate_pps2, AccelerationUnit unit, double speed_pps,
                                           double cut_in_pps) {
  const auto range = *value_range(FC::kAC, 0, unit);
  if (unit == AccelerationUnit::kPulsesPerS2) return rounded_in(rate_pps2, range);
  if (!std::isfinite(rate_pps2) || rate_pps2 <= 0.0 || !std::isfinite(speed_pps) || !std::isfinite(cut_in_pps)) {
    return DriveErrc::kDataError;
  }
  const double delta = std::abs(speed_pps) - cut_in_pps;
  if (delta <= 0.0) return static_cast<std::uint32_t>(range.min);
  return rounded_in(delta / rate_pps2 * 1000.0, range);
}

double acceleration_from_wire(std::uint32_t value, AccelerationUnit unit, double speed_pps,
                              double cut_in_pps) noexcept {
  if (unit == AccelerationUnit::kPulsesPerS2) return value;
  const double delta = std::abs(speed_pps) - cut_in_pps;
  if (delta <= 0.0 || value == 0) return std::numeric_limits<double>::infinity();
  return delta / (value / 1000.0);
}

Result<std::uint16_t> current_to_wire(double amps) {
  const auto tenths =
      rounded_in(amps * 10.0, *value_range(FC::kMT, static_cast<std::uint8_t>(MotorDriver::kWorkingCurrent)));
  if (!tenths) return tenths.error();
  return static_cast<std::uint16_t>(*tenths);
}

}  // namespace motion::uim342
