#include "motion/canopen/sync.hpp"

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
  deadline_ = config_.period > Duration::zero() ? now + config_.period : kNever;
  return next_deadline();
}

void SyncProducer::stop() {
  running_ = false;
  deadline_ = kNever;
}

TimePoint SyncProducer::trigger_now(TimePoint now) {
  emit();
  if (running_ && config_.period > Duration::zero()) deadline_ = now + config_.period;
  return next_deadline();
}

TimePoint SyncProducer::process(TimePoint now) {
  if (!running_ || now < deadline_) return next_deadline();
  emit();
  deadline_ += config_.period;
  if (deadline_ <= now) {
    const auto missed = (now - deadline_) / config_.period + 1;
    skipped_ += static_cast<std::uint64_t>(missed);
    deadline_ += missed * config_.period;
  }
  return deadline_;
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
