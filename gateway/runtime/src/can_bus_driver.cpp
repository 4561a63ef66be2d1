#include "motion/gateway/can_bus_driver.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>

#include <motionlcm/event_t.hpp>

#include "motion/uimessage/uimessage_transport.hpp"

namespace motion::gateway {

namespace {
// How long a STARTED reply waits for its start frame's echo: far longer than a frame queued
// behind a full transmit queue at 125 kbit/s takes, short against any move.
constexpr auto kEchoWait = std::chrono::milliseconds(50);
}  // namespace

// Stacks report through this: status and events pass straight on, command replies are combined.
class CanBusDriver::Combiner final : public GatewayOutput {
 public:
  explicit Combiner(CanBusDriver& owner) : owner_(owner) {}
  void axis_status(const std::string& axis, const DriveStatus& status) override {
    owner_.out_.axis_status(axis, status);
  }
  void axis_event(const std::string& axis, const DriveEvent& event) override { owner_.out_.axis_event(axis, event); }
  void command_reply(motionlcm::gateway_reply_t reply) override { owner_.on_stack_reply(std::move(reply)); }
  void drive_facts(const std::string& axis, const DriveFacts& facts) override { owner_.out_.drive_facts(axis, facts); }
  void position_lost(const std::string& axis, const std::string& why) override { owner_.out_.position_lost(axis, why); }

 private:
  CanBusDriver& owner_;
};

CanBusDriver::CanBusDriver(EventLoop& loop, std::string bus, std::unique_ptr<can::Transport> transport,
                           GatewayOutput& out)
    : loop_(loop),
      bus_(std::move(bus)),
      transport_(std::move(transport)),
      out_(out),
      combiner_(std::make_unique<Combiner>(*this)),
      pending_([this](motionlcm::gateway_reply_t reply) {
        if (reply.status == motionlcm::gateway_reply_t::STARTED) {
          emit_started(std::move(reply));
        } else {
          out_.command_reply(std::move(reply));
        }
      }),
      timer_(loop) {
  transport_->on_bus_event([this](const can::BusEvent& e) {
    const bool off = e.state == can::BusState::kBusOff || e.state == can::BusState::kDisconnected;
    if (off == bus_off_ && e.state != can::BusState::kErrorPassive) return;
    bus_off_ = off;
    DriveEvent ev;
    ev.kind = off ? motionlcm::event_t::BUS_OFF : motionlcm::event_t::BUS_RECOVERED;
    ev.severity = off ? motionlcm::event_t::ERROR : motionlcm::event_t::INFO;
    ev.code = static_cast<std::int32_t>(e.error_class);
    ev.text = "bus " + bus_ + " " + can::to_string(e.state) + (e.text.empty() ? "" : ": " + e.text);
    out_.axis_event("", ev);
  });
  watch_uimessage_crc();
}

// A UIROBOT serial gateway's CRC coverage (docs/protocols.md, UIMessage row 1): what detection
// found is a fact about the hardware the configuration did not state, said like the other
// detected variants (INFO CONFIG_MISMATCH, bus-level).
void CanBusDriver::watch_uimessage_crc() {
  auto* ui = dynamic_cast<uimessage::UiMessageTransport*>(transport_.get());
  if (ui == nullptr) return;
  ui->on_crc_detected([this](const std::string& text) {
    spdlog::info("bus {}: {}", bus_, text);
    DriveEvent ev;
    ev.kind = motionlcm::event_t::CONFIG_MISMATCH;
    ev.severity = motionlcm::event_t::INFO;
    ev.text = "bus " + bus_ + " (uimessage_crc: detect): " + text;
    out_.axis_event("", ev);
  });
}

CanBusDriver::~CanBusDriver() {
  timer_.cancel();
  for (const auto& [id, held] : held_) loop_.cancel(held.fallback);
  if (transport_->fd() >= 0) loop_.unwatch(transport_->fd());
}

CanStackContext CanBusDriver::context() {
  CanStackContext ctx;
  ctx.out = combiner_.get();
  ctx.send = [this](const can::Frame& frame) {
    if (keeping_) {
      // Taken: its echo is awaited from now on, as if handed over (start_frame may name it).
      kept_.push_back(frame);
      if (own_echo_) echoes_.sent(frame);
      return true;
    }
    if (!hand_over(frame)) return false;
    if (own_echo_) echoes_.sent(frame);
    return true;
  };
  ctx.start_frame = [this](std::int64_t command_id, const can::Frame& frame) {
    if (CyclicJob* job = cyclic_job(frame); job != nullptr && job->running && job->first_pending) {
      job->start_commands.push_back(command_id);  // the job's first frame, sent by the kernel
      cyclic_starts_.insert(command_id);
      return;
    }
    if (own_echo_) echoes_.mark_start(command_id, frame);
  };
  if (cyclic_) {
    ctx.start_cyclic = [this](const can::Frame& frame, Duration period) { return start_cyclic(frame, period); };
    ctx.stop_cyclic = [this](const can::Frame& frame) { stop_cyclic(frame); };
    ctx.retime_cyclic = [this](const can::Frame& frame, Duration interval) { return retime_cyclic(frame, interval); };
  }
  return ctx;
}

bool CanBusDriver::hand_over(const can::Frame& frame) {
  const auto ec = transport_->send(frame);
  if (ec) {
    spdlog::debug("bus {}: send {} failed: {}", bus_, can::to_cansend(frame), ec.message());
    return false;
  }
  if (tap_) tap_(frame, true);
  return true;
}

void CanBusDriver::flush_kept() {
  const std::vector<can::Frame> kept = std::move(kept_);
  kept_.clear();
  std::size_t done = 0;
  while (done < kept.size()) {
    std::error_code error;
    const std::size_t taken = transport_->send_batch(std::span(kept).subspan(done), error);
    if (tap_) {
      for (std::size_t i = done; i < done + taken; ++i) tap_(kept[i], true);
    }
    done += taken;
    if (!error) break;
    // The stack was told it was taken: said here. A start frame's STARTED still comes, after the
    // echo wait; the stack's own timeouts follow the answers that do not come. The rest still go.
    spdlog::warn("bus {}: the transport refused {}, sent by a stack while it fired: {}", bus_,
                 can::to_cansend(kept[done]), error.message());
    ++done;
  }
}

void CanBusDriver::add_stack(std::unique_ptr<CanStack> stack) {
  for (const auto& axis : stack->axes()) stack_of_axis_[axis] = stack.get();
  stacks_.push_back(std::move(stack));
}

void CanBusDriver::start() {
  own_echo_ = !transport_->set_own_echo(true);
  if (transport_->fd() >= 0) loop_.watch(transport_->fd(), [this] { on_readable(); });
  const TimePoint now = loop_.now();
  for (auto& s : stacks_) call(s.get(), [&](CanStack& stack) { stack.start(now); });
  reschedule();
}

void CanBusDriver::on_readable() {
  const TimePoint now = loop_.now();
  const int fd_before = transport_->fd();
  std::vector<std::pair<std::int64_t, std::int64_t>> started;
  while (auto frame = transport_->receive()) {
    if (!cyclic_jobs_.empty() && take_cyclic(*frame, now)) continue;
    if (own_echo_ && echoes_.on_receive(*frame, wall_time_us(), started)) {
      for (const auto& [command_id, at] : started) release_started(command_id, at);
      started.clear();
      // Our own frame back: not a received frame, but news of the wire for stacks that pace by it.
      for (auto& s : stacks_) call(s.get(), [&](CanStack& stack) { stack.on_transmitted(*frame, now); });
      continue;
    }
    if (tap_) tap_(*frame, false);
    for (auto& s : stacks_) {
      bool taken = false;
      call(s.get(), [&](CanStack& stack) { taken = stack.on_frame(*frame, now); });
      if (taken) break;
    }
  }
  if (transport_->fd() != fd_before) {  // disconnected (or reconnected on a new fd)
    loop_.unwatch(fd_before);
    if (transport_->fd() >= 0) loop_.watch(transport_->fd(), [this] { on_readable(); });
  }
  reopen_cyclic_if_recreated();
  reschedule();
}

void CanBusDriver::hold_traffic(TimePoint from, TimePoint until) {
  hold_from_ = from;
  hold_until_ = until;
}

void CanBusDriver::reschedule() {
  const TimePoint now = loop_.now();
  if (now >= hold_from_ && now < hold_until_) {
    // The fire ends the hold and comes at hold_until_; this wakes the stacks only if it did not.
    timer_.arm(hold_until_ + std::chrono::milliseconds(1), [this] { reschedule(); });
    return;
  }
  TimePoint next = kNever;
  for (auto& s : stacks_) call(s.get(), [&](CanStack& stack) { next = std::min(next, stack.process(now)); });
  timer_.arm(next, [this] { reschedule(); });
}

void CanBusDriver::execute(const motionlcm::gateway_command_t& command) {
  std::map<CanStack*, motionlcm::gateway_command_t> parts;
  for (const auto& a : command.axes) {
    auto it = stack_of_axis_.find(a.axis);
    if (it == stack_of_axis_.end()) {
      pending_.reject(command, 0,
                      "no protocol stack drives axis '" + a.axis + "' on bus " + bus_ +
                          " (family not supported by this gateway yet)");
      return;
    }
    auto& part = parts[it->second];
    if (part.axes.empty()) {
      part = command;
      part.axes.clear();
    }
    part.axes.push_back(a);
    part.num_axes = static_cast<std::int32_t>(part.axes.size());
  }
  std::vector<std::size_t> keys;
  keys.reserve(parts.size());
  for (const auto& [stack, part] : parts) keys.push_back(part_of(stack));
  pending_.release(command.command_id);  // an id used again: the new command is the one combined
  pending_.add(command, std::move(keys));
  if (command.kind == motionlcm::gateway_command_t::ARM_MOVE) {
    auto& stacks = armed_stacks_[command.command_id];
    for (const auto& [stack, part] : parts) stacks.push_back(stack);
    if (armed_stacks_.size() > 256) armed_stacks_.erase(armed_stacks_.begin());  // never fired (disarmed, failed)
  }
  const TimePoint now = loop_.now();
  hold_until_ = TimePoint{};  // a command (a stop, above all) never waits for a start's hold
  for (auto& [stack, part] : parts) call(stack, [&, &cmd = part](CanStack& s) { s.execute(cmd, now); });
  reschedule();
}

std::size_t CanBusDriver::part_of(const CanStack* s) const {
  const auto it = std::find_if(stacks_.begin(), stacks_.end(), [s](const auto& owned) { return owned.get() == s; });
  return static_cast<std::size_t>(it - stacks_.begin());
}

void CanBusDriver::on_stack_reply(motionlcm::gateway_reply_t reply) {
  auto* entry = pending_.find(reply.command_id);
  const auto to = lifecycle_of(reply.status);
  if (entry == nullptr || !to || *to == Lifecycle::kLoading) {
    out_.command_reply(std::move(reply));  // e.g. a stack's own unsolicited reply, or after STARTED
    return;
  }
  // The part of the stack being called; a reply from outside a call (none today) takes the first
  // part that can get there.
  std::optional<std::size_t> key;
  if (calling_ != nullptr && entry->slot(part_of(calling_))) key = part_of(calling_);
  for (std::size_t k = 0; !key && k < entry->nodes.size(); ++k) {
    if (find_transition(entry->parts[k], *to)) key = entry->nodes[k];
  }
  if (!key) {
    pending_.advance(reply.command_id, part_of(calling_), *to);  // refused and counted: never sent
    return;
  }
  const std::int64_t id = reply.command_id;
  auto& same = entry->data.by_status[reply.status];
  same.push_back(reply);
  // What the combined reply of this status carries: the first stack's, and for STARTED the
  // earliest trigger time, every mechanism and the larger of the predicted and the real spread.
  ReplyBuilder combined(same.front());
  if (reply.status == motionlcm::gateway_reply_t::STARTED) {
    std::int64_t first = same.front().trigger_utime;
    std::int64_t last = first;
    std::string mechanisms;
    double skew = 0;
    for (const auto& r : same) {
      first = std::min(first, r.trigger_utime);
      last = std::max(last, r.trigger_utime);
      skew = std::max(skew, r.predicted_skew_us);
      if (mechanisms.find(r.start_mechanism) == std::string::npos)
        mechanisms += (mechanisms.empty() ? "" : "+") + r.start_mechanism;
    }
    combined.started(first, mechanisms, std::max(skew, static_cast<double>(last - first)));
  }
  entry->reply =
      *to == Lifecycle::kFailed ? ReplyBuilder(reply) : std::move(combined);  // a failure as its stack said it
  // DONE keeps the first stack's reason (the combined reply's); FAILED is this stack's.
  if (!pending_.advance(id, *key, *to, reply.error_code, *to == Lifecycle::kDone ? std::string{} : reply.reason)) {
    spdlog::warn("bus {}: command {}: a {} reply refused by the ledger (not sent)", bus_, id, to_string(*to));
    return;
  }
  // After the combined STARTED (or a failure, once no part is still loading or armed) the
  // command is no longer combined: later replies pass on as they come.
  entry = pending_.find(id);
  if (entry == nullptr) return;
  const bool past_start = std::all_of(entry->parts.begin(), entry->parts.end(),
                                      [](Lifecycle p) { return p == Lifecycle::kStarted || is_terminal(p); });
  if (past_start && (entry->ended || entry->reported == motionlcm::gateway_reply_t::STARTED)) pending_.release(id);
}

void CanBusDriver::emit_started(motionlcm::gateway_reply_t reply) {
  const std::int64_t id = reply.command_id;
  if (const auto echoed = echoed_starts_.find(id); echoed != echoed_starts_.end()) {
    reply.trigger_utime = echoed->second;
    echoed_starts_.erase(echoed);
    out_.command_reply(std::move(reply));
    return;
  }
  if ((!echoes_.working() || !echoes_.awaiting(id)) && !cyclic_starts_.contains(id)) {
    echoes_.forget(id);
    out_.command_reply(std::move(reply));  // no echo to wait for: dated at the hand-off
    return;
  }
  Held& held = held_[id];
  held.reply = std::move(reply);
  held.fallback = loop_.call_after(kEchoWait, [this, id] {
    echoes_.forget(id);
    cyclic_starts_.erase(id);
    release_started(id, 0);
  });
}

void CanBusDriver::release_started(std::int64_t command_id, std::int64_t echo_utime) {
  const auto it = held_.find(command_id);
  if (it == held_.end()) {
    // The echo beat the stack's STARTED (or the command has none): kept for it, briefly.
    if (echo_utime != 0) echoed_starts_[command_id] = echo_utime;
    if (echoed_starts_.size() > 64) echoed_starts_.erase(echoed_starts_.begin());
    return;
  }
  loop_.cancel(it->second.fallback);
  motionlcm::gateway_reply_t reply = std::move(it->second.reply);
  held_.erase(it);
  if (echo_utime != 0) reply.trigger_utime = echo_utime;
  out_.command_reply(std::move(reply));
}

void CanBusDriver::fire(std::int64_t trigger_id) { fire_ordered(trigger_id, {}); }

void CanBusDriver::prepare_fire(TimePoint at) {
  const TimePoint now = loop_.now();
  for (auto& s : stacks_) call(s.get(), [&](CanStack& stack) { stack.prepare_fire(at, now); });
  reschedule();
}

Duration CanBusDriver::start_wait() const {
  Duration longest{};
  for (const auto& s : stacks_) longest = std::max(longest, s->start_wait());
  return longest;
}

void CanBusDriver::fire_ordered(std::int64_t trigger_id, const std::vector<std::int64_t>& command_order) {
  const TimePoint now = loop_.now();
  hold_until_ = TimePoint{};
  std::vector<CanStack*> order;
  for (const auto id : command_order) {
    const auto it = armed_stacks_.find(id);
    if (it == armed_stacks_.end()) continue;
    for (CanStack* s : it->second) {
      if (std::find(order.begin(), order.end(), s) == order.end()) order.push_back(s);
    }
    armed_stacks_.erase(it);
  }
  for (auto& s : stacks_) {
    if (std::find(order.begin(), order.end(), s.get()) == order.end()) order.push_back(s.get());
  }
  out_.hold();
  keeping_ = cyclic_ == nullptr;
  for (CanStack* s : order) call(s, [&](CanStack& stack) { stack.fire(trigger_id, now); });
  keeping_ = false;
  flush_kept();
  out_.release();
  reschedule();
}

LedgerCounters CanBusDriver::ledger_counters() const {
  LedgerCounters sum;
  for (const auto& stack : stacks_) sum += stack->ledger_counters();
  const auto& own = pending_.counters();
  sum.released += own.released;
  sum.refused_transitions += own.refused_transitions;
  sum.refused_terminals += own.refused_terminals;
  sum.refused_adds += own.refused_adds;
  return sum;
}

std::vector<motionlcm::bus_stats_t> CanBusDriver::statistics() const {
  motionlcm::bus_stats_t s{};
  const auto t = transport_->statistics();
  s.name = bus_;
  s.transport = transport_->name();
  if (const auto* ui = dynamic_cast<const uimessage::UiMessageTransport*>(transport_.get()))
    s.transport += " (CRC " + ui->crc_status() + ")";
  s.state = can::to_string(transport_->state());
  s.tx_frames = static_cast<std::int64_t>(t.tx_frames);
  s.rx_frames = static_cast<std::int64_t>(t.rx_frames);
  s.tx_bytes = static_cast<std::int64_t>(t.tx_bytes);
  s.rx_bytes = static_cast<std::int64_t>(t.rx_bytes);
  s.errors = static_cast<std::int64_t>(t.errors);
  s.bus_load = t.bus_load;
  for (const auto& stack : stacks_) stack->add_statistics(s);
  return {s};
}

bool CanBusDriver::ready() const {
  if (bus_off_ || transport_->fd() < 0) return false;
  return std::all_of(stacks_.begin(), stacks_.end(), [](const auto& s) { return s->ready(); });
}

}  // namespace motion::gateway
