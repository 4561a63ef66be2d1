#include "motion/core/precise_timer.hpp"

#include <sched.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <ctime>

namespace motion {

bool minimal_timer_slack() { return ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) == 0; }

bool fifo_scheduling(int priority) {
  sched_param param{};
  param.sched_priority = priority;
  return ::sched_setscheduler(0, SCHED_FIFO, &param) == 0;
}

void normal_scheduling() {
  sched_param param{};
  param.sched_priority = 0;
  ::sched_setscheduler(0, SCHED_OTHER, &param);
}

namespace {
// The kernel's struct sched_attr, its first version (SCHED_ATTR_SIZE_VER0, 48 bytes; sched(7)):
// glibc has no wrapper for sched_getattr/sched_setattr, and <linux/sched/types.h> clashes with
// <sched.h>.
struct SchedAttr {
  std::uint32_t size = sizeof(SchedAttr);
  std::uint32_t sched_policy = 0;
  std::uint64_t sched_flags = 0;
  std::int32_t sched_nice = 0;
  std::uint32_t sched_priority = 0;
  std::uint64_t sched_runtime = 0;
  std::uint64_t sched_deadline = 0;
  std::uint64_t sched_period = 0;
};
static_assert(sizeof(SchedAttr) == 48);
}  // namespace

std::optional<Duration> fair_slice(Duration slice) {
  SchedAttr attr{};
  if (::syscall(SYS_sched_getattr, 0, &attr, sizeof attr, 0) != 0) return std::nullopt;
  if (attr.sched_policy != SCHED_OTHER) {
    errno = EPERM;  // a real-time or other policy stays as it is
    return std::nullopt;
  }
  attr.size = sizeof attr;
  attr.sched_flags = 0;
  attr.sched_runtime = static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(slice).count());
  if (::syscall(SYS_sched_setattr, 0, &attr, 0) != 0) return std::nullopt;
  SchedAttr now{};
  if (::syscall(SYS_sched_getattr, 0, &now, sizeof now, 0) != 0) return std::nullopt;
  return std::chrono::duration_cast<Duration>(std::chrono::nanoseconds(now.sched_runtime));
}

PreciseTimer::PreciseTimer(EventLoop& loop) : loop_(loop) {
  // std::chrono::steady_clock is CLOCK_MONOTONIC (libstdc++, libc++): its time points are the
  // timerfd's absolute times.
  if (dynamic_cast<const SystemSteadyClock*>(&loop_.clock()) == nullptr) return;
  fd_ = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
  if (fd_ >= 0) loop_.watch(fd_, [this] { on_expired(); });
}

PreciseTimer::~PreciseTimer() {
  loop_.cancel(fallback_);
  if (fd_ >= 0) {
    loop_.unwatch(fd_);
    ::close(fd_);
  }
}

void PreciseTimer::arm(TimePoint deadline, std::function<void()> callback) {
  cancel();
  if (deadline == kNever) return;
  callback_ = std::move(callback);
  armed_ = true;
  if (fd_ < 0) {
    fallback_ = loop_.call_at(deadline, [this] {
      fallback_ = 0;
      armed_ = false;
      auto cb = std::move(callback_);
      if (cb) cb();
    });
    return;
  }
  deadline_ = deadline;
  const auto wake = spin_ > Duration::zero() ? deadline - spin_ : deadline;
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wake.time_since_epoch()).count();
  itimerspec spec{};
  // 0 would disarm: a deadline at or before the epoch is "now".
  spec.it_value.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  spec.it_value.tv_nsec = static_cast<long>(ns % 1'000'000'000);
  if (ns <= 0) spec.it_value.tv_nsec = 1;
  ::timerfd_settime(fd_, TFD_TIMER_ABSTIME, &spec, nullptr);
}

void PreciseTimer::cancel() {
  armed_ = false;
  callback_ = nullptr;
  if (fallback_ != 0) {
    loop_.cancel(fallback_);
    fallback_ = 0;
  }
  if (fd_ >= 0) {
    const itimerspec off{};
    ::timerfd_settime(fd_, TFD_TIMER_ABSTIME, &off, nullptr);
  }
}

void PreciseTimer::on_expired() {
  std::uint64_t expirations = 0;
  if (::read(fd_, &expirations, sizeof expirations) != static_cast<ssize_t>(sizeof expirations))
    return;  // EAGAIN: cancelled meanwhile
  if (!armed_) return;
  if (spin_ > Duration::zero()) {
    // The steady clock is the timerfd's (see the constructor).
    while (SteadyClock::now() < deadline_) {
#if defined(__x86_64__) || defined(__i386__)
      __builtin_ia32_pause();
#endif
    }
  }
  armed_ = false;
  auto cb = std::move(callback_);
  callback_ = nullptr;
  if (cb) cb();
}

}  // namespace motion
