// Homing on the ADAMPOWER UC57 (homing mode, 6060h = 6): the methods it supports as data, the
// homing result as read from the statusword, and the homing parameters in drive units.
//
// Sources: UC57 manual §4.2.6 (methods 17, 18, 24, 29, 41, 42, their procedures; 6099h:01 search
// speed, 6099h:02 locate speed, 609Ah ramp, 607Ch offset; statusword bit 8 "homing attained"),
// §5.2 (6098h value list), §3.1 (IN1 positive limit, IN2 origin, IN3 negative limit by default),
// §7 MC_HOME (bit 10 + bit 12 = completed). Conflicts C-07, C-08, C-17 in uc57_units.hpp.
// The manual's method drawings were lost in conversion; the back-off distance is not documented.
//
// Thread contract: constants and pure functions only; thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "motion/cia402/uc57_units.hpp"

namespace motion::cia402::uc57 {

// 6098h values the UC57 accepts (manual §4.2.6, §5.2).
enum class HomingMethod : std::uint8_t {
  kNegativeLimit = 17,                // "negative limit mode"
  kPositiveLimit = 18,                // "positive limit mode"
  kHomeSwitchPositive = 24,           // "forward origin mode"
  kHomeSwitchNegative = 29,           // "reverse origin mode"
  kHomeSwitchNegativeImmediate = 41,  // origin in the negative direction, stop immediately
  kHomeSwitchPositiveImmediate = 42,  // origin in the positive direction, stop immediately
};

enum class Direction : std::int8_t { kNegative = -1, kPositive = 1 };

// The input whose edge defines home (60FDh bit 0 negative limit, bit 1 positive limit, bit 2 origin).
enum class HomeSignal : std::uint8_t { kNegativeLimit, kPositiveLimit, kOrigin };

// What the drive does when it meets the limit switch in the search direction before home.
enum class LimitReaction : std::uint8_t {
  kNotApplicable,  // the limit is the home signal
  kReverse,        // turn round and keep searching (24, 29)
  kStopFailed,     // stop; homing not completed (41, 42)
};

struct HomingMethodInfo {
  HomingMethod method;
  std::string_view manual_name;
  Direction search_direction;  // first (fast, 6099h:01) search
  HomeSignal home_signal;
  bool backs_off_and_locates_slowly;  // stop, back off, approach again at 6099h:02
  Direction locate_direction;         // direction of the slow approach (= search direction here)
  LimitReaction on_limit;
  bool cia402_standard_number;  // 17/18/24/29 belong to CiA 402 families; 41/42 are UC57-specific
};

[[nodiscard]] std::span<const HomingMethodInfo> homing_methods();
[[nodiscard]] const HomingMethodInfo* find_homing_method(std::uint8_t value);

// Homing result from the statusword (conflict C-08). kInProgress also covers "not started".
enum class HomingResult : std::uint8_t { kInProgress, kSucceeded, kStoppedWithoutHome };
// Succeeded: bit 10 (target reached) and (bit 8 or bit 12). Stopped without home: bit 10 with
// neither (halt, limit stop of 41/42, or an invalid method); never decided from bit 13.
[[nodiscard]] HomingResult homing_result(std::uint16_t statusword);

// Homing parameters in physical units (pulses, pulses/s, pulses/s^2) and the drive integers.
struct HomingRequest {
  HomingMethod method = HomingMethod::kHomeSwitchPositive;
  double search_speed = 0.0;  // pulses/s, > 0
  double locate_speed = 0.0;  // pulses/s, > 0
  double acceleration = 0.0;  // pulses/s^2
  double offset = 0.0;        // pulses (607Ch)
};
struct HomingSettings {
  std::uint8_t method = 0;  // 6098h
  Quantized search_speed;   // 6099h:01, RPM
  Quantized locate_speed;   // 6099h:02, RPM
  Quantized acceleration;   // 609Ah (ramp from standstill to the realized search speed, C-02)
  Quantized offset;         // 607Ch, pulses
};
[[nodiscard]] HomingSettings quantize_homing(const HomingRequest& request, std::uint32_t pulses_per_rev,
                                             RampUnit unit = RampUnit::kMilliseconds,
                                             Rounding rounding = Rounding::kNearest);

}  // namespace motion::cia402::uc57
