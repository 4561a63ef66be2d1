// The Gateway's LEDGER_STATS (ledger_stats_t): its driver's command ledger counters and the commands
// it answered from its CommandMemory, published with every heartbeat.
#include "motion/gateway/gateway.hpp"

namespace motion::gateway {

motionlcm::ledger_stats_t Gateway::ledger_stats(const motionlcm::health_t& health) const {
  const LedgerCounters c = driver_ ? driver_->ledger_counters() : LedgerCounters{};
  motionlcm::ledger_stats_t m{};
  m.utime = health.utime;
  m.process = health.process;
  m.bus = bus_;
  m.uptime_s = health.uptime_s;
  const auto now = [&c](Lifecycle s) { return static_cast<std::int32_t>(c.now(s)); };
  m.now_loading = now(Lifecycle::kLoading);
  m.now_armed = now(Lifecycle::kArmed);
  m.now_started = now(Lifecycle::kStarted);
  m.now_done = now(Lifecycle::kDone);
  m.now_failed = now(Lifecycle::kFailed);
  m.now_stopped = now(Lifecycle::kStopped);
  m.accepted = c.total(Lifecycle::kLoading);
  m.armed = c.total(Lifecycle::kArmed);
  m.started = c.total(Lifecycle::kStarted);
  m.done = c.total(Lifecycle::kDone);
  m.failed = c.total(Lifecycle::kFailed);
  m.stopped = c.total(Lifecycle::kStopped);
  m.failed_refused = c.failed_as(FailureClass::kRefused);
  m.failed_fault = c.failed_as(FailureClass::kFault);
  m.failed_offline = c.failed_as(FailureClass::kOffline);
  m.failed_timeout = c.failed_as(FailureClass::kTimeout);
  m.failed_other = c.failed_as(FailureClass::kOther);
  m.repeats_answered = repeats_answered_;
  m.repeats_unanswered = repeats_unanswered_;
  m.released = c.released;
  m.refused_transitions = c.refused_transitions;
  m.refused_terminals = c.refused_terminals;
  m.refused_adds = c.refused_adds;
  return m;
}

}  // namespace motion::gateway
