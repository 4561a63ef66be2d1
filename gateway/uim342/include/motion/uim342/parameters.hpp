// Value ranges the drive accepts (manual §5.1-§5.28; error codes per §2.3, assumed: "value outside
// the documented range -> 0x33, undefined sub-index -> 0x34") and the unit conversions a driver,
// the coordinator and the simulator share: speeds in integer pulses/s (pps), AC/DC as pps^2 or as
// ramp time in ms (IC[4]), current in 0.1 A, counts per revolution = micro-steps x 200 (§3.5).
// Failed checks return DriveErrc codes (the error the drive itself would report).
// Thread contract: pure functions, thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <system_error>

#include "motion/uim342/errors.hpp"
#include "motion/uim342/instructions.hpp"

namespace motion::uim342 {

struct ValueRange {
  std::int64_t min = 0;
  std::int64_t max = 0;
  [[nodiscard]] constexpr bool contains(std::int64_t v) const noexcept { return v >= min && v <= max; }
  friend bool operator==(const ValueRange&, const ValueRange&) = default;
};

inline constexpr std::uint32_t kAccelerationRateMax = 65'000'000;  // pulse/s^2 (IC[4] = 0)
inline constexpr std::uint32_t kAccelerationTimeMaxMs = 60'000;    // ms (IC[4] = 1)
inline constexpr std::uint32_t kBacklashMax = 65'536;              // §3.4
inline constexpr std::uint32_t kFullStepsPerRevolution = 200;      // CPR = micro-steps x 200
inline constexpr std::int32_t kMs1SpeedMin = -0x800000;            // MS[1] speed: signed 24 bit
inline constexpr std::int32_t kMs1SpeedMax = 0x7FFFFF;

// Whether `index` is a defined sub-index of `function` (false for functions without sub-index).
// ER: 0, 6, 10..18; IL: 0..2, 16 and its alias 3; MS: 0, 1.
[[nodiscard]] bool is_defined_sub_index(FunctionCode function, std::uint8_t index) noexcept;

// The range of the value a set writes (AC/DC depend on IC[4]). nullopt when the function/index
// has no numeric set value or the index is undefined. MT[0] and QE[2] accept only some values of
// their range (see check_instruction).
[[nodiscard]] std::optional<ValueRange> value_range(FunctionCode function, std::uint8_t index = 0,
                                                    AccelerationUnit unit = AccelerationUnit::kPulsesPerS2) noexcept;

// What the drive would answer to this instruction's data, before any state check: {} when
// acceptable, DriveErrc::kSubIndexError for an undefined sub-index, DriveErrc::kDataError for a
// value outside its range or enumeration. Assumes the instruction encodes (body matches the form).
[[nodiscard]] std::error_code check_instruction(const Instruction& instruction,
                                                AccelerationUnit unit = AccelerationUnit::kPulsesPerS2);

// ---- Units -------------------------------------------------------------------------------------

[[nodiscard]] constexpr std::uint32_t counts_per_revolution(std::uint32_t microsteps) noexcept {
  return microsteps * kFullStepsPerRevolution;
}
// Nearest integer pps (SP/JV); data_error when not finite or outside s32.
[[nodiscard]] Result<std::int32_t> speed_to_pps(double pulses_per_s);
[[nodiscard]] Result<std::int32_t> rpm_to_pps(double rpm, std::uint32_t counts_per_rev);
[[nodiscard]] double pps_to_rpm(std::int32_t pps, std::uint32_t counts_per_rev) noexcept;

// AC/DC value for a wanted ramp rate (pulse/s^2), nearest integer within the IC[4] range.
// IC[4] = 1 (ms): ramp time T = (|speed| - cut_in) / rate; when |speed| <= cut_in
// there is no ramp and the shortest time, 1 ms, is returned. data_error outside the range.
[[nodiscard]] Result<std::uint32_t> acceleration_to_wire(double rate_pps2, AccelerationUnit unit,
                                                         double speed_pps = 0.0, double cut_in_pps = 0.0);
// Inverse: the rate (pulse/s^2) the drive ramps with; +infinity for a time ramp that has no
// speed difference to cover.
[[nodiscard]] double acceleration_from_wire(std::uint32_t value, AccelerationUnit unit, double speed_pps = 0.0,
                                            double cut_in_pps = 0.0) noexcept;

// MT[1] working current in 0.1 A steps (5..80 = 0.5..8.0 A).
[[nodiscard]] Result<std::uint16_t> current_to_wire(double amps);
[[nodiscard]] constexpr double current_from_wire(std::uint16_t tenths) noexcept { return tenths / 10.0; }

}  // namespace motion::uim342
