#include "motion/coordinator/move_planner.hpp"

#include <limits>
#include <map>
#include <memory>

#include "motion/adam/units.hpp"
#include "motion/cia402/uc57_od.hpp"
#include "motion/cia402/uc57_units.hpp"
#include "motion/planner/quantize_plan.hpp"
#include "motion/planner/sync_planner.hpp"
#include "motion/uim242/instruction.hpp"
#include "motion/uim342/parameters.hpp"

namespace motion::coordinator {
namespace {

using QuantizerOrError = std::variant<std::shared_ptr<const planner::DriveQuantizer>, std::string>;

// UIM342: SP in integer pulse/s; AC/DC as acceleration_to_wire writes them for the set-up's IC[4].
QuantizerOrError uim342_quantizer(const config::Drive& drive) {
  namespace u = uim342;
  const bool time = drive.setup_text("acceleration_unit").value_or("rate") == "time";
  const auto unit = time ? u::AccelerationUnit::milliseconds : u::AccelerationUnit::pulses_per_s2;
  const auto speed = *u::value_range(u::FunctionCode::SP);
  const auto ramp = *u::value_range(u::FunctionCode::AC, 0, unit);
  // One native step of each: SP is 1 pulse/s, AC/DC 1 pulse/s^2 or 1 ms (acceleration_from_wire).
  const double pps_per_step = 1.0;
  planner::AccelerationGrid grid;
  if (time) {
    const double cut_in = static_cast<double>(drive.setup_integer("cut_in_speed").value_or(0));
    // acceleration_from_wire(1 ms) over a 1 pulse/s change = 1 / seconds per step.
    const double seconds_per_step = 1.0 / u::acceleration_from_wire(1, unit, cut_in + 1.0, cut_in);
    grid = planner::AccelerationGrid::ramp_time(seconds_per_step, cut_in);
  } else {
    grid = planner::AccelerationGrid::rate(u::acceleration_from_wire(1, unit));
  }
  return std::make_shared<planner::GridQuantizer>(time ? "uim342 pps+ramp ms" : "uim342 pps+pps/s",
                                                  planner::VelocityGrid{pps_per_step, 1, speed.max},
                                                  grid.steps(ramp.min, ramp.max));
}

// UC57 profile position: 6081h rpm, 6083h/6084h ramp ms from the start speed 200Eh (C-02).
QuantizerOrError uc57_quantizer(const config::Config& config, const config::Drive& drive) {
  namespace od = cia402::uc57;
  const std::uint32_t ppr = assumed_pulses_per_revolution(config, drive);
  if (ppr == 0) return "drive " + drive.name + ": its set-up gives no UC57 resolution (2006h)";
  const auto* velocity = od::find_entry(od::index::kProfileVelocity, 0);
  const auto* acceleration = od::find_entry(od::index::kProfileAcceleration, 0);
  const auto* deceleration = od::find_entry(od::index::kProfileDeceleration, 0);
  const auto* start_speed = od::find_entry(od::index::kStartSpeed, 0);
  if (velocity == nullptr || acceleration == nullptr || deceleration == nullptr || start_speed == nullptr) {
    return std::string("UC57 object dictionary lacks 6081h/6083h/6084h/200Eh");
  }
  // The rate of a 1 ms ramp over a 1 pulse/s change is 1 / (seconds per ramp step).
  const double seconds_per_step = 1.0 / od::ramp_acceleration(od::RampUnit::kMilliseconds, 1, 1.0, ppr);
  const double ramp_from = od::rpm_to_pulses_per_second(static_cast<double>(start_speed->default_value), ppr);
  const auto grid = planner::AccelerationGrid::ramp_time(seconds_per_step, ramp_from)
                        .steps(std::max(acceleration->min, deceleration->min), std::min(acceleration->max, deceleration->max));
  return std::make_shared<planner::GridQuantizer>(
      "uc57 rpm+ramp ms", planner::VelocityGrid{od::rpm_to_pulses_per_second(1.0, ppr), velocity->min, velocity->max}, grid);
}

// ADAM: 0x00D8 in 0.01 rpm, 0x0098/0x0099 ms ramps from start/stop speed 0 (master_core ARM_MOVE).
QuantizerOrError adam_quantizer(const config::Config& config, const config::Drive& drive) {
  const std::uint32_t ppr = assumed_pulses_per_revolution(config, drive);
  if (!adam::check_subdivision(ppr)) {
    return "drive " + drive.name + ": subdivision " + std::to_string(ppr) + " pulses/rev is outside what the ADAM drive accepts";
  }
  const auto grid = planner::AccelerationGrid::ramp_time(adam::kRampSecondsPerStep).steps(1, adam::kMaxRampMs);
  return std::make_shared<planner::RpmQuantizer>(static_cast<double>(ppr), adam::kTargetSpeedRpmPerStep, grid,
                                                 adam::kMaxTargetSpeedCentiRpm);
}

// UIM242: SPD in integer pulse/s, MAC/MDE in integer pulse/s^2 (MCFG.AM/DM = 0, value mode, which
// the gateway's set-up keeps), ranges from the instruction table (#15, #20, #37).
QuantizerOrError uim242_quantizer() {
  const auto& speed = uim242::spec(uim242::Mnemonic::SPD);
  const auto& acceleration = uim242::spec(uim242::Mnemonic::MAC);
  const auto& deceleration = uim242::spec(uim242::Mnemonic::MDE);
  return std::make_shared<planner::GridQuantizer>(
      "uim242 pps+pps/s", planner::VelocityGrid{1.0, 1, speed.max},
      planner::AccelerationGrid::rate(1.0).steps(std::max(acceleration.min, deceleration.min),
                                                 std::min(acceleration.max, deceleration.max)));
}

}  // namespace

std::uint32_t assumed_pulses_per_revolution(const config::Config& /*config*/, const config::Drive& drive) {
  switch (drive.family) {
    case config::Family::kAdamModbus: {
      const auto pulses = adam::setup_pulses_per_revolution(drive.setup_integer("pulses_per_revolution"),
                                                            drive.setup_integer("subdivision"));
      if (!pulses) return adam::kDefaultSubdivision;
      return *pulses > 0 && *pulses <= std::numeric_limits<std::uint32_t>::max() ? static_cast<std::uint32_t>(*pulses) : 0;
    }
    case config::Family::kUc57: {
      // The gateway's own rule (2006h code from the set-up); no code: the drive keeps its factory one.
      const auto setup = cia402::uc57::setup_subdivision(drive.setup_integer("pulses_per_revolution"),
                                                         drive.setup_integer("micro_steps"));
      if (setup.status != cia402::uc57::SetupSubdivision::Status::kCode) {
        return drive.setup.contains("pulses_per_revolution") || drive.setup.contains("micro_steps")
                   ? 0
                   : cia402::uc57::kDefaultPulsesPerRevolution;
      }
      return cia402::uc57::pulses_per_revolution(setup.code).value_or(0);
    }
    default: return 0;
  }
}

QuantizerOrError make_drive_quantizer(const config::Config& config, const config::Drive& drive) {
  switch (drive.family) {
    case config::Family::kUim342: return uim342_quantizer(drive);
    case config::Family::kUc57: return uc57_quantizer(config, drive);
    case config::Family::kAdamModbus: return adam_quantizer(config, drive);
    case config::Family::kUim242: return uim242_quantizer();
  }
  return "drive " + drive.name + ": unknown drive family";
}

MovePlanner make_move_planner(const config::Config& config) {
  // Built once per drive; a drive whose quantizer cannot be built fails the plans that move it.
  auto quantizers = std::make_shared<std::map<std::string, QuantizerOrError>>();
  for (const auto& drive : config.drives) quantizers->emplace(drive.name, make_drive_quantizer(config, drive));
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
      const config::Drive* drive = axis != nullptr ? config.drive_of(*axis) : nullptr;
      const auto it = drive != nullptr ? quantizers->find(drive->name) : quantizers->end();
      if (it == quantizers->end()) return "axis " + in.axis + " has no drive";
      if (const auto* why = std::get_if<std::string>(&it->second)) return "axis " + in.axis + ": " + *why;
      per_axis.push_back(std::get<std::shared_ptr<const planner::DriveQuantizer>>(it->second).get());
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
