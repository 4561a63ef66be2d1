// The gateway's one command ledger: the lifecycle of every part of a gateway command (one part per
// node/axis in a stack, one per stack in the CAN bus driver's combining), the one builder of
// gateway_reply_t, and the one injected wall clock of the stacks.
//
// Lifecycle of a part (table kLifecycleTable, rows numbered like the CiA 402 transitions):
//
//   Loading ──► Armed ──► Started ──► Done
//      │  └───────┼──────────┼──► Failed | Stopped        (terminal: no row leaves them)
//      └─────────────────────► Done (a command without arming: ENABLE, STOP, HOME, ...)
//
// The ledger replies for the command as a whole: ARMED when the last part is Armed, STARTED when
// the last part is Started, DONE when the last part is Done, FAILED at the first part that is
// Failed or Stopped (error code, reason of that part). Exactly one terminal reply goes out per
// command: a second terminal for a part, or a finish() of a command that already ended, is
// refused, counted (refused_terminals()) and never sent. A transition that is not a table row is
// refused and counted (refused_transitions()), leaving the part where it was.
//
// Thread contract: single-threaded (the owner's event-loop thread); nothing blocks; replies go out
// synchronously through the sink given at construction, from inside the call that caused them.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>

#include "motion/core/clock.hpp"
#include "motion/lcm/reply_error.hpp"

namespace motion::gateway {

// ---- the clock ---------------------------------------------------------------------------------

// Wall time (us since the epoch) of a steady `now`: the trigger_utime of STARTED replies and the
// sample_utime of statuses. Every stack takes this one shape; tests inject a deterministic one.
using WallClock = std::function<std::int64_t(TimePoint)>;
// The default: the system clock, shifted by how long ago `now` was on the steady clock.
[[nodiscard]] std::int64_t system_wall_clock(TimePoint now);
// `clock`, or system_wall_clock when it is empty.
[[nodiscard]] WallClock or_system_clock(WallClock clock);

// ---- the lifecycle -----------------------------------------------------------------------------

enum class Lifecycle : std::uint8_t { kLoading, kArmed, kStarted, kDone, kFailed, kStopped };
[[nodiscard]] std::string_view to_string(Lifecycle state);
[[nodiscard]] constexpr bool is_terminal(Lifecycle s) {
  return s == Lifecycle::kDone || s == Lifecycle::kFailed || s == Lifecycle::kStopped;
}

struct LifecycleTransition {
  std::uint8_t number;
  Lifecycle from;
  Lifecycle to;
  std::string_view when;
};

// Every legal move of a part; anything else is refused.
inline constexpr LifecycleTransition kLifecycleTable[] = {
    {1, Lifecycle::kLoading, Lifecycle::kArmed, "every request of an ARM_MOVE part answered"},
    {2, Lifecycle::kLoading, Lifecycle::kStarted, "a motion started without arming (JOG, HOME search)"},
    {3, Lifecycle::kLoading, Lifecycle::kDone, "a command without arming carried out"},
    {4, Lifecycle::kLoading, Lifecycle::kFailed, "refused, timed out or faulted while loading"},
    {5, Lifecycle::kLoading, Lifecycle::kStopped, "preempted while loading (STOP, ESTOP, DISABLE)"},
    {6, Lifecycle::kArmed, Lifecycle::kStarted, "the start frame was handed to the wire"},
    {7, Lifecycle::kArmed, Lifecycle::kFailed, "faulted or went offline while armed"},
    {8, Lifecycle::kArmed, Lifecycle::kStopped, "disarmed, stopped or e-stopped while armed"},
    {9, Lifecycle::kStarted, Lifecycle::kDone, "in position / finished"},
    {10, Lifecycle::kStarted, Lifecycle::kFailed, "faulted, stalled or timed out while moving"},
    {11, Lifecycle::kStarted, Lifecycle::kStopped, "stopped or e-stopped while moving"},
};

[[nodiscard]] constexpr std::optional<LifecycleTransition> find_transition(Lifecycle from, Lifecycle to) {
  for (const auto& row : kLifecycleTable) {
    if (row.from == from && row.to == to) return row;
  }
  return std::nullopt;
}

// The gateway_reply_t status that reports a command whose parts all reached `state`.
[[nodiscard]] constexpr std::int8_t reply_status(Lifecycle state) {
  switch (state) {
    case Lifecycle::kLoading: return motionlcm::gateway_reply_t::ACCEPTED;
    case Lifecycle::kArmed: return motionlcm::gateway_reply_t::ARMED;
    case Lifecycle::kStarted: return motionlcm::gateway_reply_t::STARTED;
    case Lifecycle::kDone: return motionlcm::gateway_reply_t::DONE;
    case Lifecycle::kFailed:
    case Lifecycle::kStopped: return motionlcm::gateway_reply_t::FAILED;
  }
  return motionlcm::gateway_reply_t::FAILED;
}
// The state a reply status reports (ACCEPTED: Loading); nullopt for an unknown status.
[[nodiscard]] std::optional<Lifecycle> lifecycle_of(std::int8_t reply_status);

// ---- the reply builder ---------------------------------------------------------------------------

// The one place a gateway_reply_t is put together. The command's id and parameter (PARAM_READ's
// result slot) come from the command; bus and utime are the Gateway's (filled in when published).
class ReplyBuilder {
 public:
  explicit ReplyBuilder(const motionlcm::gateway_command_t& command);
  explicit ReplyBuilder(std::int64_t command_id);
  // From a reply so far (a combined or held reply, an entry's template).
  explicit ReplyBuilder(motionlcm::gateway_reply_t base) : reply_(std::move(base)) {}

  ReplyBuilder& status(std::int8_t status);
  ReplyBuilder& reason(std::string reason);
  ReplyBuilder& error(std::int32_t code);
  ReplyBuilder& error(ReplyError error) { return this->error(motion::error_code(error)); }
  // FAILED with a cause and why.
  ReplyBuilder& failed(std::int32_t code, std::string reason);
  ReplyBuilder& failed(ReplyError error, std::string reason) {
    return failed(motion::error_code(error), std::move(reason));
  }
  // STARTED's timing: when the start frame went out (wall us), how, and the predicted spread.
  ReplyBuilder& started(std::int64_t trigger_utime, std::string mechanism, double predicted_skew_us);
  ReplyBuilder& param(const motionlcm::param_t& param);
  ReplyBuilder& bus(std::string bus);

  [[nodiscard]] const motionlcm::gateway_reply_t& peek() const { return reply_; }
  [[nodiscard]] motionlcm::gateway_reply_t build() const& { return reply_; }
  [[nodiscard]] motionlcm::gateway_reply_t build() && { return std::move(reply_); }

 private:
  motionlcm::gateway_reply_t reply_{};
};

// ---- the ledger ----------------------------------------------------------------------------------

using ReplySink = std::function<void(motionlcm::gateway_reply_t)>;

inline constexpr std::size_t kLifecycleStates = 6;  // Loading .. Stopped, indexed by Lifecycle

// The classes of a Failed part's error code (README "Reply error codes") the statistics keep apart
// (ledger_stats_t on LEDGER_STATS).
enum class FailureClass : std::uint8_t {
  kRefused,  // not carried out: malformed, unknown axis, outside limits, disabled, busy, unsupported,
             // position lost (1-4, 8, 17, 22)
  kFault,    // the drive faulted, stalled or hit a limit (5, 15)
  kOffline,  // the drive went offline (6)
  kTimeout,  // (13)
  kOther,    // every other code (arming failed 11, drive error 12, none 0, ...)
};
inline constexpr std::size_t kFailureClasses = 5;
[[nodiscard]] constexpr FailureClass failure_class(std::int32_t code) {
  switch (static_cast<ReplyError>(code)) {
    case ReplyError::kMalformedRequest:
    case ReplyError::kUnknownAxis:
    case ReplyError::kOutsideLimits:
    case ReplyError::kAxisDisabled:
    case ReplyError::kAxisBusy:
    case ReplyError::kUnsupported:
    case ReplyError::kPositionLost: return FailureClass::kRefused;
    case ReplyError::kAxisFaulted:
    case ReplyError::kAxisFault: return FailureClass::kFault;
    case ReplyError::kAxisOffline: return FailureClass::kOffline;
    case ReplyError::kTimeout: return FailureClass::kTimeout;
    default: return FailureClass::kOther;
  }
}

// What a ledger counted since it was made: its parts by lifecycle state, and what it refused (each
// refusal is a bug upstream or a race it absorbed). Summed over a gateway's stacks, the gateway
// publishes them (LEDGER_STATS).
struct LedgerCounters {
  std::int64_t refused_transitions = 0;  // not a table row (including leaving a terminal state)
  std::int64_t refused_terminals = 0;    // a second terminal for a part / an ended command
  std::int64_t refused_adds = 0;         // a command id already in the ledger
  // Parts by state (index: Lifecycle): `parts` those of the commands in the ledger now (a part that
  // ended stays counted until its command leaves the ledger), `entered` every part that ever
  // entered the state (Loading: every part accepted).
  std::array<std::int64_t, kLifecycleStates> parts{};
  std::array<std::int64_t, kLifecycleStates> entered{};
  std::array<std::int64_t, kFailureClasses> failed{};  // parts that entered Failed, by failure_class
  std::int64_t released = 0;                           // commands let go of by release()

  [[nodiscard]] std::int64_t now(Lifecycle s) const { return parts[static_cast<std::size_t>(s)]; }
  [[nodiscard]] std::int64_t total(Lifecycle s) const { return entered[static_cast<std::size_t>(s)]; }
  [[nodiscard]] std::int64_t failed_as(FailureClass c) const { return failed[static_cast<std::size_t>(c)]; }
  LedgerCounters& operator+=(const LedgerCounters& o) {
    refused_transitions += o.refused_transitions;
    refused_terminals += o.refused_terminals;
    refused_adds += o.refused_adds;
    for (std::size_t i = 0; i < kLifecycleStates; ++i) {
      parts[i] += o.parts[i];
      entered[i] += o.entered[i];
    }
    for (std::size_t i = 0; i < kFailureClasses; ++i) failed[i] += o.failed[i];
    released += o.released;
    return *this;
  }
};

// Parts keyed by a small index (a stack's node index, the CAN driver's stack index); `Payload` is
// what the owner keeps per command beside the lifecycle (targets, notes, the requests it waits for).
template <typename Payload = std::monostate>
class CommandLedger {
 public:
  struct Entry {
    motionlcm::gateway_command_t command;
    std::vector<std::size_t> nodes;  // one part per node, in the command's order
    std::vector<Lifecycle> parts;
    // What every reply of this command carries besides status/reason/error (set STARTED's timing
    // here before the last part starts, PARAM_READ's value before it is done).
    ReplyBuilder reply;
    Payload data{};
    std::int8_t reported = motionlcm::gateway_reply_t::ACCEPTED;  // last progress reply sent
    bool ended = false;                                           // its terminal reply went out

    [[nodiscard]] std::optional<std::size_t> slot(std::size_t node) const {
      const auto it = std::find(nodes.begin(), nodes.end(), node);
      if (it == nodes.end()) return std::nullopt;
      return static_cast<std::size_t>(it - nodes.begin());
    }
    [[nodiscard]] std::optional<Lifecycle> state_of(std::size_t node) const {
      const auto s = slot(node);
      return s ? std::optional{parts[*s]} : std::nullopt;
    }
    [[nodiscard]] bool all(Lifecycle state) const {
      return std::all_of(parts.begin(), parts.end(), [state](Lifecycle p) { return p == state; });
    }
    [[nodiscard]] bool any(Lifecycle state) const {
      return std::find(parts.begin(), parts.end(), state) != parts.end();
    }
    [[nodiscard]] bool all_terminal() const { return std::all_of(parts.begin(), parts.end(), is_terminal); }
  };

  explicit CommandLedger(ReplySink sink) : sink_(std::move(sink)) {}

  // A command with one Loading part per node (`nodes` may not repeat a node). nullptr, counted and
  // nothing stored when the id is already in the ledger.
  Entry* add(const motionlcm::gateway_command_t& command, std::vector<std::size_t> nodes, Payload data = {}) {
    if (entries_.count(command.command_id) != 0) {
      ++counters_.refused_adds;
      return nullptr;
    }
    Entry e{command, std::move(nodes), {}, ReplyBuilder(command), std::move(data)};
    e.parts.assign(e.nodes.size(), Lifecycle::kLoading);
    counters_.parts[0] += static_cast<std::int64_t>(e.parts.size());
    counters_.entered[0] += static_cast<std::int64_t>(e.parts.size());
    return &entries_.emplace(command.command_id, std::move(e)).first->second;
  }

  [[nodiscard]] Entry* find(std::int64_t id) {
    const auto it = entries_.find(id);
    return it == entries_.end() ? nullptr : &it->second;
  }
  [[nodiscard]] const Entry* find(std::int64_t id) const {
    const auto it = entries_.find(id);
    return it == entries_.end() ? nullptr : &it->second;
  }
  // The commands with a part on `node` that has not ended, by ascending id.
  [[nodiscard]] std::vector<std::int64_t> find_by_node(std::size_t node) const {
    std::vector<std::int64_t> out;
    for (const auto& [id, e] : entries_) {
      const auto s = e.state_of(node);
      if (s && !is_terminal(*s)) out.push_back(id);
    }
    return out;
  }
  [[nodiscard]] std::size_t size() const { return entries_.size(); }
  [[nodiscard]] const LedgerCounters& counters() const { return counters_; }
  // Every live command (to iterate; do not add or remove while iterating).
  [[nodiscard]] std::map<std::int64_t, Entry>& entries() { return entries_; }
  [[nodiscard]] const std::map<std::int64_t, Entry>& entries() const { return entries_; }

  // Moves the part of `node` in command `id` to `to`; replies for the command when this completes
  // a stage (see the file comment). False (counted, nothing changed, nothing sent) when there is
  // no such part or the move is not a table row. `code`/`reason`: of a Failed or Stopped part.
  bool advance(std::int64_t id, std::size_t node, Lifecycle to, std::int32_t code = 0, std::string reason = {}) {
    Entry* e = find(id);
    const auto s = e ? e->slot(node) : std::nullopt;
    if (!s) {
      ++(is_terminal(to) ? counters_.refused_terminals : counters_.refused_transitions);
      return false;
    }
    if (!find_transition(e->parts[*s], to)) {
      ++(is_terminal(e->parts[*s]) && is_terminal(to) ? counters_.refused_terminals : counters_.refused_transitions);
      return false;
    }
    move(e->parts[*s], to, code);
    settle(id, *e, to, code, std::move(reason));
    return true;
  }
  // Every part that can move to `to` does (the others stay); true when at least one moved.
  bool advance_all(std::int64_t id, Lifecycle to, std::int32_t code = 0, std::string reason = {}) {
    Entry* e = find(id);
    if (!e) {
      ++(is_terminal(to) ? counters_.refused_terminals : counters_.refused_transitions);
      return false;
    }
    bool moved = false;
    for (auto& p : e->parts) {
      if (!find_transition(p, to)) continue;
      move(p, to, code);
      moved = true;
    }
    if (!moved) {
      ++(is_terminal(to) ? counters_.refused_terminals : counters_.refused_transitions);
      return false;
    }
    settle(id, *e, to, code, std::move(reason));
    return true;
  }

  // Ends command `id` now: every part not yet ended goes to `terminal`, the one terminal reply goes
  // out (DONE; FAILED with `code` and `reason`) unless it went out already, and the entry is taken
  // out of the ledger and returned (the owner cleans up its nodes). nullopt, counted and nothing
  // sent when the command is not in the ledger (it ended before).
  std::optional<Entry> finish(std::int64_t id, Lifecycle terminal, std::int32_t code = 0, std::string reason = {}) {
    const auto it = entries_.find(id);
    if (it == entries_.end() || !is_terminal(terminal)) {
      ++counters_.refused_terminals;
      return std::nullopt;
    }
    for (auto& p : it->second.parts) {
      if (!is_terminal(p)) move(p, terminal, code);
    }
    if (!it->second.ended) send_terminal(it->second, terminal, code, std::move(reason));
    forget(it->second);
    Entry out = std::move(it->second);
    entries_.erase(it);
    return out;
  }
  // Takes out a command whose parts have all ended (after its terminal reply); nullopt otherwise.
  std::optional<Entry> take_terminal(std::int64_t id) {
    const auto it = entries_.find(id);
    if (it == entries_.end() || !it->second.all_terminal()) return std::nullopt;
    forget(it->second);
    Entry out = std::move(it->second);
    entries_.erase(it);
    return out;
  }
  // Lets go of a command whose remaining replies are not the ledger's to combine (the CAN driver
  // after a combined STARTED: each stack's DONE passes on as it comes). No reply; counted.
  void release(std::int64_t id) {
    const auto it = entries_.find(id);
    if (it == entries_.end()) return;
    ++counters_.released;
    forget(it->second);
    entries_.erase(it);
  }

  // The one FAILED reply of a command that never entered the ledger (malformed, unknown axis,
  // busy axis, an id in use); the ledger is not touched.
  void reject(const motionlcm::gateway_command_t& command, std::int32_t code, std::string reason) {
    sink_(ReplyBuilder(command).failed(code, std::move(reason)).build());
  }
  // A progress reply of its own (e.g. ACCEPTED); terminal statuses go through advance/finish.
  void progress(std::int64_t id, std::int8_t status) {
    if (Entry* e = find(id);
        e && !e->ended && status != motionlcm::gateway_reply_t::DONE && status != motionlcm::gateway_reply_t::FAILED) {
      sink_(ReplyBuilder(e->reply.peek()).status(status).build());
    }
  }

 private:
  void settle(std::int64_t id, Entry& e, Lifecycle to, std::int32_t code, std::string reason) {
    if (!e.ended) {
      if (to == Lifecycle::kFailed || to == Lifecycle::kStopped) {
        send_terminal(e, to, code, std::move(reason));
      } else if (e.all(to)) {
        if (to == Lifecycle::kDone) {
          send_terminal(e, to, 0, std::move(reason));
        } else if (reply_status(to) != e.reported) {
          e.reported = reply_status(to);
          sink_(ReplyBuilder(e.reply.peek()).status(e.reported).build());
        }
      }
    }
    if (e.all_terminal()) {
      forget(e);
      entries_.erase(id);
    }
  }
  // Every move of a part goes through here, so that the counters follow it.
  void move(Lifecycle& part, Lifecycle to, std::int32_t code) {
    --counters_.parts[static_cast<std::size_t>(part)];
    ++counters_.parts[static_cast<std::size_t>(to)];
    ++counters_.entered[static_cast<std::size_t>(to)];
    if (to == Lifecycle::kFailed) ++counters_.failed[static_cast<std::size_t>(failure_class(code))];
    part = to;
  }
  // A command leaving the ledger takes its parts out of the counts of parts now.
  void forget(const Entry& e) {
    for (const auto p : e.parts) --counters_.parts[static_cast<std::size_t>(p)];
  }
  void send_terminal(Entry& e, Lifecycle terminal, std::int32_t code, std::string reason) {
    e.ended = true;
    ReplyBuilder r(e.reply.peek());
    if (terminal == Lifecycle::kDone) {
      r.status(motionlcm::gateway_reply_t::DONE);
      if (!reason.empty()) r.reason(std::move(reason));
    } else {
      r.failed(code, std::move(reason));
    }
    sink_(std::move(r).build());
  }

  ReplySink sink_;
  std::map<std::int64_t, Entry> entries_;
  LedgerCounters counters_;
};

}  // namespace motion::gateway
