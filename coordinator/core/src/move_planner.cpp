#include "motion/coordinator/move_planner.hpp"

#include <limits>
#include <memory>

#include "motion/planner/quantize_plan.hpp"
#include "motion/planner/sync_planner.hpp"

namespace motion::coordinator {
namespace {

struct Quantizers {
  planner::PpsRateQuantizer uim342_rate;
  planner::PpsRampTimeQuantizer uim342_time;
  planner::IdentityQuantizer identity;
};

const planner::DriveQuantizer& quantizer_for(const Quantizers& q, const config::Drive& drive) {
  if (drive.family == config::Family::kUim342) {
    auto it = drive.setup.find("acceleration_unit");
    const bool time = it != drive.setup.end() && std::get<std::string>(it->second) == "time";
    return time ? static_cast<const planner::DriveQuantizer&>(q.uim342_time) : q.uim342_rate;
  }
  return q.identity;
}

}  // namespace

MovePlanner make_move_planner(const config::Config& config) {
  auto quantizers = std::make_shared<Quantizers>();
  return [quantizers, &config](const std::vector<PlanInput>& inputs, double velocity_scale,
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
      const config::Axis* axis = config.find_axis(in.axis);
      per_axis.push_back(&quantizer_for(*quantizers, *config.drive_of(*axis)));
    }
    auto plan = planner::plan_synchronized(requests, {velocity_scale, acceleration_scale});
    if (!plan) return plan.error().message();
    auto realized = planner::quantize_plan(plan.value(), per_axis);
    if (!realized) return realized.error().message();
    MovePlan out;
    out.duration_s = realized.value().latest_arrival_s;
    out.predicted_skew_us = realized.value().predicted_spread_s() * 1e6;
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      const auto& axis = realized.value().axes[i];
      AxisPlan p;
      p.axis = inputs[i].axis;
      p.target_counts = inputs[i].target_counts;
      if (axis.setting) {
        p.velocity = axis.setting->realized.velocity_counts_per_s;
        p.acceleration = axis.setting->realized.acceleration_counts_per_s2;
        p.deceleration = axis.setting->realized.deceleration_counts_per_s2;
      }
      p.duration_s = axis.duration_s();
      out.axes.push_back(p);
    }
    return out;
  };
}

}  // namespace motion::coordinator
