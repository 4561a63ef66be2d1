// Result<T> (a T or a std::error_code; C++20 has no std::expected) and the "adam" error category
// for the drive-level conversions and encoders of this library (range checks, bad arguments).
// Modbus exception codes live in rtu.hpp ("modbus" category), frame errors there too
// ("modbus_rtu" category). Thread contract: pure, stateless, thread-safe.
#pragma once

#include <system_error>
#include <type_traits>
#include <utility>
#include <variant>

#include "motion/core/result.hpp"

namespace motion::adam {

enum class AdamErrc {
  kValueOutOfRange = 1,  // a value outside the register's documented range (manual §7/§8)
  kNonFinite,            // NaN or infinity given to a unit conversion
  kInvalidSubdivision,   // pulses/rev outside 200…1000000 (§8.29)
  kInvalidUnitAddress,   // node address outside 1…64 (§5), or 0 where a reply is needed
  kTooManyRegisters,     // more registers than one frame of ≤ 200 bytes can carry (§8.54)
  kEmptyTable,           // no table entries to load
};

[[nodiscard]] const std::error_category& adam_category() noexcept;
[[nodiscard]] inline std::error_code make_error_code(AdamErrc e) noexcept {
  return {static_cast<int>(e), adam_category()};
}

// The shared Result<T> (motion/core/result.hpp).
using motion::Result;

}  // namespace motion::adam

template <>
struct std::is_error_code_enum<motion::adam::AdamErrc> : std::true_type {};
