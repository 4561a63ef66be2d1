// Uim342Stack (uim342_stack.hpp): gateway commands, the synchronized start (§5.11, §3.2), jogs,
// parameter access, triggers.
#include "uim342_stack_impl.hpp"

namespace motion::gateway {

std::string uim342_stack_detail::command_name(std::int8_t kind) {
  switch (kind) {
    case gateway_command_t::ENABLE: return "ENABLE";
    case gateway_command_t::DISABLE: return "DISABLE";
    case gateway_command_t::ARM_MOVE: return "ARM_MOVE";
    case gateway_command_t::JOG: return "JOG";
    case gateway_command_t::STOP: return "STOP";
    case gateway_command_t::ESTOP: return "ESTOP";
    case gateway_command_t::HOME: return "HOME";
    case gateway_command_t::FAULT_RESET: return "FAULT_RESET";
    case gateway_command_t::SET_OUTPUTS: return "SET_OUTPUTS";
    case gateway_command_t::PARAM_READ: return "PARAM_READ";
    case gateway_command_t::PARAM_WRITE: return "PARAM_WRITE";
    case gateway_command_t::SET_POSITION: return "SET_POSITION";
    case gateway_command_t::DISARM: return "DISARM";
    default: return fmt::format("kind {}", kind);
  }
}

// The part of node `i` is in position: Done; the command is DONE with its last part.
void Uim342Stack::Impl::arrived(std::size_t i, TimePoint) {
  Node& n = nodes[i];
  const auto id = n.move;
  const Command* c = commands.find(id);
  if (c == nullptr || c->state_of(i) != Lifecycle::kStarted) return;
  n.status.in_position = true;
  n.status.moving = false;
  n.status.target_counts = c->data.targets.at(i);
  event(n, event_t::MOTION_COMPLETE, event_t::INFO, 0,
        fmt::format("{} in position at {}", n.name(), n.status.position_counts));
  const auto others_done = std::count(c->parts.begin(), c->parts.end(), Lifecycle::kDone);
  if (static_cast<std::size_t>(others_done) + 1 == c->parts.size()) {
    done(id);  // the last part: the nodes let go of the command, the ledger replies DONE
  } else {
    commands.advance(id, i, Lifecycle::kDone);
  }
}

void Uim342Stack::Impl::stage_done(Command& c, TimePoint now) {
  if (c.command.kind != gateway_command_t::ARM_MOVE) {
    if (c.data.unreached.empty()) {
      done(c.command.command_id, fmt::format("{}", fmt::join(c.data.notes, "; ")));
    } else {
      fail(c.command.command_id, error_code(ReplyError::kAxisOffline), c.data.unreached);
    }
    return;
  }
  // Every part Armed (the ledger replied ARMED): a move without a trigger starts at once. Later
  // steps (the BG ACKs) change no part: a part is Done when its drive is in position (arrived()).
  if (c.all(Lifecycle::kArmed) && c.command.trigger_id == 0) start_move(c, now);
}

std::optional<std::vector<std::size_t>> Uim342Stack::Impl::group_outside(const Command& c) const {
  const std::uint8_t group = nodes[c.nodes.front()].cfg.group_id;
  if (group == 0) return std::nullopt;
  for (const auto i : c.nodes) {
    if (nodes[i].cfg.group_id != group || !nodes[i].group_ok) return std::nullopt;
  }
  std::vector<std::size_t> outside;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i].cfg.group_id == group && std::find(c.nodes.begin(), c.nodes.end(), i) == c.nodes.end())
      outside.push_back(i);
  }
  return outside;
}

void Uim342Stack::Impl::start_move(Command& c, TimePoint now) {
  const auto id = c.command.command_id;
  const std::uint8_t group = nodes[c.nodes.front()].cfg.group_id;
  // One BG to the group id starts every drive of the group (§5.11), so it is used only when the
  // group's drives outside this command hold PR=0 for it (a move of zero counts, §5.20), are
  // still ready and free to take the BG now; with none outside, when the group is the command.
  const auto outside = group_outside(c);
  const bool one_frame = outside && std::all_of(outside->begin(), outside->end(), [&](std::size_t i) {
                           const Node& b = nodes[i];
                           return c.data.held.contains(i) && b.held_for == id && b.phase == Phase::kReady && !b.busy();
                         });
  const std::vector<std::size_t> bystanders = one_frame ? *outside : std::vector<std::size_t>{};
  // The holds end here: with the group BG queued ahead of anything else to the drive, or unused.
  std::set<std::size_t> holds = c.data.held;
  holds.insert(c.data.holding.begin(), c.data.holding.end());
  for (const auto b : holds) release_hold(b, std::nullopt);
  const auto bg_frame = uim342::instruction_frame(one_frame ? group : nodes[c.nodes.front()].cfg.node_id, rq::begin());
  const auto frame_us =
      std::chrono::duration<double, std::micro>(can::frame_duration(*bg_frame, config.bitrate)).count();
  // trigger_utime is set when the first BG is handed over (on_sent()).
  c.reply.started(0, one_frame ? "group-bg" : "sequential",
                  one_frame ? 0.0 : frame_us * static_cast<double>(c.nodes.size() - 1));
  std::shared_ptr<GroupSend> shared;
  if (one_frame) shared = std::make_shared<GroupSend>(GroupSend{group, id, c.nodes, bystanders});
  for (const auto i : c.nodes) enqueue(i, rq::begin(), id, /*front=*/true).group = shared;
  // A bystander's BG is the stack's own: its ACK is awaited like any other, and a timeout fails
  // nothing but takes the drive offline.
  if (one_frame) {
    for (const auto b : bystanders) enqueue(b, rq::begin(), 0, /*front=*/true).group = shared;
  }
  for (const auto i : c.nodes) pump(i, now);
}

bool Uim342Stack::Impl::may_hold(std::size_t i) const {
  const Node& n = nodes[i];
  if (n.phase != Phase::kReady || !n.group_ok || n.move != 0 || n.held_for != 0 || n.homing.command != 0) return false;
  // At rest by a status read after its last BG (a jog's goes on after the JOG is DONE): PR=0
  // would make a group BG stop a running motor. Driver on: §5.10's note asks for MO=1 before PR
  // and BG are sent ("otherwise, unexpected movement will happen" when it is switched on).
  if (!n.status.online || !n.status.enabled || n.status.moving || n.status.fault || n.started_since_status)
    return false;
  return std::none_of(n.queue.begin(), n.queue.end(), [](const Request& r) { return r.command_id != 0; });
}

void Uim342Stack::Impl::hold_bystanders(Command& c) {
  if (c.nodes.size() < 2) return;
  const auto found = group_outside(c);
  if (!found) return;
  const std::vector<std::size_t>& outside = *found;
  if (!std::all_of(outside.begin(), outside.end(), [this](std::size_t i) { return may_hold(i); })) return;
  // At most one PR=0 exchange per drive of the move: arming takes at most that much longer.
  if (outside.empty() || outside.size() > c.nodes.size()) return;
  const auto id = c.command.command_id;
  for (const auto b : outside) {
    enqueue(b, rq::set_relative_position(0), 0, /*front=*/true).hold_for = id;
    nodes[b].held_for = id;
    c.data.holding.insert(b);
  }
}

void Uim342Stack::Impl::armed_if_loaded(Command& c, TimePoint now) {
  if (!c.data.waiting.empty() || !c.data.holding.empty()) return;
  const auto id = c.command.command_id;
  const auto parts = c.nodes;
  bool loading = false;
  for (const auto i : parts) {
    const auto* entry = commands.find(id);
    if (entry == nullptr || entry->state_of(i) != Lifecycle::kLoading) continue;
    loading = true;
    commands.advance(id, i, Lifecycle::kArmed);  // the ledger replies ARMED with the last part
  }
  if (auto* armed = commands.find(id); armed != nullptr && loading) stage_done(*armed, now);
}

void Uim342Stack::Impl::hold_loaded(std::size_t i, std::int64_t command_id, TimePoint now) {
  Command* c = commands.find(command_id);
  if (c == nullptr || nodes[i].held_for != command_id || c->data.holding.erase(i) == 0) return;
  c->data.held.insert(i);
  armed_if_loaded(*c, now);
}

void Uim342Stack::Impl::release_hold(std::size_t i, std::optional<TimePoint> now) {
  Node& n = nodes[i];
  const auto id = n.held_for;
  if (id == 0) return;
  n.held_for = 0;
  std::erase_if(n.queue, [id](const Request& r) { return r.hold_for == id && !r.sent; });
  Command* c = commands.find(id);
  if (c == nullptr) return;
  c->data.holding.erase(i);
  c->data.held.erase(i);
  if (now) armed_if_loaded(*c, *now);
}

std::optional<std::size_t> Uim342Stack::Impl::node_of_axis(const std::string& axis) const {
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i].cfg.axis == axis) return i;
  }
  return std::nullopt;
}

void Uim342Stack::Impl::execute(const gateway_command_t& cmd, TimePoint now) {
  if (cmd.axes.empty()) {
    commands.reject(cmd, error_code(ReplyError::kMalformedRequest), command_name(cmd.kind) + " names no axis");
    return;
  }
  std::vector<std::size_t> parts;  // one per node
  CommandData data;
  for (const auto& a : cmd.axes) {
    const auto i = node_of_axis(a.axis);
    if (!i) {
      commands.reject(cmd, error_code(ReplyError::kUnknownAxis),
                      fmt::format("axis '{}' is not driven by a uim342 drive on bus {}", a.axis, config.bus));
      return;
    }
    if (data.targets.count(*i) != 0) {
      commands.reject(cmd, error_code(ReplyError::kMalformedRequest),
                      fmt::format("{} names axis '{}' twice", command_name(cmd.kind), a.axis));
      return;
    }
    parts.push_back(*i);
    data.targets[*i] = a.target_counts;
  }
  const bool needs_drive = cmd.kind != gateway_command_t::DISARM;
  const bool stops = cmd.kind == gateway_command_t::STOP || cmd.kind == gateway_command_t::ESTOP;
  for (const auto i : parts) {
    const Node& n = nodes[i];
    // A stop naming an offline drive still stops the others (see load()).
    if (needs_drive && n.phase == Phase::kOffline && !stops) {
      commands.reject(cmd, error_code(ReplyError::kAxisOffline), fmt::format("{} is offline", n.name()));
      return;
    }
    const bool starts_motion = cmd.kind == gateway_command_t::ARM_MOVE || cmd.kind == gateway_command_t::JOG ||
                               cmd.kind == gateway_command_t::HOME || cmd.kind == gateway_command_t::SET_POSITION;
    if (starts_motion && n.move != 0) {
      commands.reject(cmd, error_code(ReplyError::kAxisBusy),
                      fmt::format("{} is busy with move command {}", n.name(), n.move));
      return;
    }
  }
  Command* stored = commands.add(cmd, std::move(parts), std::move(data));
  if (stored == nullptr) {
    commands.reject(cmd, error_code(ReplyError::kMalformedRequest),
                    fmt::format("command id {} is already in progress", cmd.command_id));
    return;
  }
  stored->reply.bus(config.bus);
  const auto id = cmd.command_id;
  // A drive held at rest for another move's group start is now this command's: that move starts
  // drive by drive.
  const auto named = stored->nodes;
  for (const auto i : named) release_hold(i, now);
  stored = commands.find(id);
  if (stored == nullptr) return;
  if (const auto problem = load(*stored)) {
    // Nothing of it stays behind: no part, no queued request, no node bound to it.
    fail(id, problem->second, problem->first);
    drop_requests(id);
    return;
  }
  if (auto* c = commands.find(id); c != nullptr) {
    if (c->command.kind == gateway_command_t::ARM_MOVE) {
      armed_if_loaded(*c, now);
    } else if (c->data.waiting.empty()) {
      stage_done(*c, now);
    }
  }
  for (std::size_t i = 0; i < nodes.size(); ++i) pump(i, now);
}

// Queues the command's requests; a reason when the command cannot be carried out.
Uim342Stack::Impl::Problem Uim342Stack::Impl::load(Command& c) {
  const auto id = c.command.command_id;
  const auto each = [&](auto&& per_node) -> Problem {
    for (std::size_t k = 0; k < c.nodes.size(); ++k) {
      if (auto p = per_node(c.nodes[k], c.command.axes[k])) return p;
    }
    return std::nullopt;
  };
  switch (c.command.kind) {
    case gateway_command_t::ENABLE:
    case gateway_command_t::DISABLE: {
      const bool on = c.command.kind == gateway_command_t::ENABLE;
      for (const auto i : c.nodes) {
        if (!on && nodes[i].move != 0)
          fail(nodes[i].move, error_code(ReplyError::kStopped),
               fmt::format("{} disabled by command {}", nodes[i].name(), id));
        enqueue(i, rq::driver_on(on), id);
      }
      return std::nullopt;
    }
    case gateway_command_t::ARM_MOVE:
      if (auto p = each([&](std::size_t i, const motionlcm::axis_command_t& a) { return load_move(c, i, a); }))
        return p;
      for (const auto i : c.nodes) {
        nodes[i].move = id;
        nodes[i].bg_acked = false;
        nodes[i].status.target_counts = c.data.targets.at(i);
        // Polled slowly (many drives, a busy bus), the whole move may run between two samples:
        // arriving at counter 0 is then not a power-up (PowerUpWatch).
        nodes[i].power.travel_started(c.data.targets.at(i) - nodes[i].offset);
      }
      hold_bystanders(c);
      return std::nullopt;
    case gateway_command_t::JOG:
      return each([&](std::size_t i, const motionlcm::axis_command_t& a) { return load_jog(c, i, a); });
    case gateway_command_t::STOP:
    case gateway_command_t::ESTOP: {
      const bool emergency = c.command.kind == gateway_command_t::ESTOP;
      for (const auto i : c.nodes) {
        Node& n = nodes[i];
        if (n.phase == Phase::kOffline) {
          // A drive that does not answer may still hear: its stop goes out all the same, without
          // asking for an ACK (CW bit 7 clear, manual §2.1), and the reply says it is unconfirmed.
          const bool sent = transmit(n.cfg.node_id, rq::without_ack(rq::stop())) &&
                            (!emergency || transmit(n.cfg.node_id, rq::without_ack(rq::driver_on(false))));
          c.data.unreached +=
              fmt::format("{}{} is offline (not answering): {}", c.data.unreached.empty() ? "" : "; ", n.name(),
                          sent ? (emergency ? "ST and MO=0 sent, stop not confirmed" : "ST sent, stop not confirmed")
                               : "the stop could not be handed to the bus");
          continue;
        }
        const auto reason = fmt::format("{} stopped by {} command {}", n.name(), command_name(c.command.kind), id);
        if (emergency) {
          fail_commands_of(i, error_code(ReplyError::kStopped), reason, id);  // nothing queued goes out after an e-stop
        } else {
          // The running move, and every motion command whose frames are still queued (a jog's
          // JV/BG sent after the ST would start the motor again).
          std::set<std::int64_t> motion;
          if (n.move != 0) motion.insert(n.move);
          for (const auto& r : n.queue) {
            const auto* other = commands.find(r.command_id);
            if (r.command_id == id || other == nullptr) continue;
            const auto kind = other->command.kind;
            if (kind == gateway_command_t::JOG || kind == gateway_command_t::HOME ||
                kind == gateway_command_t::ARM_MOVE)
              motion.insert(r.command_id);
          }
          for (const auto m : motion) fail(m, error_code(ReplyError::kStopped), reason);
        }
        enqueue(i, rq::stop(), id, /*front=*/true);
        // An e-stop leaves the power stage off, as on every family (CiA 402 quick stop ends
        // in "switch on disabled"): the driver is switched off (MO=0, manual §5.10) once stopped.
        if (emergency) enqueue(i, rq::driver_on(false), id);
      }
      return std::nullopt;
    }
    case gateway_command_t::HOME:
      return each([&](std::size_t i, const motionlcm::axis_command_t& a) { return load_home(c, i, a); });
    case gateway_command_t::SET_POSITION:
      for (const auto i : c.nodes) enqueue(i, rq::set_origin(), id);
      return std::nullopt;
    case gateway_command_t::FAULT_RESET:
      for (const auto i : c.nodes) enqueue(i, rq::clear_motion_status(), id);
      return std::nullopt;
    case gateway_command_t::SET_OUTPUTS:
      return each([&](std::size_t i, const motionlcm::axis_command_t& a) -> Problem {
        if ((a.output_mask & ~1) != 0) {
          return std::pair{fmt::format("{} has one digital output (OP1, bit 0); mask 0x{:X} names others",
                                       nodes[i].name(), a.output_mask),
                           error_code(ReplyError::kUnsupported)};
        }
        const auto outputs =
            static_cast<std::uint8_t>((nodes[i].status.outputs & ~a.output_mask) | (a.output_value & a.output_mask));
        enqueue(i, rq::set_outputs(outputs), id);
        return std::nullopt;
      });
    case gateway_command_t::PARAM_READ:
    case gateway_command_t::PARAM_WRITE: return load_param(c);
    case gateway_command_t::DISARM: {
      std::set<std::int64_t> armed;
      for (const auto i : c.nodes) {
        const auto* move = commands.find(nodes[i].move);
        if (move != nullptr && move->all(Lifecycle::kArmed) &&
            (c.command.trigger_id == 0 || move->command.trigger_id == c.command.trigger_id)) {
          armed.insert(nodes[i].move);
        }
      }
      // A released move must leave nothing a BG could start: the drive keeps the PA it was
      // loaded with and a BG to its group or to the global id from anyone would run it (manual
      // §5.11, §5.20-§5.21: "PR/PA will take effect after a following BG"). PR=0 ("desired relative
      // position", added to the position at BG, §5.20) replaces it, so any later BG is a move of
      // zero counts; the DISARM is DONE once every drive acknowledged it.
      std::set<std::size_t> loaded;
      for (const auto a : armed) {
        if (const auto* move = commands.find(a)) loaded.insert(move->nodes.begin(), move->nodes.end());
      }
      for (const auto a : armed)
        fail(a, error_code(ReplyError::kStopped), fmt::format("move disarmed by command {}", id));
      for (const auto i : loaded) {
        if (nodes[i].phase != Phase::kOffline) enqueue(i, rq::set_relative_position(0), id, /*front=*/true);
      }
      return std::nullopt;
    }
    default:
      return std::pair{fmt::format("command kind {} is not supported by the uim342 stack", int{c.command.kind}),
                       error_code(ReplyError::kUnsupported)};
  }
}

// AC/DC in the drive's IC[4] unit; nullopt when the command leaves the drive's value.
Uim342Stack::Impl::Problem Uim342Stack::Impl::ramp(std::size_t i, double rate, double speed, bool acceleration,
                                                   std::int64_t id) {
  if (rate <= 0) return std::nullopt;
  const Node& n = nodes[i];
  const auto wire = uim342::acceleration_to_wire(rate, n.unit, speed, n.cut_in_pps);
  if (!wire) {
    return std::pair{fmt::format("{}: {} {} counts/s^2 is outside the drive's range", n.name(),
                                 acceleration ? "acceleration" : "deceleration", rate),
                     error_code(ReplyError::kOutsideLimits)};
  }
  enqueue(i, acceleration ? rq::set_acceleration(*wire) : rq::set_deceleration(*wire), id);
  return std::nullopt;
}

Uim342Stack::Impl::Problem Uim342Stack::Impl::load_move(Command& c, std::size_t i, const motionlcm::axis_command_t& a) {
  const Node& n = nodes[i];
  const auto speed = uim342::speed_to_pps(std::abs(a.velocity));
  if (!speed || *speed <= 0) {
    return std::pair{
        fmt::format("{}: ARM_MOVE needs a positive speed within 32 bits (got {} counts/s)", n.name(), a.velocity),
        error_code(ReplyError::kOutsideLimits)};
  }
  const std::int64_t drive_target = a.target_counts - n.offset;
  if (drive_target < std::numeric_limits<std::int32_t>::min() ||
      drive_target > std::numeric_limits<std::int32_t>::max()) {
    return std::pair{fmt::format("{}: target {} counts does not fit PA (32 bits)", n.name(), a.target_counts),
                     error_code(ReplyError::kOutsideLimits)};
  }
  const auto id = c.command.command_id;
  // §5.19: in PTP mode PR/PA first, then SP (otherwise error #50).
  enqueue(i, rq::set_absolute_position(static_cast<std::int32_t>(drive_target)), id);
  enqueue(i, rq::set_ptp_speed(*speed), id);
  if (auto p = ramp(i, a.acceleration, *speed, true, id)) return p;
  return ramp(i, a.deceleration, *speed, false, id);
}

Uim342Stack::Impl::Problem Uim342Stack::Impl::load_jog(Command& c, std::size_t i, const motionlcm::axis_command_t& a) {
  const auto speed = uim342::speed_to_pps(a.velocity);
  if (!speed)
    return std::pair{fmt::format("{}: jog speed {} counts/s does not fit 32 bits", nodes[i].name(), a.velocity),
                     error_code(ReplyError::kOutsideLimits)};
  const auto id = c.command.command_id;
  enqueue(i, rq::set_jog_velocity(*speed), id);
  const double magnitude = std::abs(static_cast<double>(*speed));
  if (auto p = ramp(i, a.acceleration, magnitude, true, id)) return p;
  if (auto p = ramp(i, a.deceleration, magnitude, false, id)) return p;
  enqueue(i, rq::begin(), id);
  return std::nullopt;
}

// PARAM_READ / PARAM_WRITE in the family's terms: index = function code, subindex = sub-index.
Uim342Stack::Impl::Problem Uim342Stack::Impl::load_param(Command& c) {
  const auto& p = c.command.param;
  const bool write = c.command.kind == gateway_command_t::PARAM_WRITE;
  if (c.nodes.size() != 1)
    return std::pair{std::string("a parameter command names exactly one axis"),
                     error_code(ReplyError::kMalformedRequest)};
  const Node& n = nodes[c.nodes.front()];
  if (p.space != motionlcm::param_t::UIM342_INSTRUCTION) {
    return std::pair{fmt::format("{} takes UIM342 parameters (space {}), not space {}", n.name(),
                                 int{motionlcm::param_t::UIM342_INSTRUCTION}, int{p.space}),
                     error_code(ReplyError::kUnsupported)};
  }
  const auto* forms =
      p.index >= 0 && p.index <= 0x7F ? uim342::find_forms(static_cast<std::uint8_t>(p.index)) : nullptr;
  if (!forms)
    return std::pair{fmt::format("{}: 0x{:02X} is not a UIM342 instruction", n.name(), p.index),
                     error_code(ReplyError::kMalformedRequest)};
  const auto instruction = param_instruction(*forms, p, write);
  if (!instruction)
    return std::pair{
        fmt::format("{}: {} has no {} form with this sub-index", n.name(), forms->mnemonic, write ? "set" : "get"),
        error_code(ReplyError::kMalformedRequest)};
  if (write) {
    if (const auto ec = uim342::check_instruction(*instruction, n.unit)) {
      return std::pair{
          fmt::format("{}: {} refused before sending: {}", n.name(), uim342::to_string(*instruction), ec.message()),
          error_code(ReplyError::kOutsideLimits)};
    }
  }
  enqueue(c.nodes.front(), *instruction, c.command.command_id);
  return std::nullopt;
}

std::optional<Instruction> Uim342Stack::Impl::param_instruction(const uim342::InstructionForms& forms,
                                                                const motionlcm::param_t& p, bool write) {
  using L = uim342::Layout;
  const auto sub = static_cast<std::uint8_t>(std::max(p.subindex, 0));
  const bool has_sub = p.subindex >= 0;
  const auto v = p.value;
  Instruction out{forms.function, write ? uim342::Operation::kSet : uim342::Operation::kGet, true, uim342::Empty{}};
  switch (write ? forms.set : forms.get) {
    case L::kEmpty: break;
    case L::kIndex:
      if (!has_sub) return std::nullopt;
      out.body = uim342::Index{sub};
      break;
    case L::kByte: out.body = uim342::Byte{saturate<std::uint8_t>(v)}; break;
    case L::kIndexedByte:
      if (!has_sub) return std::nullopt;
      out.body = uim342::IndexedByte{sub, saturate<std::uint8_t>(v)};
      break;
    case L::kInputLogic:
      if (sub <= 2) {
        out.body = uim342::InputActions{sub, uim342::EdgeAction::from_byte(static_cast<std::uint8_t>(v & 0xFF)),
                                        uim342::EdgeAction::from_byte(static_cast<std::uint8_t>((v >> 8) & 0xFF))};
        break;
      }
      [[fallthrough]];
    case L::kIndexedWord:
      if (!has_sub) return std::nullopt;
      out.body = uim342::IndexedWord{sub, saturate<std::uint16_t>(v)};
      break;
    case L::kU32: out.body = uim342::Unsigned{saturate<std::uint32_t>(v)}; break;
    case L::kS32: out.body = uim342::Signed{saturate<std::int32_t>(v)}; break;
    case L::kDigitalOutput: out.body = uim342::DigitalOutput{saturate<std::uint8_t>(v), 1}; break;
    default: return std::nullopt;
  }
  if (out.function == FunctionCode::kSY) out.ack_requested = false;
  return out;
}

// The value of a parameter reply: its data bytes after the echoed sub-index, little-endian,
// `width` bytes (all when 0), sign-extended when `is_signed`.
std::int64_t Uim342Stack::Impl::param_value(const uim342::Reply& ack, const motionlcm::param_t& p) {
  const auto message = uim342::encode(ack);
  if (!message) return 0;
  auto data = message->payload();
  if (ack.sub_index() && !data.empty()) data = data.subspan(1);
  const std::size_t width =
      p.width > 0 ? std::min<std::size_t>(static_cast<std::size_t>(p.width), data.size()) : data.size();
  std::uint64_t raw = 0;
  for (std::size_t k = 0; k < width && k < 8; ++k) raw |= std::uint64_t{data[k]} << (8 * k);
  if (p.is_signed && width > 0 && width < 8 && (data[width - 1] & 0x80) != 0) raw |= ~std::uint64_t{0} << (8 * width);
  return static_cast<std::int64_t>(raw);
}

void Uim342Stack::Impl::fire(std::int64_t trigger_id, TimePoint now) {
  std::vector<std::int64_t> ids;
  for (auto& [id, c] : commands.entries()) {
    if (c.command.kind == gateway_command_t::ARM_MOVE && c.all(Lifecycle::kArmed) &&
        c.command.trigger_id == trigger_id && trigger_id != 0)
      ids.push_back(id);
  }
  for (const auto id : ids) {
    if (auto* c = commands.find(id)) start_move(*c, now);
  }
}

}  // namespace motion::gateway
