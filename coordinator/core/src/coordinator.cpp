// The coordinator core: construction, time (process() and the next deadline), and the inputs
// that report what the gateways and axes are doing (AXIS_STATE, EVENT, HEALTH).
#include "motion/coordinator/coordinator.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "coordinator_kinds.hpp"
#include "motion/coordinator/move_planner.hpp"

namespace motion::coordinator {

using namespace detail;

Coordinator::Coordinator(const config::Config& config, MovePlanner planner, CoordinatorOutput& output,
                         WallClock wall_clock)
    : config_(config),
      planner_(std::move(planner)),
      out_(output),
      wall_clock_(std::move(wall_clock)),
      trigger_lead_(TriggerLead::Settings{.max_us = config.coordinator.trigger_lead_ms * 1000LL,
                                          .min_us = config.coordinator.trigger_lead_min_ms * 1000LL}) {
  for (const auto& axis : config_.axes)
    axes_[axis.name] =
        AxisLive{&axis, config_.drive_of(axis), std::nullopt, {}, 0, std::nullopt, 0, std::nullopt, nullptr, {}};
}

// ---------------------------------------------------------------- time

void Coordinator::begin(TimePoint now) {
  now_ = now;
  if (next_active_moves_ == kNever) next_active_moves_ = now + kActiveMovesPeriod;
  // A period that passed with nothing to republish is skipped, as it was when it passed.
  if (now >= next_active_moves_ && !active_moves_wanted()) {
    while (next_active_moves_ <= now) next_active_moves_ += kActiveMovesPeriod;
  }
}

TimePoint Coordinator::process(TimePoint now) {
  begin(now);
  std::vector<std::uint64_t> serials;
  serials.reserve(requests_.size());
  for (const auto& [serial, r] : requests_) serials.push_back(serial);
  // Each step may end the request: it is looked up again before the next.
  const auto find = [this](std::uint64_t serial) -> Request* {
    auto it = requests_.find(serial);
    return it == requests_.end() ? nullptr : it->second.get();
  };
  for (const auto serial : serials) {
    if (Request* r = find(serial); r != nullptr && r->timeout_at <= now) {
      r->timeout_at = kNever;
      abort_group(*r, reply_t::FAILED, ReplyError::kTimeout,
                  "timed out after " + std::to_string(r->timeout_ms) + " ms");
    }
    if (Request* r = find(serial); r != nullptr && r->phase_deadline <= now) {
      r->phase_deadline = kNever;
      on_phase_deadline(*r);
    }
    if (Request* r = find(serial); r != nullptr && r->phase == Phase::kTriggered && r->next_progress <= now) {
      const auto period = std::chrono::milliseconds(config_.coordinator.progress_period_ms);
      if (period.count() <= 0) {
        r->next_progress = kNever;
      } else {
        while (r->next_progress <= now) r->next_progress += period;  // missed periods are skipped
      }
      reply(*r, reply_t::PROGRESS);
    }
  }
  check_gateways();
  check_stops();
  next_resend_ = resend_unanswered();
  if (now >= next_model_request_) {
    if (const auto buses = buses_missing_models(); !buses.empty()) {
      // One request for every bus: a gateway answers with the models it has (one set up since).
      motionlcm::drive_model_request_t request{};
      request.utime = wall_clock_();
      request.requester = "coordinator";
      out_.drive_model_request(request);
      next_model_request_ = now + kModelRequestPeriod;
    }
  }
  if (now >= next_active_moves_) {
    while (next_active_moves_ <= now) next_active_moves_ += kActiveMovesPeriod;
    if (active_moves_wanted()) publish_active_moves();
  }
  return next_deadline();
}

TimePoint Coordinator::next_deadline() const {
  TimePoint next = kNever;
  for (const auto& [serial, r] : requests_) {
    next = std::min({next, r->timeout_at, r->phase_deadline});
    if (r->phase == Phase::kTriggered) next = std::min(next, r->next_progress);
    // The gateway watchdog: a request ends when the heartbeat of one of its buses is lost.
    for (const auto& bus : r->buses) next = std::min(next, gateway_expiry(bus));
  }
  if (const auto guard = stops_.next_deadline()) next = std::min(next, *guard);
  next = std::min(next, next_resend_);
  // A watched stop ends (unreachable) when its gateway is lost.
  for (const auto& [name, a] : axes_) {
    if (stops_.watching(name)) next = std::min(next, gateway_expiry(a.drive->bus));
  }
  if (active_moves_wanted()) next = std::min(next, next_active_moves_);
  if (!buses_missing_models().empty()) next = std::min(next, std::max(next_model_request_, now_));
  return next;
}

std::set<std::string> Coordinator::buses_missing_models() const {
  std::set<std::string> buses;
  for (const auto& [name, a] : axes_) {
    if (!a.model && gateway_alive_at(a.drive->bus, now_)) buses.insert(a.drive->bus);
  }
  return buses;
}

const motionlcm::drive_model_t* Coordinator::drive_model(const std::string& axis) const {
  const auto it = axes_.find(axis);
  return it == axes_.end() || !it->second.model ? nullptr : &*it->second.model;
}

void Coordinator::on_line_timing(const motionlcm::line_timing_t& timing, TimePoint now) {
  begin(now);
  if (config_.find_bus(timing.bus) == nullptr) return;
  constexpr double kLongestWaitUs = 1e6;  // no serial exchange of a poll takes a second
  if (!std::isfinite(timing.start_wait_us) || timing.start_wait_us < 0 || timing.start_wait_us > kLongestWaitUs) {
    publish_event("", motionlcm::event_t::WARNING, motionlcm::event_t::PROTOCOL_ERROR,
                  "line timing of bus " + timing.bus + " ignored: start_wait_us " +
                      std::to_string(timing.start_wait_us) + " is not a time from 0 to 1 s");
    return;
  }
  start_wait_us_[timing.bus] = timing.start_wait_us;
}

void Coordinator::on_arm_timing(const motionlcm::arm_timing_t& timing, TimePoint now) {
  begin(now);
  const auto it = axes_.find(timing.axis);
  if (it == axes_.end() || timing.bus != it->second.drive->bus) return;
  if (!std::isfinite(timing.arm_line_us) || !std::isfinite(timing.arm_bystander_us) || timing.arm_line_us < 0 ||
      timing.arm_bystander_us < 0) {
    publish_event(timing.axis, motionlcm::event_t::WARNING, motionlcm::event_t::PROTOCOL_ERROR,
                  "arming time of axis " + timing.axis + " ignored: not a finite, non-negative time");
    return;
  }
  it->second.arming = timing;
}

void Coordinator::on_trigger_heard(const motionlcm::trigger_heard_t& heard, TimePoint now) {
  begin(now);
  if (config_.find_bus(heard.bus) == nullptr) return;
  if (!trigger_lead_.heard(heard.bus, heard.trigger_id, heard.utime)) return;
  if (heard.utime > heard.send_utime && heard.send_utime > heard.trigger_utime) {
    // Heard after its send time: the gateway fired at once, late; this sample raises the lead.
    spdlog::warn(
        "trigger {} reached bus {} {} us after its send time (heard {} us after it was sent): the "
        "trigger lead is raised",
        heard.trigger_id, heard.bus, heard.utime - heard.send_utime, heard.utime - heard.trigger_utime);
  }
}

void Coordinator::on_drive_model(const motionlcm::drive_model_t& model, TimePoint now) {
  begin(now);
  const auto it = axes_.find(model.axis);
  std::string refused;
  if (it == axes_.end()) {
    refused = "names axis '" + model.axis + "', which is not in the configuration";
  } else if (model.bus != it->second.drive->bus) {
    refused = "comes from bus '" + model.bus + "', the axis is on bus '" + it->second.drive->bus + "'";
  } else if (model.family != config::to_string(it->second.drive->family)) {
    refused = "says family '" + model.family + "', the configuration says '" +
              std::string(config::to_string(it->second.drive->family)) + "'";
  }
  if (!refused.empty()) {
    publish_event(it == axes_.end() ? std::string() : model.axis, motionlcm::event_t::WARNING,
                  motionlcm::event_t::PROTOCOL_ERROR, "drive model of axis " + model.axis + " ignored: it " + refused);
    return;
  }
  AxisLive& a = it->second;
  auto quantizer = quantizer_from_model(model);
  a.model = model;
  if (auto* why = std::get_if<std::string>(&quantizer)) {
    a.quantizer.reset();
    a.model_error = *why;
    publish_event(model.axis, motionlcm::event_t::WARNING, motionlcm::event_t::PROTOCOL_ERROR,
                  "drive model of axis " + model.axis + " unusable: " + *why);
  } else {
    a.quantizer = std::get<std::shared_ptr<const planner::DriveQuantizer>>(std::move(quantizer));
    a.model_error.clear();
  }
}

void Coordinator::on_phase_deadline(Request& r) {
  switch (r.phase) {
    case Phase::kArming: {
      std::string buses;
      for (const auto& [id, command] : r.pending) {
        if (!command.armed) buses += (buses.empty() ? "" : ", ") + command.bus;
      }
      release_armed(r, {reply_t::FAILED, ReplyError::kArmFailed,
                        "gateway(s) " + buses + " did not confirm the armed move in time"});
      break;
    }
    case Phase::kReleasing: end_with(r, r.outcome); break;
    case Phase::kConfirming: check_confirmed(r, true); break;
    case Phase::kTriggered:
      if (is_move(r.msg.kind)) move_overdue(r);
      break;
    default: break;
  }
}

TimePoint Coordinator::resend_unanswered() {
  TimePoint next = kNever;
  for (auto& [serial, r] : requests_) {
    // Only a request waiting on its gateways; a stop's repeats are the StopGuard's.
    if (r->phase != Phase::kArming && r->phase != Phase::kReleasing && r->phase != Phase::kWaitingGateways) continue;
    for (auto& [id, p] : r->pending) {
      if (p.heard || p.resend_at == kNever) continue;
      if (p.resend_at <= now_) {
        spdlog::info("request {}/{}: no reply from bus {} to command {} yet: sent again", r->msg.client_id,
                     r->msg.request_id, p.bus, id);
        out_.gateway_command(p.bus, p.command2, p.command);
        p.resend_at = now_ + kCommandResend;
      }
      next = std::min(next, p.resend_at);
    }
  }
  return next;
}

bool Coordinator::active_moves_wanted() const {
  return active_moves_published_ ||
         std::any_of(requests_.begin(), requests_.end(), [](const auto& r) { return is_motion(r.second->msg.kind); });
}

// ---------------------------------------------------------------- inputs

void Coordinator::on_axis_state(const motionlcm::axis_state_t& state, TimePoint now) {
  begin(now);
  auto it = axes_.find(state.axis);
  if (it == axes_.end()) return;
  // Only a running gateway publishes axis states: as good a sign of life as its heartbeat, so a
  // coordinator started after its gateways accepts requests at once, not a heartbeat period
  // later. A gateway that announced STOPPING stays stopped until it heartbeats again.
  if (GatewayLive& g = gateways_[it->second.drive->bus]; !g.seen || g.last_heartbeat != TimePoint{}) {
    g.seen = true;
    g.last_heartbeat = now_;
  }
  const bool first_sight = !it->second.state.has_value();
  it->second.state = state;
  it->second.received = now_;
  if (first_sight && state.moving && state.online && it->second.busy_with == 0) {
    // Nothing this process sent moves it: a coordinator restarted while its predecessor's move,
    // jog or homing run went on, or a command from elsewhere. What nobody owns is stopped.
    const std::string text =
        "axis " + state.axis + " was moving (at " + number(state.position) +
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
                    "axis " + state.axis + " faulted: " +
                        (state.fault_text.empty() ? "code " + std::to_string(state.fault_code) : state.fault_text));
      } else if (r.phase == Phase::kTriggered && is_move(r.msg.kind)) {
        check_move_done(r);
      }
    }
  }
  // Requests whose gateways are done wait for states that show it (stops do not own axes).
  std::vector<std::uint64_t> confirming;
  for (const auto& [serial, r] : requests_) {
    if (r->phase == Phase::kConfirming && std::find(r->axes.begin(), r->axes.end(), state.axis) != r->axes.end())
      confirming.push_back(serial);
  }
  for (const auto serial : confirming) {
    if (auto rit = requests_.find(serial); rit != requests_.end()) check_confirmed(*rit->second, false);
  }
  if (stops_.watching(state.axis)) check_stops();
}

void Coordinator::on_event(const motionlcm::event_t& event, TimePoint now) {
  begin(now);
  using E = motionlcm::event_t;
  const bool fatal = event.kind == E::STALL || event.kind == E::LIMIT || event.kind == E::HEARTBEAT_LOST ||
                     event.kind == E::OFFLINE || event.kind == E::BUS_OFF ||
                     (event.kind == E::ALARM && event.severity >= E::ERROR) ||
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

void Coordinator::on_health(const motionlcm::health_t& health, TimePoint now) {
  begin(now);
  if (health.role != "gateway" || health.process.rfind("gateway:", 0) != 0) return;
  const std::string bus = health.process.substr(8);
  GatewayLive& g = gateways_[bus];
  // pid 0: known only from its axis states so far, not a restart.
  const bool restarted = g.seen && g.pid != 0 && (health.pid != g.pid || health.uptime_s + 0.5 < g.uptime_s);
  g.seen = true;
  g.pid = health.pid;
  g.host = health.host;
  g.last_health = now_;
  g.uptime_s = health.uptime_s;
  g.last_heartbeat = health.state == motionlcm::health_t::STOPPING ? TimePoint{} : now_;
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

void Coordinator::on_orphaned_moves(const motionlcm::active_moves_t& moves, TimePoint now) {
  begin(now);
  std::map<std::pair<std::string, std::int64_t>, std::vector<std::string>> requests;  // request -> its axes
  for (std::size_t i = 0; i < moves.axes.size(); ++i) {
    const std::pair<std::string, std::int64_t> id{moves.client_ids[i], moves.request_ids[i]};
    if (active_ids_.contains(id) || orphans_ended_.contains(id)) continue;
    requests[id].push_back(moves.axes[i] + " (" + moves.buses[i] + ")");
  }
  for (const auto& [id, axes] : requests) {
    orphans_ended_.insert(id);
    std::string list;
    for (const auto& a : axes) list += (list.empty() ? "" : ", ") + a;
    motionlcm::request_t msg{};
    msg.client_id = id.first;
    msg.request_id = id.second;
    msg.kind = moves.kinds.empty() ? 0 : moves.kinds[0];
    const std::string reason = "the coordinator serving this request stopped while it had " + list +
                               "; its successor ends the request (axes still moving are stopped)";
    reply_unknown(msg, reply_t::ABORTED, ReplyError::kCoordinatorRestarted, reason);
    publish_event(
        "", motionlcm::event_t::WARNING, motionlcm::event_t::UNOWNED_MOTION,
        "request " + id.first + "/" + std::to_string(id.second) + " of a previous coordinator ended: " + reason);
  }
}

void Coordinator::on_malformed_message(const std::string& what, TimePoint now) {
  begin(now);
  publish_event("", motionlcm::event_t::WARNING, motionlcm::event_t::PROTOCOL_ERROR, what);
}

// ---------------------------------------------------------------- gateways

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
      abort_group(*it->second, reply_t::ABORTED, ReplyError::kGatewayLost,
                  "lost the heartbeat of the gateway of bus " + bus);
    }
  }
}

std::vector<std::string> Coordinator::buses_without_gateway(TimePoint now) const {
  std::vector<std::string> out;
  for (const auto& bus : config_.buses) {
    if (!gateway_alive_at(bus.name, now)) out.push_back(bus.name);
  }
  return out;
}

std::vector<std::string> Coordinator::axes_never_heard() const {
  std::vector<std::string> out;
  for (const auto& [name, axis] : axes_) {
    if (!axis.state) out.push_back(name);
  }
  return out;
}

bool Coordinator::is_live_gateways_heartbeat(const motionlcm::health_t& health, TimePoint now) const {
  if (health.process.rfind("gateway:", 0) != 0) return false;
  const auto it = gateways_.find(health.process.substr(8));
  if (it == gateways_.end() || it->second.last_health == TimePoint{}) return false;
  const GatewayLive& g = it->second;
  return g.pid == health.pid && g.host == health.host &&
         now - g.last_health < std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms);
}

std::optional<std::string> Coordinator::bus_of_axis(const std::string& axis) const {
  const auto it = axes_.find(axis);
  if (it == axes_.end()) return std::nullopt;
  return it->second.drive->bus;
}

std::optional<std::string> Coordinator::bus_of_command(std::int64_t command_id) const {
  for (const auto& [serial, r] : requests_) {
    if (const auto it = r->pending.find(command_id); it != r->pending.end()) return it->second.bus;
  }
  return std::nullopt;
}

bool Coordinator::gateway_alive_at(const std::string& bus, TimePoint now) const {
  auto it = gateways_.find(bus);
  if (it == gateways_.end() || !it->second.seen || it->second.last_heartbeat == TimePoint{}) return false;
  return now - it->second.last_heartbeat < std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms);
}

TimePoint Coordinator::gateway_expiry(const std::string& bus) const {
  if (!gateway_alive(bus)) return kNever;
  return gateways_.at(bus).last_heartbeat + std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms);
}

}  // namespace motion::coordinator
