// Synchronized multi-axis point-to-point planning: one common time law for all axes.
//
// Every axis follows   position_i(t) = start_i + distance_i * s(t)   where s goes from 0 to 1 along
// a single trapezoid (or triangle) with phases t_acc, t_cruise, t_dec. So all axes start, change
// phase and arrive together, and the path is a straight line in joint space. The caps of s are the
// tightest over the moving axes (velocity, acceleration and deceleration separately): the most
// constrained axis sets the time, and the plan is time-optimal for a straight-line move.
//
// Inputs are in user units (mm, deg, ...); the plan is in drive counts (int64, exact end points).
// Thread contract: plan_synchronized is pure, thread-safe.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "motion/planner/errors.hpp"
#include "motion/planner/profile.hpp"

namespace motion::planner {

using CountsVector = Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>;

// Limits of one axis, in user units. Position limits may be +-infinity (unbounded, e.g. rotary).
struct AxisLimits {
  double min_position_user = 0.0;
  double max_position_user = 0.0;
  double max_velocity_user_per_s = 0.0;
  double max_acceleration_user_per_s2 = 0.0;
  std::optional<double> max_deceleration_user_per_s2;  // default: max_acceleration_user_per_s2
};

struct AxisRequest {
  std::string name;          // for error messages only
  double start_user = 0.0;   // current position, user units (may be outside the limits: coming back is allowed)
  double target_user = 0.0;  // user units; must lie within the position limits
  // Drive counts per user unit; positions become counts as llround(position_user * counts_per_user).
  double counts_per_user = 0.0;
  AxisLimits limits;
};

struct PlanOptions {
  // Fractions of every axis's limits to plan with, in (0, 1] (an operator's speed override).
  double velocity_scale = 1.0;
  double acceleration_scale = 1.0;  // applies to deceleration too
};

struct SyncPlan {
  // The common time law s(t), over the unit distance 0 -> 1 (peak in 1/s, ramps in 1/s^2).
  TrapezoidShape time_law;

  // Per axis, in the request's order (Eigen vectors, one row per axis).
  std::vector<std::string> axis_names;
  CountsVector start_counts;
  CountsVector target_counts;
  Eigen::VectorXd distance_counts;  // signed, target - start
  // Hard axis limits in counts (not scaled by PlanOptions): quantization must stay within them.
  Eigen::VectorXd velocity_limit_counts_per_s;
  Eigen::VectorXd acceleration_limit_counts_per_s2;
  Eigen::VectorXd deceleration_limit_counts_per_s2;
  // Each axis's own profile: the time law scaled by |distance_counts|, so every axis has the same
  // t_acc/t_cruise/t_dec; peak velocity/acceleration/deceleration in counts/s and counts/s^2.
  std::vector<AxisProfile> axes;

  [[nodiscard]] double duration_s() const { return time_law.duration_s(); }
  [[nodiscard]] Eigen::Index axis_count() const { return start_counts.size(); }
  // All axes at time `t_s` (counts, counts/s). Straight line: start + distance * s(t).
  [[nodiscard]] Eigen::VectorXd positions_counts_at(double t_s) const;
  [[nodiscard]] Eigen::VectorXd velocities_counts_per_s_at(double t_s) const;
};

// Validates every input (see PlanErrc) and plans. All-zero moves give a zero-duration plan.
[[nodiscard]] Result<SyncPlan> plan_synchronized(std::span<const AxisRequest> axes, const PlanOptions& options = {});

// The same into a caller's plan, overwritten whole (its vectors keep their storage): with a plan
// kept from move to move, planning allocates nothing once it has grown (names longer than the
// small-string buffer aside). nullopt on success; on a failure `plan` holds nothing meaningful.
[[nodiscard]] std::optional<PlanFailure> plan_synchronized_into(std::span<const AxisRequest> axes, SyncPlan& plan,
                                                                const PlanOptions& options = {});

}  // namespace motion::planner
