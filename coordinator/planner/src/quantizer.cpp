#include "motion/planner/quantizer.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace motion::planner {
namespace {

void require_valid(bool ok, std::string_view what) {
  if (!ok) throw std::invalid_argument(std::string("GridQuantizer: ") + std::string(what));
}

bool valid_range(std::int64_t min_steps, std::int64_t max_steps) { return min_steps >= 1 && max_steps >= min_steps; }

// Appends the grid indices n in [min_steps, max_steps] of the value at or just below `desired`
// and of the `neighbours` next values on either side of it (so an exactly representable desired
// value still gets a lower alternative, whatever the floating-point rounding of value_of).
// value_of is monotonic (increasing for rates, decreasing for ramp times); `guess` is the real
// index of `desired`, refined here because value_of(n) is computed in floating point.
template <typename ValueOf>
void bracket_indices(double desired, double guess, bool increasing, int neighbours, std::int64_t min_steps,
                     std::int64_t max_steps, ValueOf value_of, std::vector<std::int64_t>& out) {
  out.clear();
  const auto lowest = min_steps - 1;
  const auto highest = max_steps + 1;
  const double clamped = std::clamp(guess, static_cast<double>(lowest), static_cast<double>(highest));
  // `at_or_below`: the index of the largest value not above `desired`.
  auto at_or_below = static_cast<std::int64_t>(increasing ? std::floor(clamped) : std::ceil(clamped));
  const std::int64_t toward_lower_value = increasing ? -1 : +1;
  const auto inside = [&](std::int64_t n) { return n >= lowest && n <= highest; };
  while (inside(at_or_below + toward_lower_value) && value_of(at_or_below) > desired) at_or_below += toward_lower_value;
  while (inside(at_or_below - toward_lower_value) && value_of(at_or_below - toward_lower_value) <= desired) {
    at_or_below -= toward_lower_value;
  }
  for (int k = -neighbours; k <= neighbours; ++k) {
    // k <= 0: at or below desired; k > 0: above.
    const std::int64_t n = at_or_below - toward_lower_value * k;
    if (n >= min_steps && n <= max_steps) out.push_back(n);
  }
}

}  // namespace

void IdentityQuantizer::candidates(const DriveMotion& desired, int /*neighbours*/, std::vector<DriveSetting>& out) const {
  out.push_back(DriveSetting{NativeMotion{}, desired});
}

GridQuantizer::GridQuantizer(std::string name, VelocityGrid velocity, AccelerationGrid acceleration)
    : name_(std::move(name)), velocity_(velocity), acceleration_(acceleration) {
  require_valid(std::isfinite(velocity_.counts_per_s_per_step) && velocity_.counts_per_s_per_step > 0.0,
                "velocity step must be finite and > 0");
  require_valid(std::isfinite(acceleration_.step) && acceleration_.step > 0.0,
                "acceleration step must be finite and > 0");
  require_valid(valid_range(velocity_.min_steps, velocity_.max_steps), "velocity range must be 1 <= min <= max");
  require_valid(valid_range(acceleration_.min_steps, acceleration_.max_steps),
                "acceleration range must be 1 <= min <= max");
  require_valid(std::isfinite(acceleration_.ramp_from) && acceleration_.ramp_from >= 0.0,
                "ramp start speed must be finite and >= 0");
}

void GridQuantizer::candidates(const DriveMotion& desired, int neighbours, std::vector<DriveSetting>& out) const {
  neighbours = std::max(neighbours, 1);
  const double v_step = velocity_.counts_per_s_per_step;
  const double a_step = acceleration_.step;
  const bool ramp_time = acceleration_.kind == AccelerationGrid::Kind::ramp_time;

  std::vector<std::int64_t> velocity_steps;
  std::vector<std::int64_t> acceleration_steps;
  std::vector<std::int64_t> deceleration_steps;
  // A ramp-time drive has no ramp at or below its start speed: a slower wish is served by the
  // nearest speeds above it (long ramps then stretch the profile to the planned duration).
  double wanted_velocity = desired.velocity_counts_per_s;
  if (ramp_time) {
    const double first_above = (std::floor(acceleration_.ramp_from / v_step) + 1.0) * v_step;
    wanted_velocity = std::max(wanted_velocity, first_above);
  }
  bracket_indices(
      wanted_velocity, wanted_velocity / v_step, true, neighbours, velocity_.min_steps,
      velocity_.max_steps, [&](std::int64_t n) { return static_cast<double>(n) * v_step; }, velocity_steps);

  for (const std::int64_t v_native : velocity_steps) {
    const double velocity = static_cast<double>(v_native) * v_step;
    // The speed change a ramp covers (ramp time only).
    const double ramp_span = velocity - acceleration_.ramp_from;
    // No ramp (the drive steps to this speed); the relative margin absorbs the rounding of a grid
    // velocity that equals ramp_from.
    if (ramp_time && !(ramp_span > 1e-9 * velocity)) continue;
    const auto realized_acceleration = [&](std::int64_t n) {
      return ramp_time ? ramp_span / (static_cast<double>(n) * a_step) : static_cast<double>(n) * a_step;
    };
    const auto brackets = [&](double wanted, std::vector<std::int64_t>& indices) {
      const double guess = ramp_time ? ramp_span / (wanted * a_step) : wanted / a_step;
      bracket_indices(wanted, guess, !ramp_time, neighbours, acceleration_.min_steps, acceleration_.max_steps,
                      realized_acceleration, indices);
    };
    brackets(desired.acceleration_counts_per_s2, acceleration_steps);
    brackets(desired.deceleration_counts_per_s2, deceleration_steps);
    for (const std::int64_t a_native : acceleration_steps) {
      for (const std::int64_t d_native : deceleration_steps) {
        out.push_back(DriveSetting{NativeMotion{v_native, a_native, d_native},
                                   DriveMotion{velocity, realized_acceleration(a_native), realized_acceleration(d_native)}});
      }
    }
  }
}

PpsRateQuantizer::PpsRateQuantizer(std::int64_t max_pps, std::int64_t max_pps_per_s)
    : GridQuantizer("pps+pps/s", VelocityGrid{1.0, 1, max_pps},
                    AccelerationGrid{AccelerationGrid::Kind::rate, 1.0, 1, max_pps_per_s}) {}

PpsRampTimeQuantizer::PpsRampTimeQuantizer(std::int64_t max_pps, std::int64_t max_ramp_ms)
    : GridQuantizer("pps+ramp ms", VelocityGrid{1.0, 1, max_pps},
                    AccelerationGrid{AccelerationGrid::Kind::ramp_time, 0.001, 1, max_ramp_ms}) {}

RpmQuantizer::RpmQuantizer(double counts_per_rev, double rpm_per_step, AccelerationGrid acceleration,
                           std::int64_t max_velocity_steps)
    : GridQuantizer("rpm", VelocityGrid{counts_per_rev * rpm_per_step / 60.0, 1, max_velocity_steps}, acceleration) {}

}  // namespace motion::planner
