// One point-to-point trapezoidal (or triangular) velocity profile, and its sampling.
// Thread contract: pure functions and plain values, thread-safe.
#pragma once

#include <cmath>
#include <cstdint>

namespace motion::planner {

// The time law of a rest-to-rest move over a distance magnitude, in whatever unit that distance
// has: drive counts for an axis profile, "fraction of the move" (distance 1) for the synchronized
// time law of SyncPlan. Velocities are in that unit per second, accelerations per second squared.
struct TrapezoidShape {
  double peak_velocity = 0.0;  // the velocity actually reached (< the cap for a triangle)
  double acceleration = 0.0;   // magnitude
  double deceleration = 0.0;   // magnitude
  double t_acc_s = 0.0;
  double t_cruise_s = 0.0;  // 0 for a triangle
  double t_dec_s = 0.0;

  [[nodiscard]] double duration_s() const { return t_acc_s + t_cruise_s + t_dec_s; }
  // Distance covered after `t_s` seconds, clamped to [0, distance]. `distance` must be the one
  // the shape was built for; passing it in makes the end point exact (no accumulated rounding).
  [[nodiscard]] double travelled(double distance, double t_s) const;
  [[nodiscard]] double velocity(double t_s) const;  // >= 0
};

// The fastest rest-to-rest shape for `distance` (>= 0) with velocity, acceleration and
// deceleration caps (> 0): a trapezoid when the cruise speed is reachable, a triangle otherwise.
// This is also the model of what a drive's own ramp generator does with the values it is given.
// Inline: quantization evaluates it for every candidate setting.
[[nodiscard]] inline TrapezoidShape time_optimal_shape(double distance, double max_velocity, double max_acceleration,
                                                       double max_deceleration) {
  TrapezoidShape shape;
  if (!(distance > 0.0)) return shape;
  shape.acceleration = max_acceleration;
  shape.deceleration = max_deceleration;
  const double ramps_distance = 0.5 * max_velocity * max_velocity * (1.0 / max_acceleration + 1.0 / max_deceleration);
  if (ramps_distance <= distance) {
    shape.peak_velocity = max_velocity;
    shape.t_cruise_s = (distance - ramps_distance) / max_velocity;
  } else {
    // Triangle: v^2/(2a) + v^2/(2d) = distance.
    shape.peak_velocity =
        std::sqrt(2.0 * distance * max_acceleration * max_deceleration / (max_acceleration + max_deceleration));
  }
  shape.t_acc_s = shape.peak_velocity / max_acceleration;
  shape.t_dec_s = shape.peak_velocity / max_deceleration;
  return shape;
}

struct MotionSample {
  double position_counts = 0.0;
  double velocity_counts_per_s = 0.0;  // signed, in the direction of the move
};

// The profile of one axis in drive counts: from start_counts to target_counts (exact integers).
struct AxisProfile {
  std::int64_t start_counts = 0;
  std::int64_t target_counts = 0;
  TrapezoidShape shape;  // in counts, counts/s, counts/s^2

  [[nodiscard]] std::int64_t distance_counts() const { return target_counts - start_counts; }
  [[nodiscard]] bool is_still() const { return target_counts == start_counts; }
  [[nodiscard]] double duration_s() const { return shape.duration_s(); }
  // Position and velocity `t_s` seconds after the start; before 0 it is the start, from
  // duration_s() on it is exactly target_counts (exact as a double below 2^53 counts).
  [[nodiscard]] MotionSample sample(double t_s) const;
};

// Time-optimal profile of one axis for the given caps (counts/s, counts/s^2; all > 0 unless the
// axis is still, in which case the caps are ignored and the duration is 0).
[[nodiscard]] AxisProfile time_optimal_profile(std::int64_t start_counts, std::int64_t target_counts,
                                               double max_velocity_counts_per_s, double max_acceleration_counts_per_s2,
                                               double max_deceleration_counts_per_s2);

}  // namespace motion::planner
