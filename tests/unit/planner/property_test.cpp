// Property tests over random plans from fixed seeds: a failure names its seed and iteration, and
// reproduces exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include "axis_builder.hpp"
#include "motion/planner/quantize_plan.hpp"

namespace motion::planner {
namespace {

constexpr int kPlans = 2000;
constexpr double kRateTolerance = 1e-12;  // relative, for limits scaled through |distance|

class RandomPlans {
 public:
  explicit RandomPlans(std::uint64_t seed) : rng_(seed) {}

  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  double log_uniform(double lo, double hi) { return std::exp(uniform(std::log(lo), std::log(hi))); }
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  bool chance(double p) { return uniform(0.0, 1.0) < p; }

  // Limits are at least 100 counts/s and 100 counts/s^2 so that every quantizer below can
  // represent some value within them (1 rpm of a 3200-count motor is 53.3 counts/s).
  AxisRequest axis(int index) {
    AxisRequest a;
    a.name = "axis" + std::to_string(index);
    // 5% huge moves: up to 1e14 counts (2^53 is 9e15).
    a.counts_per_user = chance(0.05) ? log_uniform(1e8, 1e12) : log_uniform(1.0, 10000.0);
    a.limits.min_position_user = -200.0;
    a.limits.max_position_user = 200.0;
    a.limits.max_velocity_user_per_s = log_uniform(100.0, 1e6) / a.counts_per_user;
    a.limits.max_acceleration_user_per_s2 = log_uniform(100.0, 1e7) / a.counts_per_user;
    if (chance(0.5)) a.limits.max_deceleration_user_per_s2 = log_uniform(100.0, 1e7) / a.counts_per_user;
    const auto start_counts = std::round(uniform(-100.0, 100.0) * a.counts_per_user);
    a.start_user = start_counts / a.counts_per_user;
    const int kind = integer(0, 9);
    if (kind == 0) {
      a.target_user = a.start_user;  // zero distance
    } else if (kind <= 2) {
      a.target_user = (start_counts + (chance(0.5) ? 1.0 : -1.0) * integer(1, 2)) / a.counts_per_user;  // tiny
    } else {
      a.target_user = uniform(-100.0, 100.0);
    }
    return a;
  }

  PlanOptions options() { return {chance(0.3) ? 1.0 : uniform(0.05, 1.0), chance(0.3) ? 1.0 : uniform(0.05, 1.0)}; }

  const DriveQuantizer* quantizer() {
    static const IdentityQuantizer identity;
    static const PpsRateQuantizer pps_rate;
    static const PpsRampTimeQuantizer pps_ramp_ms;
    static const RpmQuantizer rpm_rate(3200.0, 1.0, AccelerationGrid::rpm_per_s(3200.0, 1.0));
    static const RpmQuantizer fine_rpm_ramp_ms(10000.0, 0.1, AccelerationGrid::ramp_time(0.001));
    static const DriveQuantizer* const all[] = {&identity, &pps_rate, &pps_ramp_ms, &rpm_rate, &fine_rpm_ramp_ms};
    return all[integer(0, 4)];
  }

 private:
  std::mt19937_64 rng_;
};

struct Case {
  std::vector<AxisRequest> axes;
  PlanOptions options;
  std::vector<const DriveQuantizer*> quantizers;
};

Case random_case(RandomPlans& random) {
  Case c;
  const int n = random.integer(1, 8);
  for (int i = 0; i < n; ++i) {
    c.axes.push_back(random.axis(i));
    c.quantizers.push_back(random.quantizer());
  }
  c.options = random.options();
  return c;
}

struct Limits {
  double velocity, acceleration, deceleration;  // counts
};

Limits hard_limits(const AxisRequest& a) {
  const double s = a.counts_per_user;
  return {a.limits.max_velocity_user_per_s * s, a.limits.max_acceleration_user_per_s2 * s,
          a.limits.max_deceleration_user_per_s2.value_or(a.limits.max_acceleration_user_per_s2) * s};
}

// Velocity and its finite-difference slope along the profile stay within the caps.
void expect_profile_within(const AxisProfile& p, const Limits& caps, double tolerance) {
  const double duration = p.duration_s();
  constexpr int kSteps = 64;
  double previous_velocity = 0.0;
  double previous_position = static_cast<double>(p.start_counts);
  const double direction = p.distance_counts() < 0 ? -1.0 : 1.0;
  for (int k = 1; k <= kSteps; ++k) {
    const double t = duration * k / kSteps;
    const MotionSample s = p.sample(t);
    EXPECT_LE(std::abs(s.velocity_counts_per_s), caps.velocity * (1 + tolerance));
    const double slope = std::abs(s.velocity_counts_per_s - previous_velocity) / (duration / kSteps);
    EXPECT_LE(slope, std::max(caps.acceleration, caps.deceleration) * (1 + 1e-6));
    EXPECT_GE(direction * (s.position_counts - previous_position), -1e-9 * std::abs(previous_position) - 1e-9);
    previous_velocity = s.velocity_counts_per_s;
    previous_position = s.position_counts;
  }
  EXPECT_EQ(p.sample(duration).position_counts, static_cast<double>(p.target_counts));
  EXPECT_EQ(p.sample(duration + 1.0).velocity_counts_per_s, 0.0);
}

void check_plan(const Case& c, const SyncPlan& plan) {
  const double duration = plan.duration_s();
  double max_velocity_use = 0.0;
  double max_acceleration_use = 0.0;
  double max_deceleration_use = 0.0;
  bool any_moving = false;
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    SCOPED_TRACE("axis " + std::to_string(i));
    const AxisRequest& request = c.axes[i];
    const AxisProfile& axis = plan.axes[i];
    // Exact end points in counts.
    EXPECT_EQ(axis.start_counts, std::llround(request.start_user * request.counts_per_user));
    EXPECT_EQ(axis.target_counts, std::llround(request.target_user * request.counts_per_user));
    // Shared phases.
    EXPECT_EQ(axis.shape.t_acc_s, plan.time_law.t_acc_s);
    EXPECT_EQ(axis.shape.t_cruise_s, plan.time_law.t_cruise_s);
    EXPECT_EQ(axis.shape.t_dec_s, plan.time_law.t_dec_s);
    if (axis.is_still()) {
      EXPECT_EQ(axis.sample(0.5 * duration).position_counts, static_cast<double>(axis.start_counts));
      continue;
    }
    any_moving = true;
    // Scaled limits respected.
    const Limits hard = hard_limits(request);
    const Limits scaled{hard.velocity * c.options.velocity_scale, hard.acceleration * c.options.acceleration_scale,
                        hard.deceleration * c.options.acceleration_scale};
    EXPECT_LE(axis.shape.peak_velocity, scaled.velocity * (1 + kRateTolerance));
    EXPECT_LE(axis.shape.acceleration, scaled.acceleration * (1 + kRateTolerance));
    EXPECT_LE(axis.shape.deceleration, scaled.deceleration * (1 + kRateTolerance));
    max_velocity_use = std::max(max_velocity_use, axis.shape.peak_velocity / scaled.velocity);
    max_acceleration_use = std::max(max_acceleration_use, axis.shape.acceleration / scaled.acceleration);
    max_deceleration_use = std::max(max_deceleration_use, axis.shape.deceleration / scaled.deceleration);
    // Each axis's rates are consistent with the shared duration: rebuilt from its own rates alone,
    // the axis's time-optimal profile lasts exactly the plan's duration.
    const AxisProfile rebuilt = time_optimal_profile(axis.start_counts, axis.target_counts, axis.shape.peak_velocity,
                                                     axis.shape.acceleration, axis.shape.deceleration);
    EXPECT_NEAR(rebuilt.duration_s(), duration, 1e-9 * duration);
    expect_profile_within(axis, scaled, kRateTolerance);
  }
  if (!any_moving) {
    EXPECT_EQ(duration, 0.0);
    return;
  }
  // Time-optimal: the most constrained axis is at its acceleration and deceleration limits, and at
  // its velocity limit whenever there is a cruise phase (a triangle stays below it).
  EXPECT_NEAR(max_acceleration_use, 1.0, 1e-9);
  EXPECT_NEAR(max_deceleration_use, 1.0, 1e-9);
  if (plan.time_law.t_cruise_s > 0.0) {
    EXPECT_NEAR(max_velocity_use, 1.0, 1e-9);
  } else {
    EXPECT_LE(max_velocity_use, 1.0 + 1e-9);
  }
  // Straight line in joint space: every moving axis has covered the same fraction of its distance.
  for (int k = 0; k <= 16; ++k) {
    const double t = duration * k / 16.0;
    const Eigen::VectorXd positions = plan.positions_counts_at(t);
    const double fraction = plan.time_law.travelled(1.0, t);
    for (Eigen::Index i = 0; i < positions.size(); ++i) {
      const double expected = static_cast<double>(plan.start_counts[i]) + fraction * plan.distance_counts[i];
      EXPECT_NEAR(positions[i], expected, 1e-9 * (std::abs(plan.distance_counts[i]) + 1.0)) << "t " << t;
    }
  }
}

// How often each interesting situation came up, so that a generator change that stops
// exercising one of them fails loudly instead of silently testing less.
struct Coverage {
  int single_axis = 0;
  int all_still = 0;
  int some_still = 0;
  int triangle = 0;
  int one_count_move = 0;
  int huge_move = 0;
  int brute_forced = 0;
  int nonzero_spread = 0;
};

// Brute force over every combination of the candidates the refinement chose from; nullopt when
// there are too many combinations to enumerate.
std::optional<double> brute_force_min_spread(const SyncPlan& plan,
                                             const std::vector<const DriveQuantizer*>& quantizers) {
  constexpr double kMaxCombinations = 100000;
  std::vector<std::vector<double>> durations;
  double combinations = 1;
  for (std::size_t i = 0; i < plan.axes.size(); ++i) {
    const AxisProfile& axis = plan.axes[i];
    if (axis.is_still()) continue;
    std::vector<DriveSetting> settings;
    append_axis_candidates(plan, i, *quantizers[i], QuantizeOptions{}, settings);
    std::vector<double>& mine = durations.emplace_back();
    for (const DriveSetting& s : settings) {
      const DriveMotion& r = s.realized;
      mine.push_back(time_optimal_profile(axis.start_counts, axis.target_counts, r.velocity_counts_per_s,
                                          r.acceleration_counts_per_s2, r.deceleration_counts_per_s2)
                         .duration_s());
    }
    std::ranges::sort(mine);
    mine.erase(std::ranges::unique(mine).begin(), mine.end());
    combinations *= static_cast<double>(mine.size());
  }
  if (durations.empty()) return 0.0;
  if (combinations > kMaxCombinations) return std::nullopt;
  double best = std::numeric_limits<double>::infinity();
  std::vector<std::size_t> pick(durations.size(), 0);
  while (true) {
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (std::size_t a = 0; a < durations.size(); ++a) {
      lo = std::min(lo, durations[a][pick[a]]);
      hi = std::max(hi, durations[a][pick[a]]);
    }
    best = std::min(best, hi - lo);
    std::size_t a = 0;
    while (a < durations.size() && ++pick[a] == durations[a].size()) pick[a++] = 0;
    if (a == durations.size()) break;
  }
  return best;
}

void check_quantized(const Case& c, const SyncPlan& plan, const QuantizedPlan& q, int& brute_forced) {
  ASSERT_EQ(q.axes.size(), c.axes.size());
  double earliest = std::numeric_limits<double>::infinity();
  double latest = 0.0;
  std::size_t moving = 0;
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    SCOPED_TRACE("quantized axis " + std::to_string(i));
    const RealizedAxis& axis = q.axes[i];
    EXPECT_EQ(axis.profile.start_counts, plan.axes[i].start_counts);
    EXPECT_EQ(axis.profile.target_counts, plan.axes[i].target_counts);
    if (plan.axes[i].is_still()) {
      EXPECT_FALSE(axis.setting.has_value());
      EXPECT_EQ(axis.duration_s(), 0.0);
      continue;
    }
    ++moving;
    ASSERT_TRUE(axis.setting.has_value());
    // The values sent to the drive never exceed the axis limits (exactly, no tolerance).
    const Limits hard = hard_limits(c.axes[i]);
    const DriveMotion& sent = axis.setting->realized;
    EXPECT_GT(sent.velocity_counts_per_s, 0.0);
    EXPECT_LE(sent.velocity_counts_per_s, hard.velocity);
    EXPECT_LE(sent.acceleration_counts_per_s2, hard.acceleration);
    EXPECT_LE(sent.deceleration_counts_per_s2, hard.deceleration);
    // The realized profile is the drive's own with those values over the exact distance.
    EXPECT_LE(axis.profile.shape.peak_velocity, sent.velocity_counts_per_s * (1 + kRateTolerance));
    EXPECT_EQ(axis.profile.shape.acceleration, sent.acceleration_counts_per_s2);
    EXPECT_EQ(axis.profile.shape.deceleration, sent.deceleration_counts_per_s2);
    expect_profile_within(axis.profile, hard, kRateTolerance);
    earliest = std::min(earliest, axis.duration_s());
    latest = std::max(latest, axis.duration_s());
  }
  if (moving == 0) {
    EXPECT_EQ(q.predicted_spread_s(), 0.0);
    return;
  }
  // Durations agree within the predicted spread, which is exactly max - min.
  EXPECT_EQ(q.earliest_arrival_s, earliest);
  EXPECT_EQ(q.latest_arrival_s, latest);
  for (const RealizedAxis& a : q.axes) {
    if (!a.setting) continue;
    for (const RealizedAxis& b : q.axes) {
      if (b.setting) { EXPECT_LE(std::abs(a.duration_s() - b.duration_s()), q.predicted_spread_s()); }
    }
  }
  // The refinement is optimal over its candidates, and (re-fitted ramps included) never worse than
  // rounding each parameter alone.
  if (const auto best = brute_force_min_spread(plan, c.quantizers)) {
    ++brute_forced;
    EXPECT_NEAR(q.predicted_spread_s(), *best, 2e-12);
  }
  const auto rounding_only = quantize_plan(plan, c.quantizers, QuantizeOptions{.match_duration = false});
  ASSERT_TRUE(rounding_only.ok());
  EXPECT_LE(q.predicted_spread_s(), rounding_only.value().predicted_spread_s() + 2e-12);
  // With identity quantizers alone nothing changes.
  if (std::ranges::all_of(c.quantizers, [](const DriveQuantizer* z) { return z->name() == "identity"; })) {
    EXPECT_LE(q.predicted_spread_s(), 1e-9 * plan.duration_s());
    EXPECT_NEAR(q.latest_arrival_s, plan.duration_s(), 1e-9 * plan.duration_s());
  }
}

void count(const Case& c, const SyncPlan& plan, const QuantizedPlan& q, Coverage& seen) {
  const auto still = std::ranges::count_if(plan.axes, &AxisProfile::is_still);
  const auto moving = static_cast<std::ptrdiff_t>(plan.axes.size()) - still;
  seen.single_axis += c.axes.size() == 1;
  seen.all_still += moving == 0;
  seen.some_still += still > 0 && moving > 0;
  seen.triangle += moving > 0 && plan.time_law.t_cruise_s == 0.0;
  seen.one_count_move +=
      std::ranges::any_of(plan.axes, [](const AxisProfile& a) { return std::abs(a.distance_counts()) == 1; });
  seen.huge_move += std::ranges::any_of(
      plan.axes, [](const AxisProfile& a) { return std::abs(a.distance_counts()) > 1'000'000'000'000; });
  seen.nonzero_spread += q.predicted_spread_s() > 0.0;
}

class PlannerProperties : public ::testing::TestWithParam<std::uint64_t> {};

TEST_P(PlannerProperties, RandomPlansKeepEveryInvariant) {
  RandomPlans random(GetParam());
  Coverage seen;
  for (int iteration = 0; iteration < kPlans; ++iteration) {
    SCOPED_TRACE("seed " + std::to_string(GetParam()) + " iteration " + std::to_string(iteration));
    const Case c = random_case(random);
    const auto plan = plan_synchronized(c.axes, c.options);
    ASSERT_TRUE(plan.ok()) << plan.error().message();
    check_plan(c, plan.value());
    const auto quantized = quantize_plan(plan.value(), c.quantizers);
    ASSERT_TRUE(quantized.ok()) << quantized.error().message();
    check_quantized(c, plan.value(), quantized.value(), seen.brute_forced);
    if (::testing::Test::HasFailure()) return;  // one readable failure rather than thousands
    count(c, plan.value(), quantized.value(), seen);
  }
  EXPECT_GE(seen.single_axis, 100);
  EXPECT_GE(seen.all_still, 10);
  EXPECT_GE(seen.some_still, 500);
  EXPECT_GE(seen.triangle, 100);
  EXPECT_GE(seen.one_count_move, 500);
  EXPECT_GE(seen.huge_move, 100);
  EXPECT_GE(seen.brute_forced, 500);
  EXPECT_GE(seen.nonzero_spread, 1000);
  std::printf(
      "coverage: single %d, all still %d, some still %d, triangle %d, 1-count %d, huge %d, brute-forced %d, "
      "spread>0 %d\n",
      seen.single_axis, seen.all_still, seen.some_still, seen.triangle, seen.one_count_move, seen.huge_move,
      seen.brute_forced, seen.nonzero_spread);
}

INSTANTIATE_TEST_SUITE_P(FixedSeeds, PlannerProperties, ::testing::Values(1u, 20240611u));

}  // namespace
}  // namespace motion::planner
