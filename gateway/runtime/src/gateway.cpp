#include "motion/gateway/gateway.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <map>
#include <vector>

#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>
#include <motionlcm/trigger_heard_t.hpp>

#include "motion/gateway/command_ledger.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/reply_error.hpp"

namespace motion::gateway {

namespace {
// A scheduled start handed over later than this is said in the log (the skew goal is 200 µs).
constexpr auto kLateFireNote = std::chrono::microseconds(100);
// Starts waiting for their send time, at most.
constexpr std::size_t kMostPendingFires = 256;
}  // namespace

Gateway::Gateway(EventLoop& loop, lcm::Node& node, lcm::HealthPublisher& health, const config::Config& config,
                 std::string bus)
    : loop_(loop),
      node_(node),
      health_(health),
      config_(config),
      bus_(std::move(bus)),
      started_utime_(wall_time_us()),
      enforce_(config.security.mode == config::SecuritySettings::Mode::kEnforce) {
  for (const config::Axis* axis : config_.axes_on_bus(bus_)) {
    axes_.emplace(axis->name, axis);
    limits_.emplace(axis->name, CountLimits::of(*axis));
  }
  if (const config::Bus* b = config_.find_bus(bus_); b != nullptr) poll_hz_ = b->poll_hz;
  node_.subscribe<motionlcm::gateway_command_t>(
      lcm::channels::gateway_command(bus_),
      [this](const motionlcm::gateway_command_t& c, const std::string&) { on_plain(c, &Gateway::on_command); });
  node_.subscribe<motionlcm::gateway_command2_t>(
      lcm::channels::gateway_command2(bus_),
      [this](const motionlcm::gateway_command2_t& c, const std::string&) { on_plain(c, &Gateway::on_command2); });
  node_.subscribe<motionlcm::signed_gateway_command_t>(
      lcm::channels::signed_gateway_command(bus_),
      [this](const motionlcm::signed_gateway_command_t& m, const std::string&) { on_signed_command(m); },
      [this](const void*, int, const std::string& why) { refuse("malformed signed command refused: " + why); });
  subscribe_coordinator_messages();
  node_.subscribe<motionlcm::health_t>(lcm::channels::kHealth,
                                       [this](const motionlcm::health_t& h, const std::string&) { on_health(h); });
  node_.subscribe<motionlcm::drive_model_request_t>(
      lcm::channels::kDriveModelRequest,
      [this](const motionlcm::drive_model_request_t& r, const std::string&) { on_model_request(r); });
  health_.set_bus_stats([this] { return driver_ ? driver_->statistics() : std::vector<motionlcm::bus_stats_t>{}; });
  health_timer_ = loop_.call_every(std::chrono::milliseconds(200), [this] { update_health(); });
  health_.set_companion(
      [this](const motionlcm::health_t& h) { node_.publish(lcm::channels::kLedgerStats, ledger_stats(h)); });
  arm_watch_.set_expiry(arm_expiry(config_, {}));
}

Gateway::~Gateway() {
  loop_.cancel(health_timer_);
  health_.set_companion({});
  if (arm_timer_ != 0) loop_.cancel(arm_timer_);
  health_.set_signed_copy({});
  pending_fires_.clear();
}

void Gateway::refusal_event(const std::string& axis, std::int64_t command_id, std::int64_t request_id,
                            std::int32_t code, const std::string& reason) {
  DriveEvent e;
  e.kind = motionlcm::event_t::PROTOCOL_ERROR;
  e.severity = motionlcm::event_t::WARNING;
  e.code = code;
  e.text = fmt::format("command {} (request {}) refused: {}", command_id, request_id, reason);
  axis_event(axis, e);
}

motionlcm::gateway_command_t Gateway::own_command(std::int8_t kind, const std::vector<std::string>& axes,
                                                  std::int64_t trigger_id) {
  motionlcm::gateway_command_t c{};
  c.utime = wall_time_us();
  c.command_id = next_own_command_--;
  c.bus = bus_;
  c.kind = kind;
  c.trigger_id = trigger_id;
  for (const auto& axis : axes) {
    motionlcm::axis_command_t a{};
    a.axis = axis;
    c.axes.push_back(a);
  }
  c.num_axes = static_cast<std::int32_t>(c.axes.size());
  return c;
}

void Gateway::attach(std::unique_ptr<BusDriver> driver) {
  driver_ = std::move(driver);
  driver_->start();
  update_health();
}

void Gateway::set_unsupported(const std::vector<const config::Drive*>& drives) {
  unsupported_.clear();
  for (const config::Drive* d : drives) unsupported_[d->name] = std::string(config::to_string(d->family));
  update_health();
}

void Gateway::set_waiting(std::string why) {
  waiting_ = std::move(why);
  update_health();
}

void Gateway::update_health() {
  std::string unsupported;
  for (const auto& [drive, family] : unsupported_)
    unsupported += (unsupported.empty() ? "" : ", ") + drive + " (" + family + ")";
  if (!unsupported.empty()) unsupported = "no driver yet for " + unsupported;
  auto join = [](const std::string& a, const std::string& b) { return b.empty() ? a : a.empty() ? b : a + "; " + b; };
  if (!driver_) {
    const std::string why = join(waiting_, unsupported);
    health_.set_state(why.empty() ? motionlcm::health_t::FAULT : motionlcm::health_t::DEGRADED,
                      why.empty() ? "no driver for bus " + bus_ : why);
  } else if (driver_->ready() && unsupported.empty()) {
    health_.set_state(motionlcm::health_t::OK, std::to_string(axes_.size()) + " axes ready");
  } else {
    std::string not_ready;
    if (!driver_->ready()) {
      not_ready = "drives not all online/set up";
      // A bus that is not open says why (e.g. "bus rs485 closed: cannot open /dev/ttyUSB0: Permission denied").
      for (const auto& b : driver_->statistics()) {
        if (b.state.rfind("closed", 0) == 0) not_ready += "; bus " + b.name + " " + b.state;
      }
    }
    health_.set_state(motionlcm::health_t::DEGRADED, join(not_ready, unsupported));
  }
}

void Gateway::on_command(const motionlcm::gateway_command_t& command) {
  if (answered_again(command)) return;
  execute_checked(command);
}

void Gateway::execute_checked(const motionlcm::gateway_command_t& command) {
  auto fail = [&](const std::string& reason, std::int32_t code = 0) {
    command_reply(ReplyBuilder(command.command_id).failed(code, reason).build());
  };
  if (command.bus != bus_) return fail("command for bus '" + command.bus + "' reached gateway of bus '" + bus_ + "'");
  if (command.num_axes != static_cast<std::int32_t>(command.axes.size()))
    return fail("num_axes does not match the axes array");
  for (const auto& a : command.axes) {
    const auto axis = axes_.find(a.axis);
    if (axis == axes_.end()) return fail("axis '" + a.axis + "' is not on bus '" + bus_ + "'");
    if (const auto u = unsupported_.find(axis->second->drive); u != unsupported_.end()) {
      return fail("axis '" + a.axis + "': drive " + u->first + " is a " + u->second +
                  " drive, which this gateway does not drive yet");
    }
  }
  // A drive that lost power does not know where the machine is: neither its limits nor a target
  // mean anything until the axis is homed or its position set.
  if (command.kind == motionlcm::gateway_command_t::ARM_MOVE || command.kind == motionlcm::gateway_command_t::JOG) {
    for (const auto& a : command.axes) {
      const auto lost = position_lost_.find(a.axis);
      if (lost == position_lost_.end()) continue;
      const std::string reason =
          fmt::format("axis {} lost its position ({}): home it or set its position first", a.axis, lost->second);
      DriveEvent e;
      e.kind = motionlcm::event_t::PROTOCOL_ERROR;
      e.severity = motionlcm::event_t::WARNING;
      e.code = error_code(ReplyError::kPositionLost);
      e.text = fmt::format("command {} (request {}) refused: {}", command.command_id, command.request_id, reason);
      axis_event(a.axis, e);
      return fail(reason, error_code(ReplyError::kPositionLost));
    }
  }
  if (command.kind == motionlcm::gateway_command_t::HOME ||
      command.kind == motionlcm::gateway_command_t::SET_POSITION) {
    auto& axes = referencing_[command.command_id];
    for (const auto& a : command.axes) axes.push_back(a.axis);
    // A new homing moves the origin: homed is what it says from now on.
    if (command.kind == motionlcm::gateway_command_t::HOME) {
      for (const auto& a : command.axes) restored_homed_.erase(a.axis);
    }
  }
  // Whoever sent it: nothing outside the configured limits reaches a drive.
  for (const auto& a : command.axes) {
    const auto status = last_status_.find(a.axis);
    const auto refusal =
        check_axis_command(command.kind, a, limits_.at(a.axis),
                           status == last_status_.end() ? std::nullopt : std::optional{status->second.position_counts});
    if (!refusal) continue;
    refusal_event(a.axis, command.command_id, command.request_id, refusal->error_code, refusal->reason);
    return fail(refusal->reason, refusal->error_code);
  }
  if (!driver_) return fail("gateway of bus '" + bus_ + "' has no driver" + (waiting_.empty() ? "" : ": " + waiting_));
  track_jogs(command);
  arm_watch_.on_command(command, loop_.now());  // before: the driver may answer ARMED at once
  driver_->execute(command);
  if (command.kind == motionlcm::gateway_command_t::JOG) {
    for (const auto& a : command.axes) check_jog(a.axis);  // a jog starting inside its braking zone
  }
}

namespace {
bool recent(const std::deque<std::int64_t>& ids, std::int64_t id) {
  return std::find(ids.begin(), ids.end(), id) != ids.end();
}
void remember(std::deque<std::int64_t>& ids, std::int64_t id) {
  ids.push_back(id);
  if (ids.size() > 64) ids.pop_front();
}
}  // namespace

void Gateway::on_trigger(const motionlcm::sync_trigger_t& trigger) {
  if (std::find(trigger.buses.begin(), trigger.buses.end(), bus_) == trigger.buses.end() || !driver_) return;
  // Scheduled (or fired) by its SYNC_TRIGGER2 already: that one carries this bus's lead.
  if (recent(scheduled_v2_, trigger.trigger_id) || recent(fired_, trigger.trigger_id) ||
      pending_fires_.contains(trigger.trigger_id))
    return;
  if (!arm_watch_.on_trigger(trigger.trigger_id)) {
    spdlog::warn("trigger {} ignored: the moves it would start on {} were released unfired", trigger.trigger_id, bus_);
    return;
  }
  schedule_fire(trigger.trigger_id, trigger.fire_utime, {});
}

void Gateway::on_trigger2(const motionlcm::sync_trigger2_t& trigger) {
  const std::int64_t heard_utime = wall_time_us();
  const auto n = std::min(
      {trigger.buses.size(), trigger.send_utime.size(), static_cast<std::size_t>(std::max(trigger.num_buses, 0))});
  std::size_t i = 0;
  while (i < n && trigger.buses[i] != bus_) ++i;
  if (i == n || !driver_ || recent(scheduled_v2_, trigger.trigger_id) || recent(fired_, trigger.trigger_id)) return;
  if (!arm_watch_.on_trigger(trigger.trigger_id)) {
    spdlog::warn("trigger {} ignored: the moves it would start on {} were released unfired", trigger.trigger_id, bus_);
    return;
  }
  remember(scheduled_v2_, trigger.trigger_id);
  if (const auto it = pending_fires_.find(trigger.trigger_id); it != pending_fires_.end()) {
    pending_fires_.erase(it);  // its SYNC_TRIGGER came first: this one knows the lead
  }
  const auto quiet = lcm::StartQuiet::interval_of(trigger);
  schedule_fire(trigger.trigger_id, trigger.send_utime[i], trigger.start_command_ids, quiet ? quiet->from_utime : 0);
  // When it was heard, once the start is scheduled (or, late, fired): the coordinator measures its
  // trigger lead from these.
  motionlcm::trigger_heard_t heard{};
  heard.utime = heard_utime;
  heard.bus = bus_;
  heard.trigger_id = trigger.trigger_id;
  heard.trigger_utime = trigger.utime;
  heard.send_utime = trigger.send_utime[i];
  publish_own(lcm::channels::kTriggerHeard, heard, true);
  // Around the start this gateway says nothing (lcm/start_quiet.hpp): its STARTED reply goes out
  // just after the act time.
  start_quiet_.keep(trigger);
}

void Gateway::schedule_fire(std::int64_t trigger_id, std::int64_t send_utime, std::vector<std::int64_t> order,
                            std::int64_t quiet_from_utime) {
  // The send time is wall-clock (common to every machine); the loop's timers are steady-clock.
  // It is when the first start frame is to begin on the wire: a bus whose frames take a while from
  // the hand-over to the wire (egress_latency_us: a USB adapter) is handed them that much earlier.
  const config::Bus* bus = config_.find_bus(bus_);
  const auto egress = std::chrono::microseconds(bus != nullptr ? bus->egress_latency_us : 0);
  const auto delay = std::chrono::microseconds(send_utime - wall_time_us()) - egress;
  const auto fire = [this, trigger_id, order = std::move(order)] {
    remember(fired_, trigger_id);
    if (driver_) driver_->fire_ordered(trigger_id, order);
  };
  if (delay <= std::chrono::microseconds::zero()) {
    if (delay < -std::chrono::milliseconds(1))
      spdlog::warn("trigger {} arrived {} us after its send time; firing now", trigger_id, -delay.count());
    fire();
    return;
  }
  if (pending_fires_.size() >= kMostPendingFires && !pending_fires_.contains(trigger_id)) {
    // Bounded, whatever a sender names (each start waiting holds a timer's descriptor): a lab has
    // a handful waiting; a move of a trigger refused here is released unfired when it expires.
    if (refused_fires_++ % 1000 == 0)
      spdlog::warn("trigger {} not scheduled on {}: {} starts wait already ({} refused so far)", trigger_id, bus_,
                   pending_fires_.size(), refused_fires_);
    return;
  }
  const TimePoint send_at = loop_.now() + delay;
  driver_->prepare_fire(send_at);
  const TimePoint at = send_at + driver_->start_delay(trigger_id);
  // Every gateway of the start idles its bus's own traffic from just before the start's quiet
  // interval until it fires: on a host with few CPUs, a gateway busy with its polls when another
  // one's fire is due held that one back by its whole burst (up to 0.6 ms under SCHED_FIFO).
  const TimePoint quiet_from =
      quiet_from_utime > 0 ? loop_.now() + std::chrono::microseconds(quiet_from_utime - wall_time_us()) : at;
  driver_->hold_traffic(std::clamp(quiet_from - kTrafficHoldBefore, at - kLongestTrafficHold, at - kTrafficHoldBefore),
                        at);
  auto& timer = pending_fires_[trigger_id];
  timer = std::make_unique<PreciseTimer>(loop_);
  if (bus != nullptr) timer->set_spin(std::chrono::microseconds(bus->timer_spin_us));
  timer->arm(at, [this, trigger_id, fire, at] {
    // A start handed over late starts its drives that much late: said, with how late the loop
    // woke and how late the fire was done (its start frames handed over in between, then its
    // replies published; a process preempted meanwhile shows as the difference).
    const auto late = [this, at] { return std::chrono::duration_cast<std::chrono::microseconds>(loop_.now() - at); };
    const auto woke = late();
    fire();
    if (const auto done = late(); done > kLateFireNote)
      spdlog::info("trigger {}: its start fired {} us late on {}, done {} us late (its frames handed over in between)",
                   trigger_id, woke.count(), bus_, done.count());
    // Destroyed after this callback (the loop holds no reference to it once it has run).
    loop_.call_after(Duration::zero(), [this, trigger_id] {
      if (const auto it = pending_fires_.find(trigger_id); it != pending_fires_.end() && !it->second->armed())
        pending_fires_.erase(it);
    });
  });
}

void Gateway::on_health(const motionlcm::health_t& health) {
  if (health.role != "coordinator") return;
  const std::string id = health.host + ":" + std::to_string(health.pid);
  const std::int64_t now = wall_time_us();
  const bool successor = !coordinator_.empty() && id != coordinator_ &&
                         now - coordinator_seen_utime_ > 3LL * std::max(health.period_ms, 1) * 1000;
  if (id == coordinator_ || coordinator_.empty() || successor) {
    if (successor && last_moves_.num_axes > 0) {
      // The coordinator that sent the last ACTIVE_MOVES is gone and another one answers: it ends
      // those requests (their clients get their terminal reply) and stops what still moves.
      spdlog::warn("coordinator {} replaced by {}: handing it the {} active move row(s) of {} left behind",
                   coordinator_, id, last_moves_.num_axes, bus_);
      last_moves_.utime = now;
      publish_own(lcm::channels::kOrphanedMoves, last_moves_, false);
      last_moves_ = {};
    }
    coordinator_ = id;
    coordinator_seen_utime_ = now;
  }
}

void Gateway::on_active_moves(const motionlcm::active_moves_t& moves) {
  // This bus's rows of the latest desired state, for a successor coordinator.
  last_moves_ = {};
  for (std::size_t i = 0; i < moves.axes.size(); ++i) {
    if (moves.buses[i] != bus_) continue;
    last_moves_.axes.push_back(moves.axes[i]);
    last_moves_.buses.push_back(moves.buses[i]);
    last_moves_.client_ids.push_back(moves.client_ids[i]);
    last_moves_.request_ids.push_back(moves.request_ids[i]);
    last_moves_.kinds.push_back(moves.kinds[i]);
    last_moves_.phases.push_back(moves.phases[i]);
    last_moves_.command_ids.push_back(moves.command_ids[i]);
    last_moves_.target_counts.push_back(moves.target_counts[i]);
    last_moves_.targets.push_back(moves.targets[i]);
    last_moves_.fire_utime.push_back(moves.fire_utime[i]);
  }
  last_moves_.num_axes = static_cast<std::int32_t>(last_moves_.axes.size());
  std::map<std::pair<std::string, std::int64_t>, std::vector<std::size_t>> inherited;  // request -> its rows here
  for (std::size_t i = 0; i < moves.axes.size(); ++i) {
    const bool ours = moves.buses[i] == bus_ && axes_.contains(moves.axes[i]);
    const bool before_us = moves.phases[i] == motionlcm::active_moves_t::MOVING && moves.fire_utime[i] != 0 &&
                           moves.fire_utime[i] < started_utime_;
    if (ours && before_us) inherited[{moves.client_ids[i], moves.request_ids[i]}].push_back(i);
  }
  for (const auto& [request, rows] : inherited) {
    if (!inherited_.insert(request).second) continue;  // said and stopped once
    motionlcm::gateway_command_t stop{};
    stop.command_id = next_own_command_--;
    stop.bus = bus_;
    stop.kind = motionlcm::gateway_command_t::STOP;
    for (const auto i : rows) {
      motionlcm::axis_command_t a{};
      a.axis = moves.axes[i];
      stop.axes.push_back(a);
      DriveEvent e;
      e.kind = motionlcm::event_t::GATEWAY_RESTARTED;
      e.severity = motionlcm::event_t::WARNING;
      e.code = static_cast<std::int32_t>(moves.command_ids[i]);
      e.text = fmt::format(
          "{} started while request {}/{} was moving {} to {:.6g} (gateway command {}, fired {:.0f} ms before this "
          "process started): {}",
          process_name(), request.first, request.second, moves.axes[i], moves.targets[i], moves.command_ids[i],
          static_cast<double>(started_utime_ - moves.fire_utime[i]) / 1000.0,
          driver_ ? "stopping it" : "no bus driver yet to stop it");
      axis_event(moves.axes[i], e);
    }
    stop.num_axes = static_cast<std::int32_t>(stop.axes.size());
    for (const auto& a : stop.axes) {
      forget_jog(a.axis);
      commanded_.insert(a.axis);  // stopped and said once
    }
    if (driver_) driver_->execute(stop);
  }
}

void Gateway::drive_facts(const std::string& axis, const DriveFacts& facts) {
  if (!axes_.contains(axis)) return;
  facts_[axis] = facts;
  publish_model(axis, false);
}

void Gateway::publish_model(const std::string& axis, bool always) {
  if (!model_builder_) return;
  const config::Axis& cfg = *axes_.at(axis);
  const auto facts = facts_.find(axis);
  auto built = model_builder_(cfg, facts == facts_.end() ? DriveFacts{} : facts->second);
  if (auto* why = std::get_if<std::string>(&built)) {
    DriveEvent e;
    e.kind = motionlcm::event_t::CONFIG_MISMATCH;
    e.severity = motionlcm::event_t::ERROR;
    e.text = "no drive model for axis " + axis + ": " + *why + " (its moves are refused)";
    axis_event(axis, e);
    models_.erase(axis);
    return;
  }
  auto& model = std::get<motionlcm::drive_model_t>(built);
  const auto last = models_.find(axis);
  // utime says since when the model is in force (gateway_command2_t's model_utime names it): an
  // unchanged model keeps it, also when it is published again on request.
  const bool unchanged = last != models_.end() && same_model(model, last->second);
  if (unchanged && !always) return;
  if (model.resolution_source == motionlcm::drive_model_t::RESOLUTION_READ_BACK &&
      model.assumed_counts_per_revolution != 0 && model.counts_per_revolution != model.assumed_counts_per_revolution &&
      (last == models_.end() || last->second.counts_per_revolution != model.counts_per_revolution)) {
    DriveEvent e;
    e.kind = motionlcm::event_t::CONFIG_MISMATCH;
    e.severity = motionlcm::event_t::WARNING;
    e.code = model.counts_per_revolution;
    e.text = fmt::format(
        "axis {}: drive {} works at {} counts/rev (read from the drive), the configuration implies {}: its moves are "
        "planned at {}",
        axis, model.drive, model.counts_per_revolution, model.assumed_counts_per_revolution,
        model.counts_per_revolution);
    axis_event(axis, e);
  }
  model.utime =
      unchanged ? last->second.utime : std::max(wall_time_us(), last == models_.end() ? 0 : last->second.utime + 1);
  models_[axis] = model;
  publish_own(lcm::channels::kDriveModel, model, true);
  publish_line_timing();
  if (!arming_builder_) return;
  auto arming = arming_builder_(cfg);
  if (auto* why = std::get_if<std::string>(&arming)) {
    spdlog::warn("bus {}: no arming time for axis {}: {}", bus_, axis, *why);
    return;
  }
  auto& timing = std::get<motionlcm::arm_timing_t>(arming);
  timing.utime = model.utime;
  publish_own(lcm::channels::kArmTiming, timing, true);
}

void Gateway::publish_line_timing() {
  if (!driver_) return;
  motionlcm::line_timing_t timing{};
  timing.utime = wall_time_us();
  timing.bus = bus_;
  timing.start_wait_us = std::chrono::duration<double, std::micro>(driver_->start_wait()).count();
  publish_own(lcm::channels::kLineTiming, timing, true);
}

void Gateway::on_model_request(const motionlcm::drive_model_request_t& request) {
  if (!request.bus.empty() && request.bus != bus_) return;
  std::vector<std::string> known;
  for (const auto& [axis, model] : models_) known.push_back(axis);
  for (const auto& axis : known) publish_model(axis, true);
}

void Gateway::axis_status(const std::string& axis, const DriveStatus& status) {
  auto it = axes_.find(axis);
  if (it == axes_.end()) return;
  const auto previous = last_status_.find(axis);
  const bool came_online = status.online && (previous == last_status_.end() || !previous->second.online);
  last_status_[axis] = status;
  // Set up (online) for the first time: its model, before the status that says so.
  if (came_online && !models_.contains(axis)) publish_model(axis, false);
  // The record is compared with, and kept from, positions read from the drive (a status published
  // between identification and the first position read carries none).
  if (records_ && status.online && status.position_read && !record_checked_.contains(axis)) check_record(axis, status);
  if (status.online && seen_online_.insert(axis).second) stop_if_found_moving(axis, status);
  check_jog(axis);
  const config::Axis& a = *it->second;
  const config::Drive* d = config_.drive_of(a);
  const AxisScale scale{a.steps_per_unit, a.invert};
  motionlcm::axis_state_t msg{};
  msg.utime = wall_time_us();
  msg.sample_utime = status.sample_utime != 0 ? status.sample_utime : msg.utime;
  msg.axis = a.name;
  msg.family = std::string(config::to_string(d->family));
  msg.bus = bus_;
  msg.node_id = d->node_id;
  msg.group_id = d->group_id;
  msg.position = scale.to_units(static_cast<double>(status.position_counts));
  msg.position_counts = status.position_counts;
  msg.velocity = scale.to_units(status.velocity_counts);
  msg.target_counts = status.target_counts;
  msg.online = status.online;
  msg.enabled = status.enabled;
  // A drive that cannot be heard (offline: timeouts, CRC errors on every try, heartbeat lost) is
  // not reported as moving on its last word: "moving" is what a live drive says. What it does is
  // unknown; the coordinator's stop watch counts an offline axis as unreachable, never as stopped.
  msg.moving = status.online && status.moving;
  msg.in_position = status.in_position;
  msg.homed = status.homed || restored_homed_.contains(axis);
  msg.fault = status.fault;
  msg.fault_code = status.fault_code;
  msg.fault_text = status.fault_text;
  if (const auto lost = position_lost_.find(axis); lost != position_lost_.end()) {
    msg.homed = false;
    if (!status.fault) {  // a fault says more; once reset, the lost position shows again
      msg.fault_code = motionlcm::axis_state_t::POSITION_LOST;
      msg.fault_text = "position lost: " + lost->second + "; home or set-position";
    }
  }
  msg.inputs = status.inputs;
  msg.outputs = status.outputs;
  if (records_ && status.online && status.position_read && record_checked_.contains(axis))
    keep_record(axis, status, msg.homed);
  publish_own(lcm::channels::kAxisState, msg, true);
}

void Gateway::position_lost(const std::string& axis, const std::string& why) {
  if (!axes_.contains(axis)) return;
  position_lost_[axis] = why;
  restored_homed_.erase(axis);
  DriveEvent e;
  e.kind = motionlcm::event_t::REBOOT;
  e.severity = motionlcm::event_t::ERROR;
  e.code = motionlcm::axis_state_t::POSITION_LOST;
  e.text = fmt::format(
      "axis {}: position lost / not homed ({}): its moves and jogs are refused until it is homed or its position set",
      axis, why);
  axis_event(axis, e);
  if (const auto status = last_status_.find(axis); status != last_status_.end())
    axis_status(axis, DriveStatus{status->second});
}

void Gateway::axis_event(const std::string& axis, const DriveEvent& event) {
  motionlcm::event_t msg{};
  msg.utime = wall_time_us();
  msg.source = process_name();
  msg.axis = axis;
  msg.bus = bus_;
  if (auto it = axes_.find(axis); it != axes_.end()) msg.node_id = config_.drive_of(*it->second)->node_id;
  msg.severity = event.severity;
  msg.kind = event.kind;
  msg.code = event.code;
  msg.text = event.text;
  if (event.severity >= motionlcm::event_t::WARNING) {
    spdlog::warn("event on {}{}: {} (code {})", bus_, axis.empty() ? "" : "/" + axis, event.text, event.code);
  }
  publish_event(msg);
}

void Gateway::command_reply(motionlcm::gateway_reply_t reply) {
  arm_watch_.on_reply(reply);  // a released move's FAILED says why
  if (reply.status == motionlcm::gateway_reply_t::ARMED) rearm_expiry_timer();
  // A jog the limit watch stopped before the driver confirmed it fails for that reason, not as
  // "stopped by" the watch's own STOP.
  if (const auto it = stopped_at_limit_.find(reply.command_id); it != stopped_at_limit_.end()) {
    if (reply.status == motionlcm::gateway_reply_t::FAILED) {
      reply.error_code = error_code(ReplyError::kAxisFault);
      reply.reason = it->second;
    }
    if (reply.status == motionlcm::gateway_reply_t::FAILED || reply.status == motionlcm::gateway_reply_t::DONE)
      stopped_at_limit_.erase(it);
  }
  jog_reply(reply);
  if (const auto it = referencing_.find(reply.command_id); it != referencing_.end()) {
    if (reply.status == motionlcm::gateway_reply_t::DONE) {
      for (const auto& axis : it->second) {
        if (position_lost_.erase(axis) == 0) continue;
        spdlog::info("axis {}: position valid again (command {})", axis, reply.command_id);
        if (const auto status = last_status_.find(axis); status != last_status_.end())
          axis_status(axis, DriveStatus{status->second});
      }
    }
    if (reply.status == motionlcm::gateway_reply_t::DONE || reply.status == motionlcm::gateway_reply_t::FAILED)
      referencing_.erase(it);
  }
  reply.utime = wall_time_us();
  reply.bus = bus_;
  if (reply.status == motionlcm::gateway_reply_t::FAILED)
    spdlog::warn("command {} failed: {}", reply.command_id, reply.reason);
  commands_seen_.replied(reply);
  publish_own(lcm::channels::kGatewayReply, reply, false);
}

}  // namespace motion::gateway
