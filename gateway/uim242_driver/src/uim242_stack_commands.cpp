// Uim242Stack (uim242_stack.hpp): gateway commands: enable, stops, jogs, moves (arm, fire, watch),
// settling, homing and parameters.
#include "uim242_stack_impl.hpp"

namespace motion::uim242_driver {

// ---- commands -------------------------------------------------------------------------------------

Uim242Stack::Drive* Uim242Stack::drive_of_axis(const std::string& axis) {
  for (auto& d : drives_) {
    if (d->axis_name == axis) return d.get();
  }
  return nullptr;
}

std::size_t Uim242Stack::index_of(const Drive& d) const {
  const auto it = std::find_if(drives_.begin(), drives_.end(), [&d](const auto& owned) { return owned.get() == &d; });
  return static_cast<std::size_t>(it - drives_.begin());
}

bool Uim242Stack::for_each_axis(const gateway_command_t& command,
                                const std::function<void(Drive&, const motionlcm::axis_command_t&)>& f, bool stops) {
  for (const auto& a : command.axes) {
    Drive* d = drive_of_axis(a.axis);
    if (!d) {
      finish(command.command_id, false, fmt::format("axis '{}' is not on bus {}", a.axis, bus_), kUnknownAxis);
      return false;
    }
    if (!d->status.online && !stops) {
      finish(command.command_id, false, fmt::format("{} (node {}) of axis '{}' is offline", d->name, d->node, a.axis),
             kAxisOffline);
      return false;
    }
  }
  for (const auto& a : command.axes) {
    Drive* d = drive_of_axis(a.axis);
    if (d->status.online) {
      f(*d, a);
    } else {
      stop_unanswering(*d, command.kind == gateway_command_t::ESTOP, command.command_id);
    }
  }
  return true;
}

// A controller that does not answer may still hear: a STOP or ESTOP naming it sends its stop
// (`STP 0;`, #44; an e-stop `OFF;` and `SPD 0;`) all the same, ahead of the queue and tied to no
// command (its failure must not cancel the others' stops), and the command ends FAILED saying
// the stop is not confirmed.
void Uim242Stack::stop_unanswering(Drive& d, bool estop, std::int64_t command_id) {
  const std::vector<Instruction> steps =
      estop ? std::vector{bare(Mnemonic::kOFF), set(Mnemonic::kSPD, 0)} : std::vector{set(Mnemonic::kSTP, 0)};
  for (auto it = steps.rbegin(); it != steps.rend(); ++it) submit(d, *it, 0, {}, true);  // front: last first
  if (Command* c = commands_.find(command_id)) {
    c->data.unreached +=
        fmt::format("{}{} (node {}) is offline (not answering): {} sent all the same, not confirmed",
                    c->data.unreached.empty() ? "" : "; ", d.name, d.node, estop ? "OFF and SPD 0" : "STP 0");
  }
  part_done(command_id);
}

void Uim242Stack::execute(const gateway_command_t& command, TimePoint now) {
  const std::int64_t id = command.command_id;
  // One part per drive named (axes of other buses fail below, in for_each_axis / arm).
  std::vector<std::size_t> parts;
  for (const auto& a : command.axes) {
    const Drive* d = drive_of_axis(a.axis);
    if (d != nullptr && std::find(parts.begin(), parts.end(), index_of(*d)) == parts.end())
      parts.push_back(index_of(*d));
  }
  Command* added = commands_.add(command, std::move(parts), CommandData{command.axes.size(), {}});
  if (added == nullptr) {
    // As the CAN stacks and the ADAM master: a reused id is refused, the running command goes on.
    commands_.reject(command, kMalformed, fmt::format("command id {} is already in progress", id));
    return;
  }
  added->reply.bus(bus_);
  Command& c = *added;
  if (command.axes.empty() && command.kind != gateway_command_t::DISARM) {
    finish(id, false, "command names no axis", kMalformed);
    return;
  }
  // One instruction sequence per axis; DONE when every axis finished it. The state it led to
  // goes out before DONE: whoever acts on the reply (the coordinator planning the next move from
  // the position, checking "enabled") has it by then.
  // `after` runs when the drive answered, long after execute() returned: it gets its own copy of
  // the axis's command (the caller's `command` is gone by then; random lab seeds 2 and 4).
  using After = std::function<void(Drive&, const motionlcm::axis_command_t&)>;
  const auto per_axis =
      [&](const std::function<std::vector<Instruction>(Drive&, const motionlcm::axis_command_t&)>& steps,
          const After& after = {}, bool stops = false) {
        for_each_axis(
            command,
            [&](Drive& d, const motionlcm::axis_command_t& a) {
              run_sequence(c, d, steps(d, a), [this, id, &d, after, a](TimePoint t) {
                if (after) {
                  after(d, a);
                  if (t != TimePoint{}) publish(d, t);  // TimePoint{}: nothing was sent, nothing changed
                }
                part_done(id);
              });
            },
            stops);
      };
  switch (command.kind) {
    case gateway_command_t::ENABLE:
      per_axis([](Drive&, const auto&) { return std::vector{bare(Mnemonic::kENA)}; },
               [](Drive& d, const auto&) { d.status.enabled = true; });
      return;
    case gateway_command_t::DISABLE:
    case gateway_command_t::ESTOP: {
      const bool estop = command.kind == gateway_command_t::ESTOP;
      const std::string why = estop ? "stopped by ESTOP" : "axis disabled";
      for (const auto& a : command.axes) {
        if (Drive* d = drive_of_axis(a.axis))
          fail_moves_of(*d, fmt::format("{} (node {}): {}", d->name, d->node, why), kStopped);
      }
      const bool every_drive =
          estop && command.axes.size() == drives_.size() &&
          std::all_of(drives_.begin(), drives_.end(), [](const auto& d) { return d->status.online; });
      // After OFF the desired speed is set to 0: a controller keeps it while disabled, and ENA
      // runs the motor at it again (manual, ENA H-Bridge Enable; the "SPD 5000; ENA;" example), so
      // a later enable would resume the interrupted jog or move.
      if (every_drive) {
        // One `gOFF;` frame disables every controller at once (Summary), one `gSPD 0;` zeroes
        // every desired speed.
        const auto broadcast = [this, id](Instruction in, std::function<void()> then) {
          Request r;
          r.drive = "gateway";
          r.instruction = in;
          r.group = id;
          r.on_reply = [then = std::move(then)](const Frame&, TimePoint) { then(); };
          r.on_failure = [this, id](const std::string& reason, bool timed_out, TimePoint) {
            finish(id, false, reason, timed_out ? kTimeout : kDriveError);
          };
          channel_.submit(std::move(r), true);
        };
        broadcast(Instruction{Mnemonic::kOFF, true, std::nullopt, false}, [this, id, broadcast] {
          for (auto& d : drives_) d->status.enabled = false;
          broadcast(Instruction{Mnemonic::kSPD, true, 0, false}, [this, id] { finish(id, true); });
        });
        return;
      }
      per_axis(
          [](Drive&, const auto&) {
            return std::vector{bare(Mnemonic::kOFF), set(Mnemonic::kSPD, 0)};
          },
          [](Drive& d, const auto&) { d.status.enabled = false; }, estop);
      return;
    }
    case gateway_command_t::STOP:
      for (const auto& a : command.axes) {
        if (Drive* d = drive_of_axis(a.axis)) {
          fail_moves_of(*d, fmt::format("{} (node {}): stopped by STOP", d->name, d->node), kStopped);
        }
      }
      // Ramped stop, DONE at rest with the real position published (settle).
      for_each_axis(
          command,
          [&](Drive& d, const motionlcm::axis_command_t&) {
            run_sequence(c, d, {set(Mnemonic::kSTP, 0)}, [this, id, &d](TimePoint t) {
              settle(d, id, t + kRestLimit, [this, id](TimePoint) { part_done(id); });
            });
          },
          true);
      return;
    case gateway_command_t::JOG:
      for (const auto& a : command.axes) {
        if (std::llround(std::abs(a.velocity)) > kSpeedMax) {
          finish(
              id, false,
              fmt::format("axis '{}': jog velocity {} above the UIM242 maximum {} pps", a.axis, a.velocity, kSpeedMax),
              kOutsideLimits);
          return;
        }
      }
      for_each_axis(command, [&](Drive& d, const motionlcm::axis_command_t& a) { jog(c, d, a); });
      return;
    case gateway_command_t::FAULT_RESET:
      per_axis([](Drive&, const auto&) { return std::vector{bare(Mnemonic::kFBK)}; },
               [](Drive& d, const auto&) {
                 d.status.fault = false;
                 d.status.fault_code = 0;
                 d.status.fault_text.clear();
               });
      return;
    case gateway_command_t::SET_OUTPUTS:
      for (const auto& a : command.axes) {
        if ((a.output_mask & ~1) != 0) {
          finish(id, false,
                 fmt::format("axis '{}': the UIM242 has one output (1 = P4), mask 0x{:X}", a.axis, a.output_mask),
                 kUnsupported);
          return;
        }
      }
      per_axis(
          [](Drive&, const motionlcm::axis_command_t& a) {
            return a.output_mask & 1 ? std::vector{set(Mnemonic::kDOU, a.output_value & 1)}
                                     : std::vector<Instruction>{};
          },
          [](Drive& d, const motionlcm::axis_command_t& a) {
            if (a.output_mask & 1) d.status.outputs = a.output_value & 1;
          });
      return;
    case gateway_command_t::SET_POSITION:
      per_axis(
          [](Drive&, const motionlcm::axis_command_t& a) { return std::vector{set(Mnemonic::kORG, a.target_counts)}; },
          [](Drive& d, const motionlcm::axis_command_t& a) { d.status.position_counts = a.target_counts; });
      return;
    case gateway_command_t::HOME:
      for_each_axis(command, [&](Drive& d, const motionlcm::axis_command_t& a) { home(c, d, *d.axis, a); });
      return;
    case gateway_command_t::PARAM_READ:
    case gateway_command_t::PARAM_WRITE:
      for_each_axis(command,
                    [&](Drive& d, const auto&) { param(command, d, command.kind == gateway_command_t::PARAM_WRITE); });
      return;
    case gateway_command_t::ARM_MOVE: arm(command, now); return;
    case gateway_command_t::DISARM: {
      // Forget armed moves (by trigger id, or naming these axes) and clear their loaded targets.
      std::vector<Drive*> loaded;
      std::vector<std::int64_t> disarmed;
      for (const auto& m : moves_) {
        const bool by_trigger = command.trigger_id != 0 && m->trigger_id == command.trigger_id;
        const bool by_axis = std::any_of(m->axes.begin(), m->axes.end(), [&](const auto& a) {
          return std::any_of(command.axes.begin(), command.axes.end(),
                             [&](const auto& ca) { return ca.axis == a.drive->axis_name; });
        });
        if (m->start_sent || !(by_trigger || by_axis)) continue;
        disarmed.push_back(m->command_id);
        for (const auto& a : m->axes) {
          if (a.loaded && !a.arrived) loaded.push_back(a.drive);
        }
      }
      for (const auto mid : disarmed) finish(mid, false, "disarmed before the trigger", kStopped);
      c.data.outstanding = loaded.size();
      if (loaded.empty()) {
        finish(id, true);
        return;
      }
      for (Drive* d : loaded) run_sequence(c, *d, {set(Mnemonic::kSTP, 0)}, [this, id](TimePoint) { part_done(id); });
      return;
    }
    default: finish(id, false, fmt::format("unknown command kind {}", command.kind), kMalformed); return;
  }
}

void Uim242Stack::arm(const gateway_command_t& command, TimePoint now) {
  const std::int64_t id = command.command_id;
  auto move = std::make_unique<Move>();
  move->command_id = id;
  move->trigger_id = command.trigger_id;
  for (const auto& a : command.axes) {
    Drive* d = drive_of_axis(a.axis);
    if (!d) return (void)finish(id, false, fmt::format("axis '{}' is not on bus {}", a.axis, bus_), kUnknownAxis);
    if (!d->status.online)
      return (void)finish(id, false, fmt::format("{} (node {}) is offline", d->name, d->node), kAxisOffline);
    if (!d->status.enabled)
      return (void)finish(id, false, fmt::format("{} (node {}) of axis '{}' is disabled", d->name, d->node, a.axis),
                          kAxisDisabled);
    const std::int64_t speed = std::llround(std::abs(a.velocity));
    if (speed < 1 || speed > kSpeedMax) {
      return (void)finish(id, false,
                          fmt::format("axis '{}': speed {} pps outside 1..{} (SPD)", a.axis, a.velocity, kSpeedMax),
                          kOutsideLimits);
    }
    move->axes.push_back({d, a.target_counts, speed, clamp_rate(a.acceleration),
                          clamp_rate(a.deceleration > 0 ? a.deceleration : a.acceleration), false, false});
  }
  Move& m = *move;
  moves_.push_back(std::move(move));
  Command& c = *commands_.find(id);
  // An axis is loaded: its part is Armed (the ledger replies ARMED with the last one).
  const auto loaded = [this, id, &m](const Drive& d, TimePoint t) {
    commands_.advance(id, index_of(d), Lifecycle::kArmed);
    const Command* armed = commands_.find(id);
    if (armed == nullptr || !armed->all(Lifecycle::kArmed)) return;
    if (std::any_of(m.axes.begin(), m.axes.end(), [](const auto& a) { return !a.loaded; }))
      return;  // an axis named twice
    if (m.trigger_id == 0) start_move(m, t);
  };
  for (auto& axis : m.axes) {
    Drive& d = *axis.drive;
    // Ramps and zero speed first (`SPD 0;` brakes a motor still running), then at rest the
    // position the relative STP is computed from (settle: EN/CN #44 counts STP from the
    // position at its receipt, which must be the position read).
    // A drive not known to hold a displacement loaded at speed 0 is loaded with nothing: its
    // start crawls into it (start_move); one whose answer is not known yet is probed first.
    const auto load = [this, &c, &d, &axis, loaded](TimePoint t) {
      const std::int64_t position = d.status.position_counts;
      const std::int64_t displacement = axis.target - position;
      if (displacement == 0) {  // already there: `STP 0;` would mean "leave PT", not "move 0"
        axis.loaded = axis.arrived = true;
        loaded(d, t);
        return;
      }
      if (std::abs(displacement) > std::numeric_limits<std::int32_t>::max()) {
        finish(c.command.command_id, false,
               fmt::format("{} (node {}): displacement {} beyond STP's range", d.name, d.node, displacement),
               kOutsideLimits);
        return;
      }
      if (d.spd0 != Drive::Spd0::kHolds) {
        axis.loaded = true;
        loaded(d, t);
        return;
      }
      run_sequence(c, d, {set(Mnemonic::kSTP, displacement)}, [&axis, &d, loaded](TimePoint t2) {
        axis.loaded = axis.preloaded = true;
        loaded(d, t2);
      });
    };
    run_sequence(
        c, d, {set(Mnemonic::kMAC, axis.acceleration), set(Mnemonic::kMDE, axis.deceleration), set(Mnemonic::kSPD, 0)},
        [this, &d, load, id](TimePoint t0) {
          settle(d, id, t0 + kRestLimit, [this, &d, load, id](TimePoint t) {
            if (d.spd0 != Drive::Spd0::kUnknown) return load(t);
            probe_spd0(d, id, [this, &d, load, id](TimePoint t2) { settle(d, id, t2 + kRestLimit, load); });
          });
        });
  }
  (void)now;
}

void Uim242Stack::reserve_line(TimePoint at, TimePoint /*now*/) {
  reserved_at_ = at;
  channel_.reserve(at);
}

Duration Uim242Stack::start_delay(std::int64_t trigger_id) const {
  for (const auto& m : moves_) {
    const Command* c = commands_.find(m->command_id);
    if (!m->start_sent && m->trigger_id == trigger_id && c != nullptr && c->all(Lifecycle::kArmed))
      return global_start_shortfall(*m);
  }
  return Duration::zero();
}

bool Uim242Stack::awaiting_trigger() const {
  return std::any_of(moves_.begin(), moves_.end(), [this](const auto& m) {
    const Command* c = commands_.find(m->command_id);
    return !m->start_sent && m->trigger_id != 0 && c != nullptr && c->all(Lifecycle::kArmed);
  });
}

Duration Uim242Stack::longest_poll_exchange() const {
  // With several controllers on the line each poll selects its own first (`ADR η;`, counted at
  // the longest node id); with one, the selection is made once.
  constexpr int kLongestNode = 125;
  const int select = drives_.size() > 1 ? kLongestNode : 0;
  Duration longest{};
  for (const auto& in : {bare(Mnemonic::kFBK), bare(Mnemonic::kQEC)})
    longest = std::max(longest, channel_.exchange_time(in, select));
  return longest;
}

void Uim242Stack::fire(std::int64_t trigger_id, TimePoint now) {
  channel_.reserve(kNever);
  // The reservation this fire was scheduled for; one left by a start that never came is stale.
  const bool reserved =
      reserved_at_ != kNever && reserved_at_ <= now && now - reserved_at_ < 5 * RequestChannel::kReplyAllowance;
  const TimePoint scheduled = reserved ? reserved_at_ : now;
  reserved_at_ = kNever;
  // start_move() may end a move at once (every axis already at its target: DONE), and finish()
  // erases it from moves_: walk a list of the command ids, and look each one up again.
  std::vector<std::int64_t> ids;
  for (const auto& m : moves_) {
    const Command* c = commands_.find(m->command_id);
    if (!m->start_sent && c != nullptr && c->all(Lifecycle::kArmed) && m->trigger_id == trigger_id)
      ids.push_back(m->command_id);
  }
  for (const auto id : ids) {
    const auto it = std::find_if(moves_.begin(), moves_.end(), [id](const auto& m) { return m->command_id == id; });
    if (it != moves_.end() && !(*it)->start_sent) start_move(**it, scheduled);
  }
}

void Uim242Stack::move_axis_arrived(Drive& d, TimePoint now) {
  for (auto& m : moves_) {
    if (!m->start_sent) continue;
    for (auto& a : m->axes) {
      if (a.drive != &d || a.arrived) continue;
      a.arrived = true;
      d.status.in_position = true;
      d.status.position_counts = a.target;
      publish(d, now);
      event(d, event_t::MOTION_COMPLETE, event_t::INFO, 0, fmt::format("{} (node {}) at {}", d.name, d.node, a.target));
      const Command* c = commands_.find(m->command_id);
      if (c == nullptr || c->reported != gateway_reply_t::STARTED) return;  // started() ends it if all are there
      if (std::all_of(m->axes.begin(), m->axes.end(), [](const auto& x) { return x.arrived; })) {
        finish(m->command_id, true);  // erases the move: stop iterating
      } else {
        commands_.advance(m->command_id, index_of(d), Lifecycle::kDone);
      }
      return;
    }
  }
}

void Uim242Stack::fail_moves_of(const Drive& d, const std::string& reason, std::int32_t code) {
  std::vector<std::int64_t> failed;
  for (const auto& m : moves_) {
    if (std::any_of(m->axes.begin(), m->axes.end(), [&](const auto& a) { return a.drive == &d && !a.arrived; })) {
      failed.push_back(m->command_id);
    }
  }
  if (d.homing_command != 0) failed.push_back(d.homing_command);
  if (d.jog_command != 0) failed.push_back(d.jog_command);
  for (const auto id : failed) finish(id, false, reason, code);
}

void Uim242Stack::jog(Command& c, Drive& d, const motionlcm::axis_command_t& a) {
  const std::int64_t id = c.command.command_id;
  const std::int64_t v = std::llround(a.velocity);
  if (v == 0) {
    run_sequence(c, d, {set(Mnemonic::kSTP, 0)}, [this, id](TimePoint) { part_done(id); });
    return;
  }
  // Leave PT (stops whatever ran), ramps, zero speed; then at rest the position the displacement
  // to the limit is counted from (STP counts from the position at its receipt, EN/CN #44).
  d.jog_command = id;
  run_sequence(
      c, d,
      {set(Mnemonic::kSTP, 0), set(Mnemonic::kMAC, clamp_rate(a.acceleration)),
       set(Mnemonic::kMDE, clamp_rate(a.deceleration > 0 ? a.deceleration : a.acceleration)), set(Mnemonic::kSPD, 0)},
      [this, &c, &d, a, v, id](TimePoint t0) {
        settle(d, id, t0 + kRestLimit, [this, &c, &d, a, v, id](TimePoint) {
          const auto limits = gateway::CountLimits::of(*d.axis);
          const auto room = gateway::jog_room(limits, a.velocity, d.status.position_counts);
          if (!room) {
            d.jog_command = 0;
            finish(id, false,
                   fmt::format("axis {}: jog toward {:.6g} {} refused: it stands at {} counts, less than one count "
                               "from that limit "
                               "({:.6g} counts)",
                               a.axis, limits.position_units(limits.limit_toward(a.velocity)), d.axis->unit,
                               d.status.position_counts, limits.limit_toward(a.velocity)),
                   kOutsideLimits);
            return;
          }
          // STP's range is a 32-bit count (EN/CN #44): a longer way is run in the part that fits.
          constexpr std::int64_t kStpMax = std::numeric_limits<std::int32_t>::max();
          const std::int64_t displacement = std::clamp(*room, -kStpMax, kStpMax);
          run_sequence(c, d, position_run(d, displacement, std::abs(v)), [this, &d, id](TimePoint) {
            if (d.jog_command == id) d.jog_command = 0;
            part_done(id);
          });
        });
      });
}

void Uim242Stack::settle(Drive& d, std::int64_t group, TimePoint give_up, std::function<void(TimePoint)> then) {
  submit(
      d, bare(Mnemonic::kFBK), group,
      [this, &d, group, give_up, then = std::move(then)](const Frame& f, TimePoint t) mutable {
        const auto s = uim242::decode_status(f);
        const std::int64_t speed = s ? s->speed : 0;
        if (speed != 0) {
          d.status.moving = true;
          d.status.velocity_counts = static_cast<double>(speed);
          if (t >= give_up) {
            finish(group, false,
                   fmt::format("{} (node {}): still moving at {} pps, not at rest within {} s", d.name, d.node, speed,
                               std::chrono::duration_cast<std::chrono::seconds>(kRestLimit).count()),
                   kDriveError);
            return;
          }
          rest_checks_.push_back({t + kRestCheck, &d, group, give_up, std::move(then)});
          return;
        }
        // At rest: the real position, published not moving before anything plans from it.
        submit(
            d, bare(Mnemonic::kQEC), group,
            [this, &d, then = std::move(then)](const Frame& q, TimePoint t2) {
              const std::int64_t position = field(q, uim242::Layout::kS32, 0);
              d.status.position_counts = position;
              d.status.position_read = true;
              d.last_polled_position = position;
              d.status.moving = false;
              d.status.velocity_counts = 0;
              publish(d, t2);
              then(t2);
            },
            true);
      },
      true);
}

void Uim242Stack::homed(Drive& d, std::int64_t offset, TimePoint now) {
  d.status.homed = true;
  d.status.position_counts = offset;
  d.status.moving = false;  // the drive took `ORG`: it refuses it while moving
  d.status.velocity_counts = 0;
  d.last_polled_position.reset();
  publish(d, now);  // before DONE (see execute)
}

void Uim242Stack::home(Command& c, Drive& d, const config::Axis& axis, const motionlcm::axis_command_t& a) {
  const std::int64_t id = c.command.command_id;
  // Offset and velocity in counts as the coordinator computed them (with the axis's direction).
  const std::int64_t offset = a.target_counts;
  if (axis.homing.method == config::HomingMethod::kNone) {
    finish(id, false, fmt::format("axis '{}' has no homing method configured", axis.name), kUnsupported);
    return;
  }
  if (axis.homing.method == config::HomingMethod::kCurrentPosition) {
    // No switch: the current position becomes the home position (ORG, #28/#29).
    run_sequence(c, d, {set(Mnemonic::kORG, offset)}, [this, id, &d, offset](TimePoint now) {
      homed(d, offset, now);
      part_done(id);
    });
    return;
  }
  const int input = axis.homing.input;
  if (input < 1 || input > 3) {
    finish(id, false, fmt::format("axis '{}': homing input {} is not S1..S3", axis.name, input), kOutsideLimits);
    return;
  }
  double velocity = a.velocity;
  if (velocity == 0) velocity = -0.1 * axis.limits.max_velocity * axis.steps_per_unit * (axis.invert ? -1.0 : 1.0);
  const std::int64_t speed = std::clamp<std::int64_t>(std::llround(velocity), -kSpeedMax, kSpeedMax);
  // Read the sensor registers, bind 1100 (reset position + emergency stop) to the switch's
  // configured edge (falling by default: a hit switch outputs 0 V, EN §8.10), then run towards
  // it. S12CON = S2RACT S2FACT S1RACT S1FACT, S34CON's low byte S3RACT S3FACT (EN/CN §8.6, §8.7).
  const bool rising = axis.homing.edge == config::HomingEdge::kRising;
  submit(d, bare(Mnemonic::kSCF), id, [this, &c, &d, input, rising, speed, offset](const Frame& f, TimePoint) {
    const auto s34_s12 = static_cast<std::uint32_t>(field(f, uim242::Layout::kScf, 0));
    const bool s3 = input == 3;
    const auto reg = static_cast<std::uint16_t>(s3 ? s34_s12 >> 16 : s34_s12 & 0xFFFF);
    const int shift = (input == 2 ? 8 : 0) + (rising ? 4 : 0);
    const auto bound = static_cast<std::uint16_t>((reg & ~(0xF << shift)) | (kResetAndEmergencyStop << shift));
    const auto which = s3 ? uim242::SensorRegister::kS34CON : uim242::SensorRegister::kS12CON;
    d.homing_restore = {which, reg};
    d.homing_edge = static_cast<uim242::Event>(0xA0 + 2 * (input - 1) + (rising ? 1 : 0));
    d.homing_offset = offset;
    d.homing_command = c.command.command_id;  // from here on, an end without the edge restores the register
    run_sequence(c, d, {uim242::make_scf({which, bound}), set(Mnemonic::kSTP, 0), set(Mnemonic::kSPD, speed)},
                 [](TimePoint) {});
  });
}

void Uim242Stack::param(const gateway_command_t& command, Drive& d, bool write) {
  const std::int64_t id = command.command_id;
  const auto& p = command.param;
  if (p.space != motionlcm::param_t::UIM242_INSTRUCTION) {
    finish(id, false, fmt::format("parameter space {} is not UIM242_INSTRUCTION", p.space), kMalformed);
    return;
  }
  const auto m =
      p.mnemonic.size() >= 3 ? uim242::parse_mnemonic(std::string_view(p.mnemonic).substr(0, 3)) : std::nullopt;
  if (!m || uim242::spec(*m).target != uim242::Target::kController || *m == Mnemonic::kNull) {
    finish(id, false, fmt::format("'{}' is not a UIM242 controller instruction", p.mnemonic), kMalformed);
    return;
  }
  Instruction in = bare(*m);
  std::function<std::int64_t(const Frame&)> value_of;
  const auto layout = [](const Instruction& i) { return uim242::reply_form(i).layout; };
  if (write) {
    const auto out_of_range = [&] {
      finish(id, false,
             fmt::format("{} (node {}): value {} outside the range of {}", d.name, d.node, p.value, p.mnemonic),
             kOutsideLimits);
    };
    const bool by_register = (*m == Mnemonic::kSCF || *m == Mnemonic::kSTG) && p.subindex >= 0;
    if (by_register) {
      // One 16-bit register (SCF 0..3, STG port 0..2): check before narrowing, or 70000 would
      // go out as 4464.
      const std::int32_t last = *m == Mnemonic::kSCF ? 3 : 2;
      if (p.subindex > last) {
        finish(id, false,
               fmt::format("{} (node {}): {} has no register {} (0..{})", d.name, d.node, p.mnemonic, p.subindex, last),
               kOutsideLimits);
        return;
      }
      if (p.value < 0 || p.value > std::numeric_limits<std::uint16_t>::max()) return out_of_range();
      const auto value = static_cast<std::uint16_t>(p.value);
      in = *m == Mnemonic::kSCF ? uim242::make_scf({static_cast<uim242::SensorRegister>(p.subindex), value})
                                : uim242::make_stg({static_cast<std::uint8_t>(p.subindex), value});
    } else {
      in = set(*m, p.value);
    }
    if (uim242::validate(in)) return out_of_range();
    const std::int64_t written = p.value;
    value_of = [written](const Frame&) { return written; };
  } else {
    switch (*m) {
      case Mnemonic::kCUR:
      case Mnemonic::kMCS:
        in = bare(Mnemonic::kNull);  // their values come with the basic ACK (§2.4)
        value_of = [mm = *m](const Frame& f) {
          const auto s = uim242::decode_status(f);
          return s ? std::int64_t{mm == Mnemonic::kCUR ? s->current_tenths : s->micro_steps} : 0;
        };
        break;
      case Mnemonic::kENA: in = Instruction{Mnemonic::kENA, false, 0xFFFF, true}; break;
      case Mnemonic::kMDL: in = set(Mnemonic::kMDL, d.node); break;
      case Mnemonic::kOFF:
      case Mnemonic::kORG:
      case Mnemonic::kSTO:
        finish(id, false, fmt::format("{} has no read form (its bare form acts)", p.mnemonic), kUnsupported);
        return;
      default: break;
    }
    if (!value_of) {
      const Instruction sent = in;
      const std::int32_t sub = p.subindex;
      value_of = [sent, sub, layout](const Frame& f) -> std::int64_t {
        const auto l = layout(sent);
        switch (l) {
          case uim242::Layout::kFlagU32: return field(f, l, 1);
          case uim242::Layout::kModel: return field(f, l, 4);
          case uim242::Layout::kStatus: return field(f, l, 3);
          case uim242::Layout::kStg: return field(f, l, static_cast<std::size_t>(std::max(sub, 0)));
          case uim242::Layout::kSensors: return field(f, l, static_cast<std::size_t>(std::clamp(sub, 0, 3)));
          case uim242::Layout::kScf: {
            const auto regs = field(f, l, 0);
            if (sub == 0) return regs & 0xFFFF;
            if (sub == 1) return (regs >> 16) & 0xFFFF;
            if (sub == 2 || sub == 3) return field(f, l, static_cast<std::size_t>(sub - 1));
            return regs;
          }
          default: return field(f, l, 0);
        }
      };
    }
  }
  submit(d, in, id, [this, id, p, value_of](const Frame& f, TimePoint) {
    motionlcm::param_t out = p;
    out.value = value_of(f);
    finish(id, true, {}, 0, out);
  });
}

}  // namespace motion::uim242_driver
