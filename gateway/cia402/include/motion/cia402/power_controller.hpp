// Master side of CiA 402 device control for one drive: brings the drive to a requested state one
// table transition at a time (state_machine.hpp), waits for each to be confirmed by the statusword,
// times out, and performs fault reset on a rising edge of controlword bit 7 (CiA 402 transition
// 15; UC57 manual §4.2.1 and appendix §7 MC_RESET: 6040h bit 7 = 0, then bit 7 = 1).
//
// Passive: it never reads a clock or touches the bus. The owner feeds every statusword it
// receives (TPDO1 or an SDO read of 6041h) and timer expiries, sends the controlwords returned in
// the Action in order, and arms a timer at Action::deadline (kNever = nothing scheduled).
// The controlwords carry only the device-control bits (0-3, 7); merge operation-mode bits with
// apply_command() when sending them together with a mode's bits.
//
// Thread contract: not thread-safe; one instance per drive, used by the thread owning that drive.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "motion/cia402/state_machine.hpp"
#include "motion/core/clock.hpp"

namespace motion::cia402 {

class PowerController {
 public:
  struct Config {
    // Longest time a transition may take to show in the statusword before the request fails.
    // Covers the automatic transitions (1, 14) as well.
    Duration state_switch_timeout = std::chrono::milliseconds(1000);
  };

  enum class Outcome : std::uint8_t {
    kIdle,         // no request
    kInProgress,   // a transition is under way (see controlwords / deadline)
    kReached,      // the drive shows the target state; the request is finished
    kTimedOut,     // the expected state did not show in time; the request is dropped
    kUnreachable,  // no command path to the target (e.g. target Fault); the request is dropped
  };

  struct Action {
    Outcome outcome = Outcome::kIdle;
    // Controlwords to send now, in this order (0, 1 or 2: a fault reset with bit 7 still high from
    // an earlier word needs 0x0000 then 0x0080).
    std::array<std::uint16_t, 2> controlword_buffer{};
    std::size_t controlword_count = 0;
    TimePoint deadline = kNever;
    std::optional<State> observed;  // the state decoded from the last statusword, if any
    std::uint8_t transition = 0;    // the transition now awaited (kInProgress)

    [[nodiscard]] std::span<const std::uint16_t> controlwords() const {
      return {controlword_buffer.data(), controlword_count};
    }
  };

  PowerController() : PowerController(Config{}) {}
  explicit PowerController(Config config) : config_(config) {}

  // Starts (or replaces) a request. Nothing is sent until the next statusword: call
  // on_statusword() with a fresh one (e.g. right after an SDO read of 6041h).
  void request(State target, TimePoint now);
  void cancel();

  // Feed every statusword received. Returns what to send and when to call on_timer().
  Action on_statusword(std::uint16_t statusword, TimePoint now);
  // Call at or after Action::deadline.
  Action on_timer(TimePoint now);

  // The controlword the controller last emitted (initially 0x0000: the UC57's 6040h default);
  // the basis of the fault-reset edge. Tell the controller about a controlword sent by someone
  // else (e.g. an RPDO carrying the mode bits) with note_controlword_sent().
  [[nodiscard]] std::uint16_t last_controlword() const { return last_controlword_; }
  void note_controlword_sent(std::uint16_t controlword) { last_controlword_ = controlword; }

  [[nodiscard]] std::optional<State> target() const { return target_; }
  [[nodiscard]] TimePoint deadline() const { return deadline_; }

 private:
  Action finish(Outcome outcome);
  Action emit(Action action, std::uint16_t controlword);

  Config config_;
  std::optional<State> target_;
  std::optional<State> observed_;
  // The transition sent (or awaited) and the state it leads to; cleared when it shows.
  std::optional<State> awaited_;
  std::optional<State> awaited_from_;
  std::uint8_t awaited_transition_ = 0;
  TimePoint deadline_ = kNever;
  std::uint16_t last_controlword_ = 0;
};

}  // namespace motion::cia402
