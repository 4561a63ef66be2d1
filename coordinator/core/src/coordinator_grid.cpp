// The coordinator core: gateway commands as they go out, gateway_command2_t (motion values as
// integers of the axes' drive-model grids, lcmtypes/gateway_command2_t.lcm). A move's integers
// are the planner's (the quantizer's native values); a jog's or homing run's are the grid values
// nearest to what the request asks for that are not faster or steeper.
#include <algorithm>
#include <cmath>

#include "motion/coordinator/coordinator.hpp"
#include "motion/lcm/gateway_commands.hpp"

namespace motion::coordinator {

motionlcm::gateway_command2_t Coordinator::to_grid(const motionlcm::gateway_command_t& command,
                                                   const std::map<std::string, motionlcm::axis_command2_t>* grid) {
  motionlcm::gateway_command2_t out{};
  lcm::copy_command_common(command, out);
  if (grid == nullptr || !lcm::carries_motion(command.kind)) return out;
  for (auto& a : out.axes) {
    const auto it = grid->find(a.axis);
    if (it == grid->end()) continue;
    a.velocity = it->second.velocity;
    a.acceleration = it->second.acceleration;
    a.deceleration = it->second.deceleration;
    a.model_utime = it->second.model_utime;
  }
  return out;
}

namespace {

// n with n * step at or below `value` (up: at or above), within [min, max]: a jog or homing run
// stays within the limits the request was checked against (a tolerance of 1e-9 steps keeps a
// value already on the grid there).
std::int64_t on_grid(double value, double step, std::int64_t min, std::int64_t max, bool up = false) {
  const double n = up ? std::ceil(value / step - 1e-9) : std::floor(value / step + 1e-9);
  if (!(n >= static_cast<double>(min))) return min;  // NaN too
  if (n > static_cast<double>(max)) return max;
  return static_cast<std::int64_t>(n);
}

}  // namespace

motionlcm::axis_command2_t Coordinator::grid_of(const motionlcm::drive_model_t& model,
                                                const motionlcm::axis_command_t& counts) {
  using M = motionlcm::drive_model_t;
  motionlcm::axis_command2_t g{};
  g.axis = counts.axis;
  g.model_utime = model.utime;
  if (counts.velocity != 0) {
    const std::int64_t n =
        on_grid(std::abs(counts.velocity), model.velocity_step, model.velocity_min, model.velocity_max);
    g.velocity = counts.velocity < 0 ? -n : n;
  }
  const double speed = std::abs(static_cast<double>(g.velocity)) * model.velocity_step;
  const auto ramp = [&](double rate) -> std::int64_t {
    if (!(rate > 0)) return 0;  // the drive's own ramp
    if (model.acceleration_kind != M::ACCEL_RAMP_TIME)
      return on_grid(rate, model.acceleration_step, model.acceleration_min, model.acceleration_max);
    const double change = speed - model.ramp_from;
    if (change <= 0) return 0;  // at or below the ramps' start speed there is no ramp: the drive's own
    return on_grid(change / rate, model.acceleration_step, model.acceleration_min, model.acceleration_max, true);
  };
  g.acceleration = ramp(counts.acceleration);
  g.deceleration = ramp(counts.deceleration);
  return g;
}

}  // namespace motion::coordinator
