// ADAMPOWER UC57 units: microstepping (2006h), pulses, RPM, the ramp settings of 6083h/6084h/609Ah,
// current (2005h), and quantization of physical motion values to the integers the drive accepts.
// Also THE place where the manual's contradictions are resolved (section "Conflicts" below); the
// object dictionary (uc57_od.hpp), modes.hpp and uc57_homing.hpp follow the choices made here.
//
// Thread contract: constants and pure functions only; thread-safe.
//
// ---------------------------------------------------------------------------------------------
// Conflicts in the UC57 manual and the choice made for each
// ---------------------------------------------------------------------------------------------
// General rule: for object attributes (type, access, range, default) the OD chapter (§5, §5.1,
// §5.2) wins over the mode sections (§4.2.x); for behaviour, the majority of the manual's text,
// tables and worked examples wins over a single contradicting place.
//
// C-01 6060h/6061h mode values: §4.2.3 table 1 = PP, 2 = PV, 3 = HM; §4.2.2, §4.2.4-§4.2.6, §5.2,
//      §7 and every example frame 1 = PP, 3 = PV, 6 = HM.
//      -> 1/3/6 (also the CiA 402 values). 6060h accepts only 0, 1, 3, 6 (ModeOfOperation).
// C-02 6083h/6084h/609Ah: (a) range 1-1200 (§4.2.4) vs 1-2000 (§4.2.5, §4.2.6, §5.2) -> 1-2000,
//      default 50 (§5.2). (b) unit "rps/s" (the tables' unit column) vs "acceleration time" (every
//      name, §1.2 feature list, §4.2.4 "theoretical total pulse count ... based on ... acceleration
//      time", and all three worked examples: value 100 = "100 ms").
//      -> default RampUnit::kMilliseconds: the ramp takes `n` ms from the start speed 200Eh to the
//      commanded speed (the trapezoid begins at the start speed, §4.2.4) [inference for the start
//      point]. RampUnit::kRevolutionsPerSecondSquared (n rev/s^2) stays selectable, to be settled
//      on the bench. Homing ramps (609Ah) are referenced to standstill -> search speed 6099h:01,
//      since the manual ties 200Eh to PP and PV only [inference].
// C-03 6081h range/default: 5-3000 RPM / 120 (§4.2.4) vs 5-1000 RPM / 60 (§5.2) -> 5-1000 / 60.
// C-04 60FFh default: 0 (§4.2.5) vs 120 (§5.2) -> 120 (§5.2). Masters always write 60FFh before
//      enabling PV (§7 MC_MOVVEL writes 0 first), so the default never moves a motor of ours.
// C-05 607Ch range: +-0x7FFFFFFF (§4.2.6) vs +-1000000 pulses (§5.2) -> +-1000000.
// C-06 6099h subindexes: the §4.2.6 example writes :00 (fast) and :01 (slow); the tables give
//      :01 fast ("search"), :02 slow ("locate"), :00 = RO entry count -> the tables. A strict OD
//      refuses the example's write to 6099h:00 (kReadOnly).
// C-07 6098h: default 0 is no method; the §4.2.6 example writes 100 (0x64) for the "forward
//      limit + origin" method, which is 24 (0x18). -> the OD accepts any U8 (the drive reports a
//      bad method as a homing error when started); valid methods are the data in
//      uc57_homing.hpp. 100 is treated as a typo for 24.
// C-08 Homing result: "homing done" = statusword bit 8 (§4.2.2, §4.2.6) vs bit 12, and failure =
//      bit 10 + bit 13 (§7 MC_HOME); bit 13 is also "motor enabled" (§4.2.2).
//      -> success = bit 10 and (bit 8 or bit 12); bit 13 = motor enabled, never read as failure.
// C-09 1A01h:00 printed 0 although two entries (6064h, 606Ch) are printed -> 2 (TPDO2 active).
//      A master reads 1A01h:00 and does not rely on the default.
// C-10 14xxh/18xxh:01 (PDO COB-ID) and 16xxh/1Axxh:00 (entry count) printed RO, which blocks the
//      CiA 301 remap -> RO as printed; WritePolicy::pdo_configuration_writable gives CiA behaviour.
// C-11 1014h default printed "0x80" (would collide with SYNC) -> 0x80 + node-ID (CiA 301).
// C-12 2011h "Fault reset": only "0: invalid" documented -> range 0..1 (1 = reset, inference).
// C-13 1009h/100Ah typed U16 with value "1.0" (CiA: VISIBLE_STRING) -> U16 0x0100 (major.minor).
// C-14 Microstepping "1-256 subdivisions" (§1.1) vs the 16-entry 2006h table -> the 2006h table.
// C-15 Node-ID 1-255 (§1.1) vs 1-127 (§4.1.2, 2008h) -> 1-127.
// C-16 PV speed object: "608100h" (§4.2.5 text) vs 60FFh (§4.2.5 table, example, §7) -> 60FFh in
//      PV; 6081h only in PP.
// C-17 Homing method 29: the slow approach is printed "in the forward direction" and has no
//      back-off; method 42 stops at the "negative" limit -> 29 mirrors 24 in the negative
//      direction (back-off, slow negative approach); 42 stops at the positive limit.
// C-18 1003h: 8 subindexes (sub00 = 8, RO) vs "supports 5 error storage units" -> 8 subindexes as
//      printed; how many are filled is the simulator's choice.
// C-19 Run current: 2005h 1-25 x 0.1 A RMS vs "0-8 A" and 5.6 A peak (§1.1, §2.1) -> 2005h.
// ---------------------------------------------------------------------------------------------
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "motion/cia402/uc57_od.hpp"

namespace motion::cia402::uc57 {

// --- Microstepping, 2006h (manual §5.1): code -> pulses per motor revolution ---
inline constexpr std::array<std::uint32_t, 16> kPulsesPerRevolutionByCode = {
    200, 400, 800, 1600, 3200, 6400, 12800, 25600, 1000, 2000, 4000, 5000, 8000, 10000, 20000, 40000};
inline constexpr std::uint16_t kDefaultSubdivisionCode = 13;
inline constexpr std::uint32_t kDefaultPulsesPerRevolution = 10000;

[[nodiscard]] std::optional<std::uint32_t> pulses_per_revolution(std::uint16_t subdivision_code);
[[nodiscard]] std::optional<std::uint16_t> subdivision_code(std::uint32_t pulses_per_revolution);

// Full steps per motor revolution of the UC57's 1.8 degree motors (200 = 2006h code 0, "200 Pu/rev").
inline constexpr std::uint32_t kFullStepsPerRevolution = 200;

// The 2006h code a node's set-up asks for: `pulses_per_revolution` when given, else
// kFullStepsPerRevolution x `micro_steps`. The one rule for the gateway's start-up write of 2006h
// and the coordinator's velocity grid.
struct SetupSubdivision {
  enum class Status : std::uint8_t {
    kNotSet,      // neither given: the drive keeps the code it stores
    kCode,        // `code` is the 2006h value for `pulses`
    kOutOfRange,  // `pulses` is not a positive 32-bit count
    kNotInTable,  // `pulses` is none of the 16 resolutions of 2006h (C-14)
  };
  Status status = Status::kNotSet;
  std::int64_t pulses = 0;        // pulses/rev asked for (0 when kNotSet)
  bool from_micro_steps = false;  // computed from `micro_steps` (no `pulses_per_revolution`)
  std::uint16_t code = 0;         // kCode only
};
[[nodiscard]] SetupSubdivision setup_subdivision(std::optional<std::int64_t> pulses_per_revolution,
                                                 std::optional<std::int64_t> micro_steps);

// --- Position and speed. Positions (607Ah, 6064h, 607Ch) are pulses = microsteps. Speeds (6081h,
// 60FFh, 606Ch, 6099h, 200Eh) are RPM of the motor shaft: pulses/s = RPM / 60 * pulses/rev. ---
[[nodiscard]] double rpm_to_pulses_per_second(double rpm, std::uint32_t pulses_per_rev);
[[nodiscard]] double pulses_per_second_to_rpm(double pulses_per_s, std::uint32_t pulses_per_rev);
[[nodiscard]] double pulses_to_revolutions(double pulses, std::uint32_t pulses_per_rev);

// --- Current, 2005h: 0.1 A RMS ---
[[nodiscard]] double run_current_amperes_rms(std::uint16_t setting);

// --- Ramps, 6083h / 6084h / 609Ah (conflict C-02) ---
enum class RampUnit : std::uint8_t {
  kMilliseconds,                 // n ms to ramp across the speed change (default, C-02)
  kRevolutionsPerSecondSquared,  // n rev/s^2 (the tables' "rps/s")
};
// The acceleration (pulses/s^2) a ramp setting realizes. `speed_change` (pulses/s, >= 0) is the
// speed difference the ramp covers (kMilliseconds only): |commanded| - start speed in PP/PV,
// search speed for homing. Returns +infinity for kMilliseconds with no speed change (a step).
[[nodiscard]] double ramp_acceleration(RampUnit unit, std::int64_t setting, double speed_change,
                                       std::uint32_t pulses_per_rev);

// --- Quantization: physical value -> integer the drive accepts, and what it really realizes ---
enum class Rounding : std::uint8_t {
  kNearest,   // nearest representable value
  kNotAbove,  // never faster (speed magnitude, acceleration) than asked; may be clamped up to min
};
struct Quantized {
  std::int64_t native = 0;  // the integer to write to the object
  double realized = 0.0;    // what the drive does with it, in the requested physical unit
  bool clamped = false;     // the request was outside the object's range
};
// Speed in pulses/s (signed where the object is) -> RPM integer for `object` (6081h, 60FFh,
// 6099h:01/02, 200Eh); realized in pulses/s.
[[nodiscard]] Quantized quantize_speed(const OdEntry& object, double pulses_per_s, std::uint32_t pulses_per_rev,
                                       Rounding rounding = Rounding::kNearest);
// Acceleration magnitude in pulses/s^2 -> ramp setting for `object` (6083h, 6084h, 609Ah);
// `speed_change` as in ramp_acceleration (use realized speeds). Realized in pulses/s^2.
[[nodiscard]] Quantized quantize_ramp(const OdEntry& object, double pulses_per_s2, double speed_change,
                                      std::uint32_t pulses_per_rev, RampUnit unit = RampUnit::kMilliseconds,
                                      Rounding rounding = Rounding::kNearest);
// Position in pulses -> integer for `object` (607Ah, 607Ch), nearest, clamped to its range.
[[nodiscard]] Quantized quantize_position(const OdEntry& object, double pulses);

// Profile-position "theoretical total pulse count" (§4.2.4): the shortest move that still reaches
// the maximum speed, i.e. ramp-up plus ramp-down distance from/to the start speed, in pulses.
// Speeds in pulses/s, accelerations in pulses/s^2 (> 0). Shorter moves never reach `max_speed`.
[[nodiscard]] double full_speed_move_pulses(double start_speed, double max_speed, double acceleration,
                                            double deceleration);

}  // namespace motion::cia402::uc57
