#include "motion/coordinator/coordinator.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include <motionlcm/active_moves_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>

#include "motion/lcm/channels.hpp"

namespace motion::coordinator {
namespace {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using motionlcm::reply_t;
using motionlcm::request_t;

bool is_move(std::int8_t kind) { return kind == request_t::MOVE_ABSOLUTE || kind == request_t::MOVE_RELATIVE; }
// Requests whose axes keep moving after their command: their desired state is republished.
bool is_motion(std::int8_t kind) { return is_move(kind) || kind == request_t::JOG || kind == request_t::HOME; }
constexpr std::chrono::milliseconds kActiveMovesPeriod{500};
bool is_stop(std::int8_t kind) { return kind == request_t::STOP || kind == request_t::ESTOP; }
bool single_axis(std::int8_t kind) {
  return kind == request_t::SET_OUTPUTS || kind == request_t::PARAM_READ || kind == request_t::PARAM_WRITE;
}
bool terminal(std::int8_t status) {
  return status == reply_t::DONE || status == reply_t::REJECTED || status == reply_t::ABORTED || status == reply_t::FAILED;
}

std::int8_t gateway_kind(std::int8_t request_kind) {
  switch (request_kind) {
    case request_t::JOG: return gateway_command_t::JOG;
    case request_t::STOP: return gateway_command_t::STOP;
    case request_t::ESTOP: return gateway_command_t::ESTOP;
    case request_t::HOME: return gateway_command_t::HOME;
    case request_t::ENABLE: return gateway_command_t::ENABLE;
    case request_t::DISABLE: return gateway_command_t::DISABLE;
    case request_t::FAULT_RESET: return gateway_command_t::FAULT_RESET;
    case request_t::SET_OUTPUTS: return gateway_command_t::SET_OUTPUTS;
    case request_t::PARAM_READ: return gateway_command_t::PARAM_READ;
    case request_t::PARAM_WRITE: return gateway_command_t::PARAM_WRITE;
    case request_t::SET_POSITION: return gateway_command_t::SET_POSITION;
    default: return 0;
  }
}

const char* kind_name(std::int8_t kind) {
  switch (kind) {
    case request_t::MOVE_ABSOLUTE: return "move";
    case request_t::MOVE_RELATIVE: return "relative move";
    case request_t::JOG: return "jog";
    case request_t::STOP: return "stop";
    case request_t::ESTOP: return "e-stop";
    case request_t::HOME: return "home";
    case request_t::ENABLE: return "enable";
    case request_t::DISABLE: return "disable";
    case request_t::FAULT_RESET: return "fault reset";
    case request_t::SET_OUTPUTS: return "set outputs";
    case request_t::PARAM_READ: return "parameter read";
    case request_t::PARAM_WRITE: return "parameter write";
    case request_t::SET_POSITION: return "set position";
    default: return "unknown";
  }
}

double scale_or_one(double s) { return s > 0 && s <= 1 ? s : 1.0; }

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// How long a move that could not be armed everywhere waits for its DISARM replies.
constexpr std::chrono::milliseconds kReleaseTimeout{500};

}  // namespace

Coordinator::Coordinator(EventLoop& loop, lcm::Node& node, const config::Config& config, MovePlanner planner)
    : loop_(loop), node_(node), config_(config), planner_(std::move(planner)) {
  for (const auto& axis : config_.axes) axes_[axis.name] = AxisLive{&axis, config_.drive_of(axis), std::nullopt, {}, 0, std::nullopt, 0};
  node_.subscribe<request_t>(
      lcm::channels::kRequest, [this](const request_t& m, const std::string&) { on_request(m); },
      [this](const void* data, int size, const std::string& why) { on_malformed_request(data, size, why); });
  node_.subscribe<motionlcm::axis_state_t>(lcm::channels::kAxisState,
                                           [this](const motionlcm::axis_state_t& m, const std::string&) { on_axis_state(m); });
  node_.subscribe<gateway_reply_t>(lcm::channels::kGatewayReply, [this](const gateway_reply_t& m, const std::string&) { on_gateway_reply(m); });
  node_.subscribe<motionlcm::event_t>(lcm::channels::kEvent, [this](const motionlcm::event_t& m, const std::string&) { on_event(m); });
  node_.subscribe<motionlcm::health_t>(lcm::channels::kHealth, [this](const motionlcm::health_t& m, const std::string&) { on_health(m); });
  // A malformed request cannot be answered (its ids are unreadable): say so loudly on EVENT.
  node_.on_malformed([this](const std::string& what) {
    spdlog::warn("{}", what);
    publish_event("", motionlcm::event_t::WARNING, motionlcm::event_t::PROTOCOL_ERROR, what);
  });
  watchdog_ = loop_.call_every(std::chrono::milliseconds(100), [this] {
    check_gateways();
    check_stops();
  });
  active_moves_timer_ = loop_.call_every(kActiveMovesPeriod, [this] {
    if (active_moves_published_ || std::any_of(requests_.begin(), requests_.end(), [](const auto& r) { return is_motion(r.second->msg.kind); })) {
      publish_active_moves();
    }
  });
}

Coordinator::~Coordinator() {
  loop_.cancel(watchdog_);
  loop_.cancel(active_moves_timer_);
}

// ---------------------------------------------------------------- inputs

void Coordinator::on_axis_state(const motionlcm::axis_state_t& state) {
  auto it = axes_.find(state.axis);
  if (it == axes_.end()) return;
  // Only a running gateway publishes axis states: as good a sign of life as its heartbeat, so a
  // coordinator started after its gateways accepts requests at once, not a heartbeat period
  // later. A gateway that announced STOPPING stays stopped until it heartbeats again.
  if (GatewayLive& g = gateways_[it->second.drive->bus]; !g.seen || g.last_heartbeat != TimePoint{}) {
    g.seen = true;
    g.last_heartbeat = loop_.now();
  }
  const bool first_sight = !it->second.state.has_value();
  it->second.state = state;
  it->second.received = loop_.now();
  if (first_sight && state.moving && state.online && it->second.busy_with == 0) {
    // Nothing this process sent moves it: a coordinator restarted while its predecessor's move,
    // jog or homing run went on, or a command from elsewhere. What nobody owns is stopped.
    const std::string text = "axis " + state.axis + " was moving (at " + number(state.position) +
                             ") when this coordinator first heard of it; no request of this coordinator moves it: stopping it";
    spdlog::warn("{}", text);
    publish_event(state.axis, motionlcm::event_t::WARNING, motionlcm::event_t::UNOWNED_MOTION, text);
    send_stop({state.axis}, false, 0);
  }
  if (const std::uint64_t serial = it->second.busy_with; serial != 0) {
    if (auto rit = requests_.find(serial); rit != requests_.end()) {
      Request& r = *rit->second;
      if (r.phase == Phase::kTriggered && state.fault) {
        abort_group(r, reply_t::ABORTED, ReplyError::kAxisFault,
                    "axis " + state.axis + " faulted: " + (state.fault_text.empty() ? "code " + std::to_string(state.fault_code) : state.fault_text));
      } else if (r.phase == Phase::kTriggered && is_move(r.msg.kind)) {
        check_move_done(r);
      }
    }
  }
  // Requests whose gateways are done wait for states that show it (stops do not own axes).
  std::vector<std::uint64_t> confirming;
  for (const auto& [serial, r] : requests_) {
    if (r->phase == Phase::kConfirming && std::find(r->axes.begin(), r->axes.end(), state.axis) != r->axes.end()) confirming.push_back(serial);
  }
  for (const auto serial : confirming) {
    if (auto rit = requests_.find(serial); rit != requests_.end()) check_confirmed(*rit->second, false);
  }
  if (stops_.watching(state.axis)) check_stops();
}

void Coordinator::on_event(const motionlcm::event_t& event) {
  using E = motionlcm::event_t;
  const bool fatal = event.kind == E::STALL || event.kind == E::LIMIT || event.kind == E::HEARTBEAT_LOST || event.kind == E::OFFLINE ||
                     event.kind == E::BUS_OFF || (event.kind == E::ALARM && event.severity >= E::ERROR) ||
                     (event.kind == E::EMCY && event.severity >= E::ERROR) || event.kind == E::REBOOT;
  if (!fatal) return;
  std::vector<std::uint64_t> hit;
  for (auto& [serial, r] : requests_) {
    if (is_stop(r->msg.kind) || r->phase == Phase::kDone) continue;
    const bool bus_event = event.axis.empty() && r->buses.contains(event.bus);
    const bool axis_event = std::find(r->axes.begin(), r->axes.end(), event.axis) != r->axes.end();
    if (bus_event || axis_event) hit.push_back(serial);
  }
  for (auto serial : hit) {
    auto it = requests_.find(serial);
    if (it == requests_.end()) continue;
    const std::string where = event.axis.empty() ? "bus " + event.bus : "axis " + event.axis;
    abort_group(*it->second, reply_t::ABORTED, ReplyError::kAxisFault, where + ": " + event.text);
  }
}

void Coordinator::on_health(const motionlcm::health_t& health) {
  if (health.role != "gateway" || health.process.rfind("gateway:", 0) != 0) return;
  const std::string bus = health.process.substr(8);
  GatewayLive& g = gateways_[bus];
  // pid 0: known only from its axis states so far, not a restart.
  const bool restarted = g.seen && g.pid != 0 && (health.pid != g.pid || health.uptime_s + 0.5 < g.uptime_s);
  g.seen = true;
  g.pid = health.pid;
  g.uptime_s = health.uptime_s;
  g.last_heartbeat = health.state == motionlcm::health_t::STOPPING ? TimePoint{} : loop_.now();
  if (restarted) publish_active_moves();  // what the new process was doing, before it is aborted
  if (restarted || health.state == motionlcm::health_t::STOPPING) {
    std::vector<std::uint64_t> hit;
    for (auto& [serial, r] : requests_) {
      if (r->buses.contains(bus)) hit.push_back(serial);
    }
    for (auto serial : hit) {
      if (auto it = requests_.find(serial); it != requests_.end()) {
        abort_group(*it->second, reply_t::ABORTED, ReplyError::kGatewayLost,
                    "gateway of bus " + bus + (restarted ? " restarted" : " stopped") + " during the request");
      }
    }
  }
}

void Coordinator::check_gateways() {
  std::vector<std::pair<std::uint64_t, std::string>> hit;
  for (auto& [serial, r] : requests_) {
    for (const auto& bus : r->buses) {
      if (!gateway_alive(bus)) {
        hit.emplace_back(serial, bus);
        break;
      }
    }
  }
  for (const auto& [serial, bus] : hit) {
    if (auto it = requests_.find(serial); it != requests_.end()) {
      abort_group(*it->second, reply_t::ABORTED, ReplyError::kGatewayLost, "lost the heartbeat of the gateway of bus " + bus);
    }
  }
}

std::vector<std::string> Coordinator::buses_without_gateway() const {
  std::vector<std::string> out;
  for (const auto& bus : config_.buses) {
    if (!gateway_alive(bus.name)) out.push_back(bus.name);
  }
  return out;
}

bool Coordinator::gateway_alive(const std::string& bus) const {
  auto it = gateways_.find(bus);
  if (it == gateways_.end() || !it->second.seen || it->second.last_heartbeat == TimePoint{}) return false;
  return loop_.now() - it->second.last_heartbeat < std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms);
}

// ---------------------------------------------------------------- requests

namespace {
std::optional<std::pair<std::string, std::int64_t>> request_ids(const void* data, int size) {
  // request_t on the wire: fingerprint (8), utime (int64), client_id (int32 length incl. NUL,
  // bytes, NUL), request_id (int64), all big-endian (LCM type specification).
  const auto* p = static_cast<const std::uint8_t*>(data);
  const auto n = static_cast<std::size_t>(std::max(size, 0));
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

void Coordinator::on_malformed_request(const void* data, int size, const std::string& why) {
  const auto ids = request_ids(data, size);
  if (!ids) return;  // nobody to answer: counted and reported by the node
  request_t msg{};
  msg.client_id = ids->first;
  msg.request_id = ids->second;
  reply_unknown(msg, reply_t::REJECTED, ReplyError::kMalformedRequest, "malformed request: " + why);
}

void Coordinator::reply_unknown(const request_t& msg, std::int8_t status, ReplyError error, const std::string& reason) {
  reply_t out{};
  out.utime = wall_time_us();
  out.client_id = msg.client_id;
  out.request_id = msg.request_id;
  out.status = status;
  out.reason = reason;
  out.error_code = static_cast<std::int32_t>(error);
  node_.publish(lcm::channels::kReply, out);
  spdlog::info("request {}/{} ({}) rejected: {}", msg.client_id, msg.request_id, kind_name(msg.kind), reason);
}

std::optional<std::pair<ReplyError, std::string>> Coordinator::check_axis_ready(const std::string& axis, bool need_enabled) {
  const AxisLive& a = axes_.at(axis);
  if (!gateway_alive(a.drive->bus)) return std::pair{ReplyError::kGatewayOffline, "gateway of bus " + a.drive->bus + " (axis " + axis + ") is offline"};
  const bool fresh = a.state && loop_.now() - a.received < std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms);
  if (!fresh || !a.state->online) return std::pair{ReplyError::kAxisOffline, "axis " + axis + " has no live state (drive offline?)"};
  if (a.state->fault) {
    return std::pair{ReplyError::kAxisFaulted, "axis " + axis + " is faulted (" +
                                                   (a.state->fault_text.empty() ? "code " + std::to_string(a.state->fault_code) : a.state->fault_text) +
                                                   "): reset it first"};
  }
  if (need_enabled && !a.state->enabled) return std::pair{ReplyError::kAxisDisabled, "axis " + axis + " is disabled: enable it first"};
  return std::nullopt;
}

std::optional<std::pair<ReplyError, std::string>> Coordinator::validate(const request_t& msg, std::vector<std::string>& axes) {
  using P = std::pair<ReplyError, std::string>;
  if (msg.kind < request_t::MOVE_ABSOLUTE || msg.kind > request_t::SET_POSITION) return P{ReplyError::kMalformedRequest, "unknown request kind " + std::to_string(msg.kind)};
  if (msg.num_axes != static_cast<std::int32_t>(msg.axes.size()) || msg.values.size() != msg.axes.size()) {
    return P{ReplyError::kMalformedRequest, "num_axes does not match the axes/values arrays"};
  }
  if (active_ids_.contains({msg.client_id, msg.request_id})) {
    return P{ReplyError::kDuplicateRequest, "request id " + std::to_string(msg.request_id) + " of client '" + msg.client_id + "' is still active"};
  }
  axes = msg.axes;
  if (axes.empty() && is_stop(msg.kind)) {
    for (const auto& a : config_.axes) axes.push_back(a.name);  // stop everything
  }
  if (axes.empty()) return P{ReplyError::kMalformedRequest, std::string(kind_name(msg.kind)) + " names no axis"};
  if (single_axis(msg.kind) && axes.size() != 1) return P{ReplyError::kMalformedRequest, std::string(kind_name(msg.kind)) + " takes exactly one axis"};
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
    if (i < msg.values.size() && !std::isfinite(msg.values[i])) return P{ReplyError::kMalformedRequest, "value for axis " + name + " is not a finite number"};
  }
  for (const auto& [name, scale] : {std::pair{"velocity_scale", msg.velocity_scale}, std::pair{"acceleration_scale", msg.acceleration_scale}}) {
    if (!std::isfinite(scale) || scale < 0 || scale > 1) {
      return P{ReplyError::kMalformedRequest, std::string(name) + " " + number(scale) + " is outside (0, 1] (0 = 1, the full limit)"};
    }
  }
  if (msg.timeout_ms < 0) {
    return P{ReplyError::kMalformedRequest, "timeout_ms " + std::to_string(msg.timeout_ms) + " is negative (0 = the default, " +
                                                std::to_string(config_.coordinator.default_timeout_ms) + " ms)"};
  }
  if (is_stop(msg.kind)) return std::nullopt;  // stops are always accepted for known axes

  for (const auto& name : axes) {
    const AxisLive& a = axes_.at(name);
    if (a.busy_with != 0) return P{ReplyError::kAxisBusy, "axis " + name + " is busy with another request (stop it first)"};
    const bool need_enabled = msg.kind != request_t::ENABLE && msg.kind != request_t::DISABLE && msg.kind != request_t::FAULT_RESET &&
                              msg.kind != request_t::PARAM_READ && msg.kind != request_t::PARAM_WRITE && msg.kind != request_t::SET_OUTPUTS &&
                              msg.kind != request_t::SET_POSITION;
    // Reset is how a faulted axis recovers: it only needs a live gateway.
    if (msg.kind == request_t::FAULT_RESET || msg.kind == request_t::DISABLE) {
      if (!gateway_alive(a.drive->bus)) return P{ReplyError::kGatewayOffline, "gateway of bus " + a.drive->bus + " (axis " + name + ") is offline"};
      continue;
    }
    if (auto err = check_axis_ready(name, need_enabled)) return err;
  }
  if (is_move(msg.kind) || msg.kind == request_t::SET_POSITION) {
    for (std::size_t i = 0; i < axes.size(); ++i) {
      const AxisLive& a = axes_.at(axes[i]);
      const double target = msg.kind == request_t::SET_POSITION ? msg.values[i] : move_target_units(a, msg.kind, msg.values[i]);
      const auto& lim = a.axis->limits;
      if (target < lim.min_position || target > lim.max_position) {
        char buf[256];
        std::snprintf(buf, sizeof buf, "%s %.6g %s of axis %s is outside its limits [%.6g, %.6g]",
                      msg.kind == request_t::SET_POSITION ? "position" : "target", target, a.axis->unit.c_str(), axes[i].c_str(),
                      lim.min_position, lim.max_position);
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
        return P{ReplyError::kUnsupported, "axis " + axes[i] + " (UC57) can set its position to 0 only, not " + number(position) + " " + a.axis->unit};
      }
    }
  }
  if (msg.kind == request_t::HOME) {
    for (const auto& name : axes) {
      // Every family alike: an axis homes only the way its configuration says.
      if (axes_.at(name).axis->homing.method_name.empty()) {
        return P{ReplyError::kUnsupported, "axis " + name + " has no homing configured (add a homing: section to the axis)"};
      }
    }
  }
  if (msg.kind == request_t::JOG) {
    for (std::size_t i = 0; i < axes.size(); ++i) {
      const auto& lim = axes_.at(axes[i]).axis->limits;
      if (std::abs(msg.values[i]) > lim.max_velocity) {
        return P{ReplyError::kOutsideLimits, "jog velocity " + std::to_string(msg.values[i]) + " of axis " + axes[i] + " exceeds its limit " +
                                                 std::to_string(lim.max_velocity)};
      }
    }
  }
  return std::nullopt;
}

void Coordinator::on_request(const request_t& msg) {
  std::vector<std::string> axes;
  bool taken_over = false;
  if (auto err = validate(msg, axes)) {
    reply_unknown(msg, reply_t::REJECTED, err->first, err->second);
    return;
  }
  // Bounded work: beyond max_active_requests a request is refused at once, never queued; stops
  // always pass (they end work, and an operator must be able to stop everything).
  const auto limit = static_cast<std::size_t>(config_.coordinator.max_active_requests);
  if (!is_stop(msg.kind) && requests_.size() >= limit) {
    reply_unknown(msg, reply_t::REJECTED, ReplyError::kBusy,
                  "busy: " + std::to_string(requests_.size()) + " requests in progress (max_active_requests " + std::to_string(limit) +
                      "); retry when one has ended");
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
  const int timeout_ms = msg.timeout_ms > 0 ? msg.timeout_ms : config_.coordinator.default_timeout_ms;
  const std::uint64_t serial = r.serial;
  r.timeout_timer = loop_.call_after(std::chrono::milliseconds(timeout_ms), [this, serial, timeout_ms] {
    if (auto it = requests_.find(serial); it != requests_.end()) {
      abort_group(*it->second, reply_t::FAILED, ReplyError::kTimeout, "timed out after " + std::to_string(timeout_ms) + " ms");
    }
  });
  spdlog::info("request {}/{} ({}) accepted for {} axes", msg.client_id, msg.request_id, kind_name(msg.kind), axes.size());
  reply(r, reply_t::ACCEPTED);
  if (taken_over) check_stops();
  if (!is_move(msg.kind)) {
    for (const auto& a : axes) {
      // Anything else that moves or re-references the axis ends "standing at the last target".
      if (msg.kind == request_t::JOG || msg.kind == request_t::HOME || msg.kind == request_t::SET_POSITION) axes_.at(a).commanded_units.reset();
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
  const bool at_commanded = a.commanded_units && a.state &&
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
      return std::pair{ReplyError::kOutsideLimits, "target " + number(target_units) + " of axis " + r.axes[i] + " does not fit in counts"};
    }
    PlanInput in;
    in.axis = r.axes[i];
    in.family = a.drive->family;
    in.start_counts = a.state->position_counts;
    in.target_counts = static_cast<std::int64_t>(target);
    in.max_velocity = a.axis->limits.max_velocity * a.axis->steps_per_unit;
    in.max_acceleration = a.axis->limits.max_acceleration * a.axis->steps_per_unit;
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
  auto planned = planner_(inputs, scale_or_one(r.msg.velocity_scale), scale_or_one(r.msg.acceleration_scale));
  if (auto* why = std::get_if<std::string>(&planned)) return std::pair{ReplyError::kPlanningFailed, "planning failed: " + *why};
  r.plan = std::get<MovePlan>(planned);
  const int timeout_ms = r.msg.timeout_ms > 0 ? r.msg.timeout_ms : config_.coordinator.default_timeout_ms;
  if (!(r.plan.duration_s * 1000.0 < static_cast<double>(timeout_ms))) {
    return std::pair{ReplyError::kPlanningFailed, "the move would take " + number(r.plan.duration_s) + " s, longer than its timeout of " +
                                                      number(timeout_ms / 1000.0) + " s (raise the speed or timeout_ms)"};
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
    const std::string by = std::string(stop.kind == request_t::ESTOP ? "e-stopped" : "stopped") + " by request " + stop.client_id + "/" +
                           std::to_string(stop.request_id);
    // The ABORTED reply waits until the stop request's stops are confirmed (start_simple watches
    // them). The axes are free at once: the stop request owns their stop, and a request sent right
    // behind the stop may take them (which ends this one's wait).
    for (const auto& a : r.axes) {
      if (auto& live = axes_.at(a); live.busy_with == serial) live.busy_with = 0;
    }
    enter_stopping(r, std::move(stopped), {reply_t::ABORTED, ReplyError::kStopped, by});
  }
}

void Coordinator::start_simple(Request& r) {
  std::map<std::string, std::vector<motionlcm::axis_command_t>> per_bus;
  for (std::size_t i = 0; i < r.axes.size(); ++i) {
    const AxisLive& a = axes_.at(r.axes[i]);
    motionlcm::axis_command_t c{};
    c.axis = r.axes[i];
    const double value = i < r.msg.values.size() ? r.msg.values[i] : 0.0;
    const double counts_per_unit = a.axis->steps_per_unit * (a.axis->invert ? -1.0 : 1.0);
    if (r.msg.kind == request_t::JOG) {
      c.velocity = value * counts_per_unit * scale_or_one(r.msg.velocity_scale);
      c.acceleration = c.deceleration = a.axis->limits.max_acceleration * a.axis->steps_per_unit * scale_or_one(r.msg.acceleration_scale);
    } else if (r.msg.kind == request_t::SET_POSITION) {
      c.target_counts = std::llround(value * counts_per_unit);
    } else if (r.msg.kind == request_t::HOME) {
      c.velocity = (a.axis->homing.velocity != 0 ? a.axis->homing.velocity : -0.1 * a.axis->limits.max_velocity) * counts_per_unit;
      c.acceleration = c.deceleration = a.axis->limits.max_acceleration * a.axis->steps_per_unit;
      c.target_counts = std::llround(a.axis->homing.offset * counts_per_unit);
    }
    c.output_mask = r.msg.output_mask;
    c.output_value = r.msg.output_value;
    per_bus[a.drive->bus].push_back(c);
  }
  r.phase = Phase::kWaitingGateways;
  for (auto& [bus, cmds] : per_bus) {
    if (is_stop(r.msg.kind) && !gateway_alive(bus)) {
      std::string names;
      for (const auto& c : cmds) names += (names.empty() ? "" : ", ") + c.axis;
      r.unreached += (r.unreached.empty() ? "" : "; ") + names + " (gateway of bus " + bus + " offline)";
      continue;
    }
    if (is_stop(r.msg.kind)) {
      for (const auto& c : cmds) stops_.watch(c.axis, r.msg.kind == request_t::ESTOP, loop_.now(), stop_allowance(axes_.at(c.axis)));
    }
    send_command(r, bus, gateway_kind(r.msg.kind), std::move(cmds));
  }
  if (r.pending.empty()) {
    // A stop whose every gateway is gone: nothing to wait for.
    r.phase = Phase::kConfirming;
    r.gateways_done = loop_.now();
    return check_confirmed(r, false);
  }
  if (is_motion(r.msg.kind)) {
    r.fire_utime = wall_time_us();  // a jog or homing run starts when its gateway gets it
    publish_active_moves();
  }
}

void Coordinator::start_move(Request& r) {
  r.trigger_id = next_trigger_id_++;
  r.phase = Phase::kArming;
  std::map<std::string, std::vector<motionlcm::axis_command_t>> per_bus;
  for (const auto& p : r.plan.axes) {
    motionlcm::axis_command_t c{};
    c.axis = p.axis;
    c.target_counts = p.target_counts;
    c.velocity = p.velocity;
    c.acceleration = p.acceleration;
    c.deceleration = p.deceleration;
    per_bus[axes_.at(p.axis).drive->bus].push_back(c);
  }
  for (auto& [bus, cmds] : per_bus) {
    // One command per start mechanism, so that each gets its one-frame start (a gateway stack
    // starts a UIM342 group with one BG only when the command holds exactly that group) and its
    // own measured start time; the common trigger id starts them together.
    for (auto& group : start_groups(bus, std::move(cmds))) {
      std::vector<std::string> names;
      for (const auto& c : group) names.push_back(c.axis);
      const std::int64_t id = send_command(r, bus, gateway_command_t::ARM_MOVE, std::move(group));
      for (const auto& n : names) r.axis_command[n] = id;
      ++r.move_commands;
    }
  }
  const std::uint64_t serial = r.serial;
  r.arm_timer = loop_.call_after(std::chrono::milliseconds(config_.coordinator.arm_timeout_ms), [this, serial] {
    auto it = requests_.find(serial);
    if (it == requests_.end() || it->second->phase != Phase::kArming) return;
    std::string buses;
    for (const auto& [id, bus] : it->second->pending) {
      if (bus.rfind("armed:", 0) != 0) buses += (buses.empty() ? "" : ", ") + bus;
    }
    release_armed(*it->second, {reply_t::FAILED, ReplyError::kArmFailed, "gateway(s) " + buses + " did not confirm the armed move in time"});
  });
}

std::vector<std::vector<motionlcm::axis_command_t>> Coordinator::start_groups(const std::string& bus,
                                                                              std::vector<motionlcm::axis_command_t> axes) const {
  std::map<std::string, std::size_t> moving;  // drive -> index in axes
  for (std::size_t i = 0; i < axes.size(); ++i) moving[axes_.at(axes[i].axis).drive->name] = i;
  std::vector<std::vector<motionlcm::axis_command_t>> out;
  std::map<std::string, std::size_t> slot;  // key -> index in out
  for (const auto& c : axes) {
    const config::Drive& d = *axes_.at(c.axis).drive;
    std::string key = std::string("family:") + std::to_string(static_cast<int>(d.family));
    if (d.family == config::Family::kUim342) {
      bool whole_group = d.group_id != 0;
      for (const auto& other : config_.drives) {
        if (whole_group && other.bus == bus && other.family == config::Family::kUim342 && other.group_id == d.group_id) {
          whole_group = moving.contains(other.name);
        }
      }
      key = whole_group ? "uim342 group " + std::to_string(d.group_id) : "uim342 node " + d.name;
    }
    const auto [it, added] = slot.emplace(key, out.size());
    if (added) out.emplace_back();
    out[it->second].push_back(c);
  }
  return out;
}

void Coordinator::fire(Request& r) {
  loop_.cancel(r.arm_timer);
  r.phase = Phase::kTriggered;
  motionlcm::sync_trigger_t t{};
  t.utime = wall_time_us();
  t.trigger_id = r.trigger_id;
  // One bus: fire at once. Several: a common time far enough ahead for every gateway to hear it.
  t.fire_utime = t.utime + (r.buses.size() > 1 ? config_.coordinator.trigger_lead_ms * 1000 : 0);
  t.buses.assign(r.buses.begin(), r.buses.end());
  t.num_buses = static_cast<std::int32_t>(t.buses.size());
  r.fire_utime = t.fire_utime;
  node_.publish(lcm::channels::kSyncTrigger, t);
  const std::uint64_t serial = r.serial;
  r.progress_timer = loop_.call_every(std::chrono::milliseconds(config_.coordinator.progress_period_ms), [this, serial] {
    if (auto it = requests_.find(serial); it != requests_.end() && it->second->phase == Phase::kTriggered) reply(*it->second, reply_t::PROGRESS);
  });
  publish_active_moves();
}

void Coordinator::check_move_done(Request& r) {
  if (r.started_utime.size() < r.move_commands) return;  // not every start mechanism has fired yet
  for (const auto& name : r.axes) {
    if (r.still.contains(name)) continue;
    const AxisLive& a = axes_.at(name);
    if (!a.state || a.state->sample_utime < r.fire_utime) return;
    if (a.state->moving) return;
    if (std::abs(static_cast<double>(a.state->position_counts - r.targets.at(name))) > tolerance_counts(a)) return;
  }
  for (const auto& name : r.axes) {
    AxisLive& a = axes_.at(name);
    a.commanded_units = r.target_units.at(name);
    a.commanded_counts = r.targets.at(name);
  }
  reply(r, reply_t::DONE);
  finish(r.serial);
}

double Coordinator::tolerance_counts(const AxisLive& a) const {
  const double t = config_.coordinator.position_tolerance * a.axis->steps_per_unit;
  return std::max(t, 1.0);
}

void Coordinator::on_gateway_reply(const gateway_reply_t& g) {
  Request* rp = find_by_command(g.command_id);
  if (rp == nullptr) return;
  Request& r = *rp;
  if (r.phase == Phase::kReleasing) {
    if (g.status == gateway_reply_t::DONE || g.status == gateway_reply_t::FAILED) {
      r.pending.erase(g.command_id);
      if (r.pending.empty()) end_with(r, r.outcome);
    }
    return;
  }
  // A stop superseded by a later stop or e-stop on the same axis: that one stops it.
  // A stop the gateway could not complete (a drive that did not answer) is not the end of it: the
  // StopGuard repeats and escalates it, and the axis states decide.
  const bool superseded_stop = is_stop(r.msg.kind) && (g.error_code == error_code(ReplyError::kStopped) || g.status == gateway_reply_t::FAILED);
  if (is_stop(r.msg.kind) && g.status == gateway_reply_t::FAILED && g.error_code != error_code(ReplyError::kStopped)) {
    r.gateway_failure += (r.gateway_failure.empty() ? "" : "; ") + ("bus " + g.bus + ": " + g.reason);
    spdlog::warn("request {}/{} (stop): bus {}: {}; the stop is repeated until the axis states confirm it", r.msg.client_id, r.msg.request_id,
                 g.bus, g.reason);
  }
  if (g.status == gateway_reply_t::FAILED && !superseded_stop) {
    r.pending.erase(g.command_id);
    // The gateway's own code says more (a refused value, a silent drive, a fault) than "drive
    // error"; a move that could not be loaded stays kArmFailed as documented.
    const bool known_code = g.error_code > 0 && g.error_code <= error_code(ReplyError::kUnsupported);
    if (r.phase == Phase::kArming) {
      release_armed(r, {reply_t::FAILED, ReplyError::kArmFailed, "bus " + g.bus + ": " + g.reason});
      return;
    }
    const ReplyError error = known_code ? static_cast<ReplyError>(g.error_code) : ReplyError::kDriveError;
    abort_group(r, r.phase == Phase::kTriggered ? reply_t::ABORTED : reply_t::FAILED, error, "bus " + g.bus + ": " + g.reason);
    return;
  }
  if (is_move(r.msg.kind)) {
    if (g.status == gateway_reply_t::ARMED && r.phase == Phase::kArming) {
      r.pending[g.command_id] = "armed:" + g.bus;
      const bool all_armed = std::all_of(r.pending.begin(), r.pending.end(), [](const auto& p) { return p.second.rfind("armed:", 0) == 0; });
      if (all_armed) fire(r);
    } else if (g.status == gateway_reply_t::STARTED) {
      r.started_utime[g.command_id] = g.trigger_utime;
      // The gateway's spread between the start frames of this command (0 for one frame; the
      // frame times of a sequential start).
      r.start_spread_us[g.command_id] = std::max(0.0, g.predicted_skew_us);
      r.plan.predicted_skew_us = std::max(r.plan.predicted_skew_us, g.predicted_skew_us);
      if (r.started_utime.size() == r.move_commands && !r.started_sent) {
        r.started_sent = true;
        reply(r, reply_t::STARTED);
      }
      check_move_done(r);
    }
    return;
  }
  if (g.status == gateway_reply_t::DONE || superseded_stop) {
    r.pending.erase(g.command_id);
    if (g.param.space != motionlcm::param_t::NONE) r.param_result = g.param;
    if (r.pending.empty()) {
      r.phase = Phase::kConfirming;
      r.gateways_done = loop_.now();
      check_confirmed(r, false);
    }
  } else if (g.status == gateway_reply_t::STARTED && r.msg.kind != request_t::JOG) {
    reply(r, reply_t::STARTED);
  }
}

std::optional<std::string> Coordinator::unconfirmed(const Request& r) const {
  const auto k = r.msg.kind;
  const bool shows_in_state = k == request_t::ENABLE || k == request_t::DISABLE || k == request_t::FAULT_RESET || is_stop(k);
  if (!shows_in_state) return std::nullopt;
  for (const auto& name : r.axes) {
    const AxisLive& a = axes_.at(name);
    // A stop cannot wait for an axis whose gateway is gone (start_simple left it out and says so).
    if (is_stop(r.msg.kind) && (!gateway_alive(a.drive->bus) || (a.state && !a.state->online))) continue;
    if (!a.state) return "no state of axis " + name;
    const auto& s = *a.state;
    // A state older than the gateway's DONE may predate what the command did.
    if (a.received < r.gateways_done) return "axis " + name + " has not reported since";
    switch (r.msg.kind) {
      case request_t::ENABLE:
        if (!s.enabled) return "axis " + name + " still reports disabled";
        break;
      case request_t::DISABLE:
        if (s.enabled && s.online) return "axis " + name + " still reports enabled";
        break;
      case request_t::FAULT_RESET:
        if (s.fault) return "axis " + name + " still reports a fault (" + (s.fault_text.empty() ? "code " + std::to_string(s.fault_code) : s.fault_text) + ")";
        break;
      case request_t::STOP:
        if (s.moving && s.online) return "axis " + name + " still reports moving";
        break;
      case request_t::ESTOP:
        if ((s.moving || s.enabled) && s.online) return "axis " + name + (s.moving ? " still reports moving" : " still reports enabled");
        break;
      default: break;
    }
  }
  return std::nullopt;
}

void Coordinator::check_confirmed(Request& r, bool final_check) {
  if (is_stop(r.msg.kind)) {
    // A stop is confirmed by the StopGuard: it repeats and escalates what does not take.
    const bool watched = std::any_of(r.axes.begin(), r.axes.end(), [this](const std::string& a) { return stops_.watching(a); });
    if (watched) return;  // check_stops() calls again when the guard resolves them
    const std::string told = r.gateway_failure.empty() ? "" : "; " + r.gateway_failure;
    for (const auto& a : r.axes) {
      if (stops_.outcome(a) == StopGuard::Outcome::kUnconfirmed) {
        return end_with(r, {reply_t::FAILED, ReplyError::kDriveError, "axis " + a + " could not be stopped (still moving after an e-stop)" + told});
      }
      if (stops_.outcome(a) == StopGuard::Outcome::kSilent) {
        return end_with(r, {reply_t::FAILED, ReplyError::kAxisOffline, "axis " + a + " could not be confirmed stopped: it has not reported since" + told});
      }
      if (r.msg.kind == request_t::STOP && stops_.escalated(a)) {
        return end_with(r, {reply_t::FAILED, ReplyError::kDriveError, "axis " + a + " did not stop on STOP; it was e-stopped (disabled)"});
      }
    }
  }
  const auto missing = unconfirmed(r);
  if (!missing && !r.unreached.empty()) {
    end_with(r, {reply_t::FAILED, ReplyError::kGatewayOffline, "not reached: " + r.unreached});
  } else if (!missing) {
    reply(r, reply_t::DONE);
    finish(r.serial);
  } else if (final_check) {
    const ReplyError error = r.msg.kind == request_t::FAULT_RESET ? ReplyError::kAxisFaulted : ReplyError::kDriveError;
    reply(r, reply_t::FAILED, error, std::string(kind_name(r.msg.kind)) + ": the gateway reported done, but " + *missing);
    finish(r.serial);
  } else if (r.arm_timer == 0) {
    // Every gateway publishes its axes at its poll rate: a few of its periods settle it.
    const std::uint64_t serial = r.serial;
    r.arm_timer = loop_.call_after(std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms), [this, serial] {
      if (auto it = requests_.find(serial); it != requests_.end() && it->second->phase == Phase::kConfirming) {
        it->second->arm_timer = 0;
        check_confirmed(*it->second, true);
      }
    });
  }
}

Coordinator::Request* Coordinator::find_by_command(std::int64_t command_id) {
  for (auto& [serial, r] : requests_) {
    if (r->pending.contains(command_id)) return r.get();
  }
  return nullptr;
}

void Coordinator::abort_group(Request& r, std::int8_t status, ReplyError error, const std::string& reason) {
  if (r.phase == Phase::kDone || r.phase == Phase::kReleasing || r.phase == Phase::kStopping) return;
  // A move not triggered yet has moved nothing: it is disarmed, not stopped.
  if (is_move(r.msg.kind) && r.phase == Phase::kArming) return release_armed(r, {status, error, reason});
  // Stop every axis of the group that may be moving.
  if (is_move(r.msg.kind) || r.msg.kind == request_t::JOG || r.msg.kind == request_t::HOME) {
    std::vector<std::string> moving;
    for (const auto& a : r.axes) {
      if (!r.still.contains(a)) moving.push_back(a);
      axes_.at(a).commanded_units.reset();
    }
    send_stop(moving, false, r.msg.request_id);
    return enter_stopping(r, {moving.begin(), moving.end()}, {status, error, reason});
  }
  end_with(r, {status, error, reason});
}

void Coordinator::enter_stopping(Request& r, std::set<std::string> axes, Outcome outcome) {
  loop_.cancel(r.arm_timer);
  loop_.cancel(r.progress_timer);
  r.arm_timer = r.progress_timer = 0;
  r.pending.clear();  // replies to its commands no longer matter
  r.phase = Phase::kStopping;
  r.stopping = std::move(axes);
  r.outcome = std::move(outcome);
  if (r.stopping.empty()) return end_with(r, r.outcome);
  // Resolved on the next guard run at the latest (a stop's watch starts when it is sent).
}

Duration Coordinator::stop_allowance(const AxisLive& a) const {
  // From the top speed at the configured acceleration, twice over (a drive's own stop ramp may
  // be gentler), plus the time a gateway needs to poll and publish the axis.
  const auto& l = a.axis->limits;
  const double ramp_s = l.max_acceleration > 0 ? 2.0 * l.max_velocity / l.max_acceleration : 1.0;
  return std::chrono::duration_cast<Duration>(std::chrono::duration<double>(ramp_s)) +
         std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms);
}

void Coordinator::check_stops() {
  const auto actions = stops_.process(loop_.now(), [this](const std::string& axis, TimePoint since) {
    const AxisLive& a = axes_.at(axis);
    StopGuard::Observation o;
    // A drive that misses polls (lost frames, noise) is offline for a while: its stop is repeated
    // and escalated like any other until it reports again; only a gone gateway ends the watch.
    o.reachable = gateway_alive(a.drive->bus);
    o.reported_since = a.state.has_value() && a.state->online && a.received > since;
    o.moving = a.state && a.state->moving;
    return o;
  });
  using E = motionlcm::event_t;
  for (const auto& act : actions) {
    switch (act.kind) {
      case StopGuard::Action::Kind::kSendStop:
      case StopGuard::Action::Kind::kSendEstop: {
        const bool estop = act.kind == StopGuard::Action::Kind::kSendEstop;
        spdlog::warn("{}", act.text);
        publish_event(act.axis, estop ? E::ERROR : E::WARNING, E::STOP_UNCONFIRMED, act.text);
        // Sent directly: the guard already counts this attempt.
        gateway_command_t c{};
        c.utime = wall_time_us();
        c.bus = axes_.at(act.axis).drive->bus;
        c.command_id = next_command_id_++;
        c.kind = estop ? gateway_command_t::ESTOP : gateway_command_t::STOP;
        motionlcm::axis_command_t ac{};
        ac.axis = act.axis;
        c.axes.push_back(ac);
        c.num_axes = 1;
        node_.publish(lcm::channels::gateway_command(c.bus), c);
        break;
      }
      case StopGuard::Action::Kind::kResolved:
        if (act.outcome == StopGuard::Outcome::kUnconfirmed || act.outcome == StopGuard::Outcome::kSilent) {
          spdlog::error("{}", act.text);
          publish_event(act.axis, E::ERROR, E::STOP_UNCONFIRMED, act.text);
        } else if (act.attempt > 1) {
          publish_event(act.axis, E::INFO, E::STOP_UNCONFIRMED, act.text);
        }
        break;
    }
  }
  // Requests waiting for these stops: stopping requests end, stop requests conclude.
  std::vector<std::uint64_t> ready;
  for (const auto& [serial, r] : requests_) {
    const bool waiting = r->phase == Phase::kStopping || (r->phase == Phase::kConfirming && is_stop(r->msg.kind));
    if (!waiting) continue;
    const auto& axes = r->phase == Phase::kStopping ? std::vector<std::string>(r->stopping.begin(), r->stopping.end()) : r->axes;
    if (std::none_of(axes.begin(), axes.end(), [this](const std::string& a) { return stops_.watching(a); })) ready.push_back(serial);
  }
  for (const auto serial : ready) {
    auto it = requests_.find(serial);
    if (it == requests_.end()) continue;
    Request& r = *it->second;
    if (r.phase == Phase::kConfirming) {
      check_confirmed(r, false);
      continue;
    }
    Outcome outcome = r.outcome;
    std::string unconfirmed_axes, unreachable_axes;
    for (const auto& a : r.stopping) {
      const auto o = stops_.outcome(a);
      if (o == StopGuard::Outcome::kUnconfirmed) unconfirmed_axes += (unconfirmed_axes.empty() ? "" : ", ") + a;
      if (!o || o == StopGuard::Outcome::kUnreachable || o == StopGuard::Outcome::kSilent) {
        unreachable_axes += (unreachable_axes.empty() ? "" : ", ") + a;
      }
    }
    if (!unconfirmed_axes.empty()) outcome.reason += "; could not stop " + unconfirmed_axes + " (still moving after an e-stop)";
    if (!unreachable_axes.empty()) outcome.reason += "; stop of " + unreachable_axes + " not confirmed (gateway or drive not reporting)";
    end_with(r, outcome);
  }
}

void Coordinator::publish_event(const std::string& axis, std::int8_t severity, std::int16_t kind, const std::string& text) {
  motionlcm::event_t e{};
  e.utime = wall_time_us();
  e.source = "coordinator";
  e.bus = axes_.contains(axis) ? axes_.at(axis).drive->bus : std::string();
  e.axis = axis;
  e.severity = severity;
  e.kind = kind;
  e.text = text;
  node_.publish(lcm::channels::kEvent, e);
}

void Coordinator::release_armed(Request& r, Outcome outcome) {
  loop_.cancel(r.arm_timer);
  r.phase = Phase::kReleasing;
  r.outcome = std::move(outcome);
  r.pending.clear();  // replies to the ARM_MOVEs no longer matter
  std::map<std::string, std::vector<motionlcm::axis_command_t>> per_bus;
  for (const auto& a : r.axes) {
    if (r.still.contains(a)) continue;
    motionlcm::axis_command_t c{};
    c.axis = a;
    per_bus[axes_.at(a).drive->bus].push_back(c);
  }
  for (auto& [bus, cmds] : per_bus) {
    if (gateway_alive(bus)) send_command(r, bus, gateway_command_t::DISARM, std::move(cmds));
  }
  if (r.pending.empty()) return end_with(r, r.outcome);
  const std::uint64_t serial = r.serial;
  r.arm_timer = loop_.call_after(kReleaseTimeout, [this, serial] {
    if (auto it = requests_.find(serial); it != requests_.end() && it->second->phase == Phase::kReleasing) {
      it->second->arm_timer = 0;
      end_with(*it->second, it->second->outcome);
    }
  });
}

void Coordinator::end_with(Request& r, const Outcome& outcome) {
  spdlog::warn("request {}/{} ({}) {}: {}", r.msg.client_id, r.msg.request_id, kind_name(r.msg.kind),
               outcome.status == reply_t::ABORTED ? "aborted" : "failed", outcome.reason);
  const Outcome copy = outcome;  // `outcome` may live in r, which reply() leaves intact but finish() frees
  reply(r, copy.status, copy.error, copy.reason);
  finish(r.serial);
}

// ---------------------------------------------------------------- outputs

std::int64_t Coordinator::send_command(Request& r, const std::string& bus, std::int8_t kind, std::vector<motionlcm::axis_command_t> axes) {
  gateway_command_t c{};
  c.utime = wall_time_us();
  c.bus = bus;
  c.command_id = next_command_id_++;
  c.request_id = r.msg.request_id;
  c.kind = kind;
  c.trigger_id = kind == gateway_command_t::ARM_MOVE || kind == gateway_command_t::DISARM ? r.trigger_id : 0;
  c.axes = std::move(axes);
  c.num_axes = static_cast<std::int32_t>(c.axes.size());
  c.param = r.msg.param;
  r.pending[c.command_id] = bus;
  node_.publish(lcm::channels::gateway_command(bus), c);
  return c.command_id;
}

void Coordinator::send_stop(const std::vector<std::string>& axes, bool emergency, std::int64_t request_id) {
  std::map<std::string, std::vector<motionlcm::axis_command_t>> per_bus;
  for (const auto& name : axes) {
    motionlcm::axis_command_t c{};
    c.axis = name;
    per_bus[axes_.at(name).drive->bus].push_back(c);
  }
  for (auto& [bus, cmds] : per_bus) {
    gateway_command_t c{};
    c.utime = wall_time_us();
    c.bus = bus;
    c.command_id = next_command_id_++;  // fire and forget: replies to it match no request
    c.request_id = request_id;
    c.kind = emergency ? gateway_command_t::ESTOP : gateway_command_t::STOP;
    for (const auto& a : cmds) stops_.watch(a.axis, emergency, loop_.now(), stop_allowance(axes_.at(a.axis)));
    c.axes = std::move(cmds);
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    node_.publish(lcm::channels::gateway_command(bus), c);
  }
}

void Coordinator::reply(Request& r, std::int8_t status, ReplyError error, const std::string& reason) {
  reply_t out{};
  out.utime = wall_time_us();
  out.client_id = r.msg.client_id;
  out.request_id = r.msg.request_id;
  out.status = status;
  out.reason = reason;
  out.error_code = static_cast<std::int32_t>(error);
  out.predicted_duration_s = r.plan.duration_s;
  out.predicted_skew_us = r.plan.predicted_skew_us;
  // Start times are the gateways' stamps of their start frames on the wire, per start mechanism
  // (one ARM_MOVE each: a UIM342 group's BG, a UC57 SYNC, an ADAM broadcast, ...). The measured
  // skew spans the earliest start frame to the latest, a sequential start's own spread included.
  std::int64_t first = 0;
  double last = 0;
  for (const auto& [command, start] : r.started_utime) {
    if (start == 0) continue;
    const auto spread = r.start_spread_us.find(command);
    first = first == 0 ? start : std::min(first, start);
    last = std::max(last, static_cast<double>(start) + (spread != r.start_spread_us.end() ? spread->second : 0.0));
  }
  double progress_sum = 0;
  for (const auto& name : r.axes) {
    const AxisLive& a = axes_.at(name);
    out.axes.push_back(name);
    const double pos = a.state ? a.state->position : 0.0;
    out.positions.push_back(pos);
    const double counts_per_unit = a.axis->steps_per_unit * (a.axis->invert ? -1.0 : 1.0);
    auto t = r.targets.find(name);
    out.targets.push_back(t != r.targets.end() ? static_cast<double>(t->second) / counts_per_unit : 0.0);
    const auto command = r.axis_command.find(name);
    const auto started = command != r.axis_command.end() ? r.started_utime.find(command->second) : r.started_utime.end();
    const std::int64_t start = started != r.started_utime.end() ? started->second : 0;
    out.start_utime.push_back(start);
    if (t != r.targets.end() && a.state) {
      const double span = static_cast<double>(t->second - r.starts[name]);
      progress_sum += span == 0 ? 1.0 : std::clamp(static_cast<double>(a.state->position_counts - r.starts[name]) / span, 0.0, 1.0);
    }
  }
  out.num_axes = static_cast<std::int32_t>(out.axes.size());
  out.measured_start_skew_us = first == 0 ? 0.0 : last - static_cast<double>(first);
  out.progress = status == reply_t::DONE ? 1.0 : (r.axes.empty() ? 0.0 : progress_sum / static_cast<double>(r.axes.size()));
  out.param = r.param_result;
  node_.publish(lcm::channels::kReply, out);
  if (terminal(status)) {
    r.phase = Phase::kDone;
    if (is_motion(r.msg.kind)) publish_active_moves();
  }
  if (status == reply_t::DONE) {
    spdlog::info("request {}/{} ({}) done", r.msg.client_id, r.msg.request_id, kind_name(r.msg.kind));
  }
}

void Coordinator::finish(std::uint64_t serial) {
  auto it = requests_.find(serial);
  if (it == requests_.end()) return;
  Request& r = *it->second;
  loop_.cancel(r.timeout_timer);
  loop_.cancel(r.progress_timer);
  loop_.cancel(r.arm_timer);
  for (const auto& a : r.axes) {
    auto& live = axes_.at(a);
    if (live.busy_with == serial) live.busy_with = 0;
  }
  active_ids_.erase({r.msg.client_id, r.msg.request_id});
  requests_.erase(it);
}

}  // namespace motion::coordinator

namespace motion::coordinator {

void Coordinator::publish_active_moves() {
  motionlcm::active_moves_t out{};
  out.utime = wall_time_us();
  for (const auto& [serial, rp] : requests_) {
    const Request& r = *rp;
    if (!is_motion(r.msg.kind) || r.phase == Phase::kDone) continue;
    for (const auto& name : r.axes) {
      const AxisLive& a = axes_.at(name);
      const std::string& bus = a.drive->bus;
      std::int64_t command = 0;
      if (const auto c = r.axis_command.find(name); c != r.axis_command.end()) {
        command = c->second;
      } else {
        for (const auto& [id, pending_bus] : r.pending) {
          if (pending_bus == bus) command = id;
        }
      }
      const auto target = r.targets.find(name);
      const std::int64_t counts = target != r.targets.end() ? target->second : 0;
      const double counts_per_unit = a.axis->steps_per_unit * (a.axis->invert ? -1.0 : 1.0);
      const bool moving = r.phase == Phase::kTriggered || (!is_move(r.msg.kind) && r.fire_utime != 0);
      out.axes.push_back(name);
      out.buses.push_back(bus);
      out.client_ids.push_back(r.msg.client_id);
      out.request_ids.push_back(r.msg.request_id);
      out.kinds.push_back(r.msg.kind);
      out.phases.push_back(moving ? std::int8_t{motionlcm::active_moves_t::MOVING} : std::int8_t{motionlcm::active_moves_t::ARMING});
      out.command_ids.push_back(command);
      out.target_counts.push_back(counts);
      out.targets.push_back(counts_per_unit != 0 ? static_cast<double>(counts) / counts_per_unit : 0.0);
      out.fire_utime.push_back(moving ? r.fire_utime : 0);
    }
  }
  out.num_axes = static_cast<std::int32_t>(out.axes.size());
  active_moves_published_ = out.num_axes > 0;
  node_.publish(lcm::channels::kActiveMoves, out);
}

}  // namespace motion::coordinator
