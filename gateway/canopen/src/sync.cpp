#include "motion/canopen/sync.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>

#include "frame_util.hpp"

namespace motion::canopen {

can::Frame encode_sync(const SyncMessage& message, std::uint32_t cob_id) {
  if (!message.counter) return detail::standard_frame(cob_id, {});
  const std::array<std::uint8_t, 1> payload{*message.counter};
  return detail::standard_frame(cob_id, payload);
}

std::optional<SyncMessage> decode_sync(std::span<const std::uint8_t> payload) {
  if (payload.empty()) return SyncMessage{};
  if (payload.size() != 1 || payload[0] == 0 || payload[0] > kMaxSyncCounterOverflow) return std::nullopt;
  return SyncMessage{payload[0]};
}

SyncProducer::SyncProducer(FrameSink sink, SyncProducerConfig config) : sink_(std::move(sink)), config_(config) {
  if (config_.counter_overflow == 1 || config_.counter_overflow > kMaxSyncCounterOverflow) {
    throw std::invalid_argument("SYNC counter overflow must be 0 or 2..240");
  }
  if (config_.period < Duration::zero()) throw std::invalid_argument("SYNC period must not be negative");
}

TimePoint SyncProducer::start(TimePoint now) {
  running_ = true;
  counter_ = 1;
  stop_cyclic();
  deadline_ = config_.period > Duration::zero() ? now + config_.period : kNever;
  return next_deadline();
}

void SyncProducer::stop() {
  running_ = false;
  stop_cyclic();
  deadline_ = kNever;
  cycle_due_ = kNever;
}

void SyncProducer::set_period(Duration period, TimePoint now) {
  if (period <= Duration::zero() || config_.period <= Duration::zero())
    throw std::invalid_argument("SYNC period: only a periodic producer's period changes, to a positive one");
  if (period == config_.period) return;
  TimePoint last = deadline_ == kNever ? now : deadline_ - config_.period;
  if (cyclic_running_) {
    stop_cyclic();
    last = last_cyclic_;
  }
  config_.period = period;
  cyclic_interval_ = Duration::zero();
  if (running_) deadline_ = std::max(last + period, now);
}

TimePoint SyncProducer::next_deadline() const { return running_ ? std::min(deadline_, cycle_due_) : kNever; }

TimePoint SyncProducer::trigger_now(TimePoint now) {
  if (running_ && cyclic_capable() && !held_ && start_cyclic(now)) {
    deadline_ = kNever;  // the sender's SYNC went out now; its period restarts from it
    return next_deadline();
  }
  emit();
  if (running_ && config_.period > Duration::zero()) deadline_ = now + config_.period;
  return next_deadline();
}

TimePoint SyncProducer::process(TimePoint now) {
  if (!running_) return kNever;
  if (cycle_due_ <= now) cycle_due_ = kNever;  // the caller has run the cycle of the SYNC seen
  if (now < deadline_) return next_deadline();
  if (cyclic_capable() && !held_ && start_cyclic(now)) {
    deadline_ = kNever;
    return next_deadline();
  }
  emit();
  deadline_ += config_.period;
  if (deadline_ <= now) {
    const auto missed = (now - deadline_) / config_.period + 1;
    skipped_ += static_cast<std::uint64_t>(missed);
    deadline_ += missed * config_.period;
  }
  return next_deadline();
}

bool SyncProducer::cyclic_capable() const {
  return sender_.start && sender_.stop && config_.period > Duration::zero() && config_.counter_overflow == 0;
}

void SyncProducer::use_cyclic_sender(SyncCyclicSender sender) {
  const bool held = held_;
  if (cyclic_running_) hold_cyclic(true, last_cyclic_);  // the job stops, the loop goes on
  sender_ = std::move(sender);
  held_ = held;
  cyclic_interval_ = Duration::zero();
}

void SyncProducer::on_cyclic_sync(TimePoint now) {
  ++sent_;
  last_cyclic_ = now;
  if (!running_ || !cyclic_running_) return;
  cycle_due_ = now;
  correct_drift(now);
}

void SyncProducer::correct_drift(TimePoint now) {
  if (!sender_.retime) return;
  if (window_start_ == kNever) {
    window_start_ = now;
    window_syncs_ = 0;
    return;
  }
  if (++window_syncs_ < kDriftWindow) return;
  const Duration mean = (now - window_start_) / kDriftWindow;
  window_start_ = now;
  window_syncs_ = 0;
  const Duration current = cyclic_interval_ > Duration::zero() ? cyclic_interval_ : config_.period;
  const Duration next = std::clamp(current - (mean - config_.period), config_.period / 2, config_.period);
  if (std::chrono::abs(next - current) < std::chrono::microseconds(1)) return;
  if (sender_.retime(next)) cyclic_interval_ = next;
}

void SyncProducer::hold_cyclic(bool hold, TimePoint now) {
  held_ = hold;
  if (!hold || !cyclic_running_) return;
  stop_cyclic();
  // The loop takes over one period after the sender's latest SYNC (seen, so the real one was
  // earlier), or one period from now when that is past: no SYNC closer than a period.
  if (!running_) return;
  deadline_ = last_cyclic_ + config_.period;
  if (deadline_ <= now) deadline_ = now + config_.period;
}

bool SyncProducer::start_cyclic(TimePoint now) {
  window_start_ = kNever;  // the first SYNC seen opens the drift window
  const Duration interval = cyclic_interval_ > Duration::zero() ? cyclic_interval_ : config_.period;
  if (!sender_.start(encode_sync({}, config_.cob_id), interval)) {
    stop_cyclic();  // a refused replacement may have left the previous job running
    return false;
  }
  cyclic_running_ = true;
  last_cyclic_ = now;
  return true;
}

void SyncProducer::stop_cyclic() {
  if (!cyclic_running_) return;
  cyclic_running_ = false;
  sender_.stop();
}

void SyncProducer::emit() {
  SyncMessage message;
  if (config_.counter_overflow != 0) {
    message.counter = counter_;
    counter_ = counter_ >= config_.counter_overflow ? std::uint8_t{1} : static_cast<std::uint8_t>(counter_ + 1);
  }
  ++sent_;
  if (sink_) sink_(encode_sync(message, config_.cob_id));
}

}  // namespace motion::canopen
