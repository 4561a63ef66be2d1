// Bit-for-bit regression of planning + quantization: thousands of random requests (own
// portable generator, fixed seed) are planned and quantized, and every output (counts, every
// double's bits, the native integers, error codes) is hashed per case and compared with
// quantize_golden.inc, recorded from the implementation before the hot-path optimization. Any
// change of a result, however small, fails here, naming the case to replay. quantize_plan_into()
// into one result reused over all cases must give the same as quantize_plan(), and
// plan_synchronized_into() the same as plan_synchronized().
//
// To re-record after an intended change of results (say why in the commit):
//   MOTION_PLANNER_GOLDEN_OUT=$PWD/tests/unit/planner/quantize_golden.inc <test_planner binary>
//     --gtest_filter='QuantizeGolden.*'
// The hashes hold for IEEE double arithmetic without contraction into fused multiply-adds (x86-64
// as built here); a target that contracts by default would need -ffp-contract=off to match.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "motion/planner/quantize_plan.hpp"

namespace motion::planner {
namespace {

constexpr std::uint64_t kGolden[] = {
#include "quantize_golden.inc"
};
constexpr int kCases = 4000;
constexpr double kInf = std::numeric_limits<double>::infinity();

// splitmix64: the same numbers on every platform and standard library.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double unit() { return static_cast<double>(next() >> 11) * 0x1p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }
  double log_uniform(double lo, double hi) { return std::exp(uniform(std::log(lo), std::log(hi))); }
  int integer(int lo, int hi) { return lo + static_cast<int>(next() % static_cast<std::uint64_t>(hi - lo + 1)); }
  bool chance(double p) { return unit() < p; }
  template <typename T, std::size_t N>
  T pick(const std::array<T, N>& from) {
    return from[static_cast<std::size_t>(integer(0, static_cast<int>(N) - 1))];
  }

 private:
  std::uint64_t state_;
};

// A family quantizer that offers a grid's settings in reverse order: velocities descending, so the
// refinement's own ordering and the default candidates_at_velocity() are exercised.
class ReversedGrid final : public DriveQuantizer {
 public:
  explicit ReversedGrid(GridQuantizer grid) : grid_(std::move(grid)) {}
  void candidates(const DriveMotion& desired, int neighbours, std::vector<DriveSetting>& out) const override {
    const auto first = static_cast<std::ptrdiff_t>(out.size());
    grid_.candidates(desired, neighbours, out);
    std::reverse(out.begin() + first, out.end());
  }
  [[nodiscard]] std::string_view name() const override { return "reversed"; }

 private:
  GridQuantizer grid_;
};

std::int64_t steps_limit(Random& r) {
  return r.chance(0.85) ? std::numeric_limits<std::int32_t>::max() : r.integer(1, 5000);
}

AccelerationGrid random_acceleration(Random& r) {
  const std::int64_t min = r.chance(0.8) ? 1 : r.integer(2, 50);
  const std::int64_t max = r.chance(0.7) ? std::numeric_limits<std::int32_t>::max() : min + r.integer(0, 3000);
  if (r.chance(0.5)) return AccelerationGrid::rate(r.log_uniform(1e-2, 1e4)).steps(min, max);
  return AccelerationGrid::ramp_time(r.log_uniform(1e-4, 0.1), r.chance(0.6) ? 0.0 : r.log_uniform(1e-2, 1e4))
      .steps(min, max);
}

std::unique_ptr<DriveQuantizer> random_quantizer(Random& r) {
  constexpr std::array kCountsPerRev{200.0, 3200.0, 10000.0, 51200.0};
  constexpr std::array kRpmSteps{1.0, 0.1, 0.01};
  switch (r.integer(0, 6)) {
    case 0: return std::make_unique<IdentityQuantizer>();
    case 1: return std::make_unique<PpsRateQuantizer>(steps_limit(r), steps_limit(r));
    case 2: return std::make_unique<PpsRampTimeQuantizer>(steps_limit(r), steps_limit(r));
    case 3: {
      const double counts = r.pick(kCountsPerRev);
      return std::make_unique<RpmQuantizer>(counts, r.pick(kRpmSteps), AccelerationGrid::rpm_per_s(counts, 1.0));
    }
    case 4:
      return std::make_unique<RpmQuantizer>(r.pick(kCountsPerRev), r.pick(kRpmSteps),
                                            AccelerationGrid::ramp_time(0.001, r.chance(0.5) ? 0.0 : 100.0));
    case 5: {
      const std::int64_t min = r.chance(0.8) ? 1 : r.integer(2, 20);
      return std::make_unique<GridQuantizer>(
          "random",
          VelocityGrid{r.log_uniform(1e-3, 1e3), min, r.chance(0.7) ? 1'000'000'000 : min + r.integer(0, 2000)},
          random_acceleration(r));
    }
    default:
      return std::make_unique<ReversedGrid>(
          GridQuantizer("reversed", VelocityGrid{r.log_uniform(0.1, 100.0)}, random_acceleration(r)));
  }
}

AxisRequest random_axis(Random& r, int index) {
  constexpr std::array kUnits{1.0, 1600.0, 3200.0 / 360.0, 0.001};
  AxisRequest a;
  a.name = "a" + std::to_string(index);
  const int unit = r.integer(0, 19);
  a.counts_per_user = unit < 8 ? r.pick(kUnits) : unit < 19 ? r.log_uniform(1e-3, 1e5) : r.log_uniform(1e8, 1e11);
  const bool bounded = r.chance(0.7);
  a.limits.min_position_user = bounded ? -200.0 : -kInf;
  a.limits.max_position_user = bounded ? 200.0 : kInf;
  // Counts/s and counts/s^2; 3% slow enough that some grids have no value within them.
  const auto rate = [&](double top) {
    return (r.chance(0.97) ? r.log_uniform(100.0, top) : r.log_uniform(1.0, 100.0));
  };
  a.limits.max_velocity_user_per_s = rate(1e7) / a.counts_per_user;
  a.limits.max_acceleration_user_per_s2 = rate(1e8) / a.counts_per_user;
  if (r.chance(0.4)) a.limits.max_deceleration_user_per_s2 = rate(1e8) / a.counts_per_user;
  const double start_counts = std::round(r.uniform(-150.0, 150.0) * a.counts_per_user);
  a.start_user = r.chance(0.03) ? 250.0 : start_counts / a.counts_per_user;  // may start outside the limits
  const double count = 1.0 / a.counts_per_user;
  switch (r.integer(0, 10)) {
    case 0: a.target_user = a.start_user; break;                                          // already there
    case 1: a.target_user = a.start_user + (r.chance(0.5) ? 0.3 : -0.45) * count; break;  // under a count
    case 2: a.target_user = a.start_user + (r.chance(0.5) ? 0.6 : -0.7) * count; break;   // rounds to one count
    case 3: a.target_user = a.start_user + r.integer(-3, 3) * count; break;               // tiny
    case 4: a.target_user = r.chance(0.5) ? a.limits.max_position_user : a.limits.min_position_user; break;
    case 5: a.target_user = r.chance(0.5) ? 200.0 : -200.0; break;  // at the limit when bounded
    default: a.target_user = r.uniform(-150.0, 150.0);
  }
  if (!std::isfinite(a.target_user)) a.target_user = r.uniform(-150.0, 150.0);
  a.target_user = std::clamp(a.target_user, a.limits.min_position_user, a.limits.max_position_user);
  return a;
}

class Digest {
 public:
  void add(std::uint64_t v) {
    for (int byte = 0; byte < 8; ++byte) { hash_ = (hash_ ^ ((v >> (8 * byte)) & 0xffU)) * 0x100000001b3ULL; }
  }
  void add(double v) { add(std::bit_cast<std::uint64_t>(v)); }
  void add(std::int64_t v) { add(static_cast<std::uint64_t>(v)); }
  void add(const TrapezoidShape& s) {
    for (const double v : {s.peak_velocity, s.acceleration, s.deceleration, s.t_acc_s, s.t_cruise_s, s.t_dec_s}) add(v);
  }
  void add(const AxisProfile& p) {
    add(p.start_counts);
    add(p.target_counts);
    add(p.shape);
  }
  void add(const PlanFailure& f) {
    add(static_cast<std::uint64_t>(f.code));
    add(static_cast<std::uint64_t>(f.axis_index));
    add(f.value);
    add(f.limit);
  }
  [[nodiscard]] std::uint64_t value() const { return hash_; }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

void add_quantized(Digest& d, const QuantizedPlan& q) {
  d.add(q.planned_duration_s);
  d.add(q.earliest_arrival_s);
  d.add(q.latest_arrival_s);
  d.add(static_cast<std::uint64_t>(q.axes.size()));
  for (const RealizedAxis& axis : q.axes) {
    d.add(static_cast<std::uint64_t>(axis.setting.has_value()));
    if (axis.setting) {
      const NativeMotion& n = axis.setting->native;
      const DriveMotion& m = axis.setting->realized;
      for (const std::int64_t v : {n.velocity, n.acceleration, n.deceleration}) d.add(v);
      for (const double v : {m.velocity_counts_per_s, m.acceleration_counts_per_s2, m.deceleration_counts_per_s2}) {
        d.add(v);
      }
    }
    d.add(axis.profile);
  }
}

enum class Outcome { kPlanRefused, kQuantizationRefused, kQuantized };

struct CaseResult {
  std::uint64_t hash;
  Outcome outcome;
};

// Plans and quantizes case `index` (its own seed) and hashes everything that came out.
CaseResult run_case(int index) {
  Random r(std::uint64_t{0x5eed0000} + static_cast<std::uint64_t>(index));
  const int axis_count = r.chance(0.02) ? r.integer(10, 64) : r.integer(1, 9);
  std::vector<AxisRequest> axes;
  std::vector<std::unique_ptr<DriveQuantizer>> owned;
  std::vector<const DriveQuantizer*> quantizers;
  for (int i = 0; i < axis_count; ++i) {
    axes.push_back(random_axis(r, i));
    owned.push_back(random_quantizer(r));
    quantizers.push_back(owned.back().get());
  }
  if (r.chance(0.08)) {  // an invalid request: refused by the planner
    AxisRequest& bad = axes[static_cast<std::size_t>(r.integer(0, axis_count - 1))];
    bad.target_user = r.chance(0.5) ? 1e18 : std::nextafter(bad.limits.max_position_user, kInf);
    if (!std::isfinite(bad.target_user)) bad.target_user = 1e18;
  }
  const PlanOptions plan_options{r.chance(0.5) ? 1.0 : r.uniform(0.01, 1.0),
                                 r.chance(0.5) ? 1.0 : r.uniform(0.01, 1.0)};
  const QuantizeOptions options{.neighbours = r.chance(0.8) ? 1 : r.integer(2, 3), .match_duration = r.chance(0.8)};

  Digest d;
  const auto plan = plan_synchronized(axes, plan_options);
  if (!plan.ok()) {
    static SyncPlan refused;
    const auto failure = plan_synchronized_into(axes, refused, plan_options);
    EXPECT_TRUE(failure.has_value() && failure->code == plan.error().code) << "case " << index;
    d.add(plan.error());
    return {d.value(), Outcome::kPlanRefused};
  }
  d.add(plan.value().time_law);
  for (const AxisProfile& p : plan.value().axes) d.add(p);
  // plan_synchronized_into a plan reused from case to case plans the same.
  static SyncPlan reused_plan;
  EXPECT_FALSE(plan_synchronized_into(axes, reused_plan, plan_options).has_value()) << "case " << index;
  Digest into_plan;
  into_plan.add(reused_plan.time_law);
  for (const AxisProfile& p : reused_plan.axes) into_plan.add(p);
  Digest from_plan;
  from_plan.add(plan.value().time_law);
  for (const AxisProfile& p : plan.value().axes) from_plan.add(p);
  EXPECT_EQ(into_plan.value(), from_plan.value()) << "case " << index << ": plan_synchronized_into differs";
  EXPECT_EQ(reused_plan.axis_names, plan.value().axis_names);
  EXPECT_EQ(reused_plan.velocity_limit_counts_per_s, plan.value().velocity_limit_counts_per_s);
  EXPECT_EQ(reused_plan.distance_counts, plan.value().distance_counts);
  const auto quantized = quantize_plan(plan.value(), quantizers, options);
  // The same into a result reused from case to case (larger and smaller plans before it).
  static QuantizedPlan reused;
  const auto failure = quantize_plan_into(plan.value(), quantizers, reused, options);
  EXPECT_EQ(failure.has_value(), !quantized.ok()) << "case " << index;
  Digest into = d;
  if (!quantized.ok()) {
    d.add(quantized.error());
    if (failure) into.add(*failure);
    EXPECT_EQ(into.value(), d.value()) << "case " << index << ": quantize_plan_into failed otherwise";
    return {d.value(), Outcome::kQuantizationRefused};
  }
  add_quantized(d, quantized.value());
  if (!failure) add_quantized(into, reused);
  EXPECT_EQ(into.value(), d.value()) << "case " << index << ": quantize_plan_into differs";
  return {d.value(), Outcome::kQuantized};
}

TEST(QuantizeGolden, EveryOutputBitIdenticalToTheRecordedOnes) {
  std::vector<std::uint64_t> hashes;
  std::array<int, 3> outcomes{};
  for (int i = 0; i < kCases; ++i) {
    const CaseResult result = run_case(i);
    hashes.push_back(result.hash);
    ++outcomes[static_cast<std::size_t>(result.outcome)];
  }
  // The mix covers refusals but mostly compares quantized plans.
  EXPECT_GT(outcomes[0], 0);
  EXPECT_GT(outcomes[1], 0);
  EXPECT_GT(outcomes[2], kCases * 6 / 10) << "plan refused " << outcomes[0] << ", quantization refused " << outcomes[1];
  if (const char* out_path = std::getenv("MOTION_PLANNER_GOLDEN_OUT")) {
    std::FILE* out = std::fopen(out_path, "w");
    ASSERT_NE(out, nullptr) << out_path;
    std::fprintf(out, "// Generated by equivalence_test.cpp (MOTION_PLANNER_GOLDEN_OUT): one hash per case.\n");
    for (std::size_t i = 0; i < hashes.size(); ++i) {
      std::fprintf(out, "0x%016llxULL,%s", static_cast<unsigned long long>(hashes[i]), i % 4 == 3 ? "\n" : " ");
    }
    std::fprintf(out, "\n");
    std::fclose(out);
    GTEST_SKIP() << "recorded " << hashes.size() << " hashes to " << out_path << " (plan refused " << outcomes[0]
                 << ", quantization refused " << outcomes[1] << ", quantized " << outcomes[2] << ")";
  }
  ASSERT_EQ(std::size(kGolden), hashes.size());
  int mismatches = 0;
  for (std::size_t i = 0; i < hashes.size(); ++i) {
    if (hashes[i] != kGolden[i] && ++mismatches <= 10) ADD_FAILURE() << "case " << i << " differs from the recording";
  }
  EXPECT_EQ(mismatches, 0);
}

}  // namespace
}  // namespace motion::planner
