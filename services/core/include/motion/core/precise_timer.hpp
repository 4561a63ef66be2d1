// A one-shot timer at an absolute instant, for deadlines that must be kept to microseconds (a
// SYNC producer's period, a scheduled start frame), next to the EventLoop's own timers.
//
// On a loop running on the system steady clock (CLOCK_MONOTONIC) it is a timerfd armed with
// TFD_TIMER_ABSTIME (timerfd_create(2)): the kernel wakes the loop at the instant itself, with no
// relative timeout computed late by a busy loop, and the wake-up keeps to the thread's timer slack
// (minimal_timer_slack()). On any other clock (a ManualClock in tests), or when timerfd is not
// available, it falls back to the loop's call_at, with the same behaviour at lower precision.
//
// minimal_timer_slack(): the calling thread's timer slack to 1 ns (prctl PR_SET_TIMERSLACK; the
// default is 50 us, by which the kernel may defer any timed wake-up, ppoll's included). Returns
// false when the kernel refused it.
// fifo_scheduling(): optional SCHED_FIFO for the same purpose, where permitted.
// fair_slice(): under normal scheduling, a short slice for the same purpose, unprivileged.
//
// set_spin(d): the timerfd wakes the loop `d` before each deadline and the callback waits for the
// deadline on the clock, busy: what is left of the wake-up latency then is the time from the
// clock read to the callback, not the scheduler's. For a thread under SCHED_FIFO (elsewhere it can
// be preempted inside the wait as well as before it); it costs up to `d` of CPU per deadline.
//
// Thread contract: the loop's thread only (as EventLoop). The callback may re-arm or cancel.
#pragma once

#include <functional>
#include <optional>

#include "motion/core/clock.hpp"
#include "motion/core/event_loop.hpp"

namespace motion {

bool minimal_timer_slack();
// The calling thread under SCHED_FIFO at `priority` (1..99), where the process is permitted
// (CAP_SYS_NICE or an RLIMIT_RTPRIO); false, and nothing changed, otherwise. Only for a thread
// that blocks in its loop (a busy real-time thread starves the CPU it runs on).
bool fifo_scheduling(int priority);
// Back to SCHED_OTHER (nice 0).
void normal_scheduling();
// The calling thread's slice under normal scheduling (Linux 6.12 and later, EEVDF: the
// sched_runtime of a SCHED_OTHER thread's sched_attr, which the kernel clamps to 100 us .. 100 ms;
// 0: the kernel's default). A waking thread whose slice is shorter than the running one's
// preempts it at once instead of waiting, up to that one's slice, for it to give the CPU up. No
// privilege is needed and the nice value stays. Returns the slice the kernel reports afterwards
// (0 from a kernel without custom slices, which ignores the request), or nullopt with errno set
// when refused. Only for a thread under normal scheduling (it would end SCHED_FIFO).
std::optional<Duration> fair_slice(Duration slice);

class PreciseTimer {
 public:
  explicit PreciseTimer(EventLoop& loop);
  ~PreciseTimer();
  PreciseTimer(const PreciseTimer&) = delete;
  PreciseTimer& operator=(const PreciseTimer&) = delete;

  // Runs `callback` once at `deadline` (at once, from the loop, when it has passed); replaces any
  // pending one. kNever cancels.
  void arm(TimePoint deadline, std::function<void()> callback);
  void cancel();
  [[nodiscard]] bool armed() const { return armed_; }
  // true: a timerfd on CLOCK_MONOTONIC; false: the loop's timers.
  [[nodiscard]] bool absolute() const { return fd_ >= 0; }
  // Wake up `spin` early and wait the rest busy (see above); zero (the default): not. Only on a
  // timerfd (absolute()); from the next arm() on.
  void set_spin(Duration spin) { spin_ = spin; }

 private:
  void on_expired();

  EventLoop& loop_;
  int fd_ = -1;
  EventLoop::TimerId fallback_ = 0;
  std::function<void()> callback_;
  bool armed_ = false;
  Duration spin_{};
  TimePoint deadline_{};
};

}  // namespace motion
