// The coordinator's MovePlanner for a configuration: the synchronized planner (motion::planner)
// with each axis's drive quantization, chosen by family and set-up:
//   UIM342  SP in integer pulse/s; AC/DC in integer pulse/s^2 (IC[4]=0, "rate") or as an integer
//           ramp time in ms (IC[4]=1, "time")  (SimpleCAN §5.14-5.19)
//   others  until their drivers pin down their units: no quantization (identity), so the
//           predicted spread is 0 for them and the measured skew tells the truth.
#pragma once

#include "motion/config/config.hpp"
#include "motion/coordinator/coordinator.hpp"

namespace motion::coordinator {

[[nodiscard]] MovePlanner make_move_planner(const config::Config& config);

}  // namespace motion::coordinator
