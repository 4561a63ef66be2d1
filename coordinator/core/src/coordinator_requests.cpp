// The coordinator core: requests in (validation, planning, admission) and stop requests preempting.
#include "motion/coordinator/coordinator.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "coordinator_kinds.hpp"

namespace motion::coordinator {

using namespace detail;

namespace {
std::optional<std::pair<std::string, std::int64_t>> request_ids(std::span<const std::uint8_t> message) {
  // request_t on the wire: fingerprint (8), utime (int64), client_id (int32 length incl. NUL,
  // bytes, NUL), request_id (int64), all big-endian (LCM type specification).
  const std::uint8_t* p = message.data();
  const std::size_t n = message.size();
  const auto be = [p](std::size_t at, std::size_t bytes) {
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < bytes; ++i) v = (v << 8) | p[at + i];
    return v;
  };
  std::size_t at = 16;
  if (n < at + 4) return std::nullopt;
  const auto length = static_cast<std::size_t>(be(at, 4));
  at += 4;
  if (length < 1 || length > n - at || n - at - length < 8 || p[at + length - 1] != 0) return std::nullopt;
  std::string client(reinterpret_cast<const char*>(p + at), length - 1);
  if (client.empty()) return std::nullopt;
  return std::pair{std::move(client), static_cast<std::int64_t>(be(at + length, 8))};
}
}  // namespace

void Coordinator::on_malformed_request(std::span<const std::uint8_t> bytes, const std::string& why, TimePoint now) {
  begin(now);
  const auto ids = request_ids(bytes);
  if (!ids) return;  // nobody to answer: counted and reported by the caller
  request_t msg{};
  msg.client_id = ids->first;
  msg.request_id = ids->second;
  reply_unknown(msg, reply_t::REJECTED, ReplyError::kMalformedRequest, "malformed request: " + why);
}

void Coordinator::on_refused_request(const std::optional<request_t>& answer_to, const std::string& reason,
                                     TimePoint now) {
  begin(now);
  publish_event("", motionlcm::event_t::WARNING, motionlcm::event_t::SECURITY, reason);
  if (answer_to) {
    reply_unknown(*answer_to, reply_t::REJECTED, ReplyError::kUnauthorized, reason);
  } else {
    spdlog::warn("request refused: {}", reason);
  }
}

void Coordinator::on_refused_message(const std::string& reason, TimePoint now) {
  begin(now);
  publish_event("", motionlcm::event_t::WARNING, motionlcm::event_t::SECURITY, reason);
  spdlog::warn("gateway message refused: {}", reason);
}

std::optional<std::pair<ReplyError, std::string>> Coordinator::check_axis_ready(const std::string& axis,
                                                                                bool need_enabled) {
  const AxisLive& a = axes_.at(axis);
  if (!gateway_alive(a.drive->bus))
    return std::pair{ReplyError::kGatewayOffline, "gateway of bus " + a.drive->bus + " (axis " + axis + ") is offline"};
  if (!a.state) {
    return std::pair{ReplyError::kAxisOffline, "axis " + axis + ": no state from the gateway of bus " + a.drive->bus +
                                                   " yet since this coordinator started"};
  }
  const auto age = std::chrono::duration_cast<std::chrono::milliseconds>(now_ - a.received);
  if (age.count() >= config_.coordinator.gateway_timeout_ms) {
    return std::pair{ReplyError::kAxisOffline, "axis " + axis + ": its last state is " + std::to_string(age.count()) +
                                                   " ms old (gateway_timeout_ms " +
                                                   std::to_string(config_.coordinator.gateway_timeout_ms) + ")"};
  }
  if (!a.state->online) {
    return std::pair{ReplyError::kAxisOffline,
                     "axis " + axis + " is offline: the gateway of bus " + a.drive->bus + " cannot reach its drive"};
  }
  if (a.state->fault) {
    return std::pair{
        ReplyError::kAxisFaulted,
        "axis " + axis + " is faulted (" +
            (a.state->fault_text.empty() ? "code " + std::to_string(a.state->fault_code) : a.state->fault_text) +
            "): reset it first"};
  }
  if (need_enabled && !a.state->enabled)
    return std::pair{ReplyError::kAxisDisabled, "axis " + axis + " is disabled: enable it first"};
  return std::nullopt;
}

std::optional<std::pair<ReplyError, std::string>> Coordinator::validate(const request_t& msg,
                                                                        std::vector<std::string>& axes) {
  using P = std::pair<ReplyError, std::string>;
  if (msg.kind < request_t::MOVE_ABSOLUTE || msg.kind > request_t::SET_POSITION)
    return P{ReplyError::kMalformedRequest, "unknown request kind " + std::to_string(msg.kind)};
  if (msg.num_axes != static_cast<std::int32_t>(msg.axes.size()) || msg.values.size() != msg.axes.size()) {
    return P{ReplyError::kMalformedRequest, "num_axes does not match the axes/values arrays"};
  }
  if (active_ids_.contains({msg.client_id, msg.request_id})) {
    return P{ReplyError::kDuplicateRequest,
             "request id " + std::to_string(msg.request_id) + " of client '" + msg.client_id + "' is still active"};
  }
  axes = msg.axes;
  if (axes.empty() && is_stop(msg.kind)) {
    for (const auto& a : config_.axes) axes.push_back(a.name);  // stop everything
  }
  if (axes.empty()) return P{ReplyError::kMalformedRequest, std::string(kind_name(msg.kind)) + " names no axis"};
  if (single_axis(msg.kind) && axes.size() != 1)
    return P{ReplyError::kMalformedRequest, std::string(kind_name(msg.kind)) + " takes exactly one axis"};
  std::set<std::string> seen;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const auto& name = axes[i];
    auto it = axes_.find(name);
    if (it == axes_.end()) {
      std::string known;
      for (const auto& a : config_.axes) known += (known.empty() ? "" : ", ") + a.name;
      return P{ReplyError::kUnknownAxis, "unknown axis '" + name + "' (axes: " + known + ")"};
    }
    if (!seen.insert(name).second) return P{ReplyError::kMalformedRequest, "axis " + name + " appears twice"};
    if (i < msg.values.size() && !std::isfinite(msg.values[i]))
      return P{ReplyError::kMalformedRequest, "value for axis " + name + " is not a finite number"};
  }
  for (const auto& [name, scale] :
       {std::pair{"velocity_scale", msg.velocity_scale}, std::pair{"acceleration_scale", msg.acceleration_scale}}) {
    if (!std::isfinite(scale) || scale < 0 || scale > 1) {
      return P{ReplyError::kMalformedRequest,
               std::string(name) + " " + number(scale) + " is outside (0, 1] (0 = 1, the full limit)"};
    }
  }
  if (msg.timeout_ms < 0) {
    return P{ReplyError::kMalformedRequest, "timeout_ms " + std::to_string(msg.timeout_ms) +
                                                " is negative (0 = the default, " +
                                                std::to_string(config_.coordinator.default_timeout_ms) + " ms)"};
  }
  if (is_stop(msg.kind)) return std::nullopt;  // stops are always accepted for known axes

  for (const auto& name : axes) {
    const AxisLive& a = axes_.at(name);
    if (a.busy_with != 0)
      return P{ReplyError::kAxisBusy, "axis " + name + " is busy with another request (stop it first)"};
    const bool need_enabled = msg.kind != request_t::ENABLE && msg.kind != request_t::DISABLE &&
                              msg.kind != request_t::FAULT_RESET && msg.kind != request_t::PARAM_READ &&
                              msg.kind != request_t::PARAM_WRITE && msg.kind != request_t::SET_OUTPUTS &&
                              msg.kind != request_t::SET_POSITION;
    // Reset is how a faulted axis recovers: it only needs a live gateway.
    if (msg.kind == request_t::FAULT_RESET || msg.kind == request_t::DISABLE) {
      if (!gateway_alive(a.drive->bus))
        return P{ReplyError::kGatewayOffline, "gateway of bus " + a.drive->bus + " (axis " + name + ") is offline"};
      continue;
    }
    if (auto err = check_axis_ready(name, need_enabled)) return err;
    // A jog's or homing run's speed and ramps go out as integers of the axis's drive model.
    if ((msg.kind == request_t::JOG || msg.kind == request_t::HOME) && !a.model) {
      return P{ReplyError::kNoDriveModel, "axis " + name + " has no drive model yet: the gateway of bus " +
                                              a.drive->bus +
                                              " has not published DRIVE_MODEL for it (drive not set up?)"};
    }
    // Its drive lost power: the position it reports is not the machine's (the gateway refuses
    // these too, whoever sends them). Home and set-position are how it becomes valid again.
    if ((is_move(msg.kind) || msg.kind == request_t::JOG) &&
        a.state->fault_code == motionlcm::axis_state_t::POSITION_LOST) {
      return P{ReplyError::kPositionLost,
               "axis " + name + " lost its position (" + a.state->fault_text + "): home it or set its position first"};
    }
  }
  if (is_move(msg.kind) || msg.kind == request_t::SET_POSITION) {
    for (std::size_t i = 0; i < axes.size(); ++i) {
      const AxisLive& a = axes_.at(axes[i]);
      const double target =
          msg.kind == request_t::SET_POSITION ? msg.values[i] : move_target_units(a, msg.kind, msg.values[i]);
      const auto& lim = a.axis->limits;
      if (target < lim.min_position || target > lim.max_position) {
        char buf[256];
        std::snprintf(buf, sizeof buf, "%s %.6g %s of axis %s is outside its limits [%.6g, %.6g]",
                      msg.kind == request_t::SET_POSITION ? "position" : "target", target, a.axis->unit.c_str(),
                      axes[i].c_str(), lim.min_position, lim.max_position);
        return P{ReplyError::kOutsideLimits, buf};
      }
    }
  }
  // A UC57 sets its present position to zero only (2012h, UC57 manual §5.1): anything else is
  // refused here, before any other axis of the request is touched.
  if (msg.kind == request_t::SET_POSITION || msg.kind == request_t::HOME) {
    for (std::size_t i = 0; i < axes.size(); ++i) {
      const AxisLive& a = axes_.at(axes[i]);
      if (a.drive->family != config::Family::kUc57) continue;
      const bool in_place = msg.kind == request_t::SET_POSITION || a.axis->homing.method_name == "current-position";
      const double position = msg.kind == request_t::SET_POSITION ? msg.values[i] : a.axis->homing.offset;
      if (in_place && std::llround(position * a.axis->steps_per_unit) != 0) {
        return P{ReplyError::kUnsupported, "axis " + axes[i] + " (UC57) can set its position to 0 only, not " +
                                               number(position) + " " + a.axis->unit};
      }
    }
  }
  if (msg.kind == request_t::HOME) {
    for (const auto& name : axes) {
      // Every family alike: an axis homes only the way its configuration says.
      if (axes_.at(name).axis->homing.method_name.empty()) {
        return P{ReplyError::kUnsupported,
                 "axis " + name + " has no homing configured (add a homing: section to the axis)"};
      }
    }
  }
  if (msg.kind == request_t::JOG) {
    for (std::size_t i = 0; i < axes.size(); ++i) {
      const auto& lim = axes_.at(axes[i]).axis->limits;
      if (std::abs(msg.values[i]) > lim.max_velocity) {
        return P{ReplyError::kOutsideLimits, "jog velocity " + std::to_string(msg.values[i]) + " of axis " + axes[i] +
                                                 " exceeds its limit " + std::to_string(lim.max_velocity)};
      }
      // A jog with less than one whole count to go before the limit in its direction (or at or
      // beyond it) has nowhere to go: refused before anything is sent, in counts as the gateway
      // checks it.
      const AxisLive& a = axes_.at(axes[i]);
      if (msg.values[i] != 0 && a.state) {
        const double limit_units = msg.values[i] > 0 ? lim.max_position : lim.min_position;
        const double counts_per_unit = a.axis->steps_per_unit * (a.axis->invert ? -1.0 : 1.0);
        const double limit_counts = limit_units * counts_per_unit;
        const auto position = static_cast<double>(a.state->position_counts);
        const bool toward_more_counts = msg.values[i] * counts_per_unit > 0;
        if ((toward_more_counts ? limit_counts - position : position - limit_counts) < 1.0) {
          char buf[256];
          std::snprintf(buf, sizeof buf,
                        "jog of axis %s toward its limit %.6g %s refused: it stands at %.6g %s, less than one count "
                        "from (or beyond) that limit",
                        axes[i].c_str(), limit_units, a.axis->unit.c_str(), a.state->position, a.axis->unit.c_str());
          return P{ReplyError::kOutsideLimits, buf};
        }
      }
    }
  }
  return std::nullopt;
}

void Coordinator::on_request(const request_t& msg, TimePoint now) {
  begin(now);
  if (answer_again(msg)) return;
  std::vector<std::string> axes;
  if (auto err = validate(msg, axes)) {
    reply_unknown(msg, reply_t::REJECTED, err->first, err->second);
    return;
  }
  // Bounded work: beyond max_active_requests a request is refused at once, never queued; stops
  // always pass (they end work, and an operator must be able to stop everything).
  const auto limit = static_cast<std::size_t>(config_.coordinator.max_active_requests);
  if (!is_stop(msg.kind) && requests_.size() >= limit) {
    reply_unknown(msg, reply_t::REJECTED, ReplyError::kBusy,
                  "busy: " + std::to_string(requests_.size()) + " requests in progress (max_active_requests " +
                      std::to_string(limit) + "); retry when one has ended");
    return;
  }
  auto owned = std::make_unique<Request>();
  Request& r = *owned;
  r.msg = msg;
  r.axes = axes;
  // A move is planned whole before anything is sent: a plan that fails is a refusal.
  if (is_move(msg.kind)) {
    if (auto err = plan_move(r)) {
      reply_unknown(msg, reply_t::REJECTED, err->first, err->second);
      return;
    }
  }
  if (is_stop(msg.kind)) preempt(msg);
  r.serial = next_serial_++;
  for (const auto& a : axes) {
    if (!r.still.contains(a)) r.buses.insert(axes_.at(a).drive->bus);
  }
  requests_.emplace(r.serial, std::move(owned));
  active_ids_.insert({msg.client_id, msg.request_id});
  bool taken_over = false;
  if (!is_stop(msg.kind)) {
    for (const auto& a : axes) {
      axes_.at(a).busy_with = r.serial;
      // An axis still braking from a stop is this request's now: its stop watch ends, and a
      // request preempted there gets its ABORTED at once (see preempt()).
      if (stops_.watching(a)) {
        stops_.forget(a);
        taken_over = true;
      }
    }
  }
  r.timeout_ms = msg.timeout_ms > 0 ? msg.timeout_ms : config_.coordinator.default_timeout_ms;
  r.timeout_at = now_ + std::chrono::milliseconds(r.timeout_ms);
  spdlog::info("request {}/{} ({}) accepted for {} axes", msg.client_id, msg.request_id, kind_name(msg.kind),
               axes.size());
  reply(r, reply_t::ACCEPTED);
  if (taken_over) check_stops();
  if (!is_move(msg.kind)) {
    for (const auto& a : axes) {
      // Anything else that moves or re-references the axis ends "standing at the last target".
      if (msg.kind == request_t::JOG || msg.kind == request_t::HOME || msg.kind == request_t::SET_POSITION)
        axes_.at(a).commanded_units.reset();
    }
    start_simple(r);
  } else if (r.plan.axes.empty()) {
    check_move_done(r);  // every axis is already at its target: nothing to send
  } else {
    start_move(r);
  }
}

double Coordinator::move_target_units(const AxisLive& a, std::int8_t kind, double value) const {
  if (kind == request_t::MOVE_ABSOLUTE) return value;
  const bool at_commanded =
      a.commanded_units && a.state &&
      std::abs(static_cast<double>(a.state->position_counts - a.commanded_counts)) <= tolerance_counts(a);
  return (at_commanded ? *a.commanded_units : (a.state ? a.state->position : 0.0)) + value;
}

std::optional<std::pair<ReplyError, std::string>> Coordinator::plan_move(Request& r) {
  std::vector<PlanInput> inputs;
  for (std::size_t i = 0; i < r.axes.size(); ++i) {
    const AxisLive& a = axes_.at(r.axes[i]);
    const double counts_per_unit = a.axis->steps_per_unit * (a.axis->invert ? -1.0 : 1.0);
    const double target_units = move_target_units(a, r.msg.kind, r.msg.values[i]);
    const double target = std::round(target_units * counts_per_unit);
    if (!(std::abs(target) < 9.0e18)) {
      return std::pair{ReplyError::kOutsideLimits,
                       "target " + number(target_units) + " of axis " + r.axes[i] + " does not fit in counts"};
    }
    PlanInput in;
    in.axis = r.axes[i];
    in.family = a.drive->family;
    in.start_counts = a.state->position_counts;
    in.target_counts = static_cast<std::int64_t>(target);
    in.max_velocity = a.axis->limits.max_velocity * a.axis->steps_per_unit;
    in.max_acceleration = a.axis->limits.max_acceleration * a.axis->steps_per_unit;
    in.quantizer = a.quantizer;
    in.model_utime = a.model ? a.model->utime : 0;
    r.starts[in.axis] = in.start_counts;
    r.targets[in.axis] = in.target_counts;
    r.target_units[in.axis] = target_units;
    // An axis already at its target needs no command: it is done while its partners move.
    if (in.target_counts == in.start_counts) {
      r.still.insert(in.axis);
      continue;
    }
    inputs.push_back(in);
  }
  if (inputs.empty()) return std::nullopt;
  // Planned and quantized from the drive model only: none yet, no move.
  for (const auto& in : inputs) {
    const AxisLive& a = axes_.at(in.axis);
    if (!a.model) {
      return std::pair{ReplyError::kNoDriveModel, "axis " + in.axis + " has no drive model yet: the gateway of bus " +
                                                      a.drive->bus +
                                                      " has not published DRIVE_MODEL for it (drive not set up?)"};
    }
    if (!in.quantizer)
      return std::pair{ReplyError::kPlanningFailed,
                       "axis " + in.axis + ": its drive model is unusable: " + a.model_error};
  }
  auto planned = planner_(inputs, scale_or_one(r.msg.velocity_scale), scale_or_one(r.msg.acceleration_scale));
  if (auto* why = std::get_if<std::string>(&planned))
    return std::pair{ReplyError::kPlanningFailed, "planning failed: " + *why};
  r.plan = std::get<MovePlan>(planned);
  const int timeout_ms = r.msg.timeout_ms > 0 ? r.msg.timeout_ms : config_.coordinator.default_timeout_ms;
  if (!(r.plan.duration_s * 1000.0 < static_cast<double>(timeout_ms))) {
    return std::pair{ReplyError::kPlanningFailed, "the move would take " + number(r.plan.duration_s) +
                                                      " s, longer than its timeout of " + number(timeout_ms / 1000.0) +
                                                      " s (raise the speed or timeout_ms)"};
  }
  return std::nullopt;
}

void Coordinator::preempt(const request_t& stop) {
  std::vector<std::uint64_t> hit;
  for (auto& [serial, r] : requests_) {
    if (is_stop(r->msg.kind)) continue;
    for (const auto& a : r->axes) {
      if (stop.axes.empty() || std::find(stop.axes.begin(), stop.axes.end(), a) != stop.axes.end()) {
        hit.push_back(serial);
        break;
      }
    }
  }
  for (auto serial : hit) {
    auto it = requests_.find(serial);
    if (it == requests_.end()) continue;
    Request& r = *it->second;
    // The stop request itself stops these axes; the preempted request only ends, and its axes
    // no longer stand at a commanded target (relative moves count from where they stop).
    std::set<std::string> stopped;
    for (const auto& a : r.axes) {
      axes_.at(a).commanded_units.reset();
      const bool named = stop.axes.empty() || std::find(stop.axes.begin(), stop.axes.end(), a) != stop.axes.end();
      if (named && !r.still.contains(a) && is_motion(r.msg.kind)) stopped.insert(a);
    }
    const std::string by = std::string(stop.kind == request_t::ESTOP ? "e-stopped" : "stopped") + " by request " +
                           stop.client_id + "/" + std::to_string(stop.request_id);
    // The ABORTED reply waits until the stop request's stops are confirmed (start_simple watches
    // them). The axes are free at once: the stop request owns their stop, and a request sent right
    // behind the stop may take them (which ends this one's wait).
    for (const auto& a : r.axes) {
      if (auto& live = axes_.at(a); live.busy_with == serial) live.busy_with = 0;
    }
    enter_stopping(r, std::move(stopped), {reply_t::ABORTED, ReplyError::kStopped, by});
  }
}

double Coordinator::tolerance_counts(const AxisLive& a) const {
  const double t = config_.coordinator.position_tolerance * a.axis->steps_per_unit;
  return std::max(t, 1.0);
}

}  // namespace motion::coordinator
