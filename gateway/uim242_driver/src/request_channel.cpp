#include "motion/uim242_driver/request_channel.hpp"

#include <algorithm>
#include <vector>

#include <fmt/format.h>

namespace motion::uim242_driver {

RequestChannel::RequestChannel(std::function<void(std::span<const std::uint8_t>)> send, ChannelSettings settings)
    : send_(std::move(send)), settings_(settings) {}

std::string RequestChannel::describe(const Request& r) {
  const auto text = uim242::encode(r.instruction);
  return fmt::format("{} (node {}): '{}'", r.drive.empty() ? "gateway" : r.drive, r.node,
                     text ? *text : std::string{uim242::to_string(r.instruction.mnemonic)});
}

void RequestChannel::submit(Request request, bool front) {
  if (front) {
    request.urgent = true;
    queue_.push_front(std::move(request));
  } else {
    queue_.push_back(std::move(request));
  }
}

void RequestChannel::cancel(std::int64_t group) {
  if (group == 0) return;
  std::erase_if(queue_, [group](const Request& r) { return r.group == group; });
  if (in_flight_ && in_flight_->request.group == group) in_flight_->cancelled = true;
}

void RequestChannel::reset() {
  queue_.clear();
  hold_until_ = TimePoint{};
  in_flight_.reset();
  selected_ = 0;
}

std::string RequestChannel::under_way(TimePoint now) const {
  if (!in_flight_) return {};
  return describe(in_flight_->request) + (in_flight_->is_selection ? " (its ADR selection)" : "") +
         fmt::format(", on the wire {} us ago",
                     std::chrono::duration_cast<std::chrono::microseconds>(now - in_flight_->on_wire).count());
}

Duration RequestChannel::exchange_time(const uim242::Instruction& instruction, int select_node) const {
  const auto characters = [](const uim242::Instruction& in) {
    const auto text = uim242::encode(in);
    return static_cast<std::int64_t>(text ? text->size() : 16U) + kReplyCharacters;
  };
  std::int64_t chars = characters(instruction);
  if (select_node != 0) chars += characters(uim242::Instruction{uim242::Mnemonic::kADR, false, select_node, false});
  return settings_.egress_latency + settings_.character_time * chars + kReplyAllowance;
}

Duration RequestChannel::exchange_time(const Request& r) const {
  return exchange_time(r.instruction, r.node != selected_ ? r.node : 0);
}

void RequestChannel::transmit(InFlight& f, TimePoint now) {
  const uim242::Instruction instruction =
      f.is_selection ? uim242::Instruction{uim242::Mnemonic::kADR, false, f.request.node, false}
                     : f.request.instruction;
  const auto text = uim242::encode(instruction);
  ++f.attempts;
  f.deadline = now + settings_.timeout;
  if (!text) return;  // refused by the codec: times out like silence (callers only build valid forms)
  send_(std::span(reinterpret_cast<const std::uint8_t*>(text->data()), text->size()));
  ++stats_.tx_frames;
  stats_.tx_bytes += static_cast<std::int64_t>(text->size());
  // The controller acts when the last character has arrived.
  const TimePoint on_wire =
      now + settings_.egress_latency + settings_.character_time * static_cast<std::int64_t>(text->size());
  f.deadline = on_wire + settings_.timeout;
  f.on_wire = on_wire;
  if (!f.is_selection && f.request.on_sent && !f.cancelled) f.request.on_sent(on_wire);
}

TimePoint RequestChannel::process(TimePoint now) {
  if (in_flight_ && now >= in_flight_->deadline) {
    if (in_flight_->attempts <= settings_.retries) {
      ++stats_.retries;
      transmit(*in_flight_, now);
    } else {
      ++stats_.timeouts;
      selected_ = 0;  // did the gateway switch? unknown: select again next time
      const auto timeout_ms = std::chrono::duration_cast<std::chrono::milliseconds>(settings_.timeout).count();
      finish_failure(fmt::format("{}: no reply{} after {} attempt(s) of {} ms", describe(in_flight_->request),
                                 in_flight_->is_selection ? " to the gateway's 'ADR' selection" : "",
                                 in_flight_->attempts, timeout_ms),
                     true, now);
    }
  }
  if (reserved_at_ != kNever && now >= reserved_at_ + 5 * kReplyAllowance)
    reserved_at_ = kNever;  // its start never came
  while (!in_flight_ && !queue_.empty()) {
    if (now < hold_until_) return hold_until_;  // the pause after an STO
    const auto next = next_to_send();
    if (next == queue_.end()) return kNever;  // what is queued waits for the start (limit())
    if (next->not_before > now) return next->not_before;
    if (reserved_at_ != kNever && now < reserved_at_ + 5 * kReplyAllowance && now + exchange_time(*next) > reserved_at_)
      return reserved_at_ + 5 * kReplyAllowance;
    InFlight f{std::move(*next), false, 0, now, false, {}};
    queue_.erase(next);
    f.is_selection = f.request.node != 0 && f.request.node != selected_;
    in_flight_ = std::move(f);
    transmit(*in_flight_, now);
  }
  return in_flight_ ? in_flight_->deadline : kNever;
}

std::deque<Request>::iterator RequestChannel::next_to_send() {
  if (limit_ == Duration::max()) return queue_.begin();
  std::vector<int> held;  // nodes whose next request is too long to begin now
  for (auto it = queue_.begin(); it != queue_.end(); ++it) {
    const bool fits = it->urgent || exchange_time(*it) <= limit_;
    if (it->node == 0) return held.empty() && fits ? it : queue_.end();
    if (std::find(held.begin(), held.end(), it->node) != held.end()) continue;
    if (fits) return it;
    held.push_back(it->node);
  }
  return queue_.end();
}

void RequestChannel::finish_failure(const std::string& reason, bool timed_out, TimePoint now) {
  InFlight f = std::move(*in_flight_);
  in_flight_.reset();
  if (!f.cancelled && f.request.on_failure) f.request.on_failure(reason, timed_out, now);
}

bool RequestChannel::on_frame(const uim242::Frame& frame, TimePoint now) {
  ++stats_.rx_frames;
  if (!in_flight_) {
    ++stats_.unexpected;
    return false;
  }
  if (const auto error = uim242::as_error(frame)) {
    ++stats_.errors;
    if (in_flight_->is_selection) selected_ = 0;
    finish_failure(fmt::format("{}: refused with {}", describe(in_flight_->request), error->code.message()), false,
                   now);
    return true;
  }
  if (in_flight_->is_selection) {
    // `AA η D0 FF` (EXT-2501 §3.3).
    const uim242::Instruction adr{uim242::Mnemonic::kADR, false, in_flight_->request.node, false};
    if (!uim242::reply_matches(frame, adr) || frame.node != in_flight_->request.node) {
      ++stats_.unexpected;
      return false;
    }
    selected_ = in_flight_->request.node;
    in_flight_->is_selection = false;
    in_flight_->attempts = 0;
    transmit(*in_flight_, now);
    return true;
  }
  const Request& r = in_flight_->request;
  const bool quantity = uim242::reply_form(r.instruction).node_is_quantity;
  const bool from_target = quantity || r.node == 0 || frame.node == r.node;
  if (!uim242::reply_matches(frame, r.instruction) || !from_target) {
    ++stats_.unexpected;
    return false;
  }
  InFlight f = std::move(*in_flight_);
  in_flight_.reset();
  // STO (UIM242 manual #42): about 20 ms to execute, "wait 20ms before sending other instructions".
  if (f.request.instruction.mnemonic == uim242::Mnemonic::kSTO) hold_until_ = now + kStoPause;
  if (!f.cancelled && f.request.on_reply) f.request.on_reply(frame, now);
  return true;
}

}  // namespace motion::uim242_driver
