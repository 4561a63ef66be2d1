#include "motion/simbus/bus.hpp"

#include <algorithm>
#include <set>
#include <tuple>

namespace motion::simbus {
namespace {

bool valid(const can::Frame& f) {
  return f.dlc <= 8 && f.id <= (f.extended ? can::kMaxExtendedId : can::kMaxStandardId);
}

std::uint64_t payload_bytes(const can::Frame& f) { return f.rtr ? 0 : f.dlc; }

Fault make_fault(Fault::Action action, std::uint64_t frames, std::vector<can::Filter> match) {
  Fault f;
  f.action = action;
  f.frames = frames;
  f.match = std::move(match);
  return f;
}

}  // namespace

Fault Fault::drop(std::uint64_t frames, std::vector<can::Filter> match) {
  return make_fault(Action::kDrop, frames, std::move(match));
}
Fault Fault::corrupt(std::uint64_t frames, std::vector<can::Filter> match) {
  return make_fault(Action::kCorrupt, frames, std::move(match));
}
Fault Fault::delay_by(Duration delay, std::uint64_t frames, std::vector<can::Filter> match) {
  Fault f = make_fault(Action::kDelay, frames, std::move(match));
  f.delay = delay;
  return f;
}

Bus::Bus(BusConfig config) : config_(config) {
  if (config_.bitrate == 0) config_.bitrate = 500'000;
}

EndpointId Bus::attach(std::string label, bool own_echo) {
  const EndpointId id = next_endpoint_++;
  Endpoint e;
  e.info.id = id;
  e.info.label = std::move(label);
  e.info.own_echo = own_echo;
  endpoints_.emplace(id, std::move(e));
  return id;
}

void Bus::detach(EndpointId id) {
  if (endpoints_.erase(id) > 0) purge_queue(id);
}

bool Bus::set_own_echo(EndpointId id, bool enabled) {
  Endpoint* e = find_endpoint(id);
  if (e == nullptr) return false;
  e->info.own_echo = enabled;
  return true;
}

std::optional<EndpointInfo> Bus::endpoint(EndpointId id) const {
  const auto it = endpoints_.find(id);
  if (it == endpoints_.end()) return std::nullopt;
  return it->second.info;
}

std::optional<EndpointId> Bus::find(std::string_view label) const {
  for (const auto& [id, e] : endpoints_) {
    if (e.info.label == label) return id;
  }
  return std::nullopt;
}

std::vector<EndpointInfo> Bus::endpoints() const {
  std::vector<EndpointInfo> out;
  out.reserve(endpoints_.size());
  for (const auto& [id, e] : endpoints_) out.push_back(e.info);
  return out;
}

Bus::Endpoint* Bus::find_endpoint(EndpointId id) {
  const auto it = endpoints_.find(id);
  return it == endpoints_.end() ? nullptr : &it->second;
}

std::error_code Bus::submit(EndpointId from, const can::Frame& frame, TimePoint now) {
  if (!valid(frame)) return std::make_error_code(std::errc::invalid_argument);
  Endpoint* sender = find_endpoint(from);
  if (sender == nullptr) return std::make_error_code(std::errc::not_connected);
  if (sender->info.state == can::BusState::kBusOff) {
    ++sender->info.rejected;
    ++stats_.rejected;
    return std::make_error_code(std::errc::network_down);
  }
  if (queue_.size() >= config_.max_queued) {
    ++sender->info.rejected;
    ++stats_.rejected;
    return std::make_error_code(std::errc::no_buffer_space);
  }
  // Not before the sender's previous frame: send times taken from different clocks (a batch's
  // one hand-over stamp converted again for each frame) must not reorder an endpoint's frames.
  sender->last_queued = std::max(sender->last_queued, now);
  Queued q{next_seq_++, from, frame, sender->last_queued};
  q.frame.timestamp_us = 0;
  if (config_.timing) {
    // In time order: a frame read late (queued at its send time) goes before those queued after it.
    const auto at = std::upper_bound(queue_.begin(), queue_.end(), q.queued_at,
                                     [](TimePoint t, const Queued& other) { return t < other.queued_at; });
    queue_.insert(at, q);
    return {};
  }
  // No wire: the frame is complete the moment it is sent.
  const Fate fate = fate_of(q);
  if (fate.drop) return {};
  const std::uint32_t bits = can::frame_bits(q.frame).total;
  occupy(bits, now);
  complete(q, fate, bits, now);
  return {};
}

void Bus::advance(TimePoint now, BusSink& sink) {
  recover_due(now);
  run_wire(now);
  emit_due(now, sink);
}

void Bus::run_wire(TimePoint now) {
  while (true) {
    if (on_wire_) {
      if (on_wire_->end_of_frame > now) return;
      const OnWire done = *on_wire_;
      on_wire_.reset();
      complete(done.frame, done.fate, done.bits, done.end_of_frame);
      continue;
    }
    if (queue_.empty()) return;
    // Queue is in time order, so its front waited longest.
    const TimePoint start = std::max(wire_free_at_, queue_.front().queued_at);
    if (start > now) return;
    Queued winner = take_winner(start);
    const Fate fate = fate_of(winner);
    if (fate.drop) continue;
    const can::FrameBits bits = can::frame_bits(winner.frame);
    occupy(bits.total, start);
    on_wire_ = OnWire{winner, fate, bits.total, start + can::bits_duration(bits.to_end_of_frame(), config_.bitrate)};
  }
}

Bus::Queued Bus::take_winner(TimePoint start) {
  // Contenders: the oldest waiting frame of each endpoint, among those already waiting when the
  // wire frees (or when the first one arrived). An endpoint sends its own frames in submission
  // order, as a SocketCAN interface does (FIFO queue discipline, one frame in the controller): a
  // SYNC queued after RPDOs must not overtake them by its higher priority.
  auto best = queue_.begin();
  std::uint64_t best_key = can::arbitration_key(best->frame);
  std::set<EndpointId> seen{best->from};
  for (auto it = std::next(queue_.begin()); it != queue_.end() && it->queued_at <= start; ++it) {
    if (!seen.insert(it->from).second) continue;  // not the head of its endpoint's queue
    const std::uint64_t key = can::arbitration_key(it->frame);
    if (key < best_key) {  // strict: equal fields keep submission order
      best = it;
      best_key = key;
    }
  }
  Queued winner = *best;
  queue_.erase(best);
  return winner;
}

Bus::Fate Bus::fate_of(const Queued& q) {
  Fate fate;
  for (auto it = faults_.begin(); it != faults_.end(); ++it) {
    Fault& f = it->second;
    if (f.sender && *f.sender != q.from) continue;
    if (!can::passes(f.match, q.frame)) continue;
    switch (f.action) {
      case Fault::Action::kDrop: fate.drop = true; break;
      case Fault::Action::kCorrupt: fate.corrupt = true; break;
      case Fault::Action::kDelay: fate.delay = f.delay; break;
    }
    if (f.frames != Fault::kUnlimited && --f.frames == 0) faults_.erase(it);
    break;
  }
  if (fate.drop) ++stats_.dropped;
  return fate;
}

void Bus::occupy(std::uint32_t bits, TimePoint start) {
  const TimePoint end = start + can::bits_duration(bits, config_.bitrate);
  wire_free_at_ = std::max(wire_free_at_, end);
  busy_.emplace_back(start, end);
  while (!busy_.empty() && busy_.front().second < start - config_.load_window) busy_.pop_front();
}

void Bus::complete(const Queued& q, const Fate& fate, std::uint32_t bits, TimePoint end_of_frame) {
  ++stats_.frames;
  stats_.bytes += payload_bytes(q.frame);
  stats_.bits += bits;
  if (fate.corrupt) {
    ++stats_.errors;
    schedule(end_of_frame, EventOut{0,
                                    can::BusEvent{can::BusState::kErrorActive, kErrorProtocol,
                                                  "CRC error: corrupted frame " + can::to_cansend(q.frame)},
                                    true});
    return;
  }
  if (Endpoint* sender = find_endpoint(q.from)) ++sender->info.tx_frames;
  FrameOut out{q.from, q.frame};
  const TimePoint received = end_of_frame + fate.delay;
  out.frame.timestamp_us = to_epoch_us(received);
  schedule(received, out);
}

void Bus::schedule(TimePoint at, Output output) {
  outputs_.emplace(std::make_pair(at, next_seq_++), std::move(output));
}

void Bus::recover_due(TimePoint now) {
  for (auto& [id, e] : endpoints_) {
    if (e.recover_at <= now) recover(id, e.recover_at);
  }
}

void Bus::emit_due(TimePoint now, BusSink& sink) {
  while (!outputs_.empty() && outputs_.begin()->first.first <= now) {
    const Output output = std::move(outputs_.begin()->second);
    outputs_.erase(outputs_.begin());
    if (const auto* f = std::get_if<FrameOut>(&output)) {
      for (auto& [id, e] : endpoints_) {
        const bool own = id == f->from;
        if ((own && !e.info.own_echo) || e.info.state == can::BusState::kBusOff) continue;
        ++e.info.rx_frames;
        sink.deliver(id, f->frame, own);
      }
      continue;
    }
    const auto& ev = std::get<EventOut>(output);
    for (auto& [id, e] : endpoints_) {
      if (ev.to != 0 && ev.to != id) continue;
      can::BusEvent event = ev.event;
      if (ev.error_frame) {
        // An error frame: reported with each receiver's own state.
        ++e.info.errors;
        event.state = e.info.state;
      }
      sink.notify(id, event);
    }
  }
}

TimePoint Bus::next_deadline() const {
  TimePoint next = kNever;
  if (on_wire_) {
    next = on_wire_->end_of_frame;
  } else if (!queue_.empty()) {
    next = std::max(wire_free_at_, queue_.front().queued_at);
  }
  if (!outputs_.empty()) next = std::min(next, outputs_.begin()->first.first);
  for (const auto& [id, e] : endpoints_) next = std::min(next, e.recover_at);
  return next;
}

FaultId Bus::inject(Fault fault) {
  const FaultId id = next_fault_++;
  faults_.emplace(id, std::move(fault));
  return id;
}

bool Bus::clear_fault(FaultId id) { return faults_.erase(id) > 0; }

void Bus::clear_faults() { faults_.clear(); }

bool Bus::set_bus_off(EndpointId id, TimePoint now, std::optional<Duration> recover_after) {
  Endpoint* e = find_endpoint(id);
  if (e == nullptr) return false;
  if (e->info.state != can::BusState::kBusOff) {
    e->info.state = can::BusState::kBusOff;
    ++e->info.bus_off_count;
    purge_queue(id);
    schedule(now, EventOut{id, can::BusEvent{can::BusState::kBusOff, kErrorBusOff, "bus-off (fault injection)"}});
  }
  e->recover_at = recover_after ? now + *recover_after : kNever;
  return true;
}

bool Bus::recover(EndpointId id, TimePoint now) {
  Endpoint* e = find_endpoint(id);
  if (e == nullptr) return false;
  e->recover_at = kNever;
  if (e->info.state != can::BusState::kBusOff) return true;
  e->info.state = can::BusState::kErrorActive;
  schedule(now, EventOut{id, can::BusEvent{can::BusState::kErrorActive, kErrorRestarted, "restarted after bus-off"}});
  return true;
}

void Bus::purge_queue(EndpointId from) {
  const auto removed = std::erase_if(queue_, [&](const Queued& q) { return q.from == from; });
  stats_.rejected += removed;
  if (Endpoint* e = find_endpoint(from)) e->info.rejected += removed;
}

BusStatistics Bus::statistics(TimePoint now) const {
  BusStatistics s = stats_;
  s.queued = queue_.size();
  const TimePoint window_start = now - config_.load_window;
  Duration busy{};
  for (const auto& [start, end] : busy_) {
    const TimePoint from = std::max(start, window_start);
    const TimePoint to = std::min(end, now);
    if (to > from) busy += to - from;
  }
  const double load = std::chrono::duration<double>(busy) / std::chrono::duration<double>(config_.load_window);
  s.bus_load = std::clamp(load, 0.0, 1.0);
  return s;
}

std::int64_t Bus::to_epoch_us(TimePoint t) const {
  return config_.epoch_offset_us + std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
}

}  // namespace motion::simbus
