// The configured limits of one axis in drive counts, and the checks the gateway applies to every
// command it receives (whatever the sender) and to a jogging axis's published status.
//
// Counts are user units x steps_per_unit, sign flipped with `invert`; the position range is
// ordered by value (an inverted axis's max_position is its lowest count). Tolerances: a target may
// lie half a count outside (the coordinator rounds each target once, llround); a velocity or
// acceleration may exceed its limit by a relative 1e-9 plus one count/s (or count/s^2) of rounding.
// Pure functions: no state, no clock.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <motionlcm/axis_command_t.hpp>

#include "motion/config/config.hpp"

namespace motion::gateway {

struct CountLimits {
  const config::Axis* axis = nullptr;
  double min_counts = 0;        // lowest allowed position (counts)
  double max_counts = 0;        // highest allowed position (counts)
  double max_velocity = 0;      // counts/s
  double max_acceleration = 0;  // counts/s^2

  [[nodiscard]] static CountLimits of(const config::Axis& axis);
  // The user-unit value of a count position / a count rate (invert applied to positions only
  // where asked).
  [[nodiscard]] double position_units(double counts) const;
  // The limit (in counts) reached when moving with the sign of `velocity` (> 0: counts up).
  [[nodiscard]] double limit_toward(double velocity) const { return velocity > 0 ? max_counts : min_counts; }
};

// A refused command: why, and the reply_t/gateway_reply_t error code.
struct Refusal {
  std::int32_t error_code = 0;
  std::string reason;
};

// Checks one axis's part of a command of `kind` (gateway_command_t kinds) against its limits:
// ARM_MOVE target, |velocity|, acceleration, deceleration; JOG |velocity|, acceleration and
// deceleration (0 = the drive's own) and, with the last known position, that the jog has at least
// one whole count to run before the limit in its direction (jog_room); SET_POSITION target; HOME |velocity| and ramps. Other
// kinds carry no motion values and pass. Non-finite values are malformed (code 1); values
// outside the limits are code 3 (outside limits).
[[nodiscard]] std::optional<Refusal> check_axis_command(std::int8_t kind, const motionlcm::axis_command_t& command,
                                                        const CountLimits& limits,
                                                        std::optional<std::int64_t> position_counts);

// The whole counts a jog from `position_counts` with the sign of `velocity` may run before the
// limit in its direction (signed like the velocity: floor toward the limit, so the last count
// lies inside it), or nothing when less than one whole count is left (or the axis is at or beyond
// that limit): such a jog is refused, by the gateway as by the coordinator.
[[nodiscard]] std::optional<std::int64_t> jog_room(const CountLimits& limits, double velocity,
                                                   std::int64_t position_counts);

// A jog watched against the limit in its direction.
struct JogWatch {
  double velocity = 0;      // commanded, counts/s (sign = direction)
  double deceleration = 0;  // commanded, counts/s^2 (0: the drive's own; the limit is used)
};

// Whether a jogging axis at `position_counts` moving at `status_velocity` must be stopped now: the
// distance left to the limit in the jog's direction is at or below the braking distance v^2/(2 a)
// plus two status periods of travel (2 v / poll_hz) plus one count, where v is the larger of the
// commanded and the reported speed and a the commanded deceleration, at most the axis's limit.
[[nodiscard]] bool jog_must_stop(const JogWatch& jog, const CountLimits& limits, std::int64_t position_counts,
                                 double status_velocity, double poll_hz);

}  // namespace motion::gateway
