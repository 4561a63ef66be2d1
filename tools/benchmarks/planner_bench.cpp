// Planning cost of a synchronized move, with and without quantization, for 2, 8 and 64 axes.
// Axes are random but from a fixed seed, with a mix of all quantizer kinds. After the google
// benchmark rows, a figure table: the fastest per-plan time over batches (the least disturbed by
// the other processes of a shared machine) against the 5 us goal and against planning
// without quantization, measured in the same run; and the same into a plan and a result reused
// from call to call (no allocation), as the coordinator calls it.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <random>
#include <vector>

#include "bench_table.hpp"
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

// The fastest per-call time of `work` in microseconds, over `batches` batches of `calls` calls.
double fastest_us(const std::function<void()>& work, int batches = 200, int calls = 200) {
  double best = 1e300;
  for (int b = 0; b < batches; ++b) {
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < calls; ++k) work();
    best = std::min(
        best, std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count() / calls);
  }
  return best;
}

void print_figures() {
  constexpr double kGoalUs = 5.0;  // issue 17: 8 axes with quantization
  std::vector<bench::Row> rows;
  double sink = 0.0;
  for (const double axes : {8.0, 64.0}) {
    const Workload w = make_workload(static_cast<int>(axes));
    const double plan_us = fastest_us([&] { sink += plan_synchronized(w.axes).value().duration_s(); });
    const double quantized_us = fastest_us(
        [&] { sink += quantize_plan(plan_synchronized(w.axes).value(), w.quantizers).value().predicted_spread_s(); });
    // The coordinator's way: into a plan and a result kept from move to move.
    SyncPlan reused_plan;
    QuantizedPlan reused;
    const double into_us = fastest_us([&] {
      const bool failed = plan_synchronized_into(w.axes, reused_plan).has_value() ||
                          quantize_plan_into(reused_plan, w.quantizers, reused).has_value();
      sink += failed ? 0.0 : reused.predicted_spread_s();
    });
    const double scale = axes / 8.0;
    rows.push_back({bench::fmt("%.0f axes, plan + quantize (match_duration)", axes),
                    bench::fmt("%.2f us", quantized_us), bench::fmt("%.2f us goal", kGoalUs * scale),
                    quantized_us / (kGoalUs * scale), axes == 8 ? "issue 17 goal" : "the goal scaled by axes / 8"});
    rows.push_back({bench::fmt("%.0f axes, plan + quantize (match_duration)", axes),
                    bench::fmt("%.2f us", quantized_us), bench::fmt("%.2f us plan alone", plan_us),
                    quantized_us / plan_us, "planning without quantization, same run"});
    rows.push_back({bench::fmt("%.0f axes, the same into a reused plan and result", axes),
                    bench::fmt("%.2f us", into_us), bench::fmt("%.2f us goal", kGoalUs * scale),
                    into_us / (kGoalUs * scale), "plan_synchronized_into + quantize_plan_into (coordinator)"});
  }
  bench::print_rows(rows, "figure (fastest of 200 batches)", "bound");
  benchmark::DoNotOptimize(sink);
}

}  // namespace
}  // namespace motion::planner

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  motion::planner::print_figures();
  return 0;
}
