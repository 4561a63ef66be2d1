// From a gateway_command2_t (motion values as integers n of the axes' drive-model grids,
// lcmtypes/gateway_command2_t.lcm) to the gateway_command_t the stacks execute: each n becomes
// exactly n * step of the model the gateway last published for the axis, which every family's
// stack turns back into that same native integer (tests/unit/gateway/grid_identity_test.cpp), so
// nothing is quantized a second time.
//
// Refused, naming what was wrong: an axis without a published model, an axis whose model_utime
// is not that of its published model (the plan is stale), a value outside the model's range.
// Pure. Thread-safe.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <variant>

#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/gateway_command2_t.hpp>
#include <motionlcm/gateway_command_t.hpp>

namespace motion::gateway {

// Counts/s of n on the model's velocity grid (signed: a JOG's sign is its direction).
[[nodiscard]] double grid_velocity(const motionlcm::drive_model_t& model, std::int64_t n);
// Counts/s^2 of n on the model's acceleration grid for a motion at `velocity` counts/s:
// ACCEL_RATE n * step; ACCEL_RAMP_TIME a ramp of n * step seconds from ramp_from to |velocity|.
// A ramp-time grid has no ramp at or below ramp_from (the drive jumps to the speed): there it is
// 0, the stack's "the drive's own ramp" (a jog slower than a UC57's start speed).
[[nodiscard]] double grid_acceleration(const motionlcm::drive_model_t& model, std::int64_t n, double velocity);

struct GridRefusal {
  std::int32_t error_code = 0;
  std::string reason;
};

// The axis's drive model as last published (null: none).
using ModelLookup = std::function<const motionlcm::drive_model_t*(const std::string& axis)>;

// The command for the stacks, or why it is refused. Kinds that carry motion values (ARM_MOVE,
// JOG, HOME) need each axis's model_utime to be its published model's and every value in its
// range (JOG and HOME: 0 too, the stack's default; JOG and HOME velocities by magnitude); the
// other kinds carry none and their values are not looked at.
[[nodiscard]] std::variant<motionlcm::gateway_command_t, GridRefusal> from_grid(
    const motionlcm::gateway_command2_t& command, const ModelLookup& model_of);

}  // namespace motion::gateway
