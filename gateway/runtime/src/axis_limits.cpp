#include "motion/gateway/axis_limits.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include <motionlcm/gateway_command_t.hpp>

#include "motion/lcm/reply_error.hpp"

namespace motion::gateway {

namespace {

using Command = motionlcm::gateway_command_t;

constexpr double kRelativeTolerance = 1e-9;
constexpr double kPositionRounding = 0.5;  // counts: one llround of the target

double rate_bound(double limit) { return limit * (1.0 + kRelativeTolerance) + 1.0; }

const char* kind_name(std::int8_t kind) {
  switch (kind) {
    case Command::ARM_MOVE: return "move";
    case Command::JOG: return "jog";
    case Command::HOME: return "homing";
    case Command::SET_POSITION: return "set position";
    default: return "command";
  }
}

}  // namespace

CountLimits CountLimits::of(const config::Axis& axis) {
  CountLimits l;
  l.axis = &axis;
  const double s = axis.steps_per_unit;
  const double a = axis.limits.min_position * s;
  const double b = axis.limits.max_position * s;
  l.min_counts = axis.invert ? -b : a;
  l.max_counts = axis.invert ? -a : b;
  if (l.min_counts > l.max_counts) std::swap(l.min_counts, l.max_counts);
  l.max_velocity = std::abs(axis.limits.max_velocity * s);
  l.max_acceleration = std::abs(axis.limits.max_acceleration * s);
  return l;
}

double CountLimits::position_units(double counts) const {
  const double s = axis->steps_per_unit;
  return (axis->invert ? -counts : counts) / s;
}

std::optional<Refusal> check_axis_command(std::int8_t kind, const motionlcm::axis_command_t& c, const CountLimits& l,
                                          std::optional<std::int64_t> position_counts) {
  const bool moves = kind == Command::ARM_MOVE || kind == Command::JOG || kind == Command::HOME;
  const bool has_target = kind == Command::ARM_MOVE || kind == Command::SET_POSITION;
  if (!moves && !has_target) return std::nullopt;
  const config::Axis& axis = *l.axis;
  const std::string& unit = axis.unit;
  const double s = axis.steps_per_unit;
  const char* what = kind_name(kind);
  // Every value outside its limit is named, the position first.
  std::string violations;
  auto outside = [&](const std::string& reason) { violations += (violations.empty() ? "" : "; ") + reason; };

  if (has_target) {
    const auto target = static_cast<double>(c.target_counts);
    if (target < l.min_counts - kPositionRounding || target > l.max_counts + kPositionRounding) {
      outside(
          fmt::format("axis {}: {} target {:.6g} {} ({} counts) is outside the limits [{:.6g}, {:.6g}] {} ([{:.6g}, "
                      "{:.6g}] counts)",
                      axis.name, what, l.position_units(target), unit, c.target_counts, axis.limits.min_position,
                      axis.limits.max_position, unit, l.min_counts, l.max_counts));
    }
  }
  if (moves) {
    for (const auto& [name, value] : {std::pair{"velocity", c.velocity}, std::pair{"acceleration", c.acceleration},
                                      std::pair{"deceleration", c.deceleration}}) {
      if (!std::isfinite(value)) {
        return Refusal{error_code(ReplyError::kMalformedRequest),
                       fmt::format("axis {}: {} {} is not a finite number", axis.name, what, name)};
      }
    }
    if (std::abs(c.velocity) > rate_bound(l.max_velocity)) {
      outside(fmt::format(
          "axis {}: {} velocity {:.6g} {}/s ({:.6g} counts/s) exceeds the limit {:.6g} {}/s ({:.6g} counts/s)",
          axis.name, what, std::abs(c.velocity) / s, unit, std::abs(c.velocity), axis.limits.max_velocity, unit,
          l.max_velocity));
    }
    for (const auto& [name, value] :
         {std::pair{"acceleration", c.acceleration}, std::pair{"deceleration", c.deceleration}}) {
      if (value < 0) {
        return Refusal{error_code(ReplyError::kMalformedRequest),
                       fmt::format("axis {}: {} {} {:.6g} counts/s^2 is negative", axis.name, what, name, value)};
      }
      if (value > rate_bound(l.max_acceleration)) {
        outside(fmt::format(
            "axis {}: {} {} {:.6g} {}/s^2 ({:.6g} counts/s^2) exceeds the limit {:.6g} {}/s^2 ({:.6g} counts/s^2)",
            axis.name, what, name, value / s, unit, value, axis.limits.max_acceleration, unit, l.max_acceleration));
      }
    }
  }
  if (kind == Command::JOG && position_counts && c.velocity != 0 && !jog_room(l, c.velocity, *position_counts)) {
    const double limit = l.limit_toward(c.velocity);
    const auto position = static_cast<double>(*position_counts);
    outside(fmt::format(
        "axis {}: jog toward {:.6g} {} refused: position {:.6g} {} ({} counts) is less than one count from (or beyond) "
        "that limit ({:.6g} counts)",
        axis.name, l.position_units(limit), unit, l.position_units(position), unit, *position_counts, limit));
  }
  if (violations.empty()) return std::nullopt;
  return Refusal{error_code(ReplyError::kOutsideLimits), violations};
}

std::optional<std::int64_t> jog_room(const CountLimits& limits, double velocity, std::int64_t position_counts) {
  if (velocity == 0) return std::nullopt;
  const double left = limits.limit_toward(velocity) - static_cast<double>(position_counts);
  const double whole = velocity > 0 ? std::floor(left) : std::ceil(left);
  if (velocity > 0 ? whole < 1 : whole > -1) return std::nullopt;
  constexpr double kMax = 9.0e18;  // far beyond any drive's range; keeps the conversion defined
  return static_cast<std::int64_t>(std::clamp(whole, -kMax, kMax));
}

bool jog_must_stop(const JogWatch& jog, const CountLimits& limits, std::int64_t position_counts, double status_velocity,
                   double poll_hz) {
  if (jog.velocity == 0) return false;
  const double limit = limits.limit_toward(jog.velocity);
  const auto position = static_cast<double>(position_counts);
  const double remaining = jog.velocity > 0 ? limit - position : position - limit;
  const double v = std::max(std::abs(jog.velocity), std::isfinite(status_velocity) ? std::abs(status_velocity) : 0.0);
  double a = limits.max_acceleration;
  if (jog.deceleration > 0) a = a > 0 ? std::min(a, jog.deceleration) : jog.deceleration;
  const double braking = a > 0 ? v * v / (2.0 * a) : 0.0;
  const double periods = poll_hz > 0 ? 2.0 * v / poll_hz : 0.0;
  return remaining <= braking + periods + 1.0;
}

}  // namespace motion::gateway
