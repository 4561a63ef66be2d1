// The coordinator core: starting requests (moves armed and triggered, other commands sent), the
// gateways' replies, and the confirmation of what a request did in the axis states.
#include "motion/coordinator/coordinator.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <set>

#include "coordinator_kinds.hpp"

namespace motion::coordinator {

using namespace detail;

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
      c.acceleration = c.deceleration =
          a.axis->limits.max_acceleration * a.axis->steps_per_unit * scale_or_one(r.msg.acceleration_scale);
    } else if (r.msg.kind == request_t::SET_POSITION) {
      c.target_counts = std::llround(value * counts_per_unit);
    } else if (r.msg.kind == request_t::HOME) {
      c.velocity = (a.axis->homing.velocity != 0 ? a.axis->homing.velocity : -0.1 * a.axis->limits.max_velocity) *
                   counts_per_unit;
      c.acceleration = c.deceleration = a.axis->limits.max_acceleration * a.axis->steps_per_unit;
      c.target_counts = std::llround(a.axis->homing.offset * counts_per_unit);
    }
    c.output_mask = r.msg.output_mask;
    c.output_value = r.msg.output_value;
    if ((r.msg.kind == request_t::JOG || r.msg.kind == request_t::HOME) && a.model)
      r.grid[c.axis] = grid_of(*a.model, c);
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
      for (const auto& c : cmds)
        stops_.watch(c.axis, r.msg.kind == request_t::ESTOP, now_, stop_allowance(axes_.at(c.axis)));
    }
    send_command(r, bus, gateway_kind(r.msg.kind), std::move(cmds));
  }
  if (r.pending.empty()) {
    // A stop whose every gateway is gone: nothing to wait for.
    r.phase = Phase::kConfirming;
    r.gateways_done = now_;
    return check_confirmed(r, false);
  }
  if (is_motion(r.msg.kind)) {
    r.fire_utime = wall_clock_();  // a jog or homing run starts when its gateway gets it
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
    auto& grid = r.grid[p.axis];
    grid.velocity = p.native.velocity;
    grid.acceleration = p.native.acceleration;
    grid.deceleration = p.native.deceleration;
    grid.model_utime = p.model_utime;
    per_bus[axes_.at(p.axis).drive->bus].push_back(c);
  }
  // The arm timeout covers processes, LCM and the host; the line time of the frames arming needs
  // comes on top (a long ADAM line readies every other drive for the broadcast start).
  r.phase_deadline = now_ + std::chrono::milliseconds(config_.coordinator.arm_timeout_ms) + arming_line_time(per_bus);
  for (auto& [bus, cmds] : per_bus) {
    // One command per start mechanism, so that each gets its one-frame start (a UIM342 stack
    // starts a command with one group BG only when it holds the group, or part of it with the
    // rest held at rest) and its own measured start time; the common trigger id starts them
    // together.
    std::vector<std::int8_t> kinds;
    auto groups = start_groups(bus, std::move(cmds), &kinds);
    for (std::size_t g = 0; g < groups.size(); ++g) {
      auto& group = groups[g];
      std::vector<std::string> names;
      for (const auto& c : group) names.push_back(c.axis);
      const double wire_us = start_frame_wire_us(group, kinds[g]);
      const double lead_in_us = start_lead_in_us(group);
      const std::int64_t id = send_command(r, bus, gateway_command_t::ARM_MOVE, std::move(group));
      const auto wait = start_wait_us_.find(bus);
      r.start_frames.push_back({bus, id, wire_us, lead_in_us, wait == start_wait_us_.end() ? 0.0 : wait->second});
      for (const auto& n : names) r.axis_command[n] = id;
      ++r.move_commands;
    }
  }
}

Duration Coordinator::arming_line_time(
    const std::map<std::string, std::vector<motionlcm::axis_command_t>>& per_bus) const {
  double slowest_us = 0;
  for (const auto& [bus, cmds] : per_bus) {
    double own_us = 0;
    double bystander_us = 0;
    for (const auto& c : cmds) {
      const auto& arming = axes_.at(c.axis).arming;
      own_us += arming.arm_line_us;
      bystander_us = std::max(bystander_us, arming.arm_bystander_us);
    }
    // An init-capture, not `bus` itself: clang 14 (clang-tidy) does not capture structured bindings.
    const auto on_bus = std::count_if(config_.drives.begin(), config_.drives.end(),
                                      [&name = bus](const config::Drive& d) { return d.bus == name; });
    const auto others = std::max<std::ptrdiff_t>(0, on_bus - static_cast<std::ptrdiff_t>(cmds.size()));
    slowest_us = std::max(slowest_us, own_us + static_cast<double>(others) * bystander_us);
  }
  return std::chrono::duration_cast<Duration>(std::chrono::duration<double, std::micro>(slowest_us));
}

double Coordinator::start_frame_wire_us(const std::vector<motionlcm::axis_command_t>& group, std::int8_t kind) const {
  double wire = 0;
  for (const auto& c : group) {
    const auto& model = axes_.at(c.axis).model;
    if (!model) continue;
    auto w = start_wire_us(*model, kind);
    if (!w) w = start_wire_us(*model, motionlcm::drive_model_t::START_SINGLE);
    if (w) wire = std::max(wire, *w);
  }
  return wire;
}

// UIM242 axes that crawl into their moves (drive model START_UIM242_CRAWL, docs/protocols.md
// UIM242 #3): their crawl instructions go out one axis after the other before the start frame,
// and each axis starts moving with its own.
double Coordinator::start_lead_in_us(const std::vector<motionlcm::axis_command_t>& group) const {
  double lead_in = 0;
  for (const auto& c : group) {
    const auto& model = axes_.at(c.axis).model;
    if (!model) continue;
    lead_in += start_wire_us(*model, motionlcm::drive_model_t::START_UIM242_CRAWL).value_or(0.0);
  }
  return lead_in;
}

namespace {

// The address a drive model gives for a start mechanism, or nullopt when it does not offer it.
std::optional<std::int32_t> start_address(const motionlcm::drive_model_t& model, std::int8_t kind) {
  for (std::size_t i = 0; i < model.start_kinds.size() && i < model.start_addresses.size(); ++i) {
    if (model.start_kinds[i] == kind) return model.start_addresses[i];
  }
  return std::nullopt;
}

}  // namespace

std::vector<std::vector<motionlcm::axis_command_t>> Coordinator::start_groups(
    const std::string& bus, std::vector<motionlcm::axis_command_t> axes, std::vector<std::int8_t>* kinds) const {
  using Model = motionlcm::drive_model_t;
  std::set<std::string> moving;  // axes of this move
  for (const auto& c : axes) moving.insert(c.axis);
  // A group BG starts every drive of the group (UIM342 manual §5.11). It starts a move that holds
  // the whole group, or at least two and at least half of its drives while each other one rests
  // with nothing to do: the gateway holds those at PR=0 until the BG, by the same rule
  // (docs/protocols.md, UIM342 row 8), and starts drive by drive when it finds one that is not
  // free after all. Members are the axes of this bus whose model offers BG to that group id, and
  // (no model yet: offline) those the configuration puts in it.
  const auto shares_group_bg = [&](std::int32_t group) {
    std::size_t in_move = 0;
    std::size_t others = 0;
    bool others_free = true;
    for (const auto& [name, live] : axes_) {
      if (live.drive->bus != bus) continue;
      const bool member = live.model ? start_address(*live.model, Model::START_UIM342_GROUP_BG) == group
                                     : live.drive->group_id == group;
      if (!member) continue;
      if (moving.contains(name)) {
        ++in_move;
        continue;
      }
      ++others;
      const auto& s = live.state;
      others_free = others_free && live.busy_with == 0 && s && s->online && s->enabled && !s->moving && !s->fault;
    }
    return others == 0 || (in_move >= 2 && others <= in_move && others_free);
  };
  // Each axis joins the first start its model offers, in this order: a whole group's BG, one
  // CANopen SYNC, one ADAM broadcast, one UIM242 global start, else a start of its own. Axes that
  // join the same start share one command.
  static constexpr std::array<std::int8_t, 4> kShared{Model::START_UIM342_GROUP_BG, Model::START_CANOPEN_SYNC,
                                                      Model::START_ADAM_BROADCAST, Model::START_UIM242_GLOBAL};
  std::vector<std::vector<motionlcm::axis_command_t>> out;
  std::map<std::pair<std::int8_t, std::string>, std::size_t> slot;  // (kind, address or axis) -> index in out
  for (const auto& c : axes) {
    const auto& model = axes_.at(c.axis).model;
    std::pair<std::int8_t, std::string> key{std::int8_t{Model::START_SINGLE}, c.axis};
    for (const std::int8_t kind : kShared) {
      const auto address = model ? start_address(*model, kind) : std::nullopt;
      if (!address || (kind == Model::START_UIM342_GROUP_BG && !shares_group_bg(*address))) continue;
      key = {kind, std::to_string(*address)};
      break;
    }
    const auto [it, added] = slot.emplace(key, out.size());
    if (added) {
      out.emplace_back();
      if (kinds != nullptr) kinds->push_back(key.first);
    }
    out[it->second].push_back(c);
  }
  return out;
}

void Coordinator::fire(Request& r) {
  r.phase_deadline = kNever;
  r.phase = Phase::kTriggered;
  // The drives act together at act_utime: each bus hands its start frames to the wire early by
  // their wire time (start_schedule.hpp). One bus: its longest lead starts now (its frames may
  // wait for an exchange under way: they still start together). Several: the hand-overs start far
  // enough ahead for every gateway to hear the trigger, as long as the gateways of these buses
  // took to hear the recent triggers (trigger_lead.hpp), and each serial line's start wait before
  // its own send time.
  const StartSchedule schedule = schedule_starts(r.start_frames);
  const std::int64_t utime = wall_clock_();
  const std::int64_t act_after =
      static_cast<std::int64_t>(std::ceil(r.buses.size() > 1 ? schedule.max_ahead_us : schedule.max_lead_us));
  const std::int64_t earliest_send = utime + (r.buses.size() > 1 ? trigger_lead_.lead_us(r.buses) : 0);
  trigger_lead_.published(r.trigger_id, utime);
  motionlcm::sync_trigger2_t t2{};
  t2.utime = utime;
  t2.trigger_id = r.trigger_id;
  t2.act_utime = earliest_send + act_after;
  t2.predicted_spread_us = schedule.predicted_spread_us;
  for (const auto& b : schedule.buses) {
    t2.buses.push_back(b.bus);
    t2.lead_us.push_back(b.lead_us);
    t2.send_utime.push_back(t2.act_utime - std::llround(b.lead_us));
    t2.start_command_ids.insert(t2.start_command_ids.end(), b.command_ids.begin(), b.command_ids.end());
  }
  t2.num_buses = static_cast<std::int32_t>(t2.buses.size());
  t2.num_starts = static_cast<std::int32_t>(t2.start_command_ids.size());
  out_.sync_trigger2(t2);
  // The same trigger for gateways that know only SYNC_TRIGGER: they start at fire_utime, as before.
  motionlcm::sync_trigger_t t{};
  t.utime = utime;
  t.trigger_id = r.trigger_id;
  t.fire_utime = earliest_send;
  t.buses.assign(r.buses.begin(), r.buses.end());
  t.num_buses = static_cast<std::int32_t>(t.buses.size());
  r.fire_utime = t.fire_utime;
  out_.sync_trigger(t);
  r.next_progress = now_ + std::chrono::milliseconds(config_.coordinator.progress_period_ms);
  // LCM delivers nothing for sure: a trigger or a STARTED reply lost on the way must not keep the
  // axes busy until the request's timeout.
  const auto ahead = std::chrono::microseconds(std::max<std::int64_t>(0, t2.act_utime - utime));
  r.phase_deadline = now_ + ahead + std::chrono::microseconds(std::llround(r.plan.duration_s * 1e6)) +
                     2 * std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms);
  publish_active_moves();
}

std::string Coordinator::short_of_target(const Request& r, std::vector<std::string>* moving) const {
  std::string text;
  for (const auto& name : r.axes) {
    if (r.still.contains(name)) continue;
    const AxisLive& a = axes_.at(name);
    if (!a.state || a.state->sample_utime < r.fire_utime || a.state->moving) {
      moving->push_back(name);
      continue;
    }
    const std::int64_t target = r.targets.at(name);
    if (std::abs(static_cast<double>(a.state->position_counts - target)) > tolerance_counts(a)) {
      text += (text.empty() ? "" : "; ") + ("axis " + name + " rests at " + std::to_string(a.state->position_counts) +
                                            " counts, its target is " + std::to_string(target));
    }
  }
  return text;
}

void Coordinator::check_move_done(Request& r) {
  if (r.started_utime.size() < r.move_commands) return;  // not every start mechanism has fired yet
  std::vector<std::string> moving;
  if (!short_of_target(r, &moving).empty() || !moving.empty()) return;
  for (const auto& name : r.axes) {
    AxisLive& a = axes_.at(name);
    a.commanded_units = r.target_units.at(name);
    a.commanded_counts = r.targets.at(name);
  }
  reply(r, reply_t::DONE);
  finish(r.serial);
}

void Coordinator::move_overdue(Request& r) {
  std::vector<std::string> moving;
  const std::string short_of = short_of_target(r, &moving);
  if (!moving.empty()) {
    // Still on its way (or its state not heard since the trigger: the gateway watchdog handles a
    // lost gateway): another look a gateway timeout later; the request's timeout bounds the wait.
    r.phase_deadline = now_ + std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms);
    return;
  }
  std::string unstarted;
  for (const auto& [id, command] : r.pending) {
    if (!r.started_utime.contains(id)) unstarted += (unstarted.empty() ? "" : ", ") + command.bus;
  }
  if (short_of.empty()) {
    // Every axis arrived: only a STARTED reply was lost.
    spdlog::warn("request {}/{}: every axis at its target, no STARTED heard from bus {}: done", r.msg.client_id,
                 r.msg.request_id, unstarted);
    for (const auto& [id, command] : r.pending) r.started_utime.try_emplace(id, r.fire_utime);
    return check_move_done(r);
  }
  abort_group(r, reply_t::FAILED, ReplyError::kTimeout,
              "the move did not arrive by its predicted end: " + short_of +
                  (unstarted.empty()
                       ? ""
                       : " (bus " + unstarted + " reported no start: its trigger or its STARTED reply was lost)"));
}

void Coordinator::on_gateway_reply(const gateway_reply_t& g, TimePoint now) {
  begin(now);
  Request* rp = find_by_command(g.command_id);
  if (rp == nullptr) return;
  Request& r = *rp;
  if (auto p = r.pending.find(g.command_id); p != r.pending.end()) {
    p->second.heard = true;
    p->second.resend_at = kNever;
  }
  if (r.phase == Phase::kReleasing) {
    if (g.status == gateway_reply_t::DONE || g.status == gateway_reply_t::FAILED) {
      r.pending.erase(g.command_id);
      if (r.pending.empty()) end_with(r, r.outcome);
    }
    return;
  }
  // A stop's gateway part that ends FAILED — superseded by a later stop of the same axis (code 14),
  // or not completed (a drive that did not answer) — is not the end of the stop: the StopGuard
  // repeats and escalates it, and the axis states decide.
  const bool stop_part_failed = is_stop(r.msg.kind) && g.status == gateway_reply_t::FAILED;
  if (stop_part_failed && g.error_code != error_code(ReplyError::kStopped)) {
    r.gateway_failure += (r.gateway_failure.empty() ? "" : "; ") + ("bus " + g.bus + ": " + g.reason);
    spdlog::warn("request {}/{} (stop): bus {}: {}; the stop is repeated until the axis states confirm it",
                 r.msg.client_id, r.msg.request_id, g.bus, g.reason);
  }
  if (g.status == gateway_reply_t::FAILED && !stop_part_failed) {
    r.pending.erase(g.command_id);
    // The gateway's own code says more (a refused value, a silent drive, a fault) than "drive
    // error"; a move that could not be loaded stays kArmFailed as documented.
    const bool known_code = g.error_code > 0 && g.error_code <= error_code(ReplyError::kUnsupported);
    if (r.phase == Phase::kArming) {
      release_armed(r, {reply_t::FAILED, ReplyError::kArmFailed, "bus " + g.bus + ": " + g.reason});
      return;
    }
    const ReplyError error = known_code ? static_cast<ReplyError>(g.error_code) : ReplyError::kDriveError;
    abort_group(r, r.phase == Phase::kTriggered ? reply_t::ABORTED : reply_t::FAILED, error,
                "bus " + g.bus + ": " + g.reason);
    return;
  }
  if (is_move(r.msg.kind)) {
    if (g.status == gateway_reply_t::ARMED && r.phase == Phase::kArming) {
      r.pending[g.command_id].armed = true;
      const bool all_armed =
          std::all_of(r.pending.begin(), r.pending.end(), [](const auto& p) { return p.second.armed; });
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
  if (g.status == gateway_reply_t::DONE || stop_part_failed) {
    r.pending.erase(g.command_id);
    if (g.param.space != motionlcm::param_t::NONE) r.param_result = g.param;
    if (r.pending.empty()) {
      r.phase = Phase::kConfirming;
      r.gateways_done = now_;
      check_confirmed(r, false);
    }
  } else if (g.status == gateway_reply_t::STARTED && r.msg.kind != request_t::JOG) {
    reply(r, reply_t::STARTED);
  }
}

std::optional<std::string> Coordinator::unconfirmed(const Request& r) const {
  const auto k = r.msg.kind;
  const bool shows_in_state =
      k == request_t::ENABLE || k == request_t::DISABLE || k == request_t::FAULT_RESET || is_stop(k);
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
        if (s.fault)
          return "axis " + name + " still reports a fault (" +
                 (s.fault_text.empty() ? "code " + std::to_string(s.fault_code) : s.fault_text) + ")";
        break;
      case request_t::STOP:
        if (s.moving && s.online) return "axis " + name + " still reports moving";
        break;
      case request_t::ESTOP:
        if ((s.moving || s.enabled) && s.online)
          return "axis " + name + (s.moving ? " still reports moving" : " still reports enabled");
        break;
      default: break;
    }
  }
  return std::nullopt;
}

void Coordinator::check_confirmed(Request& r, bool final_check) {
  if (is_stop(r.msg.kind)) {
    // A stop is confirmed by the StopGuard: it repeats and escalates what does not take.
    const bool watched =
        std::any_of(r.axes.begin(), r.axes.end(), [this](const std::string& a) { return stops_.watching(a); });
    if (watched) return;  // check_stops() calls again when the guard resolves them
    const std::string told = r.gateway_failure.empty() ? "" : "; " + r.gateway_failure;
    for (const auto& a : r.axes) {
      if (stops_.outcome(a) == StopGuard::Outcome::kUnconfirmed) {
        return end_with(r, {reply_t::FAILED, ReplyError::kDriveError,
                            "axis " + a + " could not be stopped (still moving after an e-stop)" + told});
      }
      if (stops_.outcome(a) == StopGuard::Outcome::kSilent) {
        return end_with(r, {reply_t::FAILED, ReplyError::kAxisOffline,
                            "axis " + a + " could not be confirmed stopped: it has not reported since" + told});
      }
      if (r.msg.kind == request_t::STOP && stops_.escalated(a)) {
        return end_with(r, {reply_t::FAILED, ReplyError::kDriveError,
                            "axis " + a + " did not stop on STOP; it was e-stopped (disabled)"});
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
    reply(r, reply_t::FAILED, error,
          std::string(kind_name(r.msg.kind)) + ": the gateway reported done, but " + *missing);
    finish(r.serial);
  } else if (r.phase_deadline == kNever) {
    // Every gateway publishes its axes at its poll rate: a few of its periods settle it.
    r.phase_deadline = now_ + std::chrono::milliseconds(config_.coordinator.gateway_timeout_ms);  // the final check
  }
}

Coordinator::Request* Coordinator::find_by_command(std::int64_t command_id) {
  for (auto& [serial, r] : requests_) {
    if (r->pending.contains(command_id)) return r.get();
  }
  return nullptr;
}

}  // namespace motion::coordinator
