#include "motion/gateway/grid_command.hpp"

#include <fmt/format.h>

#include <cmath>
#include <optional>

#include "motion/lcm/gateway_commands.hpp"
#include "motion/lcm/reply_error.hpp"

namespace motion::gateway {

using motionlcm::drive_model_t;
using motionlcm::gateway_command_t;

double grid_velocity(const drive_model_t& model, std::int64_t n) {
  return static_cast<double>(n) * model.velocity_step;
}

double grid_acceleration(const drive_model_t& model, std::int64_t n, double velocity) {
  const double step = static_cast<double>(n) * model.acceleration_step;
  if (model.acceleration_kind != drive_model_t::ACCEL_RAMP_TIME) return step;
  const double change = std::abs(velocity) - model.ramp_from;
  return change > 0 ? change / step : 0.0;
}

namespace {

// Why `value` of `field` is not in [min, max] (allowing 0 when `zero_ok`); nullopt when it is.
std::optional<GridRefusal> outside(const std::string& axis, const char* field, std::int64_t value, std::int64_t min,
                                   std::int64_t max, bool zero_ok) {
  if ((value >= min && value <= max) || (zero_ok && value == 0)) return std::nullopt;
  return GridRefusal{error_code(ReplyError::kOutsideLimits),
                     fmt::format("axis {}: {} {} is outside its drive model's range {}..{}{}", axis, field, value, min,
                                 max, zero_ok ? " (or 0)" : "")};
}

}  // namespace

std::variant<gateway_command_t, GridRefusal> from_grid(const motionlcm::gateway_command2_t& command,
                                                       const ModelLookup& model_of) {
  gateway_command_t out{};
  lcm::copy_command_common(command, out);
  if (!lcm::carries_motion(command.kind)) return out;
  const bool move = command.kind == gateway_command_t::ARM_MOVE;
  for (std::size_t i = 0; i < command.axes.size(); ++i) {
    const auto& a = command.axes[i];
    const drive_model_t* model = model_of(a.axis);
    if (model == nullptr) {
      return GridRefusal{error_code(ReplyError::kNoDriveModel),
                         fmt::format("axis {} has no drive model from this gateway (planned with {}): plan again "
                                     "once its DRIVE_MODEL is out",
                                     a.axis, a.model_utime)};
    }
    if (a.model_utime != model->utime) {
      return GridRefusal{error_code(ReplyError::kPlanningFailed),
                         fmt::format("drive model of axis {} changed since the move was planned (planned with {}, "
                                     "now {}): plan again",
                                     a.axis, a.model_utime, model->utime)};
    }
    const std::int64_t speed = move ? a.velocity : std::abs(a.velocity);
    if (auto why = outside(a.axis, "velocity", speed, model->velocity_min, model->velocity_max, !move)) return *why;
    if (auto why =
            outside(a.axis, "acceleration", a.acceleration, model->acceleration_min, model->acceleration_max, !move))
      return *why;
    if (auto why =
            outside(a.axis, "deceleration", a.deceleration, model->acceleration_min, model->acceleration_max, !move))
      return *why;
    auto& o = out.axes[i];
    o.velocity = grid_velocity(*model, a.velocity);
    o.acceleration = a.acceleration == 0 ? 0.0 : grid_acceleration(*model, a.acceleration, o.velocity);
    o.deceleration = a.deceleration == 0 ? 0.0 : grid_acceleration(*model, a.deceleration, o.velocity);
  }
  return out;
}

}  // namespace motion::gateway
