// The moves a gateway holds armed for a trigger, each with a deadline: a move that no trigger
// starts in time (its coordinator died between ARM_MOVE and SYNC_TRIGGER, its DISARM was lost
// again and again, its trigger never arrived) is released by the gateway itself, exactly as a
// DISARM would release it (README "Safety and faults").
//
// The clock of a move runs from the moment its ARM_MOVE is handed to the driver; it is released
// once it is both ARMED and past its deadline (a move still loading is released the moment it
// reports ARMED late). A trigger heard for it, or its terminal reply (a DISARM, STOP, fault...),
// ends the watch. A released move's FAILED reply (the driver's answer to the gateway's own
// DISARM) is rewritten to say why (code 13, "never triggered within N ms") and a trigger heard
// later for it does nothing.
//
// Passive (now in, deadlines out), like the stacks; the Gateway owns one and sends the DISARMs.
// Thread contract: single-threaded (the gateway's loop).
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>

#include "motion/core/clock.hpp"

namespace motion::gateway {

class ArmWatch {
 public:
  struct Move {
    std::int64_t command_id = 0;
    std::int64_t trigger_id = 0;
    std::vector<std::string> axes;
    TimePoint deadline = kNever;
    bool armed = false;  // its ARMED reply went out
  };

  explicit ArmWatch(Duration expiry) : expiry_(expiry) {}
  [[nodiscard]] Duration expiry() const { return expiry_; }
  // For the moves armed from now on.
  void set_expiry(Duration expiry) { expiry_ = expiry; }

  // A command handed to the driver: an ARM_MOVE for a trigger is watched from `now` (trigger id 0
  // starts at once: nothing to watch).
  void on_command(const motionlcm::gateway_command_t& command, TimePoint now);
  // A reply of the driver, before it is published: ARMED starts the countdown's end, a terminal
  // reply or STARTED ends the watch; a FAILED of a released move gets its reason (rewritten here).
  void on_reply(motionlcm::gateway_reply_t& reply);
  // A trigger heard for this bus. False: every move it names here was released (fire nothing);
  // true otherwise, and its moves are no longer watched.
  bool on_trigger(std::int64_t trigger_id);
  // The moves ARMED and past their deadline at `now`, taken out of the watch and remembered as
  // released: the caller DISARMs each in its driver.
  [[nodiscard]] std::vector<Move> due(TimePoint now);
  // The earliest deadline of an ARMED move (kNever: none).
  [[nodiscard]] TimePoint next_deadline() const;
  // What a released move's FAILED reply and event say.
  [[nodiscard]] std::string reason(const Move& move) const;
  [[nodiscard]] std::size_t watched() const { return moves_.size(); }
  [[nodiscard]] std::int64_t released_count() const { return released_count_; }

 private:
  static constexpr std::size_t kRemembered = 64;

  Duration expiry_;
  std::map<std::int64_t, Move> moves_;            // command id -> move, until triggered or ended
  std::map<std::int64_t, std::string> released_;  // command id -> reason, until its FAILED reply
  std::deque<std::int64_t> released_triggers_;    // the triggers of released moves (recent ones)
  std::int64_t released_count_ = 0;
};

}  // namespace motion::gateway
