// Stops that are confirmed: every STOP or ESTOP the coordinator sends is watched per axis until
// the axis state reported after it shows standstill. A stop frame can be lost on the wire, a
// drive can miss or refuse it; an axis that still reports moving when its allowance has passed
// is stopped again, then e-stopped (quick stop and disable), and when even that shows no effect
// the guard gives up and says the axis could not be stopped (the operator has to cut power).
//
//   STOP   -> allowance passed, still moving -> STOP again -> still moving -> ESTOP
//          -> still moving -> given up (kUnconfirmed; kSilent when the drive has not reported
//             since the last stop, e.g. it is offline)
//   ESTOP  -> still moving -> ESTOP again -> still moving -> given up (kUnconfirmed or kSilent)
// An axis whose gateway is gone cannot confirm anything: it ends kUnreachable at once (nothing can
// be sent to it). A drive that reports offline on a live gateway is watched on (its stops repeat).
//
// Passive: time comes in as `now`, observations through a callback, and what to send next comes
// out as actions; the caller owns the wire and the timers (process() at the next deadline).
// Thread contract: one thread (the coordinator's loop).
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "motion/core/clock.hpp"

namespace motion::coordinator {

class StopGuard {
 public:
  // kTakenOver: a new request moves the axis now (forget()); its stop no longer matters.
  enum class Outcome { kStopped, kUnreachable, kUnconfirmed, kSilent, kTakenOver };
  // What is known of an axis now. `reported_since`: a state sample arrived after `since`.
  struct Observation {
    bool reachable = true;
    bool reported_since = false;
    bool moving = true;
  };
  using Observe = std::function<Observation(const std::string& axis, TimePoint since)>;

  struct Action {
    enum class Kind { kSendStop, kSendEstop, kResolved };
    Kind kind = Kind::kResolved;
    std::string axis;
    Outcome outcome = Outcome::kStopped;  // kResolved only
    int attempt = 0;                      // the stop this action sends (2, 3) or ended with
    std::string text;                     // for events and replies: what happened, in words
  };

  // Starts (or restarts, at attempt 1) watching `axis` after a stop was sent at `now`.
  // `allowance`: how long the axis may take to report standstill after one stop.
  void watch(const std::string& axis, bool emergency, TimePoint now, Duration allowance);
  // Stops watching `axis` because a new request moves it (outcome kTakenOver).
  void forget(const std::string& axis);
  // Resolves what the observations show and escalates what is overdue.
  [[nodiscard]] std::vector<Action> process(TimePoint now, const Observe& observe);

  [[nodiscard]] bool watching(const std::string& axis) const { return watched_.contains(axis); }
  // The axis needed an ESTOP it was not asked for (a STOP did not take), since its last watch().
  [[nodiscard]] bool escalated(const std::string& axis) const { return escalated_.contains(axis); }
  // How the last watch of `axis` ended, if it ended.
  [[nodiscard]] std::optional<Outcome> outcome(const std::string& axis) const;
  [[nodiscard]] std::optional<TimePoint> next_deadline() const;

 private:
  struct Watch {
    bool emergency = false;   // the first stop was an ESTOP
    int attempt = 1;          // stops sent so far
    bool estop_sent = false;  // the latest stop sent was an ESTOP
    TimePoint sent{};
    TimePoint deadline{};
    Duration allowance{};
  };
  std::map<std::string, Watch> watched_;
  std::map<std::string, Outcome> outcomes_;
  std::map<std::string, bool> escalated_;
};

}  // namespace motion::coordinator
