// AdamStack (adam_stack.hpp): gateway commands: operations and their replies, enable, stops,
// jogs, homing, outputs, parameters, disarming and watching moves (arming and firing: adam_stack_arm.cpp).
#include "adam_stack_impl.hpp"

namespace motion::adam_driver {
// ---- Commands -----------------------------------------------------------------------------------

AdamStack::Operation& AdamStack::open_operation(const motionlcm::gateway_command_t& command,
                                                std::vector<Drive*> drives) {
  auto op = std::make_unique<Operation>();
  op->command = command;
  op->drives = std::move(drives);
  std::vector<std::size_t> parts;  // one per drive
  for (const Drive* d : op->drives) {
    if (std::find(parts.begin(), parts.end(), index_of(*d)) == parts.end()) parts.push_back(index_of(*d));
  }
  auto& ref = *op;
  operations_.add(command, std::move(parts), std::move(op));  // a duplicate id was refused in execute()
  return ref;
}

AdamStack::Operation* AdamStack::operation(std::int64_t id) {
  auto* entry = operations_.find(id);
  return entry != nullptr ? entry->data.get() : nullptr;
}

std::size_t AdamStack::index_of(const Drive& d) const {
  const auto it = std::find_if(drives_.begin(), drives_.end(), [&d](const auto& owned) { return owned.get() == &d; });
  return static_cast<std::size_t>(it - drives_.begin());
}

void AdamStack::add_write(Operation& op, Drive& d, const rtu::Request& request, std::function<void(TimePoint)> after) {
  ++op.outstanding;
  const std::int64_t id = op.command.command_id;
  Transaction t{request, &d, id};
  t.on_reply = [this, id, after = std::move(after)](const rtu::Response&, TimePoint now, TimePoint) {
    Operation* found = operation(id);
    if (found == nullptr) return;
    Operation& o = *found;
    if (after) after(now);  // may add writes: count them before this one is taken off
    if (--o.outstanding == 0 && o.on_transferred) std::exchange(o.on_transferred, {})(now);
  };
  t.on_fail = [this, id](const std::string& reason, std::int32_t code) {
    const Operation* o = operation(id);
    finish(id, Reply::FAILED, reason + (o != nullptr ? o->failure_note : std::string()), code);
  };
  enqueue(std::move(t));
}

void AdamStack::when_transferred(Operation& op, std::function<void(TimePoint)> next) {
  op.on_transferred = std::move(next);
}

void AdamStack::finish(std::int64_t command_id, std::int8_t status, const std::string& reason, std::int32_t code,
                       std::optional<motionlcm::param_t> param) {
  auto* entry = operations_.find(command_id);
  if (entry == nullptr) return;  // already ended: exactly one terminal reply
  if (param) entry->reply.param(*param);
  const auto terminal = status == Reply::DONE                      ? gateway::Lifecycle::kDone
                        : code == error_code(ReplyError::kStopped) ? gateway::Lifecycle::kStopped
                                                                   : gateway::Lifecycle::kFailed;
  auto ended = operations_.finish(command_id, terminal, code, reason);
  std::erase_if(queue_, [command_id](const Transaction& t) { return t.command_id == command_id; });
  for (Drive* d : ended->data->drives) {
    if (d->motion_owner != command_id) continue;
    d->motion_owner = 0;
    d->power.travel_ended();
  }
}

void AdamStack::fail_motion_of(const Drive& d, const std::string& reason, std::int32_t code) {
  if (d.motion_owner != 0) finish(d.motion_owner, Reply::FAILED, reason, code);
  // A jog or homing whose writes are still queued: they would start the motor after the stop.
  std::vector<std::int64_t> queued;
  for (const auto& [id, entry] : operations_.entries()) {
    const auto& op = entry.data;
    const auto kind = op->command.kind;
    const bool motion = kind == motionlcm::gateway_command_t::JOG || kind == motionlcm::gateway_command_t::HOME ||
                        kind == motionlcm::gateway_command_t::ARM_MOVE;
    if (motion && !op->watching && std::find(op->drives.begin(), op->drives.end(), &d) != op->drives.end()) {
      queued.push_back(id);
    }
  }
  for (const auto id : queued) finish(id, Reply::FAILED, reason, code);
}

std::optional<std::string> AdamStack::busy_reason(const std::vector<Drive*>& drives) const {
  for (const Drive* d : drives) {
    if (d->motion_owner != 0) return "axis " + d->cfg.axis + " is busy with command " + std::to_string(d->motion_owner);
    if (d->alarm.active())
      return "axis " + d->cfg.axis + " is faulted: " + std::string(adam::alarm_text(d->alarm.current));
  }
  return std::nullopt;
}

void AdamStack::execute(const motionlcm::gateway_command_t& command, TimePoint now) {
  const auto refuse = [&](const std::string& reason, std::int32_t code) { operations_.reject(command, code, reason); };
  if (operations_.find(command.command_id) != nullptr)
    return refuse("duplicate command id", error_code(ReplyError::kMalformedRequest));
  std::vector<Drive*> drives;
  for (const auto& a : command.axes) {
    Drive* d = drive_of_axis(a.axis);
    if (!d)
      return refuse("axis '" + a.axis + "' is not an ADAM axis of bus " + settings_.bus,
                    error_code(ReplyError::kUnknownAxis));
    drives.push_back(d);
  }
  const bool needs_axes = command.kind != motionlcm::gateway_command_t::DISARM;
  if (needs_axes && drives.empty()) return refuse("command names no axis", error_code(ReplyError::kMalformedRequest));
  const std::string id_text = std::to_string(command.command_id);

  switch (command.kind) {
    case motionlcm::gateway_command_t::ENABLE:
    case motionlcm::gateway_command_t::DISABLE: {
      const bool enable = command.kind == motionlcm::gateway_command_t::ENABLE;
      auto& op = open_operation(command, drives);
      for (Drive* d : drives) {
        if (!enable)
          fail_motion_of(*d, "axis " + d->cfg.axis + " disabled by command " + id_text,
                         error_code(ReplyError::kStopped));
        add_write(op, *d,
                  adam::command(d->cfg.unit, enable ? adam::EnableCommand::kEnable : adam::EnableCommand::kRelease),
                  [this, d, enable](TimePoint) {
                    d->enabled = enable;
                    publish_status(*d);
                  });
      }
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      break;
    }
    case motionlcm::gateway_command_t::STOP:
    case motionlcm::gateway_command_t::ESTOP: {
      const bool emergency = command.kind == motionlcm::gateway_command_t::ESTOP;
      for (Drive* d : drives) {
        fail_motion_of(*d, "axis " + d->cfg.axis + " stopped by command " + id_text, error_code(ReplyError::kStopped));
      }
      auto& op = open_operation(command, drives);
      op.goal = Operation::Goal::kStandStill;
      // A drive that does not answer may still hear: its stop went out (each try of it), but
      // nothing confirms it took it.
      op.failure_note = ": the stop was sent all the same, not confirmed";
      for (Drive* d : drives) {
        add_write(op, *d,
                  adam::command(d->cfg.unit, emergency ? adam::VelocityCommand::kEmergencyStop
                                                       : adam::VelocityCommand::kRampedStop));
        // An e-stop leaves the motor released, as on every family (CiA 402 quick stop ends in
        // "switch on disabled").
        if (emergency) {
          add_write(op, *d, adam::command(d->cfg.unit, adam::EnableCommand::kRelease), [this, d](TimePoint) {
            d->enabled = false;
            publish_status(*d);
          });
        }
      }
      // Urgent: a stop goes before queued polls and set-up (but after the frame on the line).
      std::stable_partition(queue_.begin(), queue_.end(),
                            [id = command.command_id](const Transaction& t) { return t.command_id == id; });
      for (auto& t : queue_) t.urgent = t.urgent || t.command_id == command.command_id;
      when_transferred(op, [this, id = command.command_id](TimePoint) {
        if (Operation* stopping = operation(id)) stopping->watching = true;
      });
      break;
    }
    case motionlcm::gateway_command_t::JOG: {
      if (auto busy = busy_reason(drives)) return refuse(*busy, error_code(ReplyError::kAxisBusy));
      auto& op = open_operation(command, drives);
      for (std::size_t i = 0; i < drives.size(); ++i) {
        Drive& d = *drives[i];
        const auto& a = command.axes[i];
        const double rpm = std::abs(rpm_of(d, a.velocity));
        const auto speed = adam::jog_speed(rpm);
        if (!speed || (a.velocity != 0 && speed.value().value == 0)) {
          return finish(
              command.command_id, Reply::FAILED,
              "axis " + a.axis + ": jog speed " + std::to_string(rpm) + " rpm outside 1…511 rpm (0x00CA, §8.65②)",
              error_code(ReplyError::kMalformedRequest));
        }
        if (a.acceleration > 0 && speed.value().value > 0) {
          const double rate = std::abs(rpm_of(d, a.acceleration));
          const auto ramp = adam::ramp_time_ms(0, speed.value().realized, rate);
          if (ramp) {
            // The ramp times span the start speed to a speed register (§8.42/§8.43): 0x009A
            // (§8.44) and 0x00D8 (§8.64) get the jog's speed too, so that they are the jog's
            // ramps, not the last move's speed over them (soak seed 7338: after a move at 1 rpm a
            // jog's ramped stop took half a minute).
            const auto rpm_whole = static_cast<std::uint16_t>(std::lround(speed.value().realized));
            add_write(op, d,
                      {d.cfg.unit, rtu::WriteRegisters{adam::address(Reg::kStartSpeed),
                                                       {0, 0, ramp.value().value, ramp.value().value, rpm_whole}}});
            add_write(op, d, adam::write32(d.cfg.unit, Reg::kTargetSpeed, static_cast<std::int32_t>(rpm_whole) * 100));
          }
        }
        adam::JogCommand jog;
        jog.direction = a.velocity < 0 ? adam::Rotation::kCcw : adam::Rotation::kCw;
        jog.speed_rpm = speed.value().value;
        jog.stop = adam::StopMethod::kDecelerate;
        jog.run = speed.value().value > 0;
        add_write(op, d, adam::write16(d.cfg.unit, Reg::kJogCommand, adam::encode(jog).value()));
      }
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      break;
    }
    case motionlcm::gateway_command_t::HOME: {
      if (auto busy = busy_reason(drives)) return refuse(*busy, error_code(ReplyError::kAxisBusy));
      auto& op = open_operation(command, drives);
      op.goal = Operation::Goal::kReachHome;
      bool any_switch = false;
      for (std::size_t i = 0; i < drives.size(); ++i) {
        Drive& d = *drives[i];
        const auto& a = command.axes[i];
        d.motion_owner = command.command_id;
        if (d.cfg.homing_method == config::HomingMethod::kNone) {
          return finish(command.command_id, Reply::FAILED, "axis " + a.axis + " has no homing method configured",
                        error_code(ReplyError::kUnsupported));
        }
        if (d.cfg.homing_method == config::HomingMethod::kCurrentPosition) {
          add_write(
              op, d,
              adam::move(d.cfg.unit, adam::MoveCommand::kPresetPosition, static_cast<std::int32_t>(a.target_counts)),
              [&d](TimePoint) { d.homed = true; });
          op.arrived.insert(&d);
          continue;
        }
        any_switch = true;
        adam::InputPair inputs;  // high byte: enable input (off); low byte: home input (§8.48)
        inputs.low = {true, true, static_cast<std::uint8_t>(std::clamp(d.cfg.home_input - 1, 0, 15))};
        add_write(op, d, adam::write16(d.cfg.unit, Reg::kEnableHomeInputs, adam::encode(inputs).value()));
        const double rpm = std::abs(rpm_of(d, a.velocity));
        adam::HomingCommand home;
        home.direction = a.velocity < 0 ? adam::Travel::kReverse : adam::Travel::kForward;
        home.speed_rpm =
            a.velocity == 0 ? kDefaultHomingRpm
                            : static_cast<std::uint16_t>(std::clamp(std::lround(rpm), 1L, long{adam::kMaxJogSpeedRpm}));
        home.stop = adam::StopMethod::kImmediate;  // stop ON the sensor: the position is zeroed there
        home.secondary_speed_code = 0;
        add_write(op, d, adam::write16(d.cfg.unit, Reg::kHomingCommand, adam::encode(home).value()));
      }
      when_transferred(op, [this, id = command.command_id, any_switch](TimePoint) {
        if (!any_switch) return finish(id, Reply::DONE);
        if (Operation* stopping = operation(id)) stopping->watching = true;
      });
      break;
    }
    case motionlcm::gateway_command_t::ARM_MOVE: {
      if (auto busy = busy_reason(drives)) return refuse(*busy, error_code(ReplyError::kAxisBusy));
      for (Drive* d : drives) {
        if (d->status && d->status->moving())
          return refuse("axis " + d->cfg.axis + " is moving; stop it before arming a move",
                        error_code(ReplyError::kAxisBusy));
      }
      auto& op = open_operation(command, drives);
      arm_move(op, now);
      break;
    }
    case motionlcm::gateway_command_t::FAULT_RESET: {
      auto& op = open_operation(command, drives);
      for (Drive* d : drives) add_write(op, *d, adam::clear_alarm(d->cfg.unit));
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      break;
    }
    case motionlcm::gateway_command_t::SET_OUTPUTS: {
      auto& op = open_operation(command, drives);
      for (std::size_t i = 0; i < drives.size(); ++i) {
        const auto& a = command.axes[i];
        if ((a.output_mask & ~((1 << kMaxOutputs) - 1)) != 0) {
          return finish(command.command_id, Reply::FAILED,
                        "axis " + a.axis + ": output mask " + hex16(static_cast<std::uint32_t>(a.output_mask)) +
                            " names outputs beyond Y0…Y7",
                        error_code(ReplyError::kMalformedRequest));
        }
        const auto on = static_cast<std::uint16_t>(a.output_mask & a.output_value);
        const auto off = static_cast<std::uint16_t>(a.output_mask & ~a.output_value);
        if (on != 0) add_write(op, *drives[i], adam::write16(drives[i]->cfg.unit, Reg::kOutputsOn, on));
        if (off != 0) add_write(op, *drives[i], adam::write16(drives[i]->cfg.unit, Reg::kOutputsOff, off));
      }
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      if (op.outstanding == 0) finish(command.command_id, Reply::DONE);
      break;
    }
    case motionlcm::gateway_command_t::SET_POSITION: {
      if (auto busy = busy_reason(drives)) return refuse(*busy, error_code(ReplyError::kAxisBusy));
      auto& op = open_operation(command, drives);
      for (std::size_t i = 0; i < drives.size(); ++i) {
        const auto target = command.axes[i].target_counts;
        if (target < std::numeric_limits<std::int32_t>::min() || target > std::numeric_limits<std::int32_t>::max()) {
          return finish(command.command_id, Reply::FAILED, "axis " + command.axes[i].axis + ": position outside INT32",
                        error_code(ReplyError::kMalformedRequest));
        }
        add_write(
            op, *drives[i],
            adam::move(drives[i]->cfg.unit, adam::MoveCommand::kPresetPosition, static_cast<std::int32_t>(target)));
      }
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      break;
    }
    case motionlcm::gateway_command_t::PARAM_READ:
    case motionlcm::gateway_command_t::PARAM_WRITE: {
      if (drives.size() != 1)
        return refuse("a parameter command names exactly one axis", error_code(ReplyError::kMalformedRequest));
      auto& op = open_operation(command, drives);
      param(op, command.param);
      break;
    }
    case motionlcm::gateway_command_t::DISARM: {
      std::vector<std::int64_t> disarmed;
      for (const auto& [id, entry] : operations_.entries()) {
        const auto& op = entry.data;
        if (op->command.kind != motionlcm::gateway_command_t::ARM_MOVE || op->watching) continue;
        const bool by_trigger = command.trigger_id != 0 && op->command.trigger_id == command.trigger_id;
        const bool by_axis = std::any_of(op->drives.begin(), op->drives.end(), [&](Drive* d) {
          return std::find(drives.begin(), drives.end(), d) != drives.end();
        });
        if (by_trigger || by_axis) disarmed.push_back(id);
      }
      // A released move leaves no start in the drive: its table entry 0 holds the move's target
      // (saved to flash with table_save, §8.69), and a broadcast "execute table data" (0x00DD,
      // §8.54, to address 0, §5) from anyone, or a later broadcast start of ours, would run it.
      // The entry is set back to where the drive stands, as for any other drive of the line at
      // arming, and saved; queued ahead of every later command's frames.
      std::set<Drive*> loaded;
      for (const auto id : disarmed) {
        if (const Operation* op = operation(id)) loaded.insert(op->drives.begin(), op->drives.end());
      }
      for (const auto id : disarmed)
        finish(id, Reply::FAILED, "disarmed by command " + id_text, error_code(ReplyError::kStopped));
      std::string neutralized;
      for (Drive* d : loaded) {
        if (neutralize(*d)) neutralized += (neutralized.empty() ? "; table entry 0 of " : ", ") + d->cfg.drive;
      }
      if (!neutralized.empty()) neutralized += " set back to its position";
      open_operation(command, drives);
      finish(command.command_id, Reply::DONE,
             std::to_string(disarmed.size()) + " armed move(s) disarmed" + neutralized);
      break;
    }
    default:
      return refuse("command kind " + std::to_string(command.kind) + " is not supported by the ADAM driver",
                    error_code(ReplyError::kUnsupported));
  }
  send_next(now);
}

void AdamStack::check_motion(Operation& op, const Drive& sampled, TimePoint now) {
  (void)now;
  const std::int64_t id = op.command.command_id;
  for (Drive* d : op.drives) {
    if (op.arrived.contains(d) || !d->status || !d->position) continue;
    const adam::DriveStatus& s = *d->status;
    const bool idle = s.phase == adam::MotionPhase::kIdle;
    if (!idle) {
      op.seen_moving.insert(d);
      continue;
    }
    bool reached = false;
    switch (op.goal) {
      case Operation::Goal::kReachTarget: reached = s.in_position && *d->position == d->target; break;
      case Operation::Goal::kReachHome: reached = s.at_home; break;
      case Operation::Goal::kStandStill:
      case Operation::Goal::kNone: reached = true; break;
    }
    if (reached) {
      op.arrived.insert(d);
      continue;
    }
    // Idle but not there: give the drive a few polls to start (the broadcast has no ack), then
    // report where it stopped. Only a fresh sample of this drive counts: the others' samples
    // come in between and would count its old one again.
    if (d == &sampled && !op.seen_moving.contains(d)) ++op.idle_polls[d];
    if (op.seen_moving.contains(d) || op.idle_polls[d] >= kIdlePollsBeforeShortStop) {
      const std::string where = "axis " + d->cfg.axis + " stopped at " + std::to_string(*d->position);
      std::string reason;
      if (s.at_limit())
        reason = where + " on its " + (s.negative_limit ? "negative" : "positive") + " limit";
      else if (op.goal == Operation::Goal::kReachHome)
        reason = where + " without finding the home switch";
      else
        reason = where + ", short of its target " + std::to_string(d->target);
      return finish(id, Reply::FAILED, reason,
                    s.at_limit() ? error_code(ReplyError::kAxisFault) : error_code(ReplyError::kDriveError));
    }
  }
  if (op.arrived.size() < op.drives.size()) return;
  if (op.goal == Operation::Goal::kReachHome) {
    for (std::size_t i = 0; i < op.drives.size(); ++i) op.drives[i]->homed = true;
    // Home is position 0 on the drive (assumed: §8.48 only says positions are relative to home); a
    // non-zero home position is preset after.
    op.watching = false;  // the presets are written, then DONE
    op.goal = Operation::Goal::kNone;
    for (std::size_t i = 0; i < op.drives.size(); ++i) {
      const auto target = op.command.axes[i].target_counts;
      if (target != 0)
        add_write(
            op, *op.drives[i],
            adam::move(op.drives[i]->cfg.unit, adam::MoveCommand::kPresetPosition, static_cast<std::int32_t>(target)));
    }
    if (op.outstanding == 0) return finish(id, Reply::DONE);
    when_transferred(op, [this, id](TimePoint) { finish(id, Reply::DONE); });
    return;
  }
  finish(id, Reply::DONE);
}

void AdamStack::param(Operation& op, const motionlcm::param_t& p) {
  const std::int64_t id = op.command.command_id;
  Drive& d = *op.drives[0];
  if (p.space != motionlcm::param_t::MODBUS_REGISTER)
    return finish(id, Reply::FAILED, "ADAM parameters are Modbus registers (param_t space MODBUS_REGISTER)",
                  error_code(ReplyError::kUnsupported));
  if (p.index < 0 || p.index > 0xFFFF)
    return finish(id, Reply::FAILED, "register " + std::to_string(p.index) + " outside 0…0xFFFF",
                  error_code(ReplyError::kMalformedRequest));
  const auto reg = static_cast<std::uint16_t>(p.index);
  const auto* info = adam::find_register(reg);
  const int width = p.width != 0 ? p.width : (info ? info->count() : 1);
  if (width != 1 && width != 2)
    return finish(id, Reply::FAILED, "width must be 1 or 2 registers", error_code(ReplyError::kMalformedRequest));
  const bool is_signed =
      p.is_signed || (info && (info->type == adam::RegType::kI16 || info->type == adam::RegType::kI32));
  if (op.command.kind == motionlcm::gateway_command_t::PARAM_READ) {
    Transaction t{{d.cfg.unit, rtu::ReadRegisters{reg, static_cast<std::uint16_t>(width)}}, &d, id};
    t.on_reply = [this, id, p, width, is_signed](const rtu::Response& r, TimePoint, TimePoint) {
      const auto& v = std::get<rtu::ReadRegistersReply>(r.pdu).values;
      motionlcm::param_t result = p;
      result.width = static_cast<std::int8_t>(width);
      if (width == 2)
        result.value =
            is_signed ? std::int64_t{adam::decode32_signed(v[0], v[1])} : std::int64_t{adam::decode32(v[0], v[1])};
      else
        result.value = is_signed ? std::int64_t{adam::decode16_signed(v[0])} : std::int64_t{v[0]};
      finish(id, Reply::DONE, {}, 0, result);
    };
    t.on_fail = [this, id](const std::string& reason, std::int32_t code) { finish(id, Reply::FAILED, reason, code); };
    enqueue(std::move(t));
    return;
  }
  const std::int64_t lo =
      width == 1 ? (is_signed ? -32768 : 0) : (is_signed ? std::numeric_limits<std::int32_t>::min() : 0);
  const std::int64_t hi = width == 1
                              ? (is_signed ? 32767 : 0xFFFF)
                              : (is_signed ? std::numeric_limits<std::int32_t>::max() : std::int64_t{0xFFFFFFFF});
  if (p.value < lo || p.value > hi)
    return finish(id, Reply::FAILED,
                  "value " + std::to_string(p.value) + " does not fit " + std::to_string(width) + " register(s)",
                  error_code(ReplyError::kMalformedRequest));
  const rtu::Request request =
      width == 1
          ? rtu::Request{d.cfg.unit, rtu::WriteRegister{reg, static_cast<std::uint16_t>(p.value)}}
          : rtu::Request{d.cfg.unit, rtu::WriteRegisters{reg,
                                                         {adam::encode32(static_cast<std::uint32_t>(p.value))[0],
                                                          adam::encode32(static_cast<std::uint32_t>(p.value))[1]}}};
  add_write(op, d, request);
  when_transferred(op, [this, id, p](TimePoint) { finish(id, Reply::DONE, {}, 0, p); });
}

}  // namespace motion::adam_driver
