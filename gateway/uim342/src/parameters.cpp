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
    IndexedRange{FC::PP, 5, 5, {0, 4}},  // bit rate code
    IndexedRange{FC::PP, 7, 8, {kMinNodeId, kMaxNodeId}},
    IndexedRange{FC::IC, 0, 7, {0, 1}},
    IndexedRange{FC::IE, 0, 2, {0, 1}},
    IndexedRange{FC::IE, 8, 8, {0, 1}},
    IndexedRange{FC::QE, 0, 0, {1, kU16Max}},   // lines per revolution
    IndexedRange{FC::QE, 1, 1, {10, kU16Max}},  // stall tolerance
    IndexedRange{FC::QE, 2, 2, {17, 20}},       // 17 or 20 bits
    IndexedRange{FC::QE, 3, 3, {0, 1}},         // battery status
    IndexedRange{FC::QE, 4, 4, {200, 25600}},   // counts per revolution
    IndexedRange{FC::MT, 0, 0, {1, 64}},        // micro-steps, powers of two
    IndexedRange{FC::MT, 1, 1, {5, 80}},        // 0.1 A
    IndexedRange{FC::MT, 2, 2, {0, 100}},       // %
    IndexedRange{FC::MT, 3, 3, {0, 60000}},     // ms
    IndexedRange{FC::TG, 0, 2, {0, kTriggerOneTime}},
    IndexedRange{FC::IL, 0, 2, {0, kU16Max}},  // two action bytes, checked separately
    IndexedRange{FC::IL, kInputLogicStallBehaviourAlias, kInputLogicStallBehaviourAlias, {0, 1}},
    IndexedRange{FC::IL, kInputLogicStallBehaviour, kInputLogicStallBehaviour, {0, 1}},
    IndexedRange{FC::ER, kErrorSlotLatest, kErrorSlotLatest, {0, 0}},  // only "=0" (clear)
    IndexedRange{FC::ER, kErrorSlotPowerOn, kErrorSlotPowerOn, {0, 0}},
    IndexedRange{FC::ER, kErrorSlotHistoryFirst, kErrorSlotHistoryLast, {0, 0}},
    IndexedRange{FC::MS, 0, 0, {0, 0}},  // MS[0]=0 clears the flags
    IndexedRange{FC::MS, 1, 1, {1, 0}},  // readable, never writable (empty range)
    IndexedRange{FC::DV, 0, 4, {1, 0}},
    IndexedRange{FC::SY, 1, 2, {0, 0}},
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
  return static_cast<std::uint8_t>(a.action) <= static_cast<std::uint8_t>(InputAction::absolute);
}

// Values the range admits but the enumeration does not.
bool excluded(FunctionCode function, std::uint8_t index, std::int64_t value) {
  const bool power_of_two = value > 0 && (value & (value - 1)) == 0;
  if (function == FC::MT && index == static_cast<std::uint8_t>(MotorDriver::microstepping)) return !power_of_two;
  if (function == FC::QE && index == static_cast<std::uint8_t>(QuadratureEncoder::absolute_resolution_bits)) {
    return value != 17 && value != 20;
  }
  if (function == FC::MF) return value == static_cast<std::uint8_t>(ParameterGroup::reserved);
  return false;
}

Result<std::uint32_t> rounded_in(double value, ValueRange range) {
  if (!std::isfinite(value)) return DriveErrc::data_error;
  const double r = std::round(value);
  if (r < static_cast<double>(range.min) || r > static_cast<double>(range.max)) return DriveErrc::data_error;
  return static_cast<std::uint32_t>(r);
}

}  // namespace

bool is_defined_sub_index(FunctionCode function, std::uint8_t index) noexcept {
  return find_indexed(function, index) != nullptr;
}

std::optional<ValueRange> value_range(FunctionCode function, std::uint8_t index, AccelerationUnit unit) noexcept {
  switch (function) {
    case FC::MO: return ValueRange{0, 1};
    case FC::MF: return ValueRange{0, static_cast<std::uint8_t>(ParameterGroup::in3_falling)};
    case FC::AC:
    case FC::DC:
      return unit == AccelerationUnit::pulses_per_s2 ? ValueRange{1, kAccelerationRateMax}
                                                     : ValueRange{1, kAccelerationTimeMaxMs};
    case FC::SS:
    case FC::SD: return ValueRange{0, kU32Max};
    case FC::BL: return ValueRange{0, kBacklashMax};
    case FC::JV:
    case FC::SP:
    case FC::PR:
    case FC::PA: return ValueRange{kS32Min, kS32Max};
    default: break;
  }
  const auto* row = find_indexed(function, index);
  if (!row || row->range.min > row->range.max) return std::nullopt;
  return row->range;
}

std::error_code check_instruction(const Instruction& instruction, AccelerationUnit unit) {
  if (!find_forms(instruction.function)) return DriveErrc::syntax_error;
  const auto index = instruction.sub_index();
  if (index && has_sub_index(instruction.function) && !is_defined_sub_index(instruction.function, *index)) {
    return DriveErrc::sub_index_error;
  }
  if (instruction.operation == Operation::get) return {};

  if (const auto* actions = std::get_if<InputActions>(&instruction.body)) {
    return is_known_action(actions->falling) && is_known_action(actions->rising)
               ? std::error_code{}
               : make_error_code(DriveErrc::data_error);
  }
  const auto value = set_value(instruction.body);
  if (!value) return {};  // BG, ST, OG, SY, DI: nothing numeric to check
  const std::uint8_t i = index.value_or(0);
  const auto range = value_range(instruction.function, i, unit);
  if (!range || !range->contains(*value) || excluded(instruction.function, i, *value)) return DriveErrc::data_error;
  return {};
}

Result<std::int32_t> speed_to_pps(double pulses_per_s) {
  if (!std::isfinite(pulses_per_s)) return DriveErrc::data_error;
  const double r = std::round(pulses_per_s);
  if (r < static_cast<double>(kS32Min) || r > static_cast<double>(kS32Max)) return DriveErrc::data_error;
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
  const auto range = *value_range(FC::AC, 0, unit);
  if (unit == AccelerationUnit::pulses_per_s2) return rounded_in(rate_pps2, range);
  if (!std::isfinite(rate_pps2) || rate_pps2 <= 0.0 || !std::isfinite(speed_pps) || !std::isfinite(cut_in_pps)) {
    return DriveErrc::data_error;
  }
  const double delta = std::abs(speed_pps) - cut_in_pps;
  if (delta <= 0.0) return static_cast<std::uint32_t>(range.min);
  return rounded_in(delta / rate_pps2 * 1000.0, range);
}

double acceleration_from_wire(std::uint32_t value, AccelerationUnit unit, double speed_pps,
                              double cut_in_pps) noexcept {
  if (unit == AccelerationUnit::pulses_per_s2) return value;
  const double delta = std::abs(speed_pps) - cut_in_pps;
  if (delta <= 0.0 || value == 0) return std::numeric_limits<double>::infinity();
  return delta / (value / 1000.0);
}

Result<std::uint16_t> current_to_wire(double amps) {
  const auto tenths =
      rounded_in(amps * 10.0, *value_range(FC::MT, static_cast<std::uint8_t>(MotorDriver::working_current)));
  if (!tenths) return tenths.error();
  return static_cast<std::uint16_t>(*tenths);
}

}  // namespace motion::uim342
