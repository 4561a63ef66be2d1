// The coordinator core: aborts, releases of armed moves, and stops watched until confirmed (StopGuard).
#include "motion/coordinator/coordinator.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "coordinator_kinds.hpp"

namespace motion::coordinator {

using namespace detail;

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
  r.phase_deadline = r.next_progress = kNever;
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
  const auto actions = stops_.process(now_, [this](const std::string& axis, TimePoint since) {
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
        c.utime = wall_clock_();
        c.bus = axes_.at(act.axis).drive->bus;
        c.command_id = next_command_id_++;
        c.kind = estop ? gateway_command_t::ESTOP : gateway_command_t::STOP;
        motionlcm::axis_command_t ac{};
        ac.axis = act.axis;
        c.axes.push_back(ac);
        c.num_axes = 1;
        out_.gateway_command(c.bus, to_grid(c, nullptr), c);
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
    const auto& axes =
        r->phase == Phase::kStopping ? std::vector<std::string>(r->stopping.begin(), r->stopping.end()) : r->axes;
    if (std::none_of(axes.begin(), axes.end(), [this](const std::string& a) { return stops_.watching(a); }))
      ready.push_back(serial);
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
    if (!unconfirmed_axes.empty())
      outcome.reason += "; could not stop " + unconfirmed_axes + " (still moving after an e-stop)";
    if (!unreachable_axes.empty())
      outcome.reason += "; stop of " + unreachable_axes + " not confirmed (gateway or drive not reporting)";
    end_with(r, outcome);
  }
}

void Coordinator::release_armed(Request& r, Outcome outcome) {
  r.phase_deadline = kNever;
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
  r.phase_deadline = now_ + kReleaseTimeout;  // the terminal reply then at the latest
}

void Coordinator::end_with(Request& r, const Outcome& outcome) {
  spdlog::warn("request {}/{} ({}) {}: {}", r.msg.client_id, r.msg.request_id, kind_name(r.msg.kind),
               outcome.status == reply_t::ABORTED ? "aborted" : "failed", outcome.reason);
  const Outcome copy = outcome;  // `outcome` may live in r, which reply() leaves intact but finish() frees
  reply(r, copy.status, copy.error, copy.reason);
  finish(r.serial);
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
    c.utime = wall_clock_();
    c.bus = bus;
    c.command_id = next_command_id_++;  // fire and forget: replies to it match no request
    c.request_id = request_id;
    c.kind = emergency ? gateway_command_t::ESTOP : gateway_command_t::STOP;
    for (const auto& a : cmds) stops_.watch(a.axis, emergency, now_, stop_allowance(axes_.at(a.axis)));
    c.axes = std::move(cmds);
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    out_.gateway_command(bus, to_grid(c, nullptr), c);
  }
}

}  // namespace motion::coordinator
