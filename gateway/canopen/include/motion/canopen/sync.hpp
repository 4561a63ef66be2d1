// CiA 301 §7.2.5 SYNC: codec and a passive SYNC producer.
//
// SyncProducer thread contract: single-threaded, owned by the poll loop. It reads no clock: the
// loop passes `now` and sleeps until the returned deadline.
#pragma once

#include <cstdint>
#include <functional>
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

// Hands the periodic SYNC to a sender outside the poll loop: on SocketCAN the kernel's broadcast
// manager (CAN_BCM), whose hrtimer keeps the period whatever the loop is doing. The master knows
// no transport: its owner fills these in (gateway: CanStackContext::start_cyclic/stop_cyclic).
struct SyncCyclicSender {
  // Sends `frame` now, then every `period` until stop(); replaces a running job (new phase).
  // false: refused (nothing runs; the producer sends that SYNC itself).
  std::function<bool(const can::Frame& frame, Duration period)> start;
  // Stops the job at once (nothing more goes out after the call returns).
  std::function<void()> stop;
  // Optional: the running job's interval from its next timer run on (nothing sent now, phase
  // kept); false: refused. Without it the producer does not correct the sender's drift.
  std::function<bool(Duration interval)> retime;
};

// Emits SYNC every `period` from start() on, and on demand. Fixed-rate: deadlines advance by
// exactly one period, so a late process() call does not shift later SYNCs; when a whole period
// was missed the producer skips it rather than sending a burst (every SYNC latches synchronous
// PDOs, so two back-to-back SYNCs would apply set-points twice).
//
// Cyclic mode (use_cyclic_sender(), a periodic producer without counter): the periodic SYNCs
// come from the sender. The producer keeps the schedule and says what changes: at a deadline
// where the loop would send a SYNC it starts the sender instead (whose first frame goes out at
// once), trigger_now() restarts it (one SYNC now, the period from now), stop() stops it. While
// the sender runs, sent() counts the SYNCs its owner saw on the wire (on_cyclic_sync(), from the
// frames looped back to the host), not by arithmetic: the kernel's BCM timer re-arms each period
// from the moment it ran (expiry = now + interval), so its SYNCs drift later than a fixed-rate
// schedule by its wake-up latency each period, and a count computed from start time and period
// would be off by one after enough periods. Seen frames also keep the wire's order: a SYNC
// seen before an SDO answer was on the wire before it (the stack's RPDO acceptance test relies
// on that). A SYNC is counted when seen, so sent() may lag the wire by the loop's latency, never
// lead it. The loop's cycle work (the next RPDO images) then runs just after each SYNC: the
// images have the whole period to get out before the next one.
// Drift: every kDriftWindow SYNCs seen, the producer compares their mean interval with the period
// and shortens the sender's interval by the difference (retime; between half the period and the
// period): the kernel's mean lateness is taken out of the mean period, its variation stays.
// hold_cyclic(true) hands the periodic SYNC back to the loop (the sender stops at once) while a
// SYNC must be preceded by frames of the loop's (the UC57 stack's masked start images);
// hold_cyclic(false) gives it to the sender again at the next deadline.
class SyncProducer {
 public:
  // Throws std::invalid_argument for a counter overflow of 1 or above 240.
  SyncProducer(FrameSink sink, SyncProducerConfig config);

  // Starts (or restarts) the periodic SYNC: the first goes out one period after `now`; the
  // counter restarts at 1. Returns the next deadline. In cyclic mode a running sender stops now.
  TimePoint start(TimePoint now);
  // In cyclic mode the sender stops at once.
  void stop();
  // A new period (1006h; > 0, for a periodic producer) from the next SYNC on: it goes out one new
  // period after the last one, or at the next process() when that is past. In cyclic mode the
  // sender stops and the loop starts it again, with the new period, at that deadline (the
  // interval learned for the old period is forgotten).
  void set_period(Duration period, TimePoint now);
  [[nodiscard]] bool running() const { return running_; }

  // Sends one SYNC now (e.g. the single SYNC that starts several axes together). While running,
  // the period restarts from `now`, so no SYNC follows closer than one period. Returns the next
  // deadline.
  TimePoint trigger_now(TimePoint now);

  // Sends the due SYNC, if any; returns the next deadline (kNever when stopped or aperiodic).
  // In cyclic mode: starts the sender at its deadline; after a seen SYNC the deadline is that
  // SYNC's time (the loop's cycle work is due), cleared by this call.
  TimePoint process(TimePoint now);
  [[nodiscard]] TimePoint next_deadline() const;

  // Cyclic mode for a periodic producer without counter (a counter changes the payload of every
  // SYNC; the loop keeps sending those): nothing changes before the next start(), trigger_now()
  // or deadline. Empty functions: the loop sends every SYNC (the sender, if running, stops).
  void use_cyclic_sender(SyncCyclicSender sender);
  // The sender's job is running (its SYNCs are the periodic ones).
  [[nodiscard]] bool cyclic() const { return cyclic_running_; }
  [[nodiscard]] bool cyclic_capable() const;
  // One of the sender's SYNCs was on the wire (seen by the owner at `now`). Counted also just
  // after a stop (a frame sent before the stop and read after it).
  void on_cyclic_sync(TimePoint now);
  void hold_cyclic(bool hold, TimePoint now);
  [[nodiscard]] bool cyclic_held() const { return held_; }
  // The interval the sender runs with (the period less the lateness learned), zero before any.
  [[nodiscard]] Duration cyclic_interval() const { return cyclic_interval_; }
  static constexpr std::uint32_t kDriftWindow = 100;

  [[nodiscard]] const SyncProducerConfig& config() const { return config_; }
  [[nodiscard]] std::uint64_t sent() const { return sent_; }
  [[nodiscard]] std::uint64_t skipped() const { return skipped_; }

 private:
  void emit();
  // The sender's first SYNC now; false: refused (the loop sent it).
  bool start_cyclic(TimePoint now);
  void stop_cyclic();
  void correct_drift(TimePoint now);

  FrameSink sink_;
  SyncProducerConfig config_;
  SyncCyclicSender sender_;
  bool running_ = false;
  bool cyclic_running_ = false;
  bool held_ = false;
  TimePoint deadline_ = kNever;      // loop mode: the next SYNC; cyclic: kNever while the sender runs
  TimePoint cycle_due_ = kNever;     // cyclic: a seen SYNC whose cycle work process() has not run
  TimePoint last_cyclic_ = kNever;   // cyclic: the latest SYNC the sender sent (its start or a seen one)
  Duration cyclic_interval_{};       // cyclic: what the sender was given (zero: the period)
  TimePoint window_start_ = kNever;  // cyclic: the first SYNC seen of the drift window
  std::uint32_t window_syncs_ = 0;   // cyclic: SYNCs seen since window_start_
  std::uint8_t counter_ = 1;
  std::uint64_t sent_ = 0;
  std::uint64_t skipped_ = 0;
};

}  // namespace motion::canopen
