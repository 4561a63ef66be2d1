// Uim242Stack (uim242_stack.hpp): construction, request plumbing, bytes and notifications in,
// identification, set-up and polling.
#include "uim242_stack_impl.hpp"

namespace motion::uim242_driver {

Uim242Stack::Uim242Stack(const config::Config& config, const std::string& bus, CoreContext context)
    : bus_(bus),
      context_(std::move(context)),
      poll_period_(std::chrono::duration_cast<Duration>(std::chrono::duration<double>(1.0 / 10.0))),
      channel_([this](std::span<const std::uint8_t> b) { context_.send(b); }, ChannelSettings{}) {
  const config::Bus* b = config.find_bus(bus);
  if (b) {
    transport_ = b->transport;
    poll_period_ = std::chrono::duration_cast<Duration>(std::chrono::duration<double>(1.0 / std::max(b->poll_hz, 0.1)));
    channel_ = RequestChannel([this](std::span<const std::uint8_t> bytes) { context_.send(bytes); },
                              ChannelSettings{std::chrono::milliseconds(b->request_timeout_ms), b->retries,
                                              gateway::serial_line_settings(*b).wire_time(1),
                                              std::chrono::microseconds(b->egress_latency_us)});
  }
  for (const auto& d : config.drives) {
    if (d.bus != bus || d.family != config::Family::kUim242) continue;
    auto drive = std::make_unique<Drive>();
    drive->config = &d;
    drive->name = d.name;
    drive->node = d.node_id;
    if (const auto answer = d.setup_text("spd0_position_move")) {
      drive->spd0 = *answer == "holds"                ? Drive::Spd0::kHolds
                    : *answer == "runs_at_last_speed" ? Drive::Spd0::kRunsAtLastSpeed
                    : *answer == "refused"            ? Drive::Spd0::kRefused
                                                      : Drive::Spd0::kUnknown;
    }
    for (const auto& a : config.axes) {
      if (a.drive == d.name) {
        drive->axis = &a;
        drive->axis_name = a.name;
      }
    }
    drives_.push_back(std::move(drive));
  }
  start_wait_ = longest_poll_exchange();
}

Uim242Stack::~Uim242Stack() = default;

std::vector<std::string> Uim242Stack::axes() const {
  std::vector<std::string> out;
  for (const auto& d : drives_) {
    if (!d->axis_name.empty()) out.push_back(d->axis_name);
  }
  return out;
}

bool Uim242Stack::ready() const {
  return std::all_of(drives_.begin(), drives_.end(), [](const auto& d) { return d->status.online && d->set_up; });
}

motionlcm::bus_stats_t Uim242Stack::statistics() const {
  const auto& s = channel_.statistics();
  motionlcm::bus_stats_t out{};
  out.name = bus_;
  out.transport = transport_;
  out.state = started_ ? "open" : "closed";
  out.tx_frames = s.tx_frames;
  out.rx_frames = s.rx_frames;
  out.tx_bytes = s.tx_bytes;
  out.rx_bytes = s.rx_bytes;
  out.errors = s.errors + s.unexpected + protocol_errors_;
  out.timeouts = s.timeouts;
  out.retries = s.retries;
  out.drives_online = static_cast<std::int32_t>(
      std::count_if(drives_.begin(), drives_.end(), [](const auto& d) { return d->status.online; }));
  out.drives_total = static_cast<std::int32_t>(drives_.size());
  return out;
}

// ---- plumbing ----------------------------------------------------------------------------------

void Uim242Stack::submit(Drive& d, Instruction in, std::int64_t group,
                         std::function<void(const Frame&, TimePoint)> on_reply, bool front) {
  Request r;
  r.drive = d.name;
  r.node = d.node;
  r.instruction = in;
  r.group = group;
  r.on_reply = std::move(on_reply);
  r.on_failure = [this, &d, group](const std::string& reason, bool timed_out, TimePoint now) {
    if (timed_out) {
      event(d, event_t::TIMEOUT, event_t::WARNING, 0, reason);
      mark_offline(d, reason, now);
    } else {
      event(d, event_t::ERROR_REPORT, event_t::ERROR, 0, reason);
    }
    if (group != 0) finish(group, false, reason, timed_out ? kTimeout : kDriveError);
  };
  channel_.submit(std::move(r), front);
}

void Uim242Stack::run_sequence(Command& c, Drive& d, std::vector<Instruction> steps,
                               const std::function<void(TimePoint)>& done) {
  const std::int64_t id = c.command.command_id;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const bool last = i + 1 == steps.size();
    submit(d, steps[i], id,
           last ? std::function<void(const Frame&, TimePoint)>{[done](const Frame&, TimePoint now) { done(now); }}
                : std::function<void(const Frame&, TimePoint)>{});
  }
  if (steps.empty()) done(TimePoint{});
}

void Uim242Stack::finish(std::int64_t command_id, bool ok, const std::string& reason, std::int32_t error_code,
                         std::optional<motionlcm::param_t> param) {
  Command* c = commands_.find(command_id);
  if (c == nullptr) return;  // already ended: exactly one terminal reply
  if (param) c->reply.param(*param);
  // The one terminal reply; the entry leaves the ledger before anything below can end it again.
  commands_.finish(command_id,
                   ok ? Lifecycle::kDone : (error_code == kStopped ? Lifecycle::kStopped : Lifecycle::kFailed),
                   ok ? 0 : error_code, reason);
  channel_.cancel(command_id);
  std::erase_if(moves_, [command_id](const auto& m) { return m->command_id == command_id; });
  std::erase_if(rest_checks_, [command_id](const RestCheck& r) { return r.group == command_id; });
  for (auto& d : drives_) {
    if (d->homing_command != command_id) continue;
    d->homing_command = 0;
    // Ended before the switch (stopped, failed, timed out): unbind the reset + e-stop action, or
    // a later pass over the switch would zero the position and stop the axis unasked.
    if (started_) submit(*d, uim242::make_scf(d->homing_restore), 0, {}, true);
  }
}

void Uim242Stack::part_done(std::int64_t command_id) {
  Command* c = commands_.find(command_id);
  if (c == nullptr) return;
  if (c->data.outstanding > 0 && --c->data.outstanding > 0) return;
  if (!c->data.unreached.empty()) return finish(command_id, false, c->data.unreached, kAxisOffline);
  finish(command_id, true);
}

void Uim242Stack::event(const Drive& d, std::int16_t kind, std::int8_t severity, std::int32_t code,
                        const std::string& text) {
  if (!context_.out) return;
  context_.out->axis_event(d.axis_name, gateway::DriveEvent{kind, severity, code, text});
}

void Uim242Stack::publish(Drive& d, TimePoint now) {
  d.status.sample_utime = context_.utime_of ? context_.utime_of(now) : steady_us(now);
  if (context_.out && !d.axis_name.empty()) context_.out->axis_status(d.axis_name, d.status);
}

// ---- bytes in ------------------------------------------------------------------------------------

void Uim242Stack::on_bytes(std::span<const std::uint8_t> bytes, TimePoint now) {
  channel_.count_received(bytes.size());
  const auto noise_before = framer_.noise_bytes() + framer_.oversize_frames();
  for (const auto& raw : framer_.push(bytes)) {
    const auto frame = uim242::parse_frame(raw);
    if (!frame) {
      ++protocol_errors_;
      continue;
    }
    on_frame(*frame, now);
  }
  if (framer_.noise_bytes() + framer_.oversize_frames() != noise_before) ++protocol_errors_;
}

void Uim242Stack::on_frame(const Frame& frame, TimePoint now) {
  if (const auto n = uim242::as_notification(frame)) {
    on_notification(*n, now);
    return;
  }
  if (uim242::as_greeting(frame)) return;  // the gateway (re)started: nothing to answer
  if (!channel_.on_frame(frame, now)) ++protocol_errors_;
}

void Uim242Stack::on_notification(const uim242::Notification& n, TimePoint now) {
  const auto it = std::find_if(drives_.begin(), drives_.end(), [&](const auto& d) { return d->node == n.node; });
  if (it == drives_.end()) {
    ++protocol_errors_;
    return;
  }
  Drive& d = **it;
  switch (n.event) {
    case uim242::Event::kDisplacementComplete:
      // The position is the arriving move's target (move_axis_arrived); a displacement that is not
      // a move's (a jog run onto its limit) leaves the position to the next poll.
      move_axis_arrived(d, now);
      return;
    case uim242::Event::kStall: {
      const std::string reason = fmt::format("{} (node {}): stall notification", d.name, d.node);
      d.status.fault = true;
      d.status.fault_code = static_cast<std::int32_t>(uim242::message::kDefaultStall);
      d.status.fault_text = "stall";
      event(d, event_t::STALL, event_t::ERROR, d.status.fault_code, reason);
      fail_moves_of(d, reason, kGroupFault);
      publish(d, now);
      return;
    }
    case uim242::Event::kPositionZero:
    case uim242::Event::kP4HighToLow:
    case uim242::Event::kP4LowToHigh:
      event(d, event_t::INPUT_EDGE, event_t::INFO, static_cast<std::int32_t>(n.event),
            fmt::format("{} (node {}): notification 0x{:02X}", d.name, d.node, static_cast<int>(n.event)));
      return;
    default: break;
  }
  // S1..S3 edges (A0..A5).
  const int input = (static_cast<int>(n.event) - 0xA0) / 2 + 1;
  const bool rising = (static_cast<int>(n.event) & 1) != 0;
  d.status.inputs = rising ? (d.status.inputs | (1 << (input - 1))) : (d.status.inputs & ~(1 << (input - 1)));
  event(d, event_t::INPUT_EDGE, event_t::INFO, input,
        fmt::format("{} (node {}): input S{} {}", d.name, d.node, input, rising ? "rising" : "falling"));
  if (d.homing_command != 0 && n.event == d.homing_edge) {
    // The switch fired: the drive reset its position and stopped (action 1100). Restore the
    // sensor register, drop the homing speed (an e-stop keeps the desired speed: the next `ENA;`
    // would run on), and apply the home offset.
    const std::int64_t id = d.homing_command;
    d.homing_command = 0;
    Command* c = commands_.find(id);
    if (c == nullptr) return;
    const std::int64_t offset = d.homing_offset;
    run_sequence(*c, d, {uim242::make_scf(d.homing_restore), set(Mnemonic::kSPD, 0), set(Mnemonic::kORG, offset)},
                 [this, id, &d, offset](TimePoint t) {
                   homed(d, offset, t);
                   part_done(id);  // DONE when every axis of the command is home
                 });
  }
}

// ---- start-up and polling -----------------------------------------------------------------------

void Uim242Stack::start(TimePoint now) {
  started_ = true;
  next_poll_ = now + poll_period_;
  for (auto& d : drives_) identify(*d, now);
  next_identify_ = now + kIdentifyRetry;
}

void Uim242Stack::line_lost(const std::string& why, TimePoint now) {
  const std::string reason = fmt::format("serial line of bus {} lost: {}", bus_, why);
  started_ = false;
  if (context_.out) context_.out->axis_event({}, gateway::DriveEvent{event_t::OFFLINE, event_t::ERROR, 0, reason});
  std::vector<std::int64_t> running;
  for (const auto& [id, c] : commands_.entries()) running.push_back(id);
  for (const auto id : running) finish(id, false, reason, kTimeout);
  // Nothing sent before the loss will be answered: forget it, and any half-received frame.
  channel_.reset();
  framer_.reset();
  timers_.clear();
  polls_outstanding_ = 0;
  for (auto& d : drives_) {
    d->identifying = false;
    mark_offline(*d, reason, now);
  }
}

void Uim242Stack::identify(Drive& d, TimePoint /*now*/) {
  if (d.identifying) return;
  d.identifying = true;
  Request r;
  r.drive = d.name;
  r.node = d.node;
  r.instruction = set(Mnemonic::kMDL, d.node);
  r.on_reply = [this, &d](const Frame& f, TimePoint now) {
    d.identifying = false;
    const auto fields = uim242::decode_fields(f.data, uim242::Layout::kModel);
    if (!fields || (*fields)[0] != 0x18 || (*fields)[1] != 0x02) {
      event(d, event_t::CONFIG_MISMATCH, event_t::WARNING, 0,
            fmt::format("{} (node {}): 'MDL {};' reports a model other than UIM242 (18 02)", d.name, d.node, d.node));
    }
    d.status.online = true;
    report_facts(d);  // before the first online status (DriveFacts)
    event(d, event_t::ONLINE, event_t::INFO, 0,
          fmt::format("{} (node {}): UIM242, firmware {}", d.name, d.node, fields ? (*fields)[4] : 0));
    stop_then_set_up(d);
    publish(d, now);
  };
  r.on_failure = [this, &d](const std::string& reason, bool, TimePoint now) {
    d.identifying = false;
    mark_offline(d, reason, now);
  };
  channel_.submit(std::move(r));
}

// A drive first heard of while it moves (a previous gateway process's move, or a move nobody
// stopped) is stopped before anything of its set-up is written: micro-steps, current and the
// configuration registers are not changed under a running motor. `FBK;` (manual §6.3, #12) gives
// its speed; a moving drive gets `STP 0;` (#44: "execute the current instruction and stop motor",
// and the drive leaves PT for VT mode with the desired speed 0, §6.1), a GATEWAY_RESTARTED event,
// and `FBK;` again every kRestCheck until it reports speed 0; only then the set-up. A drive still
// moving kRestLimit after its stop is offline (identified, and so stopped, again later).
void Uim242Stack::stop_then_set_up(Drive& d) {
  submit(d, bare(Mnemonic::kFBK), 0, [this, &d](const Frame& f, TimePoint) {
    const auto s = uim242::decode_status(f);
    const std::int64_t speed = s ? s->speed : 0;
    if (speed == 0) {
      set_up(d);
      return;
    }
    event(d, event_t::GATEWAY_RESTARTED, event_t::WARNING, 0,
          fmt::format("{} (node {}): found moving at {} pps before its set-up (a previous gateway process's move, or "
                      "one nobody stopped): stopping it (STP 0) before writing its set-up",
                      d.name, d.node, speed));
    submit(d, set(Mnemonic::kSTP, 0), 0, [this, &d](const Frame&, TimePoint t) { set_up_at_rest(d, t + kRestLimit); });
  });
}

void Uim242Stack::set_up_at_rest(Drive& d, TimePoint give_up) {
  submit(d, bare(Mnemonic::kFBK), 0, [this, &d, give_up](const Frame& f, TimePoint now) {
    const auto s = uim242::decode_status(f);
    const std::int64_t speed = s ? s->speed : 0;
    if (speed == 0) {
      set_up(d);
      return;
    }
    if (now >= give_up) {
      mark_offline(d,
                   fmt::format("{} (node {}): still moving at {} pps {} s after its stop (STP 0); not set up", d.name,
                               d.node, speed, std::chrono::duration_cast<std::chrono::seconds>(kRestLimit).count()),
                   now);
      return;
    }
    after(now + kRestCheck, [this, &d, give_up](TimePoint) { set_up_at_rest(d, give_up); });
  });
}

// UIM242 manual §5.1: an ICF write is burned into EEPROM "and the controller will auto reboot"
// (how long it takes is not said). So ICFG is read first and written only when it differs
// (bits 15..4 read 0); after the write the controller is asked again until it answers (within
// kIcfRebootLimit), and the rest of the set-up follows only when the value reads back. A value
// that does not read back is a CONFIG_MISMATCH and the drive stays not ready: never a second write.
void Uim242Stack::set_up(Drive& d) {
  const auto it = d.config->setup.find("icfg");
  if (it == d.config->setup.end() || !std::holds_alternative<long long>(it->second)) {
    set_up_steps(d);
    return;
  }
  const std::int64_t wanted = std::get<long long>(it->second) & kIcfgBits;
  const auto read_icfg = [](const Frame& f) {
    return field(f, uim242::reply_form(bare(Mnemonic::kICF)).layout, 0) & kIcfgBits;
  };
  Request r;
  r.drive = d.name;
  r.node = d.node;
  r.instruction = bare(Mnemonic::kICF);
  r.on_reply = [this, &d, wanted, read_icfg](const Frame& f, TimePoint) {
    if (read_icfg(f) == wanted) {
      set_up_steps(d);
      return;
    }
    Request w;
    w.drive = d.name;
    w.node = d.node;
    w.instruction = set(Mnemonic::kICF, wanted);
    w.on_reply = [this, &d, wanted, was = read_icfg(f)](const Frame&, TimePoint now) {
      ++icf_writes_;
      event(d, event_t::REBOOT, event_t::INFO, static_cast<std::int32_t>(wanted),
            fmt::format("{} (node {}): ICFG 0x{:X} -> 0x{:X} (ICF), the controller reboots", d.name, d.node, was,
                        wanted));
      after(now + kIcfRebootCheck,
            [this, &d, wanted, give_up = now + kIcfRebootLimit](TimePoint t) { verify_icfg(d, wanted, give_up, t); });
    };
    w.on_failure = [this, &d](const std::string& reason, bool timed_out, TimePoint now) {
      event(d, event_t::CONFIG_MISMATCH, event_t::ERROR, 0, "set-up failed: " + reason);
      if (timed_out) mark_offline(d, reason, now);
    };
    channel_.submit(std::move(w), true);
  };
  r.on_failure = [this, &d](const std::string& reason, bool timed_out, TimePoint now) {
    event(d, event_t::CONFIG_MISMATCH, event_t::ERROR, 0, "set-up failed: " + reason);
    if (timed_out) mark_offline(d, reason, now);
  };
  channel_.submit(std::move(r));
}

void Uim242Stack::verify_icfg(Drive& d, std::int64_t wanted, TimePoint give_up, TimePoint /*now*/) {
  Request r;
  r.drive = d.name;
  r.node = d.node;
  r.instruction = bare(Mnemonic::kICF);
  r.on_reply = [this, &d, wanted](const Frame& f, TimePoint now) {
    const std::int64_t read = field(f, uim242::reply_form(bare(Mnemonic::kICF)).layout, 0) & kIcfgBits;
    if (read == wanted) {
      event(d, event_t::ONLINE, event_t::INFO, 0,
            fmt::format("{} (node {}): back after its reboot, ICFG reads 0x{:X}", d.name, d.node, read));
      set_up_steps(d);
      return;
    }
    event(d, event_t::CONFIG_MISMATCH, event_t::ERROR, static_cast<std::int32_t>(read),
          fmt::format("{} (node {}): ICFG reads 0x{:X} after the write and reboot (configured 0x{:X}); not ready",
                      d.name, d.node, read, wanted));
    publish(d, now);
  };
  r.on_failure = [this, &d, wanted, give_up](const std::string& reason, bool timed_out, TimePoint now) {
    if (timed_out && now < give_up) {  // still rebooting
      after(now + kIcfRebootCheck, [this, &d, wanted, give_up](TimePoint t) { verify_icfg(d, wanted, give_up, t); });
      return;
    }
    event(d, event_t::CONFIG_MISMATCH, event_t::ERROR, 0, "not back after the ICF reboot: " + reason);
    if (timed_out) mark_offline(d, reason, now);
  };
  channel_.submit(std::move(r), true);
}

void Uim242Stack::after(TimePoint due, std::function<void(TimePoint)> then) {
  timers_.push_back({due, std::move(then)});
}

void Uim242Stack::set_up_steps(Drive& d) {
  const auto& setup = d.config->setup;
  const auto integer = [&](const char* key) -> std::optional<std::int64_t> {
    const auto it = setup.find(key);
    if (it == setup.end()) return std::nullopt;
    if (const auto* v = std::get_if<long long>(&it->second)) return *v;
    if (const auto* v = std::get_if<double>(&it->second)) return std::llround(*v);
    return std::nullopt;
  };
  std::vector<Instruction> steps;
  if (const auto m = integer("micro_steps")) steps.push_back(set(Mnemonic::kMCS, *m));
  if (const auto it = setup.find("current_a"); it != setup.end()) {
    const double amps = std::holds_alternative<double>(it->second)
                            ? std::get<double>(it->second)
                            : static_cast<double>(std::get<long long>(it->second));
    steps.push_back(set(Mnemonic::kCUR, std::llround(amps * 10)));  // tenths of an ampere (#6)
  }
  steps.push_back(set(Mnemonic::kMCF, integer("mcfg").value_or(kDefaultMcfg)));
  if (const auto v = integer("encoder_lines")) steps.push_back(set(Mnemonic::kQER, *v));
  if (const auto v = integer("stall_tolerance")) steps.push_back(set(Mnemonic::kSQT, *v));
  steps.push_back(set(Mnemonic::kMMS, 0));  // no non-linear jumps: the planner's exact trapezoid
  steps.push_back(set(Mnemonic::kMMD, 0));
  steps.push_back(set(Mnemonic::kSTP, 0));  // velocity mode, desired speed 0
  const auto submit_step = [this, &d](Instruction in, std::function<void(const Frame&, TimePoint)> on_reply,
                                      bool front) {
    Request r;
    r.drive = d.name;
    r.node = d.node;
    r.instruction = in;
    r.on_reply = std::move(on_reply);
    r.on_failure = [this, &d](const std::string& reason, bool timed_out, TimePoint now) {
      event(d, event_t::CONFIG_MISMATCH, event_t::ERROR, 0, "set-up failed: " + reason);
      if (timed_out) mark_offline(d, reason, now);
    };
    channel_.submit(std::move(r), front);
  };
  // STLIE alone sends no stall notification: a STALL action of 0000 silences it. Keep a configured
  // action, else bind "notify only" (the sensor bits of S34CON stay as they are).
  submit_step(
      bare(Mnemonic::kSCF),
      [submit_step](const Frame& f, TimePoint) {
        const auto s34con =
            static_cast<std::uint16_t>(static_cast<std::uint32_t>(field(f, uim242::Layout::kScf, 0)) >> 16);
        if ((s34con & kStallField) != 0) return;
        submit_step(
            uim242::make_scf({uim242::SensorRegister::kS34CON, static_cast<std::uint16_t>(s34con | kStallNotifyOnly)}),
            {}, true);
      },
      false);
  for (std::size_t i = 0; i < steps.size(); ++i) {
    std::function<void(const Frame&, TimePoint)> on_reply;
    if (i + 1 == steps.size()) {
      on_reply = [this, &d](const Frame&, TimePoint now) {
        d.set_up = true;
        publish(d, now);
      };
    }
    submit_step(steps[i], std::move(on_reply), false);
  }
}

void Uim242Stack::mark_offline(Drive& d, const std::string& reason, TimePoint now) {
  d.set_up = false;
  if (!d.status.online) return;
  d.status.online = false;
  event(d, event_t::OFFLINE, event_t::ERROR, 0, reason);
  fail_moves_of(d, reason, kAxisOffline);
  publish(d, now);
}

void Uim242Stack::poll(TimePoint now) {
  if (now >= next_identify_ && !awaiting_trigger()) {
    next_identify_ = now + kIdentifyRetry;
    for (auto& d : drives_) {
      if (!d->status.online) identify(*d, now);
    }
  }
  if (now < next_poll_ || polls_outstanding_ > 0) return;
  next_poll_ = now + poll_period_;
  for (auto& dp : drives_) {
    Drive& d = *dp;
    if (!d.status.online || !d.set_up) continue;
    const auto poll_request = [&](Instruction in, const std::function<void(const Frame&, TimePoint)>& on_reply) {
      ++polls_outstanding_;
      Request r;
      r.drive = d.name;
      r.node = d.node;
      r.instruction = in;
      r.on_reply = [this, on_reply](const Frame& f, TimePoint t) {
        --polls_outstanding_;
        on_reply(f, t);
      };
      r.on_failure = [this, &d](const std::string& reason, bool timed_out, TimePoint t) {
        --polls_outstanding_;
        if (timed_out) {
          event(d, event_t::TIMEOUT, event_t::WARNING, 0, reason);
          mark_offline(d, reason, t);
        }
      };
      channel_.submit(std::move(r));
    };
    poll_request(bare(Mnemonic::kFBK), [&d](const Frame& f, TimePoint) {
      if (const auto s = uim242::decode_status(f)) {
        d.status.enabled = s->enabled;
        d.status.velocity_counts = s->speed;
        d.status.moving = s->speed != 0;
      }
    });
    poll_request(bare(Mnemonic::kQEC), [this, &d](const Frame& f, TimePoint t) {
      const std::int64_t position = field(f, uim242::Layout::kS32, 0);
      const bool still = !d.status.moving && d.last_polled_position == position;
      d.status.position_counts = position;
      d.status.position_read = true;
      d.last_polled_position = position;
      // The move of this drive that is under way, and when its run should have ended.
      std::optional<TimePoint> due;
      for (const auto& m : moves_) {
        const Command* c = commands_.find(m->command_id);
        if (c == nullptr || c->reported != gateway_reply_t::STARTED) continue;  // not moving yet
        for (const auto& a : m->axes) {
          if (a.drive == &d && !a.arrived) due = m->last_start + a.planned;
        }
      }
      const bool moving_to_target = due.has_value();
      d.status.in_position = !moving_to_target || (position == d.status.target_counts && !d.status.moving);
      if (moving_to_target) {
        if (position == d.status.target_counts && !d.status.moving) {
          move_axis_arrived(d, t);
        } else if (still && t >= *due && ++d.still_polls >= kStillPollsBeforeFailure) {
          fail_moves_of(d,
                        fmt::format("{} (node {}): stopped at {} before the target {}", d.name, d.node, position,
                                    d.status.target_counts),
                        kGroupFault);
        }
      }
      if (!still) d.still_polls = 0;
      publish(d, t);
    });
  }
}

TimePoint Uim242Stack::process(TimePoint now) {
  if (started_) poll(now);
  // Due rest checks leave the list before they ask again (settle() may add to it).
  const auto split = std::stable_partition(rest_checks_.begin(), rest_checks_.end(),
                                           [now](const RestCheck& r) { return r.due > now; });
  std::vector<RestCheck> due(std::make_move_iterator(split), std::make_move_iterator(rest_checks_.end()));
  rest_checks_.erase(split, rest_checks_.end());
  for (auto& r : due) settle(*r.drive, r.group, r.give_up, std::move(r.then));
  const auto timers_split =
      std::stable_partition(timers_.begin(), timers_.end(), [now](const Timer& t) { return t.due > now; });
  std::vector<Timer> due_timers(std::make_move_iterator(timers_split), std::make_move_iterator(timers_.end()));
  timers_.erase(timers_split, timers_.end());
  for (auto& t : due_timers) t.then(now);
  // While a move awaits its trigger no exchange longer than the announced start wait begins.
  channel_.limit(awaiting_trigger() ? start_wait() : Duration::max());
  const TimePoint channel_deadline = channel_.process(now);
  if (!started_) return channel_deadline;
  TimePoint next = std::min(channel_deadline, next_poll_);
  for (const auto& r : rest_checks_) next = std::min(next, r.due);
  for (const auto& t : timers_) next = std::min(next, t.due);
  if (std::any_of(drives_.begin(), drives_.end(), [](const auto& d) { return !d->status.online; })) {
    next = std::min(next, next_identify_);
  }
  return next;
}

}  // namespace motion::uim242_driver
