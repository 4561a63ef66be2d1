#include "motion/coordinator/stop_guard.hpp"

#include <chrono>

namespace motion::coordinator {

namespace {
std::string milliseconds(Duration d) {
  return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d).count()) + " ms";
}
}  // namespace

void StopGuard::watch(const std::string& axis, bool emergency, TimePoint now, Duration allowance) {
  watched_[axis] = Watch{emergency, 1, emergency, now, now + allowance, allowance};
  outcomes_.erase(axis);
  escalated_.erase(axis);
}

void StopGuard::forget(const std::string& axis) {
  if (watched_.erase(axis) > 0) outcomes_[axis] = Outcome::kTakenOver;
}

std::optional<StopGuard::Outcome> StopGuard::outcome(const std::string& axis) const {
  const auto it = outcomes_.find(axis);
  if (it == outcomes_.end()) return std::nullopt;
  return it->second;
}

std::optional<TimePoint> StopGuard::next_deadline() const {
  std::optional<TimePoint> next;
  for (const auto& [axis, w] : watched_) {
    if (!next || w.deadline < *next) next = w.deadline;
  }
  return next;
}

std::vector<StopGuard::Action> StopGuard::process(TimePoint now, const Observe& observe) {
  std::vector<Action> out;
  for (auto it = watched_.begin(); it != watched_.end();) {
    const std::string& axis = it->first;
    Watch& w = it->second;
    const Observation seen = observe(axis, w.sent);
    auto resolve = [&](Outcome outcome, std::string text) {
      out.push_back({Action::Kind::kResolved, axis, outcome, w.attempt, std::move(text)});
      outcomes_[axis] = outcome;
      it = watched_.erase(it);
    };
    if (!seen.reachable) {
      resolve(Outcome::kUnreachable, "axis " + axis + " cannot confirm its stop: its gateway or drive is offline");
      continue;
    }
    if (seen.reported_since && !seen.moving) {
      resolve(Outcome::kStopped, w.attempt == 1
                                     ? "axis " + axis + " stopped"
                                     : "axis " + axis + " stopped after " + std::to_string(w.attempt) + " stops");
      continue;
    }
    if (now < w.deadline) {
      ++it;
      continue;
    }
    const std::string late = "axis " + axis + " still " +
                             (seen.reported_since ? "reports moving " : "has not reported ") +
                             milliseconds(now - w.sent) + " after " + (w.estop_sent ? "an e-stop" : "a stop");
    if (w.attempt >= 3 || (w.emergency && w.attempt >= 2)) {
      if (seen.reported_since) {
        resolve(Outcome::kUnconfirmed, late + "; giving up: it could not be stopped, cut its power");
      } else {
        resolve(Outcome::kSilent, late + "; giving up: its stop cannot be confirmed while it does not report");
      }
      continue;
    }
    ++w.attempt;
    // The third stop of a STOP sequence is an ESTOP; an ESTOP sequence repeats its ESTOP.
    const bool estop = w.emergency || w.attempt == 3;
    if (estop && !w.emergency) escalated_[axis] = true;
    w.estop_sent = estop;
    w.sent = now;
    w.deadline = now + w.allowance;
    out.push_back({estop ? Action::Kind::kSendEstop : Action::Kind::kSendStop, axis, Outcome::kStopped, w.attempt,
                   late + (estop ? "; e-stopping it (quick stop, then disable)" : "; stopping it again")});
    ++it;
  }
  return out;
}

}  // namespace motion::coordinator
