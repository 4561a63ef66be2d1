// The CiA 402 power drive system state machine ("device control") as data: one transition table
// carrying the CiA 402 transition numbers 0-16, used by both sides of the bus:
//  - the master: decode_state(statusword) and plan_next_command(current, target): the next
//    controlword on the shortest path through the table (see power_controller.hpp for the
//    stateful wrapper with timeouts and the fault-reset edge);
//  - a drive simulator: find_command_transition(state, previous controlword, controlword) and
//    find_event_transition(state, event), then compose_statusword(state, other bits).
//
// Sources: CiA 402 (transition list, statusword masks), UC57 manual §4.2.1 (states, controlword
// commands with their transition numbers, statusword patterns) and §4.2.2 (the 0x00/0x06/0x07/0x0F
// short form). The manual's own state diagram was lost in conversion; the transition list is CiA's.
//
// Thread contract: the table is immutable constexpr data; every function here is pure and
// thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <variant>

namespace motion::cia402 {

// The eight CiA 402 states, plus kStart: the pseudo-state before power-on (source of transition
// 0). kStart is never decoded from a statusword.
enum class State : std::uint8_t {
  kStart,
  kNotReadyToSwitchOn,
  kSwitchOnDisabled,
  kReadyToSwitchOn,
  kSwitchedOn,
  kOperationEnabled,
  kQuickStopActive,
  kFaultReactionActive,
  kFault,
};
[[nodiscard]] std::string_view to_string(State state);

// The states a statusword can show (every State but kStart), in CiA 402 order.
inline constexpr State kDecodableStates[] = {
    State::kNotReadyToSwitchOn, State::kSwitchOnDisabled, State::kReadyToSwitchOn,     State::kSwitchedOn,
    State::kOperationEnabled,   State::kQuickStopActive,  State::kFaultReactionActive, State::kFault,
};

// Statusword pattern of a state: (statusword & mask) == value. Bits 0-3, 5, 6 (UC57 §4.2.1; masks
// from CiA 402). The eight patterns are mutually exclusive.
struct StatusPattern {
  std::uint16_t mask;
  std::uint16_t value;
};
[[nodiscard]] StatusPattern status_pattern(State state);  // kStart: {0, 0}, matches nothing decoded

// The state shown by a statusword; nullopt for a word that matches no pattern (e.g. 0x0001).
[[nodiscard]] std::optional<State> decode_state(std::uint16_t statusword);

// Simulator side: the statusword of `state`, keeping the bits outside the state pattern (UC57 bits
// 7-15, bit 4) from `other_bits`. "Don't care" bits of the pattern are 0.
[[nodiscard]] std::uint16_t compose_statusword(State state, std::uint16_t other_bits = 0);

// Device-control commands of the controlword (UC57 §4.2.1 table). kSwitchOn and kDisableOperation
// share one bit pattern; the state they are sent in decides the transition.
enum class Command : std::uint8_t {
  kShutdown,
  kSwitchOn,
  kEnableOperation,
  kDisableVoltage,
  kQuickStop,
  kDisableOperation,
  kFaultReset,
};
[[nodiscard]] std::string_view to_string(Command command);

// The bits of the controlword that select the command (bits 0-3 and 7): `mask` covers the bits
// the command defines, `value` their values; the remaining bits are "X" (don't care).
// Fault reset is additionally edge-triggered: bit 7 must have been 0 in the previous controlword.
struct CommandPattern {
  std::uint16_t mask;
  std::uint16_t value;
};
[[nodiscard]] CommandPattern command_pattern(Command command);
[[nodiscard]] bool matches(Command command, std::uint16_t previous_controlword, std::uint16_t controlword);

// The controlword a master sends for a command: the pattern with every "X" bit at 0 (UC57 §4.2.2:
// 0x00, 0x06, 0x07, 0x0F; fault reset 0x80 after a word with bit 7 = 0).
[[nodiscard]] std::uint16_t controlword_for(Command command);

// Bits 0-3 and 7 belong to device control; the rest (4-6, 8-15) to the operation mode.
inline constexpr std::uint16_t kDeviceControlBits = 0x008F;
// Replaces the device-control bits of `controlword` with those of `command`, keeping the
// operation-mode bits (new set-point, abs/rel, halt...).
[[nodiscard]] std::uint16_t apply_command(std::uint16_t controlword, Command command);

// Transitions the drive takes by itself (CiA 402 transitions 0, 1, 12 (automatic variant), 13, 14).
enum class DriveEvent : std::uint8_t {
  kPowerOn,            // 0
  kInitialized,        // 1: self-test and initialisation done
  kQuickStopFinished,  // 12 (automatic variant; depends on 605Ah, which the UC57 does not list)
  kFaultDetected,      // 13
  kFaultReactionDone,  // 14
};
[[nodiscard]] std::string_view to_string(DriveEvent event);

using Trigger = std::variant<Command, DriveEvent>;

// One row of the table. A CiA transition with several triggers or (13) several source states
// has one row per trigger and source, all with the same number.
struct Transition {
  std::uint8_t number;  // CiA 402 transition number
  State from;
  State to;
  Trigger trigger;
};

// The whole table, in transition-number order (CiA 402 §"state machine"; UC57 §4.2.1).
[[nodiscard]] std::span<const Transition> transition_table();

// Drive side: the row a controlword triggers in `state`; nullopt = no transition (stay).
// `previous_controlword` is needed for the fault-reset edge. When the row leads to a state in
// which the same controlword triggers another row (0x0F in Ready to switch on: "3+4"), the
// caller applies it again.
[[nodiscard]] std::optional<Transition> find_command_transition(State state, std::uint16_t previous_controlword,
                                                                std::uint16_t controlword);
// Drive side: the row an internal event triggers in `state`; nullopt = the event has no effect.
[[nodiscard]] std::optional<Transition> find_event_transition(State state, DriveEvent event);

// Master side: the next step from `current` towards `target` on the shortest path through the
// command rows of the table. Among equally short paths, the earlier table row wins, so
// Ready to switch on -> Operation enabled goes through Switch on (0x07) as in UC57 §4.2.2.
struct PlanStep {
  enum class Kind : std::uint8_t {
    kAtTarget,      // nothing to send
    kSendCommand,   // send `command`; `transition` leads to `next`
    kWaitForDrive,  // the drive leaves `current` by itself (transitions 1, 14); `transition`, `next`
    kUnreachable,   // no command path (target kStart / Not ready / Fault reaction active / Fault)
  };
  Kind kind = Kind::kUnreachable;
  Command command = Command::kShutdown;
  std::uint8_t transition = 0;
  State next = State::kStart;
  friend bool operator==(const PlanStep&, const PlanStep&) = default;
};
[[nodiscard]] PlanStep plan_next_command(State current, State target);

}  // namespace motion::cia402
