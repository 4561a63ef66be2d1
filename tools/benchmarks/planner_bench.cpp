// Planning cost of a synchronized move, with and without quantization, for 2, 8 and 64 axes.
// Axes are random but from a fixed seed, with a mix of all quantizer kinds.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "motion/planner/quantize_plan.hpp"

namespace motion::planner {
namespace {

struct Workload {
  std::vector<AxisRequest> axes;
  std::vector<const DriveQuantizer*> quantizers;
};

Workload make_workload(int axis_count) {
  static const IdentityQuantizer identity;
  static const PpsRateQuantizer pps_rate;
  static const PpsRampTimeQuantizer pps_ramp_ms;
  static const RpmQuantizer rpm(3200.0, 1.0, AccelerationGrid::rpm_per_s(3200.0, 1.0));
  static const DriveQuantizer* const kinds[] = {&pps_rate, &pps_ramp_ms, &rpm, &identity};

  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> position(-100.0, 100.0);
  Workload w;
  for (int i = 0; i < axis_count; ++i) {
    // 1600 counts/mm, 50 mm/s, 500 mm/s^2: typical of a lead-screw stepper axis.
    w.axes.push_back(AxisRequest{"axis", position(rng), position(rng), 1600.0,
                                 AxisLimits{-200.0, 200.0, 50.0, 500.0, std::nullopt}});
    w.quantizers.push_back(kinds[i % 4]);
  }
  return w;
}

void BM_Plan(benchmark::State& state) {
  const Workload w = make_workload(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    auto plan = plan_synchronized(w.axes);
    benchmark::DoNotOptimize(plan);
  }
}

// range(1): QuantizeOptions::match_duration (0: rounding neighbours only).
void BM_PlanAndQuantize(benchmark::State& state) {
  const Workload w = make_workload(static_cast<int>(state.range(0)));
  const QuantizeOptions options{.match_duration = state.range(1) != 0};
  double spread_s = 0.0;
  for (auto _ : state) {
    auto plan = plan_synchronized(w.axes);
    auto quantized = quantize_plan(plan.value(), w.quantizers, options);
    spread_s = quantized.value().predicted_spread_s();
    benchmark::DoNotOptimize(quantized);
  }
  state.counters["spread_us"] = spread_s * 1e6;
}

BENCHMARK(BM_Plan)->ArgName("axes")->Arg(2)->Arg(8)->Arg(64);
BENCHMARK(BM_PlanAndQuantize)->ArgNames({"axes", "match"})->ArgsProduct({{2, 8, 64}, {0, 1}});

}  // namespace
}  // namespace motion::planner

BENCHMARK_MAIN();
