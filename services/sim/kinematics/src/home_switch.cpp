#include "motion/sim/home_switch.hpp"

#include <cmath>

namespace motion::sim {

std::optional<HomeSwitch> home_switch(const config::Config& config, const config::Drive& drive) {
  const config::Axis* axis = nullptr;
  for (const auto& a : config.axes) {
    if (a.drive == drive.name) axis = &a;
  }
  if (!axis || axis->homing.method != config::HomingMethod::kSwitch || axis->homing.input < 1 || axis->homing.input > 3)
    return std::nullopt;
  const double sign = axis->invert ? -1.0 : 1.0;
  // The coordinator's default search goes toward min (HOME velocity 0).
  const bool toward_min = axis->homing.velocity <= 0;
  HomeSwitch sw;
  sw.port = static_cast<std::size_t>(axis->homing.input - 1);
  sw.active_level = axis->homing.edge == config::HomingEdge::kRising;
  sw.side = (toward_min ? -1 : 1) * (axis->invert ? -1 : 1);
  const double limit = toward_min ? axis->limits.min_position : axis->limits.max_position;
  sw.edge = std::llround(limit * axis->steps_per_unit * sign / 2);
  if (const auto it = config.simulation.home_switches.find(drive.name); it != config.simulation.home_switches.end()) {
    if (!it->second) return std::nullopt;
    sw.edge = *it->second;
  }
  return sw;
}

}  // namespace motion::sim
