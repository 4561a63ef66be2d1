// The quiet interval around a scheduled start: see start_quiet.hpp.
#include "motion/lcm/start_quiet.hpp"

#include <algorithm>

#include "motion/core/clock.hpp"

namespace motion::lcm {

std::optional<QuietInterval> StartQuiet::interval_of(const motionlcm::sync_trigger2_t& trigger) {
  const auto n = std::min(trigger.send_utime.size(), static_cast<std::size_t>(std::max(trigger.num_buses, 0)));
  if (n == 0) return std::nullopt;
  const std::int64_t first_send =
      *std::min_element(trigger.send_utime.begin(), trigger.send_utime.begin() + static_cast<std::ptrdiff_t>(n));
  const std::int64_t until = std::max(trigger.act_utime, first_send) + kAfter.count();
  return QuietInterval{std::max(first_send - kBefore.count(), until - kLongest.count()), until};
}

StartQuiet::~StartQuiet() {
  for (const auto& [id, timer] : waiting_) loop_.cancel(timer);
}

void StartQuiet::keep(const motionlcm::sync_trigger2_t& trigger) {
  if (const auto interval = interval_of(trigger)) keep(trigger.trigger_id, *interval);
}

void StartQuiet::keep(std::int64_t trigger_id, QuietInterval interval) {
  // Wall clock in, loop clock out.
  const std::int64_t wall_now = wall_time_us();
  const auto to_loop = [&](std::int64_t utime) { return loop_.now() + std::chrono::microseconds(utime - wall_now); };
  const TimePoint until = to_loop(interval.until_utime);
  const TimePoint from = to_loop(interval.from_utime);
  if (const auto old = waiting_.find(trigger_id); old != waiting_.end()) {
    loop_.cancel(old->second);
    waiting_.erase(old);
  }
  if (from <= loop_.now()) {
    node_.quiet_until(until);
    return;
  }
  if (waiting_.size() >= kMostWaiting) {
    loop_.cancel(waiting_.begin()->second);
    waiting_.erase(waiting_.begin());
  }
  waiting_[trigger_id] = loop_.call_at(from, [this, trigger_id, until] {
    waiting_.erase(trigger_id);
    node_.quiet_until(until);
  });
}

}  // namespace motion::lcm
