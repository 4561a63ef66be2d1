#include "motion/coordinator/move_planner.hpp"

#include <cmath>
#include <limits>
#include <memory>

#include "motion/planner/quantize_plan.hpp"
#include "motion/planner/sync_planner.hpp"

namespace motion::coordinator {

std::variant<std::shared_ptr<const planner::DriveQuantizer>, std::string> quantizer_from_model(
    const motionlcm::drive_model_t& m) {
  using M = motionlcm::drive_model_t;
  const auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!positive(m.velocity_step))
    return "velocity step " + std::to_string(m.velocity_step) + " counts/s is not positive";
  if (!positive(m.acceleration_step))
    return "acceleration step " + std::to_string(m.acceleration_step) + " is not positive";
  if (m.velocity_min < 1 || m.velocity_max < m.velocity_min) {
    return "velocity range " + std::to_string(m.velocity_min) + ".." + std::to_string(m.velocity_max) + " is empty";
  }
  if (m.acceleration_min < 1 || m.acceleration_max < m.acceleration_min) {
    return "acceleration range " + std::to_string(m.acceleration_min) + ".." + std::to_string(m.acceleration_max) +
           " is empty";
  }
  if (!std::isfinite(m.ramp_from) || m.ramp_from < 0)
    return "ramp start speed " + std::to_string(m.ramp_from) + " is negative";
  planner::AccelerationGrid grid;
  switch (m.acceleration_kind) {
    case M::ACCEL_RATE: grid = planner::AccelerationGrid::rate(m.acceleration_step); break;
    case M::ACCEL_RAMP_TIME: grid = planner::AccelerationGrid::ramp_time(m.acceleration_step, m.ramp_from); break;
    default: return "unknown acceleration kind " + std::to_string(m.acceleration_kind);
  }
  return std::make_shared<planner::GridQuantizer>(
      m.grid.empty() ? m.family : m.grid, planner::VelocityGrid{m.velocity_step, m.velocity_min, m.velocity_max},
      grid.steps(m.acceleration_min, m.acceleration_max));
}

MovePlanner make_move_planner() {
  return [](const std::vector<PlanInput>& inputs, double velocity_scale,
            double acceleration_scale) -> std::variant<MovePlan, std::string> {
    // The coordinator has checked positions against the limits in user units; here everything is
    // in counts (counts_per_user = 1) and position limits are open.
    constexpr double kOpen = std::numeric_limits<double>::infinity();
    std::vector<planner::AxisRequest> requests;
    std::vector<const planner::DriveQuantizer*> per_axis;
    for (const auto& in : inputs) {
      planner::AxisRequest r;
      r.name = in.axis;
      r.start_user = static_cast<double>(in.start_counts);
      r.target_user = static_cast<double>(in.target_counts);
      r.counts_per_user = 1.0;
      r.limits = {-kOpen, kOpen, in.max_velocity, in.max_acceleration, std::nullopt};
      requests.push_back(r);
      if (!in.quantizer) return "axis " + in.axis + " has no drive model";
      per_axis.push_back(in.quantizer.get());
    }
    // Planned and quantized into this thread's plan and result, reused from move to move (no
    // allocation there once they have grown).
    thread_local planner::SyncPlan plan;
    thread_local planner::QuantizedPlan realized;
    if (auto failure = planner::plan_synchronized_into(requests, plan, {velocity_scale, acceleration_scale})) {
      return failure->message();
    }
    if (auto failure = planner::quantize_plan_into(plan, per_axis, realized)) return failure->message();
    MovePlan out;
    out.duration_s = realized.latest_arrival_s;
    out.predicted_skew_us = realized.predicted_spread_s() * 1e6;
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      const auto& axis = realized.axes[i];
      AxisPlan p;
      p.axis = inputs[i].axis;
      p.target_counts = inputs[i].target_counts;
      if (axis.setting) {
        p.velocity = axis.setting->realized.velocity_counts_per_s;
        p.acceleration = axis.setting->realized.acceleration_counts_per_s2;
        p.deceleration = axis.setting->realized.deceleration_counts_per_s2;
        p.native = axis.setting->native;
      }
      p.model_utime = inputs[i].model_utime;
      p.duration_s = axis.duration_s();
      out.axes.push_back(p);
    }
    return out;
  };
}

}  // namespace motion::coordinator
