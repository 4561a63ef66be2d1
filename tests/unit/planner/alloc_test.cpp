// The coordinator's planning path allocates nothing once its buffers have grown:
// plan_synchronized_into + quantize_plan_into into a plan and a result reused from move to move
// (the hot path of issue 17), counted by this test binary's own replacement of operator new. Own
// executable: the replacement counts every allocation of the binary.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "motion/planner/quantize_plan.hpp"

namespace {

std::atomic<std::size_t> g_allocations{0};

void* counted_alloc(std::size_t size) {
  g_allocations.fetch_add(1);
  void* p = std::malloc(size == 0 ? 1 : size);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}

}  // namespace

void* operator new(std::size_t size) { return counted_alloc(size); }
void* operator new[](std::size_t size) { return counted_alloc(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace motion::planner {
namespace {

// The benchmark's workload: lead-screw axes (1600 counts/mm, 50 mm/s, 500 mm/s^2) over every
// quantizer kind, targets spread over +-100 mm.
struct Workload {
  std::vector<AxisRequest> axes;
  std::vector<const DriveQuantizer*> quantizers;
};

Workload make_workload(int axis_count, int seed) {
  static const IdentityQuantizer identity;
  static const PpsRateQuantizer pps_rate;
  static const PpsRampTimeQuantizer pps_ramp_ms;
  static const RpmQuantizer rpm(3200.0, 1.0, AccelerationGrid::rpm_per_s(3200.0, 1.0));
  static const RpmQuantizer rpm_ramp_ms(3200.0, 0.1, AccelerationGrid::ramp_time(0.001, 100.0));
  static const DriveQuantizer* const kinds[] = {&pps_rate, &pps_ramp_ms, &rpm, &identity, &rpm_ramp_ms};
  Workload w;
  for (int i = 0; i < axis_count; ++i) {
    const double start = -100.0 + 37.0 * ((i * 7 + seed * 13) % 11) / 2.0;
    const double target = 100.0 - 41.0 * ((i * 5 + seed * 3) % 9) / 2.0;
    w.axes.push_back(AxisRequest{"axis", start, target, 1600.0, AxisLimits{-200.0, 200.0, 50.0, 500.0, std::nullopt}});
    w.quantizers.push_back(kinds[(i + seed) % 5]);
  }
  return w;
}

TEST(PlannerAllocations, ReusedPlanAndResultAllocateNothingOnceGrown) {
  std::vector<Workload> workloads;
  for (const int axes : {64, 8, 2, 33}) {
    for (int seed = 0; seed < 3; ++seed) workloads.push_back(make_workload(axes, seed));
  }
  SyncPlan plan;
  QuantizedPlan result;
  const auto plan_all = [&] {
    for (const Workload& w : workloads) {
      ASSERT_FALSE(plan_synchronized_into(w.axes, plan).has_value());
      ASSERT_FALSE(quantize_plan_into(plan, w.quantizers, result).has_value());
      ASSERT_FALSE(result.axes.empty());
    }
  };
  plan_all();  // the buffers grow to the largest plan
  const std::size_t before = g_allocations.load();
  for (int round = 0; round < 3; ++round) plan_all();
  EXPECT_EQ(g_allocations.load() - before, 0U) << "allocations on the reused planning path";
}

// The counter sees this binary's allocations (the test above would pass vacuously otherwise).
TEST(PlannerAllocations, TheCounterCountsAFreshResult) {
  const Workload w = make_workload(8, 0);
  const std::size_t before = g_allocations.load();
  const auto plan = plan_synchronized(w.axes);
  ASSERT_TRUE(plan.ok());
  const auto quantized = quantize_plan(plan.value(), w.quantizers);
  ASSERT_TRUE(quantized.ok());
  EXPECT_GT(g_allocations.load() - before, 0U);
}

}  // namespace
}  // namespace motion::planner
