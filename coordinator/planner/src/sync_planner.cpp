#include "motion/planner/sync_planner.hpp"

#include <cmath>
#include <limits>

namespace motion::planner {
namespace {

// Beyond 2^53 a double no longer holds every integer: sampled positions would stop being exact.
constexpr double kMaxExactCounts = 9007199254740992.0;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

PlanFailure failure(PlanErrc code, std::size_t index, const AxisRequest* axis, double value = 0.0, double limit = 0.0) {
  return PlanFailure{code, index, axis != nullptr ? axis->name : std::string{}, value, limit};
}

std::optional<PlanFailure> check_options(const PlanOptions& options) {
  for (const double scale : {options.velocity_scale, options.acceleration_scale}) {
    if (!std::isfinite(scale)) return failure(PlanErrc::kNonFiniteInput, kNoAxis, nullptr, scale);
    if (!(scale > 0.0 && scale <= 1.0)) return failure(PlanErrc::kInvalidSpeedScale, kNoAxis, nullptr, scale, 1.0);
  }
  return std::nullopt;
}

double deceleration_limit(const AxisLimits& limits) {
  return limits.max_deceleration_user_per_s2.value_or(limits.max_acceleration_user_per_s2);
}

std::optional<PlanFailure> check_axis(std::size_t index, const AxisRequest& axis) {
  const AxisLimits& limits = axis.limits;
  const double rates[] = {limits.max_velocity_user_per_s, limits.max_acceleration_user_per_s2,
                          deceleration_limit(limits)};
  for (const double finite : {axis.start_user, axis.target_user, axis.counts_per_user, rates[0], rates[1], rates[2]}) {
    if (!std::isfinite(finite)) return failure(PlanErrc::kNonFiniteInput, index, &axis, finite);
  }
  // Position limits may be infinite (unbounded) but never NaN.
  for (const double bound : {limits.min_position_user, limits.max_position_user}) {
    if (std::isnan(bound)) return failure(PlanErrc::kNonFiniteInput, index, &axis, bound);
  }
  if (!(axis.counts_per_user > 0.0)) return failure(PlanErrc::kNonPositiveScale, index, &axis, axis.counts_per_user);
  for (const double rate : rates) {
    if (!(rate > 0.0)) return failure(PlanErrc::kNonPositiveLimit, index, &axis, rate);
  }
  if (limits.min_position_user > limits.max_position_user) {
    return failure(PlanErrc::kInvalidPositionRange, index, &axis, limits.min_position_user, limits.max_position_user);
  }
  if (axis.target_user < limits.min_position_user) {
    return failure(PlanErrc::kTargetBelowMin, index, &axis, axis.target_user, limits.min_position_user);
  }
  if (axis.target_user > limits.max_position_user) {
    return failure(PlanErrc::kTargetAboveMax, index, &axis, axis.target_user, limits.max_position_user);
  }
  for (const double position : {axis.start_user, axis.target_user}) {
    const double counts = position * axis.counts_per_user;
    if (!(std::abs(counts) <= kMaxExactCounts)) {
      return failure(PlanErrc::kCountsOutOfRange, index, &axis, counts, kMaxExactCounts);
    }
  }
  return std::nullopt;
}

// std::llround(user * counts_per_user) bit for bit, without the library call: check_axis() keeps
// the counts within 2^53, where truncation and the fraction it leaves are exact, so rounding half
// away from zero by hand is exact too.
std::int64_t to_counts(double user, double counts_per_user) {
  const double counts = user * counts_per_user;
  auto whole = static_cast<std::int64_t>(counts);
  const double fraction = counts - static_cast<double>(whole);
  if (fraction >= 0.5) {
    ++whole;
  } else if (fraction <= -0.5) {
    --whole;
  }
  return whole;
}

// min over moving axes of limit_i / |distance_i|: the cap of s(t) that keeps every axis in limits.
template <typename Limits, typename Distances>
double tightest_unit_cap(const Eigen::ArrayBase<Limits>& limit_counts,
                         const Eigen::ArrayBase<Distances>& abs_distance) {
  return (abs_distance > 0.0).select(limit_counts / abs_distance, kInfinity).minCoeff();
}

}  // namespace

Eigen::VectorXd SyncPlan::positions_counts_at(double t_s) const {
  Eigen::VectorXd out(axis_count());
  for (Eigen::Index i = 0; i < out.size(); ++i) out[i] = axes[static_cast<std::size_t>(i)].sample(t_s).position_counts;
  return out;
}

Eigen::VectorXd SyncPlan::velocities_counts_per_s_at(double t_s) const {
  Eigen::VectorXd out(axis_count());
  for (Eigen::Index i = 0; i < out.size(); ++i) {
    out[i] = axes[static_cast<std::size_t>(i)].sample(t_s).velocity_counts_per_s;
  }
  return out;
}

Result<SyncPlan> plan_synchronized(std::span<const AxisRequest> axes, const PlanOptions& options) {
  SyncPlan plan;
  if (auto bad = plan_synchronized_into(axes, plan, options)) return *std::move(bad);
  return plan;
}

std::optional<PlanFailure> plan_synchronized_into(std::span<const AxisRequest> axes, SyncPlan& plan,
                                                  const PlanOptions& options) {
  if (axes.empty()) return failure(PlanErrc::kNoAxes, kNoAxis, nullptr);
  if (auto bad = check_options(options)) return bad;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    if (auto bad = check_axis(i, axes[i])) return bad;
  }

  const auto n = static_cast<Eigen::Index>(axes.size());
  plan.time_law = TrapezoidShape{};
  plan.axis_names.resize(axes.size());
  plan.start_counts.resize(n);
  plan.target_counts.resize(n);
  plan.velocity_limit_counts_per_s.resize(n);
  plan.acceleration_limit_counts_per_s2.resize(n);
  plan.deceleration_limit_counts_per_s2.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const AxisRequest& axis = axes[static_cast<std::size_t>(i)];
    plan.axis_names[static_cast<std::size_t>(i)] = axis.name;
    plan.start_counts[i] = to_counts(axis.start_user, axis.counts_per_user);
    plan.target_counts[i] = to_counts(axis.target_user, axis.counts_per_user);
    plan.velocity_limit_counts_per_s[i] = axis.limits.max_velocity_user_per_s * axis.counts_per_user;
    plan.acceleration_limit_counts_per_s2[i] = axis.limits.max_acceleration_user_per_s2 * axis.counts_per_user;
    plan.deceleration_limit_counts_per_s2[i] = deceleration_limit(axis.limits) * axis.counts_per_user;
  }
  plan.distance_counts = (plan.target_counts - plan.start_counts).cast<double>();

  const auto abs_distance = plan.distance_counts.array().abs();  // an expression: nothing allocated
  if ((abs_distance > 0.0).any()) {
    const double unit_velocity =
        options.velocity_scale * tightest_unit_cap(plan.velocity_limit_counts_per_s.array(), abs_distance);
    const double unit_acceleration =
        options.acceleration_scale * tightest_unit_cap(plan.acceleration_limit_counts_per_s2.array(), abs_distance);
    const double unit_deceleration =
        options.acceleration_scale * tightest_unit_cap(plan.deceleration_limit_counts_per_s2.array(), abs_distance);
    plan.time_law = time_optimal_shape(1.0, unit_velocity, unit_acceleration, unit_deceleration);
  }

  plan.axes.clear();
  for (Eigen::Index i = 0; i < n; ++i) {
    AxisProfile profile{plan.start_counts[i], plan.target_counts[i], plan.time_law};
    // Same phase times; rates scaled from "fraction of the move" to counts (zero for a still axis,
    // which thus keeps the shared phase times too).
    profile.shape.peak_velocity *= abs_distance[i];
    profile.shape.acceleration *= abs_distance[i];
    profile.shape.deceleration *= abs_distance[i];
    plan.axes.push_back(profile);
  }
  return std::nullopt;
}

}  // namespace motion::planner
