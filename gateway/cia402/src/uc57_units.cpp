#include "motion/cia402/uc57_units.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace motion::cia402::uc57 {
namespace {

// Tolerance for "exactly representable" requests, so that e.g. 100.000000001 ms does not round
// away from 100 under Rounding::kNotAbove.
constexpr double kEpsilon = 1e-9;

std::int64_t round_magnitude_down(double value) {
  return static_cast<std::int64_t>(std::trunc(value + std::copysign(kEpsilon, value)));
}
std::int64_t round_up(double value) { return static_cast<std::int64_t>(std::ceil(value - kEpsilon)); }
std::int64_t round_nearest(double value) { return static_cast<std::int64_t>(std::llround(value)); }

// Clamps `native` into the object's range; sets `clamped` when it had to.
Quantized clamp_to(const OdEntry& object, std::int64_t native) {
  Quantized result;
  result.native = std::clamp(native, object.min, object.max);
  result.clamped = result.native != native;
  return result;
}

// A double far outside any object's range saturates instead of overflowing the integer cast.
double saturate(double value) {
  constexpr double kLimit = 1e15;
  return std::clamp(value, -kLimit, kLimit);
}

}  // namespace

std::optional<std::uint32_t> pulses_per_revolution(std::uint16_t subdivision_code) {
  if (subdivision_code >= kPulsesPerRevolutionByCode.size()) return std::nullopt;
  return kPulsesPerRevolutionByCode[subdivision_code];
}

std::optional<std::uint16_t> subdivision_code(std::uint32_t pulses_per_rev) {
  const auto* found = std::find(kPulsesPerRevolutionByCode.begin(), kPulsesPerRevolutionByCode.end(), pulses_per_rev);
  if (found == kPulsesPerRevolutionByCode.end()) return std::nullopt;
  return static_cast<std::uint16_t>(found - kPulsesPerRevolutionByCode.begin());
}

SetupSubdivision setup_subdivision(std::optional<std::int64_t> pulses_per_revolution,
                                   std::optional<std::int64_t> micro_steps) {
  SetupSubdivision out;
  if (pulses_per_revolution) {
    out.pulses = *pulses_per_revolution;
  } else if (micro_steps) {
    out.pulses = *micro_steps * kFullStepsPerRevolution;
    out.from_micro_steps = true;
  } else {
    return out;
  }
  if (out.pulses <= 0 || out.pulses > std::numeric_limits<std::uint32_t>::max()) {
    out.status = SetupSubdivision::Status::kOutOfRange;
    return out;
  }
  const auto code = subdivision_code(static_cast<std::uint32_t>(out.pulses));
  if (!code) {
    out.status = SetupSubdivision::Status::kNotInTable;
    return out;
  }
  out.status = SetupSubdivision::Status::kCode;
  out.code = *code;
  return out;
}

double rpm_to_pulses_per_second(double rpm, std::uint32_t pulses_per_rev) { return rpm / 60.0 * pulses_per_rev; }

double pulses_per_second_to_rpm(double pulses_per_s, std::uint32_t pulses_per_rev) {
  return pulses_per_s * 60.0 / pulses_per_rev;
}

double pulses_to_revolutions(double pulses, std::uint32_t pulses_per_rev) { return pulses / pulses_per_rev; }

double run_current_amperes_rms(std::uint16_t setting) { return setting / 10.0; }

double ramp_acceleration(RampUnit unit, std::int64_t setting, double speed_change, std::uint32_t pulses_per_rev) {
  switch (unit) {
    case RampUnit::kRevolutionsPerSecondSquared: return static_cast<double>(setting) * pulses_per_rev;
    case RampUnit::kMilliseconds:
      if (speed_change <= 0.0) return std::numeric_limits<double>::infinity();
      return speed_change / (static_cast<double>(setting) / 1000.0);
  }
  return 0.0;
}

Quantized quantize_speed(const OdEntry& object, double pulses_per_s, std::uint32_t pulses_per_rev, Rounding rounding) {
  const double rpm = saturate(pulses_per_second_to_rpm(pulses_per_s, pulses_per_rev));
  Quantized result = clamp_to(object, rounding == Rounding::kNearest ? round_nearest(rpm) : round_magnitude_down(rpm));
  result.realized = rpm_to_pulses_per_second(static_cast<double>(result.native), pulses_per_rev);
  return result;
}

Quantized quantize_ramp(const OdEntry& object, double pulses_per_s2, double speed_change, std::uint32_t pulses_per_rev,
                        RampUnit unit, Rounding rounding) {
  Quantized result;
  switch (unit) {
    case RampUnit::kRevolutionsPerSecondSquared: {
      const double rev_per_s2 = saturate(pulses_per_s2 / pulses_per_rev);
      result = clamp_to(object,
                        rounding == Rounding::kNearest ? round_nearest(rev_per_s2) : round_magnitude_down(rev_per_s2));
      break;
    }
    case RampUnit::kMilliseconds: {
      if (speed_change <= 0.0) {
        result = clamp_to(object, object.min);  // nothing to ramp over: any setting is a step
        break;
      }
      if (pulses_per_s2 <= 0.0) {
        result = clamp_to(object, object.max);
        result.clamped = true;
        break;
      }
      // A longer ramp is a lower acceleration: "not above" rounds the time up.
      const double ramp_ms = saturate(speed_change / pulses_per_s2 * 1000.0);
      result = clamp_to(object, rounding == Rounding::kNearest ? round_nearest(ramp_ms) : round_up(ramp_ms));
      break;
    }
  }
  result.realized = ramp_acceleration(unit, result.native, speed_change, pulses_per_rev);
  return result;
}

Quantized quantize_position(const OdEntry& object, double pulses) {
  Quantized result = clamp_to(object, round_nearest(saturate(pulses)));
  result.realized = static_cast<double>(result.native);
  return result;
}

double full_speed_move_pulses(double start_speed, double max_speed, double acceleration, double deceleration) {
  const double span = max_speed * max_speed - start_speed * start_speed;
  return span / (2.0 * acceleration) + span / (2.0 * deceleration);
}

}  // namespace motion::cia402::uc57
