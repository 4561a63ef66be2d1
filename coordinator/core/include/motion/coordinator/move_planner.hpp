// The coordinator's MovePlanner: the synchronized planner (motion::planner) with, per axis, the
// quantizer made of the drive model its gateway published (DRIVE_MODEL, drive_model_t). The
// coordinator knows a drive only through that message: the grids (native integer steps of
// velocity and of acceleration / ramp time, with their ranges and the ramp start speed) are the
// gateway's, made from the family code and what it read from the drive, so the realized values
// the planner predicts are what the gateway's stack programs.
// Pure: thread-safe, no I/O.
#pragma once

#include <memory>
#include <string>
#include <variant>

#include <motionlcm/drive_model_t.hpp>

#include "motion/coordinator/coordinator.hpp"
#include "motion/planner/quantizer.hpp"

namespace motion::coordinator {

// The quantizer of a drive model, or why the model is unusable (a non-positive or non-finite
// step, an empty range, an unknown acceleration kind).
[[nodiscard]] std::variant<std::shared_ptr<const planner::DriveQuantizer>, std::string> quantizer_from_model(
    const motionlcm::drive_model_t& model);

// Plans with PlanInput::quantizer (an input without one fails the plan, naming the axis).
[[nodiscard]] MovePlanner make_move_planner();

}  // namespace motion::coordinator
