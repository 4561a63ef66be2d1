// CiA 301 §7.2.5 SYNC: codec and a passive SYNC producer.
//
// SyncProducer thread contract: single-threaded, owned by the poll loop. It reads no clock: the
// loop passes `now` and sleeps until the returned deadline.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/types.hpp"
#include "motion/core/clock.hpp"

namespace motion::canopen {

// 1019h synchronous counter overflow value: 0 = no counter byte, 2..240 = counter 1..value.
inline constexpr std::uint8_t kMinSyncCounterOverflow = 2;
inline constexpr std::uint8_t kMaxSyncCounterOverflow = 240;

struct SyncMessage {
  std::optional<std::uint8_t> counter;  // 1..240 when the producer runs with a counter
  friend constexpr bool operator==(const SyncMessage&, const SyncMessage&) = default;
};

[[nodiscard]] can::Frame encode_sync(const SyncMessage& message, std::uint32_t cob_id = kSyncCobId);
// 0 bytes (no counter) or 1 byte holding a counter of 1..240.
[[nodiscard]] std::optional<SyncMessage> decode_sync(std::span<const std::uint8_t> payload);

struct SyncProducerConfig {
  Duration period{};                  // 1006h; zero = no periodic SYNC (trigger_now() only)
  std::uint8_t counter_overflow = 0;  // 1019h; 0 or 2..240
  std::uint32_t cob_id = kSyncCobId;  // 1005h
};

// Emits SYNC every `period` from start() on, and on demand. Fixed-rate: deadlines advance by
// exactly one period, so a late process() call does not shift later SYNCs; when a whole period
// was missed the producer skips it rather than sending a burst (every SYNC latches synchronous
// PDOs, so two back-to-back SYNCs would apply set-points twice).
class SyncProducer {
 public:
  // Throws std::invalid_argument for a counter overflow of 1 or above 240.
  SyncProducer(FrameSink sink, SyncProducerConfig config);

  // Starts (or restarts) the periodic SYNC: the first goes out one period after `now`; the
  // counter restarts at 1. Returns the next deadline.
  TimePoint start(TimePoint now);
  void stop();
  [[nodiscard]] bool running() const { return running_; }

  // Sends one SYNC now (e.g. the single SYNC that starts several axes together). While running,
  // the period restarts from `now`, so no SYNC follows closer than one period. Returns the next
  // deadline.
  TimePoint trigger_now(TimePoint now);

  // Sends the due SYNC, if any; returns the next deadline (kNever when stopped or aperiodic).
  TimePoint process(TimePoint now);
  [[nodiscard]] TimePoint next_deadline() const { return running_ ? deadline_ : kNever; }

  [[nodiscard]] const SyncProducerConfig& config() const { return config_; }
  [[nodiscard]] std::uint64_t sent() const { return sent_; }
  [[nodiscard]] std::uint64_t skipped() const { return skipped_; }

 private:
  void emit();

  FrameSink sink_;
  SyncProducerConfig config_;
  bool running_ = false;
  TimePoint deadline_ = kNever;
  std::uint8_t counter_ = 1;
  std::uint64_t sent_ = 0;
  std::uint64_t skipped_ = 0;
};

}  // namespace motion::canopen
