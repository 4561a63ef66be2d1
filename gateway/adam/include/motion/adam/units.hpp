// Unit conversions and quantization for the ADAM drive (manual §8.29, §8.40–§8.44, §8.64,
// §8.65②): speeds in rpm (0x009A, integer), 0.01 rpm (0x00D8/0x00D6, INT32) or pulses/s, ramps as
// TIMES in ms from the start speed to the target speed (0x0098) and from the target speed to the
// stop speed (0x0099), positions in pulses of the subdivision (0x0024, pulses per revolution).
//
// Every quantizer returns the integer the drive accepts AND the value it realizes, or
// AdamErrc::kValueOutOfRange / non_finite / invalid_subdivision. Rounding: nearest, ties away
// from zero. Step rate = rpm × subdivision / 60 (not stated in the manual: assumed from §8.29,
// §8.44).
//
// Thread contract: pure functions, thread-safe.
#pragma once

#include <cstdint>
#include <optional>

#include "motion/adam/result.hpp"

namespace motion::adam {

template <typename T>
struct Quantized {
  T value{};              // what goes into the register
  double realized = 0.0;  // what the drive then does, in the caller's unit
  friend bool operator==(const Quantized&, const Quantized&) = default;
};

// Register grids and ranges.
inline constexpr std::uint32_t kMinSubdivision = 200;  // §8.29
inline constexpr std::uint32_t kMaxSubdivision = 1'000'000;
inline constexpr std::uint32_t kDefaultSubdivision = 4000;
inline constexpr double kWorkingSpeedRpmPerStep = 1.0;  // 0x009A
inline constexpr std::uint16_t kMaxWorkingSpeedRpm = 1000;
inline constexpr double kTargetSpeedRpmPerStep = 0.01;  // 0x00D8
inline constexpr std::int32_t kMaxTargetSpeedCentiRpm = 999'999;
inline constexpr std::uint16_t kMaxStartSpeedRpm = 300;  // 0x0096
inline constexpr std::uint16_t kMaxStopSpeedRpm = 1000;  // 0x0097
inline constexpr double kRampSecondsPerStep = 0.001;     // 0x0098 / 0x0099, ms
inline constexpr std::uint16_t kMaxRampMs = 0xFFFF;
inline constexpr std::uint16_t kMaxJogSpeedRpm = 511;  // 0x00CA / 0x00C9 bits 14…6

[[nodiscard]] Result<std::uint32_t> check_subdivision(std::uint32_t pulses_per_rev);

// Full steps per revolution of the manual's NEMA8–23 hybrid steppers (1.8°, §8.8).
inline constexpr std::int64_t kFullStepsPerRevolution = 200;
// The 0x0024 subdivision (pulses/rev) a drive's set-up asks for: `pulses_per_revolution` when
// given, else kFullStepsPerRevolution × `subdivision` (micro-steps per full step); nullopt when
// neither is given (the drive keeps what it stores: kDefaultSubdivision from the factory). Not
// range-checked (check_subdivision does that). The one rule for the gateway's start-up write and
// the coordinator's velocity grid.
[[nodiscard]] constexpr std::optional<std::int64_t> setup_pulses_per_revolution(
    std::optional<std::int64_t> pulses_per_revolution, std::optional<std::int64_t> subdivision) noexcept {
  if (pulses_per_revolution) return *pulses_per_revolution;
  if (subdivision) return kFullStepsPerRevolution * *subdivision;
  return std::nullopt;
}

// rpm ↔ pulses/s at a subdivision (no range checks; subdivision must be > 0).
[[nodiscard]] constexpr double rpm_to_pps(double rpm, std::uint32_t subdivision) noexcept {
  return rpm * subdivision / 60.0;
}
[[nodiscard]] constexpr double pps_to_rpm(double pps, std::uint32_t subdivision) noexcept {
  return pps * 60.0 / subdivision;
}

// 0x009A working speed, whole rpm 0…1000. realized in rpm.
[[nodiscard]] Result<Quantized<std::uint16_t>> working_speed(double rpm);
// 0x00D8 target speed, 0.01 rpm, −999999…999999. realized in rpm.
[[nodiscard]] Result<Quantized<std::int32_t>> target_speed(double rpm);
// 0x00D8 from pulses/s at `subdivision`. realized in pulses/s.
[[nodiscard]] Result<Quantized<std::int32_t>> target_speed_from_pps(double pps, std::uint32_t subdivision);
// 0x0096 start speed (0…300 rpm) and 0x0097 stop speed (0…1000 rpm). realized in rpm.
[[nodiscard]] Result<Quantized<std::uint16_t>> start_speed(double rpm);
[[nodiscard]] Result<Quantized<std::uint16_t>> stop_speed(double rpm);
// Jog / homing speed field, whole rpm 0…511.
[[nodiscard]] Result<Quantized<std::uint16_t>> jog_speed(double rpm);

// Ramp time (0x0098 from `from_rpm` = start speed to `to_rpm` = target; 0x0099 from target to
// stop speed) for a linear ramp of `rpm_per_s` (> 0). realized = the resulting rate in rpm/s
// (0 when the speeds are equal). Ramp time 0…65535 ms.
[[nodiscard]] Result<Quantized<std::uint16_t>> ramp_time_ms(double from_rpm, double to_rpm, double rpm_per_s);
// Rate in rpm/s of a ramp of `ms` milliseconds between two speeds (0 ms: instantaneous → 0).
[[nodiscard]] double ramp_rate_rpm_per_s(double from_rpm, double to_rpm, std::uint16_t ms) noexcept;

// Position in pulses (INT32) of `revolutions` at `subdivision`. realized in revolutions.
[[nodiscard]] Result<Quantized<std::int32_t>> pulses_from_revolutions(double revolutions, std::uint32_t subdivision);

}  // namespace motion::adam
