// Shorthand for AxisRequest in the planner tests.
#pragma once

#include <optional>
#include <string>

#include "motion/planner/sync_planner.hpp"

namespace motion::planner::testing {

struct AxisSpec {
  std::string name = "x";
  double start_user = 0.0;
  double target_user = 0.0;
  double counts_per_user = 1.0;
  double max_velocity_user_per_s = 1.0;
  double max_acceleration_user_per_s2 = 1.0;
  std::optional<double> max_deceleration_user_per_s2 = std::nullopt;
  double min_position_user = -1e9;
  double max_position_user = 1e9;
};

inline AxisRequest make_axis(const AxisSpec& s) {
  return AxisRequest{s.name, s.start_user, s.target_user, s.counts_per_user,
                     AxisLimits{s.min_position_user, s.max_position_user, s.max_velocity_user_per_s,
                                s.max_acceleration_user_per_s2, s.max_deceleration_user_per_s2}};
}

}  // namespace motion::planner::testing
