// Uc57Stack (uc57_stack.hpp): gateway commands: bookkeeping of jobs and tasks, power, stops,
// jogs, homing, outputs, set position (arming and firing: uc57_stack_start.cpp; parameters:
// uc57_stack_params.cpp).
#include "uc57_stack_impl.hpp"

namespace motion::uc57_driver {

// ---------------------------------------------------------------------------------------------
// Commands: bookkeeping
// ---------------------------------------------------------------------------------------------

void Uc57Stack::start_task(std::size_t n, TaskKind kind, std::int64_t command_id, TimePoint deadline) {
  Node& node = *nodes_[n];
  node.task = kind;
  node.task_command = command_id;
  node.task_deadline = deadline;
  node.task_watching = false;
}

void Uc57Stack::end_task(std::size_t n, std::int32_t code, const std::string& reason) {
  Node& node = *nodes_[n];
  if (node.task == TaskKind::kNone) return;
  part_failed(node.task_command, n, code, reason);
}

void Uc57Stack::part_done(std::int64_t command_id, std::size_t n) {
  Node& node = *nodes_[n];
  if (node.task_command == command_id) {
    node.task = TaskKind::kNone;
    node.task_deadline = kNever;
  }
  Job* job = jobs_.find(command_id);
  const auto part = job != nullptr ? job->state_of(n) : std::nullopt;
  if (!part || gateway::is_terminal(*part)) return;
  const auto done_parts = std::count(job->parts.begin(), job->parts.end(), Lifecycle::kDone);
  if (static_cast<std::size_t>(done_parts) + 1 < job->parts.size()) {
    jobs_.advance(command_id, n, Lifecycle::kDone);
    return;
  }
  // The last part. The state the command left its axes in goes out first: whoever acts on the
  // reply (the coordinator checking "enabled" for the next move, a client reading "homed") has it by then.
  for (const std::size_t done : job->nodes) publish_status(done);
  if (job->data.unreached.empty()) {
    jobs_.finish(command_id, Lifecycle::kDone);
  } else {
    jobs_.finish(command_id, Lifecycle::kFailed, job->data.unreached_code, job->data.unreached);
  }
}

void Uc57Stack::part_failed(std::int64_t command_id, std::size_t n, std::int32_t code, const std::string& reason) {
  if (nodes_[n]->task_command == command_id) {
    // A power task ended from outside (a STOP while ENABLE switches the drive on) also ends its
    // power sequence: left running, its timer would stay due with no task to act on it.
    if (nodes_[n]->task == TaskKind::kPower) nodes_[n]->power.cancel();
    nodes_[n]->task = TaskKind::kNone;
    nodes_[n]->task_deadline = kNever;
  }
  const auto terminal = code == error_code(ReplyError::kStopped) ? Lifecycle::kStopped : Lifecycle::kFailed;
  const auto job = jobs_.finish(command_id, terminal, code, reason);  // the one terminal reply
  if (!job) return;
  // The command is over: the other axes' tasks for it end silently.
  for (const std::size_t other : job->nodes) {
    Node& node = *nodes_[other];
    if (node.task_command != command_id || node.task == TaskKind::kNone) continue;
    if (node.task == TaskKind::kPower) node.power.cancel();
    node.task = TaskKind::kNone;
    node.task_deadline = kNever;
  }
}

void Uc57Stack::part_armed(std::int64_t command_id, std::size_t n, TimePoint now) {
  Node& node = *nodes_[n];
  node.task = TaskKind::kArmed;
  node.task_deadline = kNever;
  // The ledger replies ARMED with the last part.
  if (!jobs_.advance(command_id, n, Lifecycle::kArmed)) return;
  Job* job = jobs_.find(command_id);
  if (job == nullptr || !job->all(Lifecycle::kArmed)) return;
  if (job->command.trigger_id == 0) {
    fire_at_once(command_id, now);  // "0 = at once"
  } else {
    preload(*job);
  }
}

void Uc57Stack::check_task_timeouts(TimePoint now) {
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    if (node.task == TaskKind::kPower && node.power.deadline() <= now) apply_power_action(n, node.power.on_timer(now));
    if (node.task == TaskKind::kNone || now < node.task_deadline) continue;
    const std::string label = node.settings.label();
    const auto ms = [](Duration d) {
      return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d).count());
    };
    switch (node.task) {
      case TaskKind::kArming:
        part_failed(node.task_command, n, error_code(ReplyError::kArmFailed),
                    label + ": not ready for a set-point (statusword bit 12 still set or 6061h != 1) within " +
                        ms(options_.set_point_timeout) + " ms");
        break;
      case TaskKind::kTriggered:
      case TaskKind::kReleasing:
        part_failed(node.task_command, n, error_code(ReplyError::kTimeout),
                    label + ": set-point handshake timed out (statusword bit 12 " +
                        (node.task == TaskKind::kTriggered ? "never acknowledged" : "never released") + ")");
        break;
      case TaskKind::kHalt:
      case TaskKind::kQuickStop:
        part_failed(node.task_command, n, error_code(ReplyError::kTimeout),
                    label + ": motor still running " + ms(options_.stop_timeout) + " ms after the stop");
        break;
      default:
        part_failed(node.task_command, n, error_code(ReplyError::kTimeout),
                    label + ": no answer from the drive in time");
        break;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Commands: execution
// ---------------------------------------------------------------------------------------------

void Uc57Stack::execute(const Command& command, TimePoint now) {
  now_ = now;
  std::vector<std::size_t> parts;  // one per node
  for (const auto& axis : command.axes) {
    const auto it =
        std::find_if(nodes_.begin(), nodes_.end(), [&](const auto& node) { return node->settings.axis == axis.axis; });
    if (it == nodes_.end())
      return jobs_.reject(command, error_code(ReplyError::kUnknownAxis),
                          "axis '" + axis.axis + "' is not driven by a UC57 on bus " + bus_);
    const auto n = static_cast<std::size_t>(it - nodes_.begin());
    if (std::find(parts.begin(), parts.end(), n) != parts.end()) {
      return jobs_.reject(command, error_code(ReplyError::kMalformedRequest),
                          "the command names axis '" + axis.axis + "' twice");
    }
    parts.push_back(n);
  }
  if (parts.empty()) return jobs_.reject(command, error_code(ReplyError::kMalformedRequest), "command names no axis");

  const std::int8_t kind = command.kind;
  const bool stops = kind == Command::STOP || kind == Command::ESTOP;
  const bool preempts = stops || kind == Command::DISABLE || kind == Command::FAULT_RESET;
  // Parameter and output commands are plain SDO transfers: they may run next to a motion.
  const bool needs_slot = kind != Command::DISARM && kind != Command::PARAM_READ && kind != Command::PARAM_WRITE &&
                          kind != Command::SET_OUTPUTS;
  // Checks first, so that a refused command starts nothing on the wire.
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::size_t n = parts[i];
    const Node& node = *nodes_[n];
    // A stop naming an offline node must still stop the others (a group aborted because one of
    // its nodes fell silent): that node only makes the reply fail, below.
    if (node.phase != Node::Phase::kOperational && !stops) {
      return jobs_.reject(command, error_code(ReplyError::kAxisOffline), offline_text(n));
    }
    if (needs_slot && !preempts && node.task != TaskKind::kNone) {
      return jobs_.reject(command, error_code(ReplyError::kAxisBusy),
                          node.settings.label() + " is busy with command " + std::to_string(node.task_command));
    }
    const auto state = drive_state(n);
    const bool motion = kind == Command::ARM_MOVE || kind == Command::JOG || kind == Command::HOME;
    if (motion && is_fault_state(state)) {
      return jobs_.reject(command, error_code(ReplyError::kAxisFaulted),
                          node.settings.label() + " is faulted: " + node.status.fault_text);
    }
    if (motion && state != State::kOperationEnabled) {
      return jobs_.reject(command, error_code(ReplyError::kAxisDisabled),
                          node.settings.label() + " is not enabled (" +
                              (state ? std::string(cia402::to_string(*state)) : "no statusword") + ")");
    }
    // What this drive cannot do for this axis refuses the whole command here: found while the
    // parts start, an earlier axis would already have been changed (random lab seed 1: a HOME
    // that failed for its second axis had zeroed the first one's position).
    if (auto refusal = refuse(n, command, command.axes[i])) {
      return jobs_.reject(command, refusal->first, refusal->second);
    }
  }
  if ((kind == Command::PARAM_READ || kind == Command::PARAM_WRITE) && parts.size() != 1) {
    return jobs_.reject(command, error_code(ReplyError::kMalformedRequest),
                        "a parameter command names exactly one axis");
  }
  // Which nodes had nothing running before this command preempted it (a STOP there is DONE at once).
  std::vector<bool> idle(parts.size());
  for (std::size_t i = 0; i < parts.size(); ++i) idle[i] = at_rest(parts[i]);
  if (preempts) {
    const std::string why = std::string(kind == Command::ESTOP  ? "e-stopped"
                                        : kind == Command::STOP ? "stopped"
                                                                : "superseded") +
                            " by command " + std::to_string(command.command_id);
    for (const std::size_t n : parts)
      end_task(n, error_code(ReplyError::kStopped), nodes_[n]->settings.label() + ": " + why);
  }

  const std::int64_t id = command.command_id;
  Job* added = jobs_.add(command, parts);
  if (added == nullptr)
    return jobs_.reject(command, error_code(ReplyError::kMalformedRequest),
                        "command id " + std::to_string(id) + " is already running");
  Job& live = *added;
  const std::vector<std::size_t> targets = live.nodes;
  for (std::size_t i = 0; i < targets.size(); ++i) {
    if (jobs_.find(id) == nullptr) return;  // an earlier part already ended the command
    const std::size_t n = targets[i];
    const auto& axis = command.axes[i];
    if (stops && nodes_[n]->phase != Node::Phase::kOperational) {
      const bool sent = send_blind_stop(n, kind == Command::ESTOP);
      live.data.unreached += (live.data.unreached.empty() ? "" : "; ") + offline_text(n) +
                             (sent ? " (its stop sent in RPDO1 all the same, not confirmed)" : "");
      live.data.unreached_code = error_code(ReplyError::kAxisOffline);
      part_done(id, n);
      continue;
    }
    switch (kind) {
      case Command::ENABLE: start_power(n, live, State::kOperationEnabled, now); break;
      case Command::DISABLE:
        if (is_fault_state(drive_state(n))) {
          part_done(id, n);  // the motor is already released in Fault
        } else {
          start_power(n, live, State::kReadyToSwitchOn, now);
        }
        break;
      case Command::FAULT_RESET:
        if (!is_fault_state(drive_state(n)) && !cia402::is_set(nodes_[n]->statusword.value_or(0), StatusBit::kAlarm)) {
          part_done(id, n);
        } else {
          start_power(n, live, State::kSwitchOnDisabled, now);
        }
        break;
      case Command::ESTOP: start_quick_stop(n, live, now); break;
      case Command::STOP: start_halt(n, live, idle[i], now); break;
      case Command::ARM_MOVE: start_arm(n, live, axis, now); break;
      case Command::JOG: start_jog(n, live, axis, now); break;
      case Command::HOME: start_home(n, live, axis, now); break;
      case Command::SET_OUTPUTS: start_outputs(n, live, axis); break;
      case Command::SET_POSITION: start_set_position(n, live, axis); break;
      case Command::PARAM_READ:
      case Command::PARAM_WRITE: start_param(n, live); break;
      case Command::DISARM:
        disarm(live);
        part_done(id, n);
        break;
      default:
        part_failed(id, n, error_code(ReplyError::kMalformedRequest),
                    "unknown gateway command kind " + std::to_string(kind));
        return;
    }
  }
}

void Uc57Stack::start_power(std::size_t n, Job& job, State target, TimePoint now) {
  Node& node = *nodes_[n];
  start_task(n, TaskKind::kPower, job.command.command_id, kNever);
  node.power.note_controlword_sent(latest_image(n).controlword);
  node.power.request(target, now);
  if (node.statusword) apply_power_action(n, node.power.on_statusword(*node.statusword, now));
}

void Uc57Stack::apply_power_action(std::size_t n, const cia402::PowerController::Action& action) {
  Node& node = *nodes_[n];
  const std::int64_t id = node.task_command;
  for (const std::uint16_t device_control : action.controlwords()) {
    // Only the device-control bits come from the controller; bit 4 is cleared so that enabling
    // never starts a set-point, the mode bits (halt, abs/rel) stay.
    RpdoImage image = latest_image(n);
    const auto mode_bits = static_cast<std::uint16_t>(image.controlword & ~cia402::kDeviceControlBits &
                                                      ~cia402::mask(ControlBit::kNewSetPoint));
    image.controlword = static_cast<std::uint16_t>(mode_bits | (device_control & cia402::kDeviceControlBits));
    queue_image(n, image);
  }
  if (action.outcome == cia402::PowerController::Outcome::kInProgress) node.power_transition = action.transition;
  const std::string label = node.settings.label();
  const auto target = node.power.target();
  switch (action.outcome) {
    case cia402::PowerController::Outcome::kReached: part_done(id, n); break;
    case cia402::PowerController::Outcome::kTimedOut:
      part_failed(
          id, n, error_code(ReplyError::kTimeout),
          label + ": CiA 402 transition " + std::to_string(node.power_transition) +
              " not confirmed by the statusword within " +
              std::to_string(
                  std::chrono::duration_cast<std::chrono::milliseconds>(options_.state_switch_timeout).count()) +
              " ms (state " + (action.observed ? std::string(cia402::to_string(*action.observed)) : "unknown") + ")");
      break;
    case cia402::PowerController::Outcome::kUnreachable:
      part_failed(
          id, n,
          is_fault_state(action.observed) ? error_code(ReplyError::kAxisFaulted) : error_code(ReplyError::kDriveError),
          label + ": cannot reach " + (target ? std::string(cia402::to_string(*target)) : "the requested state") +
              " from " + (action.observed ? std::string(cia402::to_string(*action.observed)) : "an unknown state") +
              (is_fault_state(action.observed) ? " (FAULT_RESET first)" : ""));
      break;
    case cia402::PowerController::Outcome::kIdle:
    case cia402::PowerController::Outcome::kInProgress: break;
  }
}

void Uc57Stack::start_quick_stop(std::size_t n, Job& job, TimePoint now) {
  if (drive_state(n) != State::kOperationEnabled) return part_done(job.command.command_id, n);  // nothing runs
  start_task(n, TaskKind::kQuickStop, job.command.command_id, now + options_.stop_timeout);
  RpdoImage image = latest_image(n);
  image.controlword = cia402::with(cia402::apply_command(image.controlword, cia402::Command::kQuickStop),
                                   ControlBit::kNewSetPoint, false);
  // A jog's speed must not survive the e-stop: enabled again, a drive in profile velocity mode
  // would run on at 60FFh. Zeroed in the process data and in the object (written by SDO for jogs).
  image.target_velocity = 0;
  queue_image(n, image);
  sdo_write(n, {od::kTargetVelocity, 0}, le<std::int32_t>(0), [](std::error_code, std::span<const std::uint8_t>) {});
}

void Uc57Stack::start_halt(std::size_t n, Job& job, bool idle, TimePoint now) {
  if (drive_state(n) != State::kOperationEnabled) return part_done(job.command.command_id, n);
  RpdoImage image = latest_image(n);
  image.controlword =
      cia402::with(cia402::with(image.controlword, ControlBit::kHalt, true), ControlBit::kNewSetPoint, false);
  image.target_velocity = 0;  // manual §7 MC_STOP: bit 8 = 1 and 60FFh = 0 (in the RPDO of the default layout)
  if (idle) {
    // Nothing runs: the halt still goes out with the next SYNC, but the STOP does not hold the
    // node for the two SYNC cycles that would confirm it. The coordinator's abort of a failed
    // request is such a STOP, and the request after it found the node "busy" (random lab seed 1).
    queue_image(n, image);
    return part_done(job.command.command_id, n);
  }
  start_task(n, TaskKind::kHalt, job.command.command_id, now + options_.stop_timeout);
  queue_image(n, image);
}

// At rest for certain: no task, every queued image applied and seen, the motor not running in
// the statusword, and the applied image is no jog (a jog's task ends when it runs; its first
// statusword may still be one from before the ramp).
bool Uc57Stack::at_rest(std::size_t n) {
  const Node& node = *nodes_[n];
  if (node.task != TaskKind::kNone || !image_applied(n) || !node.statusword) return false;
  if (cia402::is_set(*node.statusword, StatusBit::kMotorRunning)) return false;
  const bool halted = cia402::is_set(node.image.controlword, ControlBit::kHalt);
  return halted || node.image.mode != kModeProfileVelocity || node.image.target_velocity == 0;
}

// Why `command` cannot run on node n whatever its state: (reply code, reason), checked before any
// part starts.
std::optional<std::pair<std::int32_t, std::string>> Uc57Stack::refuse(std::size_t n, const Command& command,
                                                                      const motionlcm::axis_command_t& axis) const {
  const Node& node = *nodes_[n];
  const std::string label = node.settings.label();
  switch (command.kind) {
    case Command::HOME: {
      const config::Homing& homing = node.settings.homing;
      if (homing.method == config::HomingMethod::kCurrentPosition) {
        if (axis.target_counts == 0) return std::nullopt;
        return std::pair{error_code(ReplyError::kUnsupported),
                         label + ": the UC57 can only zero its position (2012h); offset " +
                             std::to_string(axis.target_counts) + " counts is not supported"};
      }
      if (homing.method != config::HomingMethod::kSwitch) {
        return std::pair{error_code(ReplyError::kUnsupported),
                         label + ": no homing method configured for axis " + node.settings.axis};
      }
      if (homing.input < 1 || homing.input > 3) {
        return std::pair{error_code(ReplyError::kUnsupported),
                         label + ": homing on input " + std::to_string(homing.input) +
                             " is not possible (UC57: IN1 positive limit, IN2 origin, IN3 negative limit)"};
      }
      return std::nullopt;
    }
    case Command::SET_POSITION:
      if (axis.target_counts == 0) return std::nullopt;
      return std::pair{error_code(ReplyError::kUnsupported),
                       label + ": the UC57 can only set its position to zero (2012h); " +
                           std::to_string(axis.target_counts) + " counts is not possible"};
    case Command::SET_OUTPUTS:
      if ((axis.output_mask & ~((1 << kOutputCount) - 1)) == 0) return std::nullopt;
      return std::pair{error_code(ReplyError::kOutsideLimits),
                       label + ": output mask " + hex(static_cast<std::uint32_t>(axis.output_mask), 2) +
                           " names outputs the UC57 does not have (OUT1, OUT2)"};
    case Command::PARAM_WRITE: return refuse_model_write(n, command.param);
    default: return std::nullopt;
  }
}

void Uc57Stack::set_mode(std::size_t n, std::int8_t mode, Continue done) {
  sdo_write(n, {od::kModesOfOperation, 0}, le<std::int8_t>(mode),
            [this, n, mode, done = std::move(done)](std::error_code ec, std::span<const std::uint8_t>) {
              if (ec) return done(sdo_failure(n, true, {od::kModesOfOperation, 0}, ec));
              Node& node = *nodes_[n];
              node.image.mode = mode;
              for (auto& queued : node.rpdo_queue) queued.mode = mode;
              done(std::nullopt);
            });
}

void Uc57Stack::start_jog(std::size_t n, Job& job, const motionlcm::axis_command_t& axis, TimePoint now) {
  Node& node = *nodes_[n];
  const std::int64_t id = job.command.command_id;
  const auto speed = cia402::uc57::quantize_speed(*cia402::uc57::find_entry(od::kTargetVelocity, 0), axis.velocity,
                                                  node.pulses_per_rev);
  const double speed_change = std::max(0.0, std::abs(speed.realized) - node.start_speed);
  const auto accel = cia402::uc57::quantize_ramp(*cia402::uc57::find_entry(od::kProfileAcceleration, 0),
                                                 std::max(axis.acceleration, 1.0), speed_change, node.pulses_per_rev);
  const auto decel = cia402::uc57::quantize_ramp(*cia402::uc57::find_entry(od::kProfileDeceleration, 0),
                                                 std::max(axis.deceleration, 1.0), speed_change, node.pulses_per_rev);
  const auto rpm = static_cast<std::int32_t>(speed.native);
  start_task(n, TaskKind::kJog, id, now + options_.state_switch_timeout + 3 * cycle());
  // Manual §7 MC_JOG: ramps, 60FFh = 0 before the mode switch (no jump), mode 3, then the speed.
  sdo_write_all(n,
                {{{od::kProfileAcceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(accel.native))},
                 {{od::kProfileDeceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(decel.native))},
                 {{od::kTargetVelocity, 0}, le<std::int32_t>(0)}},
                [this, n, id, rpm](std::optional<std::string> failure) {
                  // Superseded (a STOP while the ramps went out): neither the mode nor the speed
                  // follows, or the drive would hold the jog's 60FFh behind the halt.
                  if (nodes_[n]->task_command != id || nodes_[n]->task != TaskKind::kJog) return;
                  if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
                  set_mode(n, kModeProfileVelocity, [this, n, id, rpm](std::optional<std::string> mode_failure) {
                    if (nodes_[n]->task_command != id || nodes_[n]->task != TaskKind::kJog) return;
                    if (mode_failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *mode_failure);
                    sdo_write_all(n, {{{od::kTargetVelocity, 0}, le<std::int32_t>(rpm)}},
                                  [this, n, id, rpm](std::optional<std::string> speed_failure) {
                                    Node& nd = *nodes_[n];
                                    if (speed_failure)
                                      return part_failed(id, n, error_code(ReplyError::kDriveError), *speed_failure);
                                    if (nd.task_command != id || nd.task != TaskKind::kJog) return;
                                    RpdoImage image = latest_image(n);
                                    image.controlword = cia402::profile_position_controlword(
                                        {}, false, false);  // 0x0F = PV start, halt off
                                    image.target_velocity = rpm;
                                    image.mode = kModeProfileVelocity;
                                    queue_image(n, image);
                                    nd.task_watching = true;
                                  });
                  });
                });
}

void Uc57Stack::start_home(std::size_t n, Job& job, const motionlcm::axis_command_t& axis, TimePoint /*now*/) {
  Node& node = *nodes_[n];
  const std::int64_t id = job.command.command_id;
  const std::string label = node.settings.label();
  const config::Homing& homing = node.settings.homing;
  if (homing.method == config::HomingMethod::kCurrentPosition) {
    if (axis.target_counts != 0) {
      return part_failed(id, n, error_code(ReplyError::kUnsupported),
                         label + ": the UC57 can only zero its position (2012h); offset " +
                             std::to_string(axis.target_counts) + " counts is not supported");
    }
    start_task(n, TaskKind::kSdoOnly, id, kNever);
    return sdo_write_all(n, {{{od::kZeroPosition, 0}, le<std::uint16_t>(kZeroPositionCommand)}},
                         [this, n, id](std::optional<std::string> failure) {
                           if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
                           part_done(id, n);
                         });
  }
  if (homing.method != config::HomingMethod::kSwitch) {
    return part_failed(id, n, error_code(ReplyError::kUnsupported),
                       label + ": no homing method configured for axis " + node.settings.axis);
  }
  // The manual's default input functions (§3.1): IN1 positive limit, IN2 origin, IN3 negative limit.
  const double direction = axis.velocity != 0 ? axis.velocity : homing.velocity;
  cia402::uc57::HomingMethod method{};
  switch (homing.input) {
    case 1: method = cia402::uc57::HomingMethod::kPositiveLimit; break;
    case 2:
      method = direction >= 0 ? cia402::uc57::HomingMethod::kHomeSwitchPositive
                              : cia402::uc57::HomingMethod::kHomeSwitchNegative;
      break;
    case 3: method = cia402::uc57::HomingMethod::kNegativeLimit; break;
    default:
      return part_failed(id, n, error_code(ReplyError::kUnsupported),
                         label + ": homing on input " + std::to_string(homing.input) +
                             " is not possible (UC57: IN1 positive limit, IN2 origin, IN3 negative limit)");
  }
  cia402::uc57::HomingRequest request;
  request.method = method;
  request.search_speed = std::max(std::abs(axis.velocity), 1.0);
  request.locate_speed = request.search_speed / 4;  // the slow approach decides the accuracy (§4.2.6)
  request.acceleration = std::max(axis.acceleration, 1.0);
  request.offset = static_cast<double>(axis.target_counts);
  const auto settings = cia402::uc57::quantize_homing(request, node.pulses_per_rev);
  if (settings.offset.clamped) {
    return part_failed(
        id, n, error_code(ReplyError::kOutsideLimits),
        label + ": homing offset " + std::to_string(axis.target_counts) + " counts exceeds 607Ch's range");
  }
  start_task(n, TaskKind::kHoming, id, kNever);
  sdo_write_all(
      n,
      {{{od::kHomingMethod, 0}, le<std::uint8_t>(settings.method)},
       {{od::kHomingSpeeds, 1}, le<std::uint32_t>(static_cast<std::uint32_t>(settings.search_speed.native))},
       {{od::kHomingSpeeds, 2}, le<std::uint32_t>(static_cast<std::uint32_t>(settings.locate_speed.native))},
       {{od::kHomingAcceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(settings.acceleration.native))},
       {{od::kHomeOffset, 0}, le<std::int32_t>(static_cast<std::int32_t>(settings.offset.native))}},
      [this, n, id](std::optional<std::string> failure) {
        if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
        set_mode(n, kModeHoming, [this, n, id](std::optional<std::string> mode_failure) {
          Node& nd = *nodes_[n];
          if (mode_failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *mode_failure);
          if (nd.task_command != id || nd.task != TaskKind::kHoming) return;
          // Two SYNC cycles: bit 4 = 0, then 1 -> the rising edge starts homing (0x0F -> 0x1F).
          RpdoImage image = latest_image(n);
          image.mode = kModeHoming;
          image.controlword = cia402::profile_position_controlword({}, false, false);
          queue_image(n, image);
          image.controlword = cia402::profile_position_controlword({}, true, false);
          queue_image(n, image);
          nd.task_watching = true;
        });
      });
}

void Uc57Stack::start_outputs(std::size_t n, Job& job, const motionlcm::axis_command_t& axis) {
  const std::int64_t id = job.command.command_id;
  const std::string label = nodes_[n]->settings.label();
  if ((axis.output_mask & ~((1 << kOutputCount) - 1)) != 0) {
    return part_failed(id, n, error_code(ReplyError::kOutsideLimits),
                       label + ": output mask " + hex(static_cast<std::uint32_t>(axis.output_mask), 2) +
                           " names outputs the UC57 does not have (OUT1, OUT2)");
  }
  // The outputs are driven by their function selection (2030h:0D/0E): 5 = high, 6 = low. RW/S,
  // not stored: the configured function returns after a power cycle.
  std::vector<std::pair<ObjectAddress, std::vector<std::uint8_t>>> writes;
  for (int output = 0; output < kOutputCount; ++output) {
    if ((axis.output_mask & (1 << output)) == 0) continue;
    const bool high = (axis.output_value & (1 << output)) != 0;
    writes.push_back({{od::kIoConfiguration, static_cast<std::uint8_t>(kFirstOutputFunctionSub + output)},
                      le<std::uint16_t>(high ? kOutputForcedHigh : kOutputForcedLow)});
  }
  sdo_write_all(n, std::move(writes),
                [this, n, id, mask = axis.output_mask, value = axis.output_value](std::optional<std::string> failure) {
                  if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
                  auto& outputs = nodes_[n]->status.outputs;
                  outputs = (outputs & ~mask) | (value & mask);
                  publish_status(n);
                  part_done(id, n);
                });
}

void Uc57Stack::start_set_position(std::size_t n, Job& job, const motionlcm::axis_command_t& axis) {
  const std::int64_t id = job.command.command_id;
  if (axis.target_counts != 0) {
    return part_failed(id, n, error_code(ReplyError::kUnsupported),
                       nodes_[n]->settings.label() + ": the UC57 can only set its position to zero (2012h); " +
                           std::to_string(axis.target_counts) + " counts is not possible");
  }
  start_task(n, TaskKind::kSdoOnly, id, kNever);
  sdo_write_all(n, {{{od::kZeroPosition, 0}, le<std::uint16_t>(kZeroPositionCommand)}},
                [this, n, id](std::optional<std::string> failure) {
                  if (failure) return part_failed(id, n, error_code(ReplyError::kDriveError), *failure);
                  nodes_[n]->status.position_counts = 0;
                  part_done(id, n);
                });
}

}  // namespace motion::uc57_driver
