#include "motion/planner/quantizer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "axis_builder.hpp"
#include "motion/planner/quantize_plan.hpp"

namespace motion::planner {
namespace {

using testing::make_axis;
using NativeSet = std::set<std::tuple<std::int64_t, std::int64_t, std::int64_t>>;

std::vector<DriveSetting> candidates_of(const DriveQuantizer& q, DriveMotion desired, int neighbours = 1) {
  std::vector<DriveSetting> out;
  q.candidates(desired, neighbours, out);
  return out;
}

NativeSet natives(const std::vector<DriveSetting>& settings) {
  NativeSet out;
  for (const DriveSetting& s : settings) out.emplace(s.native.velocity, s.native.acceleration, s.native.deceleration);
  return out;
}

// Every combination of the per-parameter native values.
NativeSet combinations(const std::vector<std::int64_t>& v, const std::vector<std::int64_t>& a,
                       const std::vector<std::int64_t>& d) {
  NativeSet out;
  for (const auto nv : v) {
    for (const auto na : a) {
      for (const auto nd : d) out.emplace(nv, na, nd);
    }
  }
  return out;
}

TEST(Quantizers, PpsRateOffersRoundedDownAndNeighbours) {
  // 1000.4 pps rounds down to 1000 -> {999, 1000, 1001}; 3000.6 pps/s -> {2999, 3000, 3001};
  // 2000 is exact -> {1999, 2000, 2001}.
  const PpsRateQuantizer q;
  const auto settings = candidates_of(q, {1000.4, 3000.6, 2000.0});
  EXPECT_EQ(natives(settings), combinations({999, 1000, 1001}, {2999, 3000, 3001}, {1999, 2000, 2001}));
  for (const DriveSetting& s : settings) {
    EXPECT_EQ(s.realized.velocity_counts_per_s, static_cast<double>(s.native.velocity));
    EXPECT_EQ(s.realized.acceleration_counts_per_s2, static_cast<double>(s.native.acceleration));
    EXPECT_EQ(s.realized.deceleration_counts_per_s2, static_cast<double>(s.native.deceleration));
  }
  // Two neighbours each side: 998..1002 -> 5 x 5 x 5.
  EXPECT_EQ(candidates_of(q, {1000.4, 3000.6, 2000.0}, 2).size(), 125u);
}

TEST(Quantizers, PpsRateDropsZeroAndOutOfRangeValues) {
  // 0.3 pps rounds down to 0, which is no speed: only 1 is left. The rate grid stops at 10:
  // 10 -> {9, 10}; 9.5 -> {8, 9, 10}.
  const PpsRateQuantizer q(1000, 10);
  EXPECT_EQ(natives(candidates_of(q, {0.3, 10.0, 9.5})), combinations({1}, {9, 10}, {8, 9, 10}));
}

TEST(Quantizers, PpsRampTimeConvertsMillisecondsToAcceleration) {
  // v 1000.4 -> {999, 1000, 1001} pps. For 1000 pps and 3000 pps/s the ramp is 1000/3000 s =
  // 333.33 ms: the shortest ramp not above 3000 pps/s is 334 ms (1000/0.334 = 2994.012), its
  // neighbours 333 ms (3003.003) and 335 ms (2985.075).
  const PpsRampTimeQuantizer q;
  const auto settings = candidates_of(q, {1000.4, 3000.0, 3000.0});
  EXPECT_EQ(settings.size(), 27u);
  for (const DriveSetting& s : settings) {
    EXPECT_NEAR(s.realized.acceleration_counts_per_s2,
                static_cast<double>(s.native.velocity) / (0.001 * static_cast<double>(s.native.acceleration)), 1e-9);
  }
  std::set<std::int64_t> ramps_at_1000;
  for (const DriveSetting& s : settings) {
    if (s.native.velocity == 1000) ramps_at_1000.insert(s.native.acceleration);
  }
  EXPECT_EQ(ramps_at_1000, (std::set<std::int64_t>{333, 334, 335}));
  const auto it = std::ranges::find(settings, NativeMotion{1000, 334, 333}, &DriveSetting::native);
  ASSERT_NE(it, settings.end());
  EXPECT_NEAR(it->realized.acceleration_counts_per_s2, 2994.0119760479, 1e-6);
  EXPECT_NEAR(it->realized.deceleration_counts_per_s2, 3003.0030030030, 1e-6);
}

TEST(Quantizers, RpmWithRateInRpmPerSecond) {
  // 3200 counts/rev, 1 rpm = 3200/60 = 53.33 c/s. 1000 c/s = 18.75 rpm -> {17, 18, 19}.
  // Acceleration in rpm/s: 5000 c/s^2 = 93.75 rpm/s -> {92, 93, 94}.
  const RpmQuantizer q(3200.0, 1.0, AccelerationGrid::rpm_per_s(3200.0, 1.0));
  const auto settings = candidates_of(q, {1000.0, 5000.0, 5000.0});
  EXPECT_EQ(natives(settings), combinations({17, 18, 19}, {92, 93, 94}, {92, 93, 94}));
  const auto it = std::ranges::find(settings, NativeMotion{19, 94, 92}, &DriveSetting::native);
  ASSERT_NE(it, settings.end());
  EXPECT_NEAR(it->realized.velocity_counts_per_s, 19.0 * 3200.0 / 60.0, 1e-9);
  EXPECT_NEAR(it->realized.acceleration_counts_per_s2, 94.0 * 3200.0 / 60.0, 1e-9);
}

// GridQuantizer::blocks() expanded (every acceleration with every deceleration) is candidates()
// (candidates_at_velocity() with at_velocity), setting by setting in the same order.
TEST(Quantizers, GridBlocksAreTheCandidatesInOrder) {
  const GridQuantizer grids[] = {
      PpsRateQuantizer(),
      PpsRampTimeQuantizer(),
      RpmQuantizer(3200.0, 1.0, AccelerationGrid::rpm_per_s(3200.0, 1.0)),
      GridQuantizer("ramp from", VelocityGrid{10.0, 1, 1000}, AccelerationGrid::ramp_time(0.01, 25.0).steps(2, 40)),
  };
  const DriveMotion wishes[] = {{1234.4, 5678.9, 4321.1}, {26.0, 0.5, 3.0e6}, {1e9, 1e9, 1e-9}, {5.0, 10.0, 10.0}};
  int compared = 0;
  for (const GridQuantizer& grid : grids) {
    for (const DriveMotion& wish : wishes) {
      for (const int neighbours : {1, 2, 7}) {
        for (const bool at_velocity : {false, true}) {
          std::vector<DriveSetting> expected;
          DriveMotion desired = wish;
          if (at_velocity) {  // a velocity the grid offers
            const auto first_round = candidates_of(grid, wish, neighbours);
            if (first_round.empty()) continue;
            desired.velocity_counts_per_s = first_round.back().realized.velocity_counts_per_s;
            grid.candidates_at_velocity(desired, neighbours, expected);
          } else {
            grid.candidates(desired, neighbours, expected);
          }
          std::vector<GridBlock> blocks;
          std::vector<GridRamp> ramps;
          grid.blocks(desired, neighbours, at_velocity, blocks, ramps);
          std::vector<DriveSetting> expanded;
          for (const GridBlock& b : blocks) {
            ASSERT_GT(b.accelerations, 0U);
            ASSERT_GT(b.decelerations, 0U);
            for (std::uint32_t ja = 0; ja < b.accelerations; ++ja) {
              for (std::uint32_t jd = 0; jd < b.decelerations; ++jd) {
                const GridRamp& a = ramps[b.first_ramp + ja];
                const GridRamp& d = ramps[b.first_ramp + b.accelerations + jd];
                expanded.push_back({{b.velocity_native, a.native, d.native},
                                    {b.velocity_counts_per_s, a.counts_per_s2, d.counts_per_s2}});
              }
            }
          }
          ASSERT_EQ(expanded.size(), expected.size()) << grid.name() << " neighbours " << neighbours;
          for (std::size_t k = 0; k < expected.size(); ++k) {
            EXPECT_EQ(expanded[k].native, expected[k].native) << k;
            EXPECT_EQ(expanded[k].realized.velocity_counts_per_s, expected[k].realized.velocity_counts_per_s) << k;
            EXPECT_EQ(expanded[k].realized.acceleration_counts_per_s2, expected[k].realized.acceleration_counts_per_s2);
            EXPECT_EQ(expanded[k].realized.deceleration_counts_per_s2, expected[k].realized.deceleration_counts_per_s2);
          }
          compared += static_cast<int>(expected.size());
        }
      }
    }
  }
  EXPECT_GT(compared, 1000);
}

TEST(Quantizers, IdentityPassesThrough) {
  const IdentityQuantizer q;
  const auto settings = candidates_of(q, {1.5, 2.5, 3.5}, 3);
  ASSERT_EQ(settings.size(), 1u);
  EXPECT_EQ(settings[0].realized.deceleration_counts_per_s2, 3.5);
}

TEST(Quantizers, RejectsMeaninglessGrids) {
  EXPECT_THROW(GridQuantizer("bad", VelocityGrid{0.0}, AccelerationGrid::rate(1.0)), std::invalid_argument);
  EXPECT_THROW(GridQuantizer("bad", VelocityGrid{1.0}, AccelerationGrid::ramp_time(-1.0)), std::invalid_argument);
  EXPECT_THROW(GridQuantizer("bad", VelocityGrid{1.0, 5, 4}, AccelerationGrid::rate(1.0)), std::invalid_argument);
  EXPECT_THROW(GridQuantizer("bad", VelocityGrid{1.0, 0, 4}, AccelerationGrid::rate(1.0)), std::invalid_argument);
}

// A family plugs its own drive in by deriving: here velocity in 10-pps steps, fixed acceleration.
class TenPpsFixedRamp final : public DriveQuantizer {
 public:
  void candidates(const DriveMotion& desired, int, std::vector<DriveSetting>& out) const override {
    const auto low = static_cast<std::int64_t>(desired.velocity_counts_per_s / 10.0);
    for (const std::int64_t n : {low, low + 1}) {
      out.push_back({{n, 0, 0}, {10.0 * static_cast<double>(n), 1000.0, 1000.0}});
    }
  }
  [[nodiscard]] std::string_view name() const override { return "ten-pps"; }
};

// ---- quantize_plan --------------------------------------------------------------------------

SyncPlan plan_of(const std::vector<AxisRequest>& axes) {
  auto result = plan_synchronized(axes);
  EXPECT_TRUE(result.ok());
  return std::move(result).value();
}

SyncPlan x1000_y333() {
  return plan_of({make_axis({.name = "x",
                             .target_user = 1000.0,
                             .max_velocity_user_per_s = 100.0,
                             .max_acceleration_user_per_s2 = 1000.0}),
                  make_axis({.name = "y",
                             .target_user = 333.0,
                             .max_velocity_user_per_s = 100.0,
                             .max_acceleration_user_per_s2 = 1000.0})});
}

TEST(QuantizePlan, RefinementPicksTheRoundingThatMinimizesSpread) {
  // x: 1000 counts, v 100 c/s, a = d = 1000 c/s^2; y: 333 counts, same limits.
  // Unit caps: V = min(100/1000, 100/333) = 0.1, A = min(1000/1000, 1000/333) = 1.
  // t_acc = 0.1 s, ramps 2 * 0.1^2/2 = 0.01 of the move, cruise 0.99/0.1 = 9.9 s: T = 10.1 s.
  // x wants (100, 1000, 1000) exactly; 101 / 1001 would exceed its limits, so it may only stay or
  // slow down. y wants (33.3, 333, 333). A trapezoid lasts D/v + v/2 * (1/a + 1/d):
  //   y plain rounding (33, 333, 333): 333/33 + 33/333 = 10.0909 + 0.0991 = 10.1900 -> spread 0.0900
  //   y (33, 332, 332): 333/33 + 33/332 = 10.1903;  x (99, 1000, 1000): 1000/99 + 99/1000 = 10.2000
  //   -> spread 0.0097, the smallest over all 8 x 27 combinations (checked by brute force).
  const SyncPlan plan = x1000_y333();
  ASSERT_NEAR(plan.duration_s(), 10.1, 1e-12);
  const PpsRateQuantizer pps;
  const std::vector<const DriveQuantizer*> quantizers{&pps, &pps};
  const auto result = quantize_plan(plan, quantizers, QuantizeOptions{.match_duration = false});
  ASSERT_TRUE(result.ok()) << result.error().message();
  const QuantizedPlan& q = result.value();
  EXPECT_EQ(q.axes[0].setting->native, (NativeMotion{99, 1000, 1000}));
  EXPECT_EQ(q.axes[1].setting->native, (NativeMotion{33, 332, 332}));
  const double x_arrival = 1000.0 / 99.0 + 99.0 / 1000.0;
  const double y_arrival = 333.0 / 33.0 + 33.0 / 332.0;
  EXPECT_NEAR(q.earliest_arrival_s, y_arrival, 1e-12);
  EXPECT_NEAR(q.latest_arrival_s, x_arrival, 1e-12);
  EXPECT_NEAR(q.predicted_spread_s(), x_arrival - y_arrival, 1e-12);
  EXPECT_EQ(q.axes[1].profile.sample(y_arrival).position_counts, 333.0);
}

TEST(QuantizePlan, DurationMatchingRampsShrinkTheSpread) {
  // Same plan (T = 10.1 s). With y at 34 c/s, ramps a = d = lambda * 333 arrive at T when
  // 333/34 + 34/(lambda*333) = 10.1  ->  lambda = (34/333) / (10.1 - 9.794118) = 0.33380,
  // a = 111.16 -> 111 c/s^2: 333/34 + 34/111 = 9.794118 + 0.306306 = 10.100424 s.
  // x (100, 999, 999): 1000/100 + 100/999 = 10.100100 s. Spread 0.000324 s instead of 0.0097 s.
  const SyncPlan plan = x1000_y333();
  const PpsRateQuantizer pps;
  const std::vector<const DriveQuantizer*> quantizers{&pps, &pps};
  const auto result = quantize_plan(plan, quantizers);
  ASSERT_TRUE(result.ok());
  const QuantizedPlan& q = result.value();
  EXPECT_EQ(q.axes[0].setting->native, (NativeMotion{100, 999, 999}));
  EXPECT_EQ(q.axes[1].setting->native, (NativeMotion{34, 111, 111}));
  EXPECT_NEAR(q.predicted_spread_s(), (333.0 / 34.0 + 34.0 / 111.0) - (10.0 + 100.0 / 999.0), 1e-12);
}

TEST(QuantizePlan, SlowTinyMoveGetsATriangleOfRefittedRamps) {
  // x: 100000 counts, v 1000, a 1000 (identity drive): T = 100000/1000 + 1000/1000 = 101 s.
  // y: 3 counts on a pps + ramp-ms drive. Planned v = 3 * 0.01 = 0.03 c/s -> 1 pps at least;
  // planned a = 3 * 0.01 = 0.03 c/s^2, i.e. a ramp of 1/0.03 s = 33333 ms: at 1 pps the ramps would
  // need 2 * 1/(2 * 0.03) = 33 counts > 3, so a triangle of 2 * sqrt(3/0.03) = 20 s: 81 s early.
  // Re-fitted: a triangle lasting 101 s needs a = 4 * 3 / 101^2 = 0.0011763 c/s^2, a ramp of
  // 1/a = 850083 ms; 2 * sqrt(3 * 850.083) = 101.0000 s.
  const SyncPlan plan = plan_of({make_axis({.name = "x",
                                            .target_user = 100000.0,
                                            .max_velocity_user_per_s = 1000.0,
                                            .max_acceleration_user_per_s2 = 1000.0}),
                                 make_axis({.name = "y",
                                            .target_user = 3.0,
                                            .max_velocity_user_per_s = 1000.0,
                                            .max_acceleration_user_per_s2 = 1000.0})});
  ASSERT_NEAR(plan.duration_s(), 101.0, 1e-9);
  const IdentityQuantizer identity;
  const PpsRampTimeQuantizer ramp_ms;
  const std::vector<const DriveQuantizer*> quantizers{&identity, &ramp_ms};

  const auto rounded = quantize_plan(plan, quantizers, QuantizeOptions{.match_duration = false});
  ASSERT_TRUE(rounded.ok());
  EXPECT_NEAR(rounded.value().axes[1].duration_s(), 20.0, 0.01);

  const auto refitted = quantize_plan(plan, quantizers);
  ASSERT_TRUE(refitted.ok());
  const RealizedAxis& y = refitted.value().axes[1];
  // (1 pps with 850083 ms and 2 pps with 1700166 ms are the same triangle: the peak stays below
  // either velocity.)
  EXPECT_LE(y.setting->native.velocity, 2);
  EXPECT_NEAR(y.setting->realized.acceleration_counts_per_s2, 4.0 * 3.0 / (101.0 * 101.0), 1e-8);
  EXPECT_LT(refitted.value().predicted_spread_s(), 1e-4);
  EXPECT_EQ(y.profile.sample(y.duration_s()).position_counts, 3.0);
}

TEST(QuantizePlan, IdentityHasNoSpreadAndStillAxesGetNoSetting) {
  const SyncPlan plan = plan_of({make_axis({.target_user = 10.0}), make_axis({.start_user = 4.0, .target_user = 4.0}),
                                 make_axis({.target_user = -7.0})});
  const IdentityQuantizer identity;
  const std::vector<const DriveQuantizer*> quantizers{&identity, &identity, &identity};
  const auto result = quantize_plan(plan, quantizers);
  ASSERT_TRUE(result.ok());
  EXPECT_NEAR(result.value().predicted_spread_s(), 0.0, 1e-12);
  EXPECT_NEAR(result.value().latest_arrival_s, plan.duration_s(), 1e-9);
  EXPECT_FALSE(result.value().axes[1].setting.has_value());
  EXPECT_EQ(result.value().axes[1].duration_s(), 0.0);
  EXPECT_EQ(result.value().axes[1].profile.sample(1.0).position_counts, 4.0);
}

TEST(QuantizePlan, AllStillNeedsNoQuantizerCall) {
  const SyncPlan plan = plan_of({make_axis({.start_user = 1.0, .target_user = 1.0})});
  const TenPpsFixedRamp custom;
  const std::vector<const DriveQuantizer*> quantizers{&custom};
  const auto result = quantize_plan(plan, quantizers);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.value().predicted_spread_s(), 0.0);
  EXPECT_EQ(result.value().latest_arrival_s, 0.0);
}

TEST(QuantizePlan, CustomFamilyQuantizerPlugsIn) {
  // 100 counts at v 55 c/s, a 1000: the drive offers 50 or 60 c/s; 60 exceeds the limit of 55.
  const SyncPlan plan = plan_of(
      {make_axis({.target_user = 100.0, .max_velocity_user_per_s = 55.0, .max_acceleration_user_per_s2 = 1000.0})});
  const TenPpsFixedRamp custom;
  const std::vector<const DriveQuantizer*> quantizers{&custom};
  const auto result = quantize_plan(plan, quantizers);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.value().axes[0].setting->native.velocity, 5);
  // 100/50 + 50/1000 = 2.05 s.
  EXPECT_NEAR(result.value().latest_arrival_s, 2.05, 1e-12);
}

TEST(QuantizePlan, Errors) {
  const SyncPlan plan = plan_of({make_axis({.name = "slow",
                                            .target_user = 100.0,
                                            .counts_per_user = 1.0,
                                            .max_velocity_user_per_s = 10.0,
                                            .max_acceleration_user_per_s2 = 100.0})});
  const PpsRateQuantizer pps;
  const std::vector<const DriveQuantizer*> none;
  EXPECT_EQ(quantize_plan(plan, none).error().code, PlanErrc::kQuantizerCountMismatch);
  const std::vector<const DriveQuantizer*> null_one{nullptr};
  EXPECT_EQ(quantize_plan(plan, null_one).error().code, PlanErrc::kQuantizerCountMismatch);
  // 1 rpm of a 3200-count motor is 53.3 c/s: above the 10 c/s limit, nothing representable.
  const RpmQuantizer coarse(3200.0, 1.0, AccelerationGrid::ramp_time(0.001));
  const std::vector<const DriveQuantizer*> coarse_one{&coarse};
  const auto result = quantize_plan(plan, coarse_one);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, PlanErrc::kQuantizationImpossible);
  EXPECT_EQ(result.error().axis_name, "slow");
  EXPECT_NE(result.error().message().find("axis 0 'slow'"), std::string::npos);
}

}  // namespace
}  // namespace motion::planner
