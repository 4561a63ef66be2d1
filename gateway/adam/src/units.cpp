#include "motion/adam/units.hpp"

#include <cmath>
#include <limits>

namespace motion::adam {
namespace {

// Rounds `value / step` to the nearest integer within [min, max].
template <typename T>
Result<Quantized<T>> quantize(double value, double step, std::int64_t min, std::int64_t max) {
  if (!std::isfinite(value)) return AdamErrc::kNonFinite;
  const double steps = std::round(value / step);
  if (steps < static_cast<double>(min) || steps > static_cast<double>(max)) return AdamErrc::kValueOutOfRange;
  return Quantized<T>{static_cast<T>(steps), steps * step};
}

}  // namespace

Result<std::uint32_t> check_subdivision(std::uint32_t pulses_per_rev) {
  if (pulses_per_rev < kMinSubdivision || pulses_per_rev > kMaxSubdivision) return AdamErrc::kInvalidSubdivision;
  return pulses_per_rev;
}

Result<Quantized<std::uint16_t>> working_speed(double rpm) {
  return quantize<std::uint16_t>(rpm, kWorkingSpeedRpmPerStep, 0, kMaxWorkingSpeedRpm);
}

Result<Quantized<std::int32_t>> target_speed(double rpm) {
  return quantize<std::int32_t>(rpm, kTargetSpeedRpmPerStep, -kMaxTargetSpeedCentiRpm, kMaxTargetSpeedCentiRpm);
}

Result<Quantized<std::int32_t>> target_speed_from_pps(double pps, std::uint32_t subdivision) {
  if (auto ok = check_subdivision(subdivision); !ok) return ok.error();
  auto q = target_speed(pps_to_rpm(pps, subdivision));
  if (!q) return q.error();
  return Quantized<std::int32_t>{q.value().value, rpm_to_pps(q.value().realized, subdivision)};
}

Result<Quantized<std::uint16_t>> start_speed(double rpm) {
  return quantize<std::uint16_t>(rpm, kWorkingSpeedRpmPerStep, 0, kMaxStartSpeedRpm);
}

Result<Quantized<std::uint16_t>> stop_speed(double rpm) {
  return quantize<std::uint16_t>(rpm, kWorkingSpeedRpmPerStep, 0, kMaxStopSpeedRpm);
}

Result<Quantized<std::uint16_t>> jog_speed(double rpm) {
  return quantize<std::uint16_t>(rpm, kWorkingSpeedRpmPerStep, 0, kMaxJogSpeedRpm);
}

double ramp_rate_rpm_per_s(double from_rpm, double to_rpm, std::uint16_t ms) noexcept {
  if (ms == 0) return 0.0;
  return std::abs(to_rpm - from_rpm) / (ms * kRampSecondsPerStep);
}

Result<Quantized<std::uint16_t>> ramp_time_ms(double from_rpm, double to_rpm, double rpm_per_s) {
  if (!std::isfinite(from_rpm) || !std::isfinite(to_rpm) || !std::isfinite(rpm_per_s)) return AdamErrc::kNonFinite;
  if (rpm_per_s <= 0.0) return AdamErrc::kValueOutOfRange;
  const double seconds = std::abs(to_rpm - from_rpm) / rpm_per_s;
  auto q = quantize<std::uint16_t>(seconds, kRampSecondsPerStep, 0, kMaxRampMs);
  if (!q) return q.error();
  q.value().realized = ramp_rate_rpm_per_s(from_rpm, to_rpm, q.value().value);
  return q;
}

Result<Quantized<std::int32_t>> pulses_from_revolutions(double revolutions, std::uint32_t subdivision) {
  if (auto ok = check_subdivision(subdivision); !ok) return ok.error();
  const double step = 1.0 / subdivision;
  return quantize<std::int32_t>(revolutions, step, std::numeric_limits<std::int32_t>::min(),
                                std::numeric_limits<std::int32_t>::max());
}

}  // namespace motion::adam
