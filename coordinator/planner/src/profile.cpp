#include "motion/planner/profile.hpp"

#include <algorithm>
#include <cmath>

namespace motion::planner {

double TrapezoidShape::travelled(double distance, double t_s) const {
  if (t_s <= 0.0) return 0.0;
  const double total = duration_s();
  if (t_s >= total) return distance;
  if (t_s < t_acc_s) return 0.5 * acceleration * t_s * t_s;
  if (t_s < t_acc_s + t_cruise_s) return 0.5 * acceleration * t_acc_s * t_acc_s + peak_velocity * (t_s - t_acc_s);
  // Measured back from the end so that the last phase lands exactly on `distance`.
  const double remaining = total - t_s;
  return std::clamp(distance - 0.5 * deceleration * remaining * remaining, 0.0, distance);
}

double TrapezoidShape::velocity(double t_s) const {
  if (t_s <= 0.0) return 0.0;
  const double total = duration_s();
  if (t_s >= total) return 0.0;
  if (t_s < t_acc_s) return acceleration * t_s;
  if (t_s < t_acc_s + t_cruise_s) return peak_velocity;
  return deceleration * (total - t_s);
}

MotionSample AxisProfile::sample(double t_s) const {
  const std::int64_t distance = distance_counts();
  const double direction = distance < 0 ? -1.0 : 1.0;
  const double magnitude = std::abs(static_cast<double>(distance));
  MotionSample out;
  out.position_counts = t_s >= duration_s()
                            ? static_cast<double>(target_counts)
                            : static_cast<double>(start_counts) + direction * shape.travelled(magnitude, t_s);
  out.velocity_counts_per_s = direction * shape.velocity(t_s);
  return out;
}

AxisProfile time_optimal_profile(std::int64_t start_counts, std::int64_t target_counts,
                                 double max_velocity_counts_per_s, double max_acceleration_counts_per_s2,
                                 double max_deceleration_counts_per_s2) {
  AxisProfile profile{start_counts, target_counts, {}};
  profile.shape =
      time_optimal_shape(std::abs(static_cast<double>(target_counts - start_counts)), max_velocity_counts_per_s,
                         max_acceleration_counts_per_s2, max_deceleration_counts_per_s2);
  return profile;
}

}  // namespace motion::planner
