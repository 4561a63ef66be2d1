// AdamStack (adam_stack.hpp): settings from the configuration, the line (one transaction at a
// time, replies, timeouts, retries), drives and polling.
#include "adam_stack_impl.hpp"

namespace motion::adam_driver {

MasterSettings settings_from_config(const config::Config& config, const config::Bus& bus) {
  MasterSettings s;
  s.bus = bus.name;
  s.transport = bus.transport;
  s.format.baud = static_cast<std::uint32_t>(bus.baud);
  s.format.parity = bus.parity == 'E' ? rtu::Parity::kEven : bus.parity == 'O' ? rtu::Parity::kOdd : rtu::Parity::kNone;
  s.format.stop_bits = static_cast<std::uint8_t>(bus.stop_bits);
  s.poll_period = std::chrono::duration_cast<Duration>(std::chrono::duration<double>(1.0 / std::max(bus.poll_hz, 0.1)));
  s.egress_latency = std::chrono::microseconds(bus.egress_latency_us);
  for (const auto& d : config.drives) {
    if (d.bus != bus.name || d.family != config::Family::kAdamModbus) continue;
    DriveSettings ds;
    ds.drive = d.name;
    ds.unit = static_cast<std::uint8_t>(d.node_id);
    ds.request_timeout = std::chrono::milliseconds(d.request_timeout_ms.value_or(bus.request_timeout_ms));
    ds.retries = d.retries.value_or(bus.retries);
    for (const auto& a : config.axes) {
      if (a.drive != d.name) continue;
      ds.axis = a.name;
      ds.home_input = a.homing.input;
      ds.homing_method = a.homing.method;
    }
    if (const auto pulses = adam::setup_pulses_per_revolution(d.setup_integer("pulses_per_revolution"),
                                                              d.setup_integer("subdivision"))) {
      const auto w = adam::encode32(static_cast<std::uint32_t>(*pulses));
      ds.setup_writes.push_back({adam::address(Reg::kSubdivision), {w[0], w[1]}});
    }
    if (const auto it = d.setup.find("current_a"); it != d.setup.end()) {
      ds.setup_writes.push_back({adam::address(Reg::kRatedCurrent),
                                 {static_cast<std::uint16_t>(std::lround(setup_number(it->second) * 100))}});
    }
    ds.table_save = d.setup_flag("table_save").value_or(true);
    if (const auto it = d.setup.find("closed_loop"); it != d.setup.end() && setup_int(it->second) == 0) {
      ds.setup_writes.push_back({adam::address(Reg::kMinEncoderLines), {kForceOpenLoopLines}});
    }
    s.drives.push_back(std::move(ds));
  }
  return s;
}

AdamStack::AdamStack(MasterSettings settings, Send send, gateway::GatewayOutput& out, WallClock wall_clock)
    : settings_(std::move(settings)),
      send_(std::move(send)),
      out_(out),
      wall_clock_(gateway::or_system_clock(std::move(wall_clock))),
      timing_(rtu::frame_timing(settings_.format)),
      framer_(timing_.t3_5),
      operations_([this](motionlcm::gateway_reply_t r) { out_.command_reply(std::move(r)); }) {
  for (const auto& d : settings_.drives) {
    auto drive = std::make_unique<Drive>();
    drive->cfg = d;
    drives_.push_back(std::move(drive));
  }
  start_wait_ = longest_poll_read();
}

AdamStack::~AdamStack() = default;

// ---- Line ---------------------------------------------------------------------------------------

void AdamStack::enqueue(Transaction t, bool urgent) {
  // A Save is never sent twice (a retry would erase flash again, §8.69).
  if (t.drive && !t.is_poll) t.max_retries = adam::is_save(t.request) ? 0 : t.drive->cfg.retries;
  if (urgent) {
    t.urgent = true;
    queue_.push_front(std::move(t));
  } else if (t.is_poll) {
    queue_.push_back(std::move(t));
  } else {
    // Commands (and set-up) go before the polls already queued, in their own order: with N
    // drives a poll round queues 2N reads, which a command must not wait behind.
    const auto first_poll = std::find_if(queue_.begin(), queue_.end(), [](const Transaction& q) { return q.is_poll; });
    queue_.insert(first_poll, std::move(t));
  }
}

std::string AdamStack::describe(const Transaction& t) const {
  if (const auto* read = std::get_if<rtu::ReadRegisters>(&t.request.pdu)) {
    const std::uint32_t last = std::uint32_t{read->start} + read->quantity - 1;
    return "reading register " + hex16(read->start) + (last != read->start ? "…" + hex16(last) : "") +
           register_name(read->start);
  }
  const std::uint16_t reg = std::holds_alternative<rtu::WriteRegister>(t.request.pdu)
                                ? std::get<rtu::WriteRegister>(t.request.pdu).address
                                : std::get<rtu::WriteRegisters>(t.request.pdu).start;
  return "writing register " + hex16(reg) + register_name(reg);
}

std::string AdamStack::exchange_under_way(TimePoint now) const {
  if (!in_flight_) {
    if (now >= line_free_at_) return {};
    return "the silent interval after the last frame (Modbus over serial line §2.5.1.1), " +
           std::to_string(std::chrono::duration_cast<std::chrono::microseconds>(line_free_at_ - now).count()) +
           " us more";
  }
  const Transaction& t = *in_flight_;
  const std::string who = t.drive == nullptr
                              ? "broadcast"
                              : "drive " + t.drive->cfg.drive + " (slave " + std::to_string(t.drive->cfg.unit) + ")";
  return who + " " + describe(t) + ", its request ended " +
         std::to_string(std::chrono::duration_cast<std::chrono::microseconds>(now - t.frame_end).count()) + " us ago";
}

std::deque<AdamStack::Transaction>::iterator AdamStack::next_to_send() {
  if (!awaiting_trigger()) return queue_.begin();
  std::vector<const Drive*> held;  // drives whose next transaction is too long to begin now
  for (auto it = queue_.begin(); it != queue_.end();) {
    Drive* d = it->drive;
    if (d == nullptr) return held.empty() ? it : queue_.end();  // a broadcast passes nothing
    if (it->is_poll && !d->online) {
      d->poll_queued = false;  // a read queued before the move was armed: tried again after the start
      it = queue_.erase(it);
      continue;
    }
    if (std::find(held.begin(), held.end(), d) == held.end()) {
      if (it->urgent || line_time(it->request) <= start_wait_) return it;
      held.push_back(d);
    }
    ++it;
  }
  return queue_.end();
}

void AdamStack::send_next(TimePoint now) {
  while (!in_flight_ && !queue_.empty() && now >= line_free_at_) {
    const auto next = next_to_send();
    if (next == queue_.end()) break;
    if (reserved_at_ != kNever && now < reserved_at_ + kReservationGrace && next->drive != nullptr) {
      // A scheduled start frame goes out at reserved_at_: nothing that would still run then (nor
      // after it, until the fire comes or the grace is over).
      if (now + line_time(next->request) > reserved_at_) break;
    }
    Transaction t = std::move(*next);
    queue_.erase(next);
    auto frame = rtu::encode_request(t.request);
    if (!frame) {  // only a programming error gets here (the builders validate)
      if (t.on_fail)
        t.on_fail("cannot encode " + describe(t) + ": " + frame.error().message(),
                  error_code(ReplyError::kMalformedRequest));
      continue;
    }
    const auto& bytes = frame.value();
    if (!line_open_ || !send_(bytes)) {
      ++errors_;
      if (t.on_fail)
        t.on_fail("serial line of bus " + settings_.bus + " not writable while " + describe(t),
                  error_code(ReplyError::kTimeout));
      continue;
    }
    ++tx_frames_;
    tx_bytes_ += static_cast<std::int64_t>(bytes.size());
    const Duration on_wire = rtu::transmission_time(settings_.format, bytes.size());
    busy_time_ += on_wire;
    if (first_activity_ == kNever) first_activity_ = now;
    last_activity_ = now;
    t.frame_end = now + settings_.egress_latency + on_wire;
    ++t.attempts;
    framer_.clear();  // anything before our request is not its reply
    if (t.drive == nullptr) {
      // Broadcast: executed by every drive, answered by none (§5). Keep the line silent long
      // enough for every drive to see the frame end and act before the next one.
      line_free_at_ = t.frame_end + timing_.t3_5 + settings_.broadcast_guard;
      if (t.on_reply) t.on_reply(rtu::Response{}, now, t.frame_end);
      continue;
    }
    if (!adam::expects_reply(t.request)) {  // restart (§8.67): no reply even when addressed
      line_free_at_ = t.frame_end + timing_.t3_5 + settings_.broadcast_guard;
      if (t.on_reply) t.on_reply(rtu::Response{}, now, t.frame_end);
      continue;
    }
    reply_deadline_ =
        t.frame_end + t.drive->cfg.request_timeout + (adam::is_save(t.request) ? adam::kSaveEraseTime : Duration{});
    in_flight_ = std::make_unique<Transaction>(std::move(t));
  }
}

std::optional<std::size_t> AdamStack::expected_reply_size(std::span<const std::uint8_t> pending) const {
  if (!in_flight_ || pending.size() < 2) return std::nullopt;
  if ((pending[1] & rtu::kExceptionFlag) != 0) return 5;  // unit, function|0x80, code, CRC
  if (const auto* read = std::get_if<rtu::ReadRegisters>(&in_flight_->request.pdu)) return 5U + 2U * read->quantity;
  return 8;  // FC 0x06 echo, FC 0x10 start + quantity
}

void AdamStack::on_bytes(std::span<const std::uint8_t> bytes, TimePoint now) {
  framer_.push(bytes, now);
  const auto pending = framer_.pending();
  // A pty delivers a frame at once; closing it at its known length saves the t3.5 wait. A frame
  // of the right length with a bad CRC waits for the silence (more garbage may follow). Bytes
  // beyond a valid reply (a late answer to an earlier attempt, joined to this one without a
  // silence between them) stay buffered as a frame of their own.
  if (const auto size = expected_reply_size(pending);
      size && pending.size() >= *size && rtu::crc_ok(pending.first(*size))) {
    on_reply_frame(framer_.complete_prefix(*size), now);
  }
}

void AdamStack::on_reply_frame(std::vector<std::uint8_t> frame, TimePoint now) {
  ++rx_frames_;
  rx_bytes_ += static_cast<std::int64_t>(frame.size());
  busy_time_ += rtu::transmission_time(settings_.format, frame.size());
  last_activity_ = now;
  line_free_at_ = std::max(line_free_at_, now + timing_.t3_5);
  if (!in_flight_) {
    ++errors_;
    event(nullptr, Event::PROTOCOL_ERROR, Event::WARNING, 0,
          "unsolicited " + std::to_string(frame.size()) + "-byte frame on bus " + settings_.bus + " dropped");
    return;
  }
  auto decoded = rtu::decode_response(frame, in_flight_->request);
  Drive& d = *in_flight_->drive;
  const std::string who = "drive " + d.cfg.drive + " (slave " + std::to_string(d.cfg.unit) + ")";
  if (!decoded) {
    ++errors_;
    const bool crc = decoded.error() == rtu::FrameErrc::kBadCrc;
    const std::string what =
        (crc ? "CRC error in the reply of " : "malformed reply (" + decoded.error().message() + ") from ") + who + " " +
        describe(*in_flight_);
    event(&d, Event::PROTOCOL_ERROR, Event::WARNING, decoded.error().value(), what);
    retry_or_fail(what, error_code(ReplyError::kDriveError), now);
    return;
  }
  set_online(d, true, {});
  if (const auto* exception = std::get_if<rtu::ExceptionReply>(&decoded.value().pdu)) {
    const auto code = make_error_code(exception->code);
    const std::string what = who + " refused " + describe(*in_flight_) + ": Modbus exception " +
                             std::to_string(static_cast<int>(exception->code)) + " (" + code.message() + ")";
    event(&d, Event::ERROR_REPORT, Event::ERROR, static_cast<std::int32_t>(exception->code), what);
    auto t = std::move(in_flight_);
    reply_deadline_ = kNever;
    if (t->on_fail) t->on_fail(what, error_code(ReplyError::kDriveError));
    return;
  }
  complete_in_flight(decoded.value(), now);
}

void AdamStack::complete_in_flight(const rtu::Response& response, TimePoint now) {
  auto t = std::move(in_flight_);
  reply_deadline_ = kNever;
  // A Save (§8.69) stores every register, the power-on marker too: it is written anew.
  if (t->drive != nullptr && adam::is_save(t->request)) t->drive->marker_saved = true;
  if (t->on_reply) t->on_reply(response, now, t->frame_end);
}

void AdamStack::on_timeout(TimePoint now) {
  ++timeouts_;
  Drive& d = *in_flight_->drive;
  const std::string what =
      "drive " + d.cfg.drive + " (slave " + std::to_string(d.cfg.unit) + ") did not answer " + describe(*in_flight_) +
      " within " +
      std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d.cfg.request_timeout).count()) + " ms";
  line_free_at_ = now;  // the silence has long elapsed
  retry_or_fail(what, error_code(ReplyError::kTimeout), now);
}

void AdamStack::retry_or_fail(const std::string& why, std::int32_t code, TimePoint now) {
  framer_.clear();
  reply_deadline_ = kNever;
  auto t = std::move(in_flight_);
  if (t->attempts <= t->max_retries) {
    ++retries_;
    queue_.push_front(std::move(*t));  // the same request again, before anything else
    send_next(now);
    return;
  }
  const std::string reason = why + " (" + std::to_string(t->attempts) + (t->attempts == 1 ? " attempt)" : " attempts)");
  // No reply, or only garbled ones (CRC, malformed) on every attempt: the drive cannot be heard,
  // so its last state (position, "moving") is no longer known; it is offline until a reply decodes.
  set_online(*t->drive, false, reason);
  if (t->on_fail) t->on_fail(reason, code);
}

bool AdamStack::reply_incomplete() const {
  const auto pending = framer_.pending();
  return in_flight_ && !pending.empty() && pending.size() < expected_reply_size(pending).value_or(kShortestReply);
}

TimePoint AdamStack::process(TimePoint now) {
  if (in_flight_) {
    // Bytes short of the reply's known length are not a reply yet, whatever the silence after them:
    // a USB adapter or a loaded host delivers one reply in pieces with pauses longer than t3.5, and
    // the rest (or the reply deadline) decides. The Modbus RTU rule (a frame ends at t3.5 silence)
    // still ends every frame of full length or more.
    if (!reply_incomplete()) {
      if (auto frame = framer_.take_if_silent(now)) on_reply_frame(std::move(*frame), now);
    }
  } else if (auto stray = framer_.take_if_silent(now)) {
    on_reply_frame(std::move(*stray), now);  // counted and reported as unsolicited
  }
  if (in_flight_ && now >= reply_deadline_) on_timeout(now);
  if (reserved_at_ != kNever && now >= reserved_at_ + kReservationGrace) reserved_at_ = kNever;  // the fire never came
  if (started_ && now >= next_poll_) {
    poll(now);
    // Fixed rate, but never a burst of catch-up polls after a long stall.
    next_poll_ = std::max(next_poll_ + settings_.poll_period, now);
  }
  send_next(now);

  TimePoint next = started_ ? next_poll_ : kNever;
  if (in_flight_)
    next = std::min({next, reply_deadline_, reply_incomplete() ? kNever : framer_.deadline()});
  else if (next_to_send() != queue_.end())  // none while what is queued waits for a start
    next = std::min(next,
                    reserved_at_ != kNever && now >= line_free_at_ ? reserved_at_ + kReservationGrace : line_free_at_);
  if (!in_flight_ && !framer_.pending().empty()) next = std::min(next, framer_.deadline());
  return next;
}

void AdamStack::reserve_line(TimePoint at, TimePoint /*now*/) { reserved_at_ = at; }

Duration AdamStack::line_time(const rtu::Request& request) const {
  return settings_.egress_latency + adam::transaction_time(settings_.format, request);
}

Duration AdamStack::longest_poll_read() const {
  Duration longest{};
  for (const auto& read : {position_status_read(1), outputs_alarm_read(1)})
    longest = std::max(longest, line_time(read));
  return longest;
}

void AdamStack::line_lost(const std::string& why, TimePoint now) {
  (void)now;
  line_open_ = false;
  event(nullptr, Event::OFFLINE, Event::ERROR, 0, "serial line of bus " + settings_.bus + " lost: " + why);
  std::vector<std::int64_t> ids;
  for (const auto& [id, entry] : operations_.entries()) ids.push_back(id);
  for (const auto id : ids)
    finish(id, Reply::FAILED, "serial line of bus " + settings_.bus + " lost: " + why,
           error_code(ReplyError::kTimeout));
  queue_.clear();
  in_flight_.reset();
  reply_deadline_ = kNever;
  for (auto& d : drives_) {
    d->poll_queued = false;
    set_online(*d, false, why);
  }
}

// ---- Drives and polling -------------------------------------------------------------------------

void AdamStack::start(TimePoint now) {
  started_ = true;
  line_open_ = true;
  line_free_at_ = now;
  next_poll_ = now;
  for (auto& d : drives_) run_setup(*d);
  send_next(now);
}

void AdamStack::run_setup(Drive& d) {
  Drive* drive = &d;
  drive->setup_running = true;
  const auto setup_failed = [this, drive](const std::string& reason, std::int32_t) {
    drive->setup_running = false;
    event(drive, Event::CONFIG_MISMATCH, Event::ERROR, 0, "set-up of " + drive->cfg.drive + " failed: " + reason);
  };
  Transaction power_on{adam::read(drive->cfg.unit, Reg::kProtectionBits), drive};
  power_on.on_reply = [drive](const rtu::Response& r, TimePoint, TimePoint) {
    const auto& v = std::get<rtu::ReadRegistersReply>(r.pdu).values;
    drive->enabled = (v.at(0) & static_cast<std::uint16_t>(adam::ProtectionBit::kDisabledAtPowerOn)) == 0;
  };
  power_on.on_fail = setup_failed;
  enqueue(std::move(power_on));
  for (const auto& [reg, words] : drive->cfg.setup_writes) {
    rtu::Request request{drive->cfg.unit, words.size() == 1 ? rtu::RequestPdu{rtu::WriteRegister{reg, words[0]}}
                                                            : rtu::RequestPdu{rtu::WriteRegisters{reg, words}}};
    Transaction write{request, drive};
    write.on_fail = setup_failed;
    enqueue(std::move(write));
  }
  Transaction subdivision{adam::read(drive->cfg.unit, Reg::kSubdivision), drive};
  subdivision.on_reply = [this, drive](const rtu::Response& r, TimePoint, TimePoint) {
    const auto& v = std::get<rtu::ReadRegistersReply>(r.pdu).values;
    const std::uint32_t ppr = adam::decode32(v.at(0), v.at(1));
    drive->setup_running = false;
    if (!adam::check_subdivision(ppr)) {
      event(drive, Event::CONFIG_MISMATCH, Event::ERROR, 0,
            drive->cfg.drive + " reports subdivision " + std::to_string(ppr) + " outside 200…1000000 pulses/rev");
      return;
    }
    drive->pulses_per_rev = ppr;
    drive->set_up = true;
  };
  subdivision.on_fail = setup_failed;
  enqueue(std::move(subdivision));
  read_marker(d);
}

// ---- Power-on marker ----------------------------------------------------------------------------
// The drive sends nothing when it powers up (a Modbus RTU slave only answers), but a register
// written and not saved holds its value only until power-off: the drive powers up with what was
// last saved (0x00DC, §8.69), or its default (§7 register table; §8.6 on the baud rate: "you need
// to save parameters. Otherwise ... still the factory default"). The marker is position reminder
// X19 (0x00C6, §8.53; default 1073741823, "≥ 1073741823"), which only sets status bit X19 (unused
// here) when the position passes its threshold: this stack writes one of three thresholds just
// below the default (never reached in practice) different from what it reads, and a read that no
// longer finds it shows a power-up. A Save stores it too, so after every Save the next of the
// three is written (a power cycle between the Save and that write is not caught by it). Read at
// every set-up and while the position reads 0 at rest (what a power-up leaves): at once when that
// sample is new, else at most once a second. Not caught: a power-up before it is first written.

namespace {
constexpr std::uint32_t kMarkerValues[] = {0x3FFFFFFE, 0x3FFFFFFD, 0x3FFFFFFC};
constexpr Duration kMarkerRecheck = std::chrono::seconds(1);
}  // namespace

void AdamStack::read_marker(Drive& d) {
  Drive* drive = &d;
  drive->marker_busy = true;
  Transaction t{{d.cfg.unit, rtu::ReadRegisters{adam::address(Reg::kReminderX19), 2}}, drive};
  t.on_reply = [this, drive](const rtu::Response& r, TimePoint at, TimePoint) {
    drive->marker_busy = false;
    const auto& v = std::get<rtu::ReadRegistersReply>(r.pdu).values;
    const std::uint32_t value = adam::decode32(v.at(0), v.at(1));
    drive->marker_seen = value;
    drive->marker_checked = at;
    if (!drive->marker || value == *drive->marker) return;
    powered_up(*drive,
               fmt::format("{} (slave {}) powered up, detected by its power-on marker: position reminder X19 reads "
                           "{:#010x}, not the unsaved {:#010x} written to it (lost at power-off, manual §8.53, §8.69)",
                           drive->cfg.drive, drive->cfg.unit, value, *drive->marker));
  };
  t.on_fail = [drive](const std::string&, std::int32_t) { drive->marker_busy = false; };
  enqueue(std::move(t));
}

void AdamStack::arm_marker(Drive& d) {
  Drive* drive = &d;
  const std::uint32_t after = d.marker.value_or(*d.marker_seen);
  std::uint32_t value = kMarkerValues[0];
  for (std::size_t k = 0; k + 1 < std::size(kMarkerValues); ++k) {
    if (after == kMarkerValues[k]) value = kMarkerValues[k + 1];
  }
  drive->marker_busy = true;
  Transaction t{adam::write32(d.cfg.unit, Reg::kReminderX19, value), drive};
  t.on_reply = [drive, value](const rtu::Response&, TimePoint, TimePoint) {
    drive->marker_busy = false;
    drive->marker = value;
    drive->marker_saved = false;
  };
  t.on_fail = [drive](const std::string&, std::int32_t) { drive->marker_busy = false; };
  enqueue(std::move(t));
}

void AdamStack::powered_up(Drive& d, const std::string& why) {
  fail_motion_of(d, why, error_code(ReplyError::kAxisFault));
  d.homed = false;
  d.table_entry.reset();  // its registers are back at their saved values or defaults
  d.set_up = false;       // set up again at the next poll (poll())
  d.marker.reset();
  d.marker_saved = false;
  d.power.forget();
  if (!d.cfg.axis.empty()) out_.position_lost(d.cfg.axis, why);
}

void AdamStack::poll(TimePoint now) {
  (void)now;
  const bool armed = awaiting_trigger();
  for (auto& d : drives_) {
    Drive* drive = d.get();
    if (drive->poll_queued) continue;
    if (!drive->online && armed) continue;
    // A drive that was not there at start-up (or failed its set-up) is set up once it answers.
    if (drive->online && !drive->set_up && !drive->setup_running) run_setup(*drive);
    if (drive->online && drive->set_up && !drive->marker_busy && drive->marker_seen &&
        (!drive->marker || drive->marker_saved))
      arm_marker(*drive);
    if (!drive->online && drive->ever_answered && ++drive->poll_skips % kOfflinePollDivider != 0) continue;
    drive->poll_queued = true;
    Transaction position{position_status_read(drive->cfg.unit), drive};
    position.is_poll = true;
    position.on_reply = [this, drive](const rtu::Response& r, TimePoint at, TimePoint) {
      on_position_status(*drive, std::get<rtu::ReadRegistersReply>(r.pdu).values, at);
    };
    position.on_fail = [drive](const std::string&, std::int32_t) { drive->poll_queued = false; };
    Transaction alarm{outputs_alarm_read(drive->cfg.unit), drive};
    alarm.is_poll = true;
    alarm.on_reply = [this, drive](const rtu::Response& r, TimePoint at, TimePoint) {
      drive->poll_queued = false;
      on_outputs_alarm(*drive, std::get<rtu::ReadRegistersReply>(r.pdu).values, at);
    };
    alarm.on_fail = position.on_fail;
    const bool answering = drive->online || !drive->ever_answered;
    // An offline drive gets one try per poll; a live one its configured retries.
    position.max_retries = answering ? drive->cfg.retries : 0;
    alarm.max_retries = position.max_retries;
    enqueue(std::move(position));
    enqueue(std::move(alarm));
  }
}

void AdamStack::on_position_status(Drive& d, std::span<const std::uint16_t> words, TimePoint now) {
  const std::int32_t position = adam::decode32_signed(words[0], words[1]);
  const adam::DriveStatus status = adam::decode_status(words[2], words[3]);
  if (d.position) {
    const double dt = std::chrono::duration<double>(now - d.position_time).count();
    if (dt > 0) d.velocity = (position - *d.position) / dt;
  }
  if (!status.moving()) d.velocity = 0;
  // The drive sends nothing when it powers up (Modbus RTU slaves only answer); its position
  // register starts at 0 and every register at its default (manual §7 register table), so a power
  // cycle shows in the samples only (PowerUpWatch). Not watched while a homing or preset of the
  // drive is under way (the position is set on purpose), or before it is set up.
  const bool presetting =
      std::any_of(operations_.entries().begin(), operations_.entries().end(), [&d](const auto& entry) {
        const auto& op = *entry.second.data;
        const auto kind = op.command.kind;
        return (kind == motionlcm::gateway_command_t::HOME || kind == motionlcm::gateway_command_t::SET_POSITION) &&
               std::find(op.drives.begin(), op.drives.end(), &d) != op.drives.end();
      });
  if (presetting || !d.set_up) {
    d.power.forget();
  } else if (auto why = d.power.sample(position, d.velocity, now, false)) {
    powered_up(d, fmt::format("{} (slave {}) powered up, detected by its answers: {}", d.cfg.drive, d.cfg.unit, *why));
  } else if (d.marker && !d.marker_busy && position == 0 && !status.moving() &&
             (d.position != 0 || now - d.marker_checked >= kMarkerRecheck)) {
    d.marker_checked = now;
    read_marker(d);
  }
  const bool limit_before = d.status && d.status->at_limit();
  d.position = position;
  d.position_time = now;
  d.sample_utime = wall_clock_(now);
  d.status = status;
  if (status.at_limit() && !limit_before) {
    event(&d, Event::LIMIT, Event::WARNING, status.negative_limit ? -1 : 1,
          d.cfg.drive + " at its " + (status.negative_limit ? "negative" : "positive") + " limit, position " +
              std::to_string(position));
  }
  publish_status(d);
  std::vector<Operation*> watching;
  for (auto& [id, entry] : operations_.entries()) {
    const auto& op = entry.data;
    if (op->watching && std::find(op->drives.begin(), op->drives.end(), &d) != op->drives.end())
      watching.push_back(op.get());
  }
  for (Operation* op : watching) check_motion(*op, d, now);  // may finish (erase) ops: iterate a copy
}

void AdamStack::on_outputs_alarm(Drive& d, std::span<const std::uint16_t> words, TimePoint now) {
  (void)now;
  d.outputs = words[0];
  const adam::AlarmState alarm = adam::decode_alarms(words[1]);
  const bool new_alarm = alarm.active() && alarm.current != d.alarm.current;
  d.alarm = alarm;
  if (new_alarm) {
    const std::string text = d.cfg.drive + " alarm " + std::to_string(static_cast<int>(alarm.current)) + ": " +
                             std::string(adam::alarm_text(alarm.current));
    event(&d, Event::ALARM, Event::ERROR, static_cast<std::int32_t>(alarm.current), text);
    fail_motion_of(d, text, error_code(ReplyError::kAxisFaulted));
  }
  publish_status(d);
}

void AdamStack::publish_status(const Drive& d) const {
  if (d.cfg.axis.empty()) return;
  gateway::DriveStatus s;
  s.sample_utime = d.sample_utime;
  s.position_counts = d.position.value_or(0);
  s.position_read = d.position.has_value();
  s.velocity_counts = d.velocity;
  s.target_counts = d.target;
  // Online for the axis's users once its position and status are known (a set-up reply alone
  // would publish position 0, and a relative move would be planned from it).
  s.online = d.online && d.position.has_value() && d.status.has_value();
  s.enabled = d.enabled;
  s.moving = d.status && d.status->moving();
  s.in_position = d.status && d.status->in_position;
  s.homed = d.homed;
  s.fault = d.alarm.active();
  s.fault_code = static_cast<std::int32_t>(d.alarm.current);
  s.fault_text = d.alarm.active() ? std::string(adam::alarm_text(d.alarm.current)) : std::string{};
  s.inputs = d.status ? d.status->inputs : 0;  // bit n = Xn = input n+1
  s.outputs = d.outputs & 0xFF;                // bit n = Yn = output n+1
  out_.axis_status(d.cfg.axis, s);
}

void AdamStack::set_online(Drive& d, bool online, const std::string& why) {
  if (online) d.ever_answered = true;
  if (d.online == online) return;
  d.online = online;
  d.poll_skips = 0;
  if (online) {
    event(&d, Event::ONLINE, Event::INFO, 0, d.cfg.drive + " (slave " + std::to_string(d.cfg.unit) + ") answers");
  } else {
    event(&d, Event::OFFLINE, Event::ERROR, 0,
          d.cfg.drive + " (slave " + std::to_string(d.cfg.unit) + ") offline: " + why);
  }
  publish_status(d);
}

void AdamStack::event(const Drive* d, std::int16_t kind, std::int8_t severity, std::int32_t code,
                      const std::string& text) const {
  gateway::DriveEvent e;
  e.kind = kind;
  e.severity = severity;
  e.code = code;
  e.text = text;
  out_.axis_event(d ? d->cfg.axis : std::string{}, e);
}

AdamStack::Drive* AdamStack::drive_of_axis(const std::string& axis) {
  for (auto& d : drives_) {
    if (!axis.empty() && d->cfg.axis == axis) return d.get();
  }
  return nullptr;
}

double AdamStack::rpm_of(const Drive& d, double counts_per_s) const {
  return adam::pps_to_rpm(counts_per_s, d.pulses_per_rev);
}

motionlcm::bus_stats_t AdamStack::statistics() const {
  motionlcm::bus_stats_t s{};
  s.name = settings_.bus;
  s.transport = settings_.transport;
  s.state = line_open_ ? (started_ ? "open" : "closed") : "lost";
  s.tx_frames = tx_frames_;
  s.rx_frames = rx_frames_;
  s.tx_bytes = tx_bytes_;
  s.rx_bytes = rx_bytes_;
  s.errors = errors_;
  s.timeouts = timeouts_;
  s.retries = retries_;
  if (first_activity_ != kNever && last_activity_ > first_activity_) {
    s.bus_load = std::min(1.0, std::chrono::duration<double>(busy_time_).count() /
                                   std::chrono::duration<double>(last_activity_ - first_activity_).count());
  }
  s.drives_total = static_cast<std::int32_t>(drives_.size());
  s.drives_online =
      static_cast<std::int32_t>(std::count_if(drives_.begin(), drives_.end(), [](const auto& d) { return d->online; }));
  return s;
}

bool AdamStack::ready() const {
  return started_ && line_open_ &&
         std::all_of(drives_.begin(), drives_.end(), [](const auto& d) { return d->online && d->set_up; });
}

}  // namespace motion::adam_driver
