// Uim342Stack (uim342_stack.hpp): configuration, construction, command bookkeeping, sending,
// polling, incoming frames and notifications, timeouts, and the public forwarding.
#include "uim342_stack_impl.hpp"

namespace motion::gateway {

// ---- configuration -------------------------------------------------------------------------------

Uim342StackConfig Uim342StackConfig::from(const config::Config& config, std::string_view bus) {
  Uim342StackConfig out;
  out.bus = std::string(bus);
  const auto* b = config.find_bus(bus);
  if (b) {
    out.bitrate = static_cast<std::uint32_t>(std::max(b->bitrate, 1));
    out.poll_period =
        std::chrono::milliseconds(b->poll_hz > 0 ? static_cast<long>(std::lround(1000.0 / b->poll_hz)) : 1000);
  }
  for (const auto& d : config.drives) {
    if (d.family != config::Family::kUim342 || d.bus != bus) continue;
    Uim342NodeConfig n;
    n.drive = d.name;
    for (const auto& a : config.axes) {
      if (a.drive != d.name) continue;
      n.axis = a.name;
      n.homing = a.homing;
      n.travel_counts = std::llround((a.limits.max_position - a.limits.min_position) * a.steps_per_unit);
    }
    n.node_id = static_cast<std::uint8_t>(d.node_id);
    n.group_id = static_cast<std::uint8_t>(d.group_id);
    n.request_timeout = std::chrono::milliseconds(d.request_timeout_ms.value_or(b ? b->request_timeout_ms : 50));
    n.retries = d.retries.value_or(b ? b->retries : 2);
    n.setup = d.setup;
    out.nodes.push_back(std::move(n));
  }
  return out;
}

// ---- the stack -----------------------------------------------------------------------------------

Uim342Stack::Impl::Impl(Uim342StackConfig c, CanStackContext ctx, WallClock wc, Counters& shared_counters)
    : config(std::move(c)),
      context(std::move(ctx)),
      wall(wc ? std::move(wc) : WallClock{system_wall_clock}),
      counters(shared_counters) {
  for (const auto& n : config.nodes) {
    Node node;
    node.cfg = n;
    nodes.push_back(std::move(node));
    exchange_time = std::max(exchange_time, poll_exchange_time(n.node_id, config.bitrate));
  }
  estimate_poll_period();
}

// Wire time of one request and its ACK to `node`, for the longest of the poll's exchanges (the
// MS[1] ACK carries 8 bytes); an upper bound for the ACK of any other instruction too.
Duration Uim342Stack::Impl::poll_exchange_time(std::uint8_t node, std::uint32_t bitrate) {
  const auto request = uim342::instruction_frame(node, rq::get(uim342::MotionStatusIndex::kKinematics));
  const auto ack = uim342::reply_frame(node, uim342::Reply{FunctionCode::kMS, uim342::MotionKinematics{-1, -1}});
  if (!request.ok() || !ack.ok()) return Duration::zero();
  return can::frame_duration(*request, bitrate) + can::frame_duration(*ack, bitrate);
}

// The poll period the bus allows: every drive polled once (two requests and their ACKs each)
// back to back on an otherwise idle bus. Longer than the configured period: said at start().
void Uim342Stack::Impl::estimate_poll_period() {
  poll_period = config.poll_period;
  const auto cycle = 2 * exchange_time * static_cast<std::int64_t>(nodes.size());  // one poll of every drive
  if (cycle <= poll_period) return;
  poll_period = cycle;
  poll_warning = fmt::format(
      "bus {}: polling {} UIM342 drives at {:.1f} Hz needs {:.0f}% of {} bit/s; each drive is polled at about "
      "{:.1f} Hz instead (polls fill the bus, commands go first)",
      config.bus, nodes.size(), 1.0 / std::chrono::duration<double>(config.poll_period).count(),
      100.0 * std::chrono::duration<double>(cycle).count() / std::chrono::duration<double>(config.poll_period).count(),
      config.bitrate, 1.0 / std::chrono::duration<double>(poll_period).count());
}

// How long a request just handed to the transport may wait for the wire: every other request
// in flight on this bus, and its ACK, may go first. Counted into its deadline so a long
// transmit queue is not taken for a silent drive.
Duration Uim342Stack::Impl::queued_wire_time() const {
  const auto in_flight = std::count_if(nodes.begin(), nodes.end(), [](const Node& n) { return n.busy(); });
  return exchange_time * in_flight;
}

void Uim342Stack::Impl::publish(Node& n, TimePoint now) {
  if (n.cfg.axis.empty()) return;
  n.status.sample_utime = wall(now);
  context.out->axis_status(n.cfg.axis, n.status);
}

void Uim342Stack::Impl::event(const Node& n, std::int16_t kind, std::int8_t severity, std::int32_t code,
                              std::string text) {
  DriveEvent e;
  e.kind = kind;
  e.severity = severity;
  e.code = code;
  e.text = std::move(text);
  context.out->axis_event(n.axis_or_drive(), e);
}

void Uim342Stack::Impl::finish(std::int64_t id, Lifecycle terminal, std::int32_t code, std::string reason) {
  auto c = commands.finish(id, terminal, code, std::move(reason));
  if (!c) return;  // ended before (its one terminal reply went out then)
  for (const auto b : c->data.holding) release_hold(b, std::nullopt);
  for (const auto b : c->data.held) release_hold(b, std::nullopt);
  for (const auto i : c->nodes) {
    Node& n = nodes[i];
    if (n.move == id) {
      n.move = 0;
      n.power.travel_ended();
    }
    // Queued (unsent) requests of this command are dropped; an outstanding one runs out.
    std::erase_if(n.queue, [id](const Request& r) { return r.command_id == id && !r.sent; });
    if (n.homing.command == id) {
      // A homing that ends early leaves no origin action armed (§5.26): IL[i] as it was.
      if (n.homing.armed && n.homing.previous)
        enqueue(i, rq::set_input_logic(n.homing.port, n.homing.previous->falling, n.homing.previous->rising), 0);
      n.homing = {};
    }
  }
}

// Every command with work on node `i` (queued requests or an active move) fails.
void Uim342Stack::Impl::fail_commands_of(std::size_t i, std::int32_t code, const std::string& reason,
                                         std::int64_t except) {
  std::set<std::int64_t> ids;
  for (const auto& r : nodes[i].queue) {
    if (r.command_id != 0 && r.command_id != except) ids.insert(r.command_id);
  }
  if (nodes[i].move != 0 && nodes[i].move != except) ids.insert(nodes[i].move);
  for (const auto id : ids) fail(id, code, reason);
}

Uim342Stack::Impl::Request& Uim342Stack::Impl::enqueue(std::size_t i, Instruction instruction, std::int64_t command_id,
                                                       bool front) {
  Request r;
  r.instruction = instruction;
  r.command_id = command_id;
  r.background = command_id == 0 && !front;  // identification, set-up, polls
  if (command_id != 0) {
    if (auto* c = commands.find(command_id)) c->data.waiting.insert(i);
  }
  auto& q = nodes[i].queue;
  // Behind the outstanding request (one at a time per node), ahead of everything queued.
  if (front) return *q.insert(q.begin() + (nodes[i].busy() ? 1 : 0), std::move(r));
  if (r.background) return q.emplace_back(std::move(r));
  // A command's request goes ahead of the polls (and set-up) not yet handed to the transport.
  const auto first_poll = std::find_if(q.begin(), q.end(), [](const Request& x) { return x.background && !x.sent; });
  return *q.insert(first_poll, std::move(r));
}

void Uim342Stack::Impl::drop_requests(std::int64_t command_id) {
  for (auto& n : nodes)
    std::erase_if(n.queue, [command_id](const Request& r) { return r.command_id == command_id && !r.sent; });
}

bool Uim342Stack::Impl::has_request_of(std::size_t i, std::int64_t command_id) const {
  return std::any_of(nodes[i].queue.begin(), nodes[i].queue.end(),
                     [command_id](const Request& r) { return r.command_id == command_id; });
}

bool Uim342Stack::Impl::transmit(std::uint8_t target, const Instruction& instruction, can::Frame* sent) {
  const auto frame = uim342::instruction_frame(target, instruction);
  if (!frame.ok() || !context.send(*frame)) return false;
  if (sent != nullptr) *sent = *frame;
  return true;
}

void Uim342Stack::Impl::pump(std::size_t i, TimePoint now) {
  Node& n = nodes[i];
  while (!n.queue.empty() && !n.queue.front().sent) {
    Request& r = n.queue.front();
    std::uint8_t target = n.cfg.node_id;
    if (r.group) {
      const auto group = r.group;  // keep alive while members are marked
      const auto free = [&](std::size_t m) {
        const auto& q = nodes[m].queue;
        return !q.empty() && q.front().group == group && !q.front().sent;
      };
      if (!std::all_of(group->members.begin(), group->members.end(), free) ||
          !std::all_of(group->bystanders.begin(), group->bystanders.end(), free))
        return;  // the last member to become free sends it
      if (!transmit(group->group_id, r.instruction)) return;
      for (const auto& list : {group->members, group->bystanders}) {
        for (const auto m : list) {
          Request& mr = nodes[m].queue.front();
          mr.sent = true;
          mr.attempts = 1;
          mr.deadline = deadline_of(nodes[m], now);
          mr.answer_due = now + kCommandAnswerWindow;
        }
      }
      on_sent(group->command_id, group->group_id, group->members, now);
      return;
    }
    if (!r.background && held_for_start(r, now)) return;
    // A node already waiting keeps its place in poll_queue (grant_polls() clears the flag first).
    if (r.background && (n.poll_waiting || !poll_may_go(now))) {
      wait_for_poll_slot(i);
      return;
    }
    can::Frame frame;
    if (!transmit(target, r.instruction, &frame)) return;  // transport refused: retried at the next process()
    r.attempts = 1;
    r.sent = true;
    r.deadline = deadline_of(n, now);
    // Without echoes, the poll is taken as on the wire once the requests in flight could have gone.
    if (r.background) {
      r.poll_seq = ++polls_handed;
      r.answer_due = now + poll_horizon();
      poll_slot = PollSlot{i, frame, echoes_seen ? r.deadline : now + queued_wire_time()};
    } else {
      r.answer_due = now + kCommandAnswerWindow;
    }
    const std::int64_t command_id = r.command_id;
    const bool is_start = r.instruction.function == FunctionCode::kBG;
    if (!uim342::expected_reply(r.instruction)) {
      // SY (never answered): done once sent.
      const Request done = std::move(r);
      n.queue.pop_front();
      completed(i, done, std::nullopt, now);
      continue;
    }
    if (is_start) on_sent(command_id, target, {i}, now);
    return;
  }
}

// A start frame (BG to `target`) of a move was handed to the transport; the driver dates the
// STARTED reply by its echo when it can (CanStackContext::start_frame).
void Uim342Stack::Impl::on_sent(std::int64_t command_id, std::uint8_t target, const std::vector<std::size_t>& parts,
                                TimePoint now) {
  Command* c = commands.find(command_id);
  if (!c || c->command.kind != gateway_command_t::ARM_MOVE) return;
  if (context.start_frame) {
    if (const auto frame = uim342::instruction_frame(target, rq::begin()); frame.ok())
      context.start_frame(command_id, *frame);
  }
  if (c->reply.peek().trigger_utime == 0) {
    c->reply.started(wall(now), c->reply.peek().start_mechanism, c->reply.peek().predicted_skew_us);
  }
  for (const auto i : parts) commands.advance(command_id, i, Lifecycle::kStarted);
}

// Set-up nodes are polled, except an armed one: it waits for its trigger with an empty queue so
// the BG goes out without delay (and nothing changes on a drive that has not started).
bool Uim342Stack::Impl::polled(const Node& n) const {
  if (n.phase != Phase::kReady && n.phase != Phase::kSetupFailed) return false;
  if (n.held_for != 0) return false;
  if (n.move == 0) return true;
  const auto* c = commands.find(n.move);
  return c == nullptr || !c->all(Lifecycle::kArmed);
}

void Uim342Stack::Impl::poll_if_due(std::size_t i, TimePoint now) {
  Node& n = nodes[i];
  if (!polled(n) || !n.queue.empty() || now < n.next_poll) return;
  n.next_poll = now + config.poll_period;  // the asked rate; the poll slot keeps it within the bus
  enqueue(i, rq::get(uim342::MotionStatusIndex::kStatus), 0);
  enqueue(i, rq::get(uim342::MotionStatusIndex::kKinematics), 0);
}

void Uim342Stack::Impl::wait_for_poll_slot(std::size_t i) {
  if (nodes[i].poll_waiting) return;
  nodes[i].poll_waiting = true;
  poll_queue.push_back(i);
}

bool Uim342Stack::Impl::poll_may_go(TimePoint now) const {
  if (poll_slot) return false;
  if (start_reserved(now)) return false;
  return std::none_of(nodes.begin(), nodes.end(), [this, now](const Node& n) {
    if (!n.busy()) return false;
    const Request& r = n.queue.front();
    // A command's answer arbitrates against the polls' frames: a drive of a high node id (a high
    // identifier, UIM342 manual §2.5) would lose to them for as long as they fill the bus.
    if (!r.background) return now < r.answer_due;
    return now < r.answer_due && r.poll_seq + (kPollsInFlight - 1) <= polls_handed;
  });
}

bool Uim342Stack::Impl::start_reserved(TimePoint now) const {
  return reserved_at != kNever && now < reserved_at + kReservationGrace && now + poll_horizon() > reserved_at;
}

bool Uim342Stack::Impl::held_for_start(const Request& r, TimePoint now) const {
  if (!start_reserved(now) || r.instruction.function == FunctionCode::kBG) return false;
  const Command* c = commands.find(r.command_id);
  return c != nullptr && c->command.kind != gateway_command_t::STOP && c->command.kind != gateway_command_t::ESTOP;
}

void Uim342Stack::Impl::grant_polls(TimePoint now) {
  while (!poll_queue.empty() && poll_may_go(now)) {
    const auto j = poll_queue.front();
    poll_queue.pop_front();
    nodes[j].poll_waiting = false;
    pump(j, now);  // takes the slot when its next request is still a poll
  }
}

void Uim342Stack::Impl::release_poll_slot(TimePoint now) {
  poll_slot.reset();
  grant_polls(now);
}

void Uim342Stack::Impl::poll_answered(std::size_t i, TimePoint now) {
  // An answered poll has been on the wire (its echo may still be on its way).
  if (poll_slot && poll_slot->node == i) poll_slot.reset();
  grant_polls(now);
}

void Uim342Stack::Impl::on_transmitted(const can::Frame& frame, TimePoint now) {
  echoes_seen = true;
  if (poll_slot && poll_slot->frame == frame) release_poll_slot(now);
}

void Uim342Stack::Impl::go_offline(std::size_t i, const std::string& reason, TimePoint now) {
  Node& n = nodes[i];
  release_hold(i, now);
  const bool was_online = n.status.online;
  const bool first_report = !n.offline_reported;
  n.offline_reported = true;
  n.phase = Phase::kOffline;
  n.status.online = false;
  n.status.moving = false;
  fail_commands_of(i, error_code(ReplyError::kAxisOffline), reason);
  n.queue.clear();
  n.backoff = n.backoff.count() == 0 ? config.offline_retry_first : std::min(n.backoff * 2, config.offline_retry_max);
  n.retry_at = now + n.backoff;
  if (first_report) {
    event(n, event_t::OFFLINE, was_online ? event_t::ERROR : event_t::WARNING, 0,
          fmt::format("{} offline: {}; retrying in {} ms", n.name(), reason, n.backoff.count()));
    publish(n, now);
  }
}

std::optional<std::size_t> Uim342Stack::Impl::node_of_id(std::uint8_t id) const {
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i].cfg.node_id == id) return i;
  }
  return std::nullopt;
}

bool Uim342Stack::Impl::on_frame(const can::Frame& frame, TimePoint now) {
  if (!frame.extended) return false;
  const auto fields = uim342::decode_can_id(frame.id);
  const auto i = fields ? node_of_id(fields->producer) : std::nullopt;
  if (!i) {
    ++counters.foreign;
    return false;
  }
  const auto message = uim342::decode_can(frame);
  const auto drive_message =
      message ? uim342::decode_drive_message(message->message) : uim342::Result<uim342::DriveMessage>(message.error());
  if (!drive_message) {
    ++counters.malformed;
    return true;
  }
  if (const auto* notification = std::get_if<uim342::Notification>(&*drive_message)) {
    ++counters.notifications;
    on_notification(*i, *notification, now);
  } else {
    on_reply(*i, message->message, std::get<uim342::Reply>(*drive_message), now);
  }
  pump(*i, now);
  return true;
}

void Uim342Stack::Impl::on_reply(std::size_t i, const uim342::Message& message, const uim342::Reply& reply,
                                 TimePoint now) {
  Node& n = nodes[i];
  const auto kind =
      n.busy() ? uim342::classify_reply(n.queue.front().instruction, message) : uim342::ReplyKind::kUnrelated;
  if (kind == uim342::ReplyKind::kAck) {
    const Request r = std::move(n.queue.front());
    n.queue.pop_front();
    if (r.background) poll_answered(i, now);
    completed(i, r, reply, now);
    return;
  }
  if (reply.function == FunctionCode::kER) {
    ++counters.error_reports;
    const auto& record = std::get<uim342::ErrorRecord>(reply.body);
    if (kind == uim342::ReplyKind::kErrorReport) {
      const Request r = std::move(n.queue.front());
      n.queue.pop_front();
      if (r.background) poll_answered(i, now);
      refused(i, r, record, now);
    } else {
      event(n, event_t::ERROR_REPORT, event_t::WARNING, record.code,
            fmt::format("{} reported {} on CW 0x{:02X}", n.name(), record.error().message(), record.control_word));
    }
    return;
  }
  ++counters.unexpected;
}

// §2.3: the instruction was not executed.
void Uim342Stack::Impl::refused(std::size_t i, const Request& r, const uim342::ErrorRecord& record, TimePoint now) {
  Node& n = nodes[i];
  const auto reason =
      fmt::format("{} refused {}: {}", n.name(), uim342::to_string(r.instruction), record.error().message());
  event(n, event_t::ERROR_REPORT, event_t::WARNING, record.code, reason);
  if (r.hold_for != 0) {  // the drive does not hold: the move starts drive by drive
    if (n.held_for == r.hold_for) release_hold(i, now);
    return;
  }
  if (r.command_id != 0) {
    fail(r.command_id, error_code(ReplyError::kDriveError), reason);
    return;
  }
  if (n.phase == Phase::kSettingUp &&
      record.code == static_cast<std::uint8_t>(uim342::DriveErrc::kNotAllowedWhileRunning)) {
    // §2.3: the motor runs (a move of a previous gateway process, whose request has ended): the
    // set-up would be refused value by value. Stopped first (ST, manual §5.12: at the stop deceleration SD), then
    // identified and set up again; still running then: stopped again.
    event(n, event_t::GATEWAY_RESTARTED, event_t::WARNING, record.code,
          fmt::format("{} runs a move nothing of this gateway started ({}): stopping it, set-up again at rest",
                      n.name(), reason));
    n.queue.clear();
    enqueue(i, rq::stop(), 0);
    n.phase = Phase::kStoppingForSetup;
    n.retry_at = now + config.reboot_wait;
    return;
  }
  if (is_marker(r)) {  // no power-on marker on this drive: its answers alone show a power-up
    if (n.phase == Phase::kSettingUp && n.queue.empty()) setup_finished(i, now);
    return;
  }
  if (n.phase == Phase::kSettingUp) {
    // A set-up value the drive does not take: the rest is applied, but ready() stays false.
    event(n, event_t::CONFIG_MISMATCH, event_t::ERROR, record.code, reason);
    n.setup_refused = true;
    if (n.queue.empty()) setup_finished(i, now);
  }
}

void Uim342Stack::Impl::on_notification(std::size_t i, const uim342::Notification& notification, TimePoint now) {
  Node& n = nodes[i];
  if (const auto* alarm = std::get_if<uim342::AlarmNotification>(&notification)) {
    const auto code = static_cast<std::int32_t>(alarm->alarm);
    const auto text = fmt::format("{}: {} (alarm 0x{:02X})", n.name(), uim342::describe(alarm->alarm), code);
    std::int16_t kind = event_t::ALARM;
    if (alarm->alarm == uim342::AlarmCode::kStall) kind = event_t::STALL;
    if (alarm->alarm == uim342::AlarmCode::kBelowLowerLimit || alarm->alarm == uim342::AlarmCode::kAboveUpperLimit)
      kind = event_t::LIMIT;
    const bool warning_only = alarm->alarm == uim342::AlarmCode::kEncoderBatteryLow;
    event(n, kind, warning_only ? event_t::WARNING : event_t::ERROR, code, text);
    if (!warning_only) {
      n.status.fault = true;
      n.status.fault_code = code;
      n.status.fault_text = uim342::describe(alarm->alarm);
      if (n.move != 0) fail(n.move, error_code(ReplyError::kAxisFault), text);
    }
    publish(n, now);
  } else if (const auto* edge = std::get_if<uim342::InputEdgeNotification>(&notification)) {
    const int bit = 1 << static_cast<int>(edge->port);
    n.status.inputs = edge->edge == uim342::Edge::kRising ? (n.status.inputs | bit) : (n.status.inputs & ~bit);
    event(n, event_t::INPUT_EDGE, event_t::INFO, static_cast<std::int32_t>(edge->code()),
          fmt::format("{}: IN{} {} edge", n.name(), static_cast<int>(edge->port) + 1,
                      edge->edge == uim342::Edge::kRising ? "rising" : "falling"));
    if (n.homing.step == Node::Homing::Step::kSearching && edge->port == n.homing.port &&
        (edge->edge == uim342::Edge::kRising) == n.homing.rising) {
      n.homing.edge_seen = true;
    }
    publish(n, now);
  } else if (const auto* reached = std::get_if<uim342::PositionReachedNotification>(&notification)) {
    // The drive's own counter at rest: a sample like a poll's, judged while its move is still the
    // current one, so a move to 0 that ran whole between two polls arrives (PowerUpWatch).
    if (auto why = powered_up(n, uim342::MotionKinematics{0, reached->position}, now)) {
      on_power_cycle(i, *why, now);
      return;
    }
    n.status.position_counts = reached->position + n.offset;
    n.status.position_read = true;
    n.status.in_position = true;
    n.status.moving = false;
    n.status.velocity_counts = 0;
    if (n.move != 0) {
      const auto* c = commands.find(n.move);
      if (c != nullptr && c->state_of(i) == Lifecycle::kStarted) arrived(i, now);
    }
    publish(n, now);
    if (n.homing.command != 0) homing_observe(i, now);
  }
}

TimePoint Uim342Stack::Impl::process(TimePoint now) {
  if (reserved_at != kNever && now >= reserved_at + kReservationGrace) reserved_at = kNever;  // no fire came
  if (poll_slot && now >= poll_slot->release_by) release_poll_slot(now);
  grant_polls(now);  // the waiting polls first, in their order
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    Node& n = nodes[i];
    if ((n.phase == Phase::kOffline || n.phase == Phase::kRebooting || n.phase == Phase::kStoppingForSetup) &&
        now >= n.retry_at)
      identify(i, now);
    if (n.busy() && now >= n.queue.front().deadline) timed_out(i, now);
    if (n.homing.command != 0 && now >= n.homing.deadline) homing_not_found(i, now);
    poll_if_due(i, now);
    pump(i, now);
  }
  grant_polls(now);  // a timeout above may have freed a place for the waiting polls
  TimePoint next = kNever;
  for (const Node& n : nodes) {
    next = std::min(next, n.homing.deadline);
    if (n.busy()) next = std::min(next, n.queue.front().deadline);
    if (n.phase == Phase::kOffline || n.phase == Phase::kRebooting || n.phase == Phase::kStoppingForSetup)
      next = std::min(next, n.retry_at);
    if (polled(n) && n.queue.empty()) next = std::min(next, n.next_poll);
    // A frame the transport refused is tried again soon (a waiting poll goes when its turn comes).
    if (!n.queue.empty() && !n.queue.front().sent && !n.poll_waiting)
      next = std::min(next, now + n.cfg.request_timeout);
  }
  if (poll_slot) next = std::min(next, poll_slot->release_by);
  if (reserved_at != kNever) next = std::min(next, reserved_at + kReservationGrace);  // what waits for it
  if (!poll_queue.empty()) {  // waiting polls go once an unanswered one no longer holds them back
    for (const Node& n : nodes) {
      if (n.busy() && n.queue.front().answer_due > now) next = std::min(next, n.queue.front().answer_due);
    }
  }
  return next;
}

void Uim342Stack::Impl::timed_out(std::size_t i, TimePoint now) {
  Node& n = nodes[i];
  Request& r = n.queue.front();
  const int tries = 1 + std::max(n.cfg.retries, 0);
  if (r.attempts < tries) {
    // A shared group BG is retried to this node alone: the others have started.
    if (transmit(n.cfg.node_id, r.instruction)) {
      r.group.reset();
      ++r.attempts;
      ++counters.retries;
      r.deadline = deadline_of(n, now);
      if (!r.background) r.answer_due = now + kCommandAnswerWindow;
      return;
    }
  }
  ++counters.timeouts;
  const auto reason = fmt::format("{} did not answer {} after {} tries", n.name(),
                                  uim342::mnemonic(r.instruction.function), r.attempts);
  event(n, event_t::TIMEOUT, event_t::WARNING, 0, reason);
  if (r.command_id != 0) fail(r.command_id, error_code(ReplyError::kTimeout), reason);
  go_offline(i, reason, now);
}

// ---- public forwarding ------------------------------------------------------------------------------

Uim342Stack::Uim342Stack(Uim342StackConfig config, CanStackContext context, WallClock wall_clock)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(context), std::move(wall_clock), counters_)) {}

Uim342Stack::Uim342Stack(const config::Config& config, std::string_view bus, CanStackContext context,
                         WallClock wall_clock)
    : Uim342Stack(Uim342StackConfig::from(config, bus), std::move(context), std::move(wall_clock)) {}

Uim342Stack::~Uim342Stack() = default;

std::vector<std::string> Uim342Stack::axes() const {
  std::vector<std::string> out;
  for (const auto& n : impl_->nodes) {
    if (!n.cfg.axis.empty()) out.push_back(n.cfg.axis);
  }
  return out;
}

void Uim342Stack::start(TimePoint now) {
  impl_->started = true;
  if (!impl_->poll_warning.empty()) {
    DriveEvent e;
    e.kind = event_t::CONFIG_MISMATCH;
    e.severity = event_t::WARNING;
    e.text = impl_->poll_warning;
    impl_->context.out->axis_event("", e);
  }
  for (std::size_t i = 0; i < impl_->nodes.size(); ++i) impl_->identify(i, now);
}

bool Uim342Stack::on_frame(const can::Frame& frame, TimePoint now) { return impl_->on_frame(frame, now); }
void Uim342Stack::on_transmitted(const can::Frame& frame, TimePoint now) { impl_->on_transmitted(frame, now); }
TimePoint Uim342Stack::process(TimePoint now) { return impl_->process(now); }
void Uim342Stack::execute(const motionlcm::gateway_command_t& command, TimePoint now) { impl_->execute(command, now); }
void Uim342Stack::fire(std::int64_t trigger_id, TimePoint now) {
  impl_->reserved_at = kNever;
  impl_->fire(trigger_id, now);
}

void Uim342Stack::prepare_fire(TimePoint at, TimePoint /*now*/) { impl_->reserved_at = at; }

Duration Uim342Stack::start_wait() const {
  // The poll's own request, the polls that may be in flight ahead of it, and the answer slack.
  return (1 + static_cast<std::int64_t>(Impl::kPollsInFlight) + Impl::kAnswerSlackExchanges) * impl_->exchange_time;
}

Duration Uim342Stack::poll_period() const { return impl_->poll_period; }

bool Uim342Stack::ready() const {
  return impl_->started && std::all_of(impl_->nodes.begin(), impl_->nodes.end(),
                                       [](const Impl::Node& n) { return n.phase == Impl::Phase::kReady; });
}

LedgerCounters Uim342Stack::ledger_counters() const { return impl_->commands.counters(); }

void Uim342Stack::add_statistics(motionlcm::bus_stats_t& stats) const {
  stats.timeouts += counters_.timeouts;
  stats.retries += counters_.retries;
  stats.errors += counters_.malformed;
  for (const auto& n : impl_->nodes) {
    if (n.status.online) ++stats.drives_online;
  }
  stats.drives_total += static_cast<std::int32_t>(impl_->nodes.size());
}

std::optional<DriveStatus> Uim342Stack::status(std::string_view axis) const {
  for (const auto& n : impl_->nodes) {
    if (n.cfg.axis == axis) return n.status;
  }
  return std::nullopt;
}

}  // namespace motion::gateway
