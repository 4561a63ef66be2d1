// Uim342Stack (uim342_stack.hpp): identification (§5.4 ML), set-up (§5.1, §5.7, §5.9, §5.3), reboots
// (SY[1]), what each ACK and status read means, and power cycles seen in the answers.
#include "uim342_stack_impl.hpp"

namespace motion::gateway {

void Uim342Stack::Impl::identify(std::size_t i, TimePoint now) {
  Node& n = nodes[i];
  n.phase = Phase::kIdentifying;
  n.queue.clear();
  enqueue(i, rq::get(FunctionCode::kML), 0);
  pump(i, now);
}

void Uim342Stack::Impl::set_up(std::size_t i) {
  Node& n = nodes[i];
  n.phase = Phase::kSettingUp;
  const auto& s = n.cfg.setup;
  using uim342::InitialConfig;
  using uim342::MotorDriver;
  using uim342::QuadratureEncoder;
  if (n.cfg.group_id != 0) enqueue(i, rq::get(uim342::ProtocolParameter::kGroupId), 0);
  enqueue(i, rq::get(MotorDriver::kAutoEnableDelayMs), 0);  // the power-on marker (check_marker())
  if (config::setup_integer(s, "micro_steps")) {
    // §5.9, §5.7: MT[0] (with CPR QE[4]) takes effect only after it is stored with the driver
    // off and the drive restarted. Read first; a difference is written by
    // store_micro_steps_and_restart() once the QE[4] answer is in.
    enqueue(i, rq::get(MotorDriver::kMicrostepping), 0);
    enqueue(i, rq::get(QuadratureEncoder::kCountsPerRevolution), 0);
  }
  if (const auto v = config::setup_number(s, "current_a")) {
    const auto tenths = uim342::current_to_wire(*v);
    enqueue(i, rq::set(MotorDriver::kWorkingCurrent, tenths ? *tenths : saturate<std::uint16_t>(std::lround(*v * 10))),
            0);
  }
  if (const auto v = config::setup_integer(s, "idle_current_percent"))
    enqueue(i, rq::set(MotorDriver::kIdleCurrentPercent, saturate<std::uint16_t>(*v)), 0);
  if (const auto v = config::setup_flag(s, "auto_enable"))
    enqueue(i, rq::set(InitialConfig::kAutoDriverOn, *v ? 1 : 0), 0);
  if (const auto v = config::setup_text(s, "direction"))
    enqueue(i, rq::set(InitialConfig::kPositiveDirection, *v == "ccw" ? 1 : 0), 0);
  if (const auto v = config::setup_text(s, "acceleration_unit")) {
    n.unit = *v == "time" ? uim342::AccelerationUnit::kMilliseconds : uim342::AccelerationUnit::kPulsesPerS2;
    enqueue(i, rq::set(InitialConfig::kAccelerationUnit, static_cast<std::uint16_t>(n.unit)), 0);
  }
  if (const auto v = config::setup_flag(s, "closed_loop"))
    enqueue(i, rq::set(InitialConfig::kClosedLoop, *v ? 1 : 0), 0);
  if (const auto v = config::setup_flag(s, "software_limits"))
    enqueue(i, rq::set(InitialConfig::kSoftwareLimits, *v ? 1 : 0), 0);
  if (const auto v = config::setup_integer(s, "encoder_resolution"))
    enqueue(i, rq::set(QuadratureEncoder::kLinesPerRevolution, saturate<std::uint16_t>(*v)), 0);
  if (const auto v = config::setup_integer(s, "stall_tolerance"))
    enqueue(i, rq::set(QuadratureEncoder::kStallTolerance, saturate<std::uint16_t>(*v)), 0);
  if (const auto v = config::setup_integer(s, "cut_in_speed")) {
    n.cut_in_pps = static_cast<double>(*v);
    enqueue(i, rq::set_cut_in_speed(saturate<std::uint32_t>(*v)), 0);
  }
  if (const auto v = config::setup_integer(s, "stop_deceleration"))
    enqueue(i, rq::set_stop_deceleration(saturate<std::uint32_t>(*v)), 0);
  if (const auto v = config::setup_integer(s, "backlash")) enqueue(i, rq::set_backlash(saturate<std::uint32_t>(*v)), 0);
  // Notifications this stack relies on (§5.3): inputs for INPUT_EDGE, PTP finished for DONE.
  // Alarms (stall, limits) have no enable bit and are always sent.
  for (const auto e : {uim342::InformationEnable::kIn1Change, uim342::InformationEnable::kIn2Change,
                       uim342::InformationEnable::kIn3Change, uim342::InformationEnable::kPositionReached}) {
    enqueue(i, rq::set(e, true), 0);
  }
  // The last setup request: its ACK makes the node ready (see completed()).
  enqueue(i, rq::get(uim342::MotionStatusIndex::kStatus), 0);
  enqueue(i, rq::get(uim342::MotionStatusIndex::kKinematics), 0);
}

void Uim342Stack::Impl::completed(std::size_t i, const Request& r, const std::optional<uim342::Reply>& ack,
                                  TimePoint now) {
  Node& n = nodes[i];
  if (ack) apply_ack(i, r, *ack, now);
  if (r.hold_for != 0) {
    hold_loaded(i, r.hold_for, now);
    return;
  }
  if (r.instruction.function == FunctionCode::kSY) {
    // The drive reboots without answering; identified and set up again after reboot_wait.
    n.power.forget();  // our own reboot: its counter restarts at 0 (not a lost power)
    n.marker.reset();  // and its RAM is cleared by our own doing
    fail_commands_of(i, error_code(ReplyError::kAxisOffline),
                     fmt::format("{} is rebooting to apply its set-up (PP[8], MT[0])", n.name()));
    n.phase = Phase::kRebooting;
    n.queue.clear();
    n.retry_at = now + config.reboot_wait;
    return;
  }
  if (r.command_id != 0 && n.homing.command == r.command_id) {
    if (!has_request_of(i, r.command_id)) homing_step_loaded(i, now);
    return;
  }
  if (r.command_id != 0) {
    Command* c = commands.find(r.command_id);
    if (c != nullptr && !has_request_of(i, r.command_id)) {
      c->data.waiting.erase(i);
      // An ARM_MOVE is Armed once every part is loaded and every bystander holds.
      if (c->command.kind == gateway_command_t::ARM_MOVE) {
        armed_if_loaded(*c, now);
      } else if (c->data.waiting.empty()) {
        stage_done(*c, now);
      }
    }
    return;
  }
  if (n.phase == Phase::kSettingUp && n.queue.empty()) setup_finished(i, now);
}

// §5.9, §5.7: MT[0] and QE[4] as read at set-up against the configured micro-steps. Equal: the
// drive runs at them (after a restart, or since its last one). Different the first time: driver
// off (MO=0, so the values go to EEPROM and not only to RAM), MT[0], QE[4], restart (SY[1]);
// set-up runs again after the reboot and reads them back. Different after that restart: the
// drive does not keep them, and counts per unit would be wrong: CONFIG_MISMATCH, never ready.
void Uim342Stack::Impl::check_micro_steps(std::size_t i, std::uint16_t read_cpr) {
  Node& n = nodes[i];
  const auto wanted = saturate<std::uint16_t>(config::setup_integer(n.cfg.setup, "micro_steps").value_or(0));
  const auto wanted_cpr = saturate<std::uint16_t>(std::int64_t{wanted} * uim342::kFullStepsPerRevolution);
  if (n.read_micro_steps == wanted && read_cpr == wanted_cpr) return;
  const auto found = fmt::format("MT[0] {} / QE[4] {} (configured micro_steps {}: MT[0] {} / QE[4] {})",
                                 n.read_micro_steps, read_cpr, wanted, wanted, wanted_cpr);
  if (n.restarted_for_micro_steps) {
    event(n, event_t::CONFIG_MISMATCH, event_t::ERROR, n.read_micro_steps,
          fmt::format("{} reads {} after storing them and restarting: counts per unit would be wrong; not ready",
                      n.name(), found));
    n.setup_refused = true;
    return;
  }
  event(n, event_t::REBOOT, event_t::INFO, n.read_micro_steps,
        fmt::format("{}: {}; driver off, storing, restarting (SY[1])", n.name(), found));
  n.restarted_for_micro_steps = true;
  n.queue.erase(n.queue.begin() + (n.busy() ? 1 : 0), n.queue.end());
  enqueue(i, rq::driver_on(false), 0);
  enqueue(i, rq::set(uim342::MotorDriver::kMicrostepping, wanted), 0);
  enqueue(i, rq::set(uim342::QuadratureEncoder::kCountsPerRevolution, wanted_cpr), 0);
  enqueue(i, rq::system(uim342::SystemOperation::kReboot), 0);
}

// The last set-up request was answered (or refused).
void Uim342Stack::Impl::setup_finished(std::size_t i, TimePoint now) {
  Node& n = nodes[i];
  n.phase = n.setup_refused ? Phase::kSetupFailed : Phase::kReady;
  n.backoff = std::chrono::milliseconds{0};
  n.next_poll = now + poll_period;
  if (n.setup_refused) return;          // CONFIG_MISMATCH already reported
  n.restarted_for_micro_steps = false;  // a later mismatch (someone rewrote MT) may restart once more
  event(n, event_t::ONLINE, event_t::INFO, 0,
        fmt::format("{} set up{}", n.name(),
                    n.cfg.group_id != 0 && !n.group_ok ? " (group start disabled: group id not confirmed)" : ""));
}

void Uim342Stack::Impl::apply_ack(std::size_t i, const Request& r, const uim342::Reply& ack, TimePoint now) {
  Node& n = nodes[i];
  const auto& body = ack.body;
  switch (r.instruction.function) {
    case FunctionCode::kML: {
      const auto& model = std::get<uim342::ModelInfo>(body);
      n.status.online = true;
      n.offline_reported = false;
      n.setup_refused = false;
      event(n, event_t::ONLINE, event_t::INFO, static_cast<std::int32_t>(model.model_bytes[0]),
            fmt::format("{} online: model {:02X} {:02X} {:02X}, firmware {}", n.name(), model.model_bytes[0],
                        model.model_bytes[1], model.model_bytes[2], model.firmware));
      n.ever_online = true;
      if (n.phase == Phase::kIdentifying) set_up(i);
      break;
    }
    case FunctionCode::kPP: {
      const auto& pp = std::get<uim342::IndexedByte>(body);
      if (pp.index != static_cast<std::uint8_t>(uim342::ProtocolParameter::kGroupId) ||
          r.instruction.operation != uim342::Operation::kGet)
        break;
      n.group_ok = pp.value == n.cfg.group_id;
      if (n.group_ok) break;
      if (n.rebooted_for_group) {
        event(n, event_t::CONFIG_MISMATCH, event_t::ERROR, pp.value,
              fmt::format("{} keeps group id {} after a reboot (configured {}): moves start axis by axis", n.name(),
                          pp.value, n.cfg.group_id));
        break;
      }
      // §5.1: PP values act after a reboot; everything in RAM is set up again afterwards.
      event(n, event_t::REBOOT, event_t::INFO, pp.value,
            fmt::format("{}: group id {} -> {} (PP[8]), rebooting (SY[1])", n.name(), pp.value, n.cfg.group_id));
      n.rebooted_for_group = true;
      n.queue.erase(n.queue.begin() + (n.busy() ? 1 : 0), n.queue.end());
      enqueue(i, rq::set(uim342::ProtocolParameter::kGroupId, n.cfg.group_id), 0);
      enqueue(i, rq::system(uim342::SystemOperation::kReboot), 0);
      break;
    }
    case FunctionCode::kMT: {
      const auto& word = std::get<uim342::IndexedWord>(body);
      const bool delay = word.index == static_cast<std::uint8_t>(uim342::MotorDriver::kAutoEnableDelayMs);
      if (r.instruction.operation == uim342::Operation::kGet) {
        if (delay && r.command_id == 0) {
          marker_read(i, word.value, now);
        } else if (word.index == static_cast<std::uint8_t>(uim342::MotorDriver::kMicrostepping)) {
          n.read_micro_steps = word.value;
        }
      } else if (delay) {
        // Ours: the marker is in its RAM now. A PARAM_WRITE of MT[3]: no marker of ours is there.
        n.marker = r.command_id == 0 ? std::optional<std::uint16_t>{word.value} : std::nullopt;
      }
      break;
    }
    case FunctionCode::kQE:
      if (r.instruction.operation == uim342::Operation::kGet && n.phase == Phase::kSettingUp) {
        check_micro_steps(i, std::get<uim342::IndexedWord>(body).value);
      }
      break;
    case FunctionCode::kMO: {
      n.status.enabled = std::get<uim342::Byte>(body).value != 0;
      if (!n.status.enabled) n.status.moving = false;
      publish(n, now);
      break;
    }
    case FunctionCode::kMS:
      if (const auto* s = std::get_if<uim342::MotionStatus>(&body)) on_motion_status(i, *s, r, now);
      if (const auto* k = std::get_if<uim342::MotionKinematics>(&body)) {
        if (auto why = powered_up(n, *k, now)) {
          on_power_cycle(i, *why, now);
          break;
        }
        check_marker(i, *k, n.was_enabled && !n.status.enabled, now);
        n.status.position_counts = k->absolute_position + n.offset;
        n.status.position_read = true;
        n.status.velocity_counts = k->speed;
        publish(n, now);
        arm_marker(i);
      }
      break;
    case FunctionCode::kOG: {
      const auto* c = commands.find(r.command_id);
      if (c == nullptr) break;
      // SET_POSITION's value, or the homing offset: the position the origin gets.
      n.power.counter_set(0, now);  // the counter is 0 now by our own doing
      n.offset = c->data.targets.at(i);
      n.status.position_counts = n.offset;
      if (c->command.kind == gateway_command_t::HOME) n.status.homed = true;
      publish(n, now);
      break;
    }
    case FunctionCode::kIL: {
      if (n.homing.command == 0 || r.command_id != n.homing.command) break;
      const auto* actions = std::get_if<uim342::InputActions>(&body);
      if (!actions) break;
      if (r.instruction.operation == uim342::Operation::kGet) {
        n.homing.previous = *actions;
      } else {
        n.homing.armed = n.homing.step == Node::Homing::Step::kSearchingLoad;  // the restore's ACK disarms
      }
      break;
    }
    case FunctionCode::kDI: {
      const auto& io = std::get<uim342::DigitalIo>(body);
      n.status.inputs = io.inputs & 0x07;
      n.status.outputs = io.outputs & 0x01;
      publish(n, now);
      break;
    }
    case FunctionCode::kBG:
      n.started_since_status = true;
      if (n.move == r.command_id && r.command_id != 0) {
        n.bg_acked = true;
        n.seen_moving = false;
        n.status.in_position = false;
        n.status.moving = true;
      }
      break;
    default: break;
  }
  if (auto* c = commands.find(r.command_id)) {
    if (c->command.kind == gateway_command_t::PARAM_READ || c->command.kind == gateway_command_t::PARAM_WRITE) {
      auto param = c->reply.peek().param;
      param.value = param_value(ack, param);
      c->reply.param(param);
    }
  }
}

void Uim342Stack::Impl::on_motion_status(std::size_t i, const uim342::MotionStatus& s, const Request& r,
                                         TimePoint now) {
  Node& n = nodes[i];
  using uim342::IoStatusBit;
  using uim342::StatusFlag;
  n.status.online = true;
  n.started_since_status = false;  // asked after the last BG's ACK (one request at a time per drive)
  n.was_enabled = n.status.enabled;
  n.status.enabled = s.has(IoStatusBit::kDriverOn);
  n.status.moving = !s.has(StatusFlag::kStopped);
  n.status.in_position = s.has(StatusFlag::kInPosition);
  n.status.inputs =
      (s.has(IoStatusBit::kIn1) ? 1 : 0) | (s.has(IoStatusBit::kIn2) ? 2 : 0) | (s.has(IoStatusBit::kIn3) ? 4 : 0);
  n.status.outputs = s.has(IoStatusBit::kOp1) ? 1 : 0;
  const bool stalled = s.has(StatusFlag::kStalled);
  const bool locked = s.has(StatusFlag::kLocked);
  if (stalled || locked || s.has(StatusFlag::kError)) {
    n.status.fault = true;
    if (stalled) n.status.fault_text = "motor stall detected (TLIF)";
    if (locked) n.status.fault_text = "system locked down (LOCK): only a reboot or power cycle releases it";
    if (!stalled && !locked) n.status.fault_text = "system error detected (ERR)";
  } else {
    n.status.fault = false;
    n.status.fault_code = 0;
    n.status.fault_text.clear();
  }
  const auto* c = commands.find(r.command_id);
  if (c != nullptr && c->command.kind == gateway_command_t::FAULT_RESET && locked) {
    fail(r.command_id, error_code(ReplyError::kDriveError),
         fmt::format("{} is locked down (LOCK); MS[0]=0 does not release it, a reboot (SY[1]) or power cycle does",
                     n.name()));
  }
  if (n.homing.command != 0) {
    homing_observe(i, now);
    return;
  }
  // Completion of an active move, from a status read sent after its BG was acknowledged. A
  // driver turned off by nobody may be a power cycle: the position read next decides (powered_up()).
  const bool switched_off = n.was_enabled && !n.status.enabled;
  if (n.move != 0 && n.bg_acked && !(switched_off && r.command_id == 0)) {
    if (stalled) {
      fail(n.move, error_code(ReplyError::kAxisFault), fmt::format("{} stalled during the move (TLIF)", n.name()));
    } else if (n.status.moving) {
      n.seen_moving = true;
    } else if (n.status.in_position) {
      arrived(i, now);
    } else if (n.seen_moving) {
      fail(n.move, error_code(ReplyError::kAxisFault),
           fmt::format("{} stopped short of its target without a stop command", n.name()));
    }
  }
}

// The UIM342 sends nothing when it powers up (no such notification in §2.4 or §5.3; §5.2 IC and
// §5.9 MT[3] only say what it does at power-on), so a power cycle shows in what it answers
// afterwards: the power-on marker (check_marker()) once its driver was on, and always
// PowerUpWatch: its position counter starts at 0 (the manual keeps no position over
// power loss; it names PP values as saved to flash, §5.1), at rest, with the driver off unless
// IC auto-enable is set (§5.2). Not watched while it is identified or homed (the origin moves).
std::optional<std::string> Uim342Stack::Impl::powered_up(Node& n, const uim342::MotionKinematics& k, TimePoint now) {
  const bool watched = n.phase == Phase::kReady || n.phase == Phase::kSetupFailed || n.phase == Phase::kSettingUp;
  if (!watched || n.homing.command != 0) {
    n.power.forget();
    return std::nullopt;
  }
  const bool switched_off = n.was_enabled && !n.status.enabled;
  auto why = n.power.sample(k.absolute_position, static_cast<double>(k.speed), now, switched_off);
  if (!why) return std::nullopt;
  return fmt::format("{} powered up, detected by its answers: {}", n.name(), *why);
}

void Uim342Stack::Impl::arm_marker(std::size_t i) {
  Node& n = nodes[i];
  if (n.phase != Phase::kReady || !n.status.enabled || n.marker || !n.delay_read || marker_queued(n)) return;
  // At rest, and nothing of a command queued or on its way: MT[i]=N is refused while the motor
  // runs (§2.3 error 0x3D, which also raises ERR); queued first, no BG goes ahead of it.
  const bool commanded =
      std::any_of(n.queue.begin(), n.queue.end(), [](const Request& r) { return r.command_id != 0; });
  if (n.status.moving || n.move != 0 || n.homing.command != 0 || commanded) return;
  // Any value but the one read (which is the EEPROM's after a power-up); MT[3] is 0...60000 ms.
  constexpr std::uint16_t kMaxDelay = 60000;
  const auto value = static_cast<std::uint16_t>(*n.delay_read < kMaxDelay ? *n.delay_read + 1 : *n.delay_read - 1);
  enqueue(i, rq::set(uim342::MotorDriver::kAutoEnableDelayMs, value), 0, /*front=*/true);
}

void Uim342Stack::Impl::check_marker(std::size_t i, const uim342::MotionKinematics& k, bool switched_off,
                                     TimePoint now) {
  Node& n = nodes[i];
  constexpr Duration kRecheck = std::chrono::seconds(1);
  if (!n.marker || n.phase != Phase::kReady || n.homing.command != 0 || marker_queued(n)) return;
  if (k.absolute_position != 0 || k.speed != 0) return;
  const bool fresh = !n.status.position_read || n.status.position_counts != n.offset || switched_off;
  if (!fresh && now - n.marker_checked < kRecheck) return;
  n.marker_checked = now;
  enqueue(i, rq::get(uim342::MotorDriver::kAutoEnableDelayMs), 0);
}

bool Uim342Stack::Impl::marker_read(std::size_t i, std::uint16_t value, TimePoint now) {
  Node& n = nodes[i];
  n.delay_read = value;
  n.marker_checked = now;
  if (!n.marker || value == *n.marker) return false;
  const auto why = fmt::format(
      "{} powered up, detected by its power-on marker: MT[3] reads {}, not the {} written to its RAM (lost at "
      "power-off, manual §5.9)",
      n.name(), value, *n.marker);
  on_power_cycle(i, why, now);
  return true;
}

bool Uim342Stack::Impl::is_marker(const Request& r) {
  return r.command_id == 0 && r.instruction.function == FunctionCode::kMT &&
         r.instruction.sub_index() == static_cast<std::uint8_t>(uim342::MotorDriver::kAutoEnableDelayMs);
}

bool Uim342Stack::Impl::marker_queued(const Node& n) const {
  return std::any_of(n.queue.begin(), n.queue.end(), [](const Request& r) { return is_marker(r); });
}

// A power cycle seen in its answers: what it was doing ended, its position is lost, and its
// RAM settings are gone, so it is identified and set up again (as after a reboot).
void Uim342Stack::Impl::on_power_cycle(std::size_t i, const std::string& why, TimePoint now) {
  Node& n = nodes[i];
  release_hold(i, now);
  fail_commands_of(i, error_code(ReplyError::kAxisFault), why);
  n.marker.reset();  // gone with its RAM; armed again once set up and its driver is on
  n.power.forget();
  n.offset = 0;
  n.status.position_counts = 0;
  n.status.velocity_counts = 0;
  n.status.moving = false;
  n.status.in_position = false;
  n.status.homed = false;
  publish(n, now);
  if (!n.cfg.axis.empty()) context.out->position_lost(n.cfg.axis, why);
  if (n.phase == Phase::kSettingUp) return;  // being set up already (it was offline)
  identify(i, now);                          // commands arriving meanwhile queue behind its set-up
}

}  // namespace motion::gateway
