// A home switch of the simulated machine (not part of any drive), shared by the drive families'
// simulators: input `port` (0 = the drive's first input) is at `active_level` while the axis's
// physical position (counts from power-up; setting the drive's origin does not move it) is at or
// beyond `edge` on `side`, and at the other level elsewhere.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

#include "motion/config/config.hpp"

namespace motion::sim {

struct HomeSwitch {
  std::size_t port = 0;
  std::int64_t edge = 0;
  int side = -1;              // -1: active at and below edge; +1: at and above
  bool active_level = false;  // the level after the axis's homing edge (falling: low)

  [[nodiscard]] bool level_at(std::int64_t physical_counts) const {
    return side * (physical_counts - edge) >= 0 ? active_level : !active_level;
  }
};

// The switch of `drive` from the configuration: its axis's `homing` (method switch: input 1..3,
// edge, direction) and `simulation.home_switches` (edge position, or none; default half way from
// the power-up position to the travel limit in the homing direction). nullopt: no switch.
[[nodiscard]] std::optional<HomeSwitch> home_switch(const config::Config& config, const config::Drive& drive);

}  // namespace motion::sim
