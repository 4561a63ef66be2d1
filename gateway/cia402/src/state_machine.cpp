#include "motion/cia402/state_machine.hpp"

#include <array>
#include <cstddef>

#include "motion/cia402/words.hpp"

namespace motion::cia402 {
namespace {

using enum State;
using C = Command;
using E = DriveEvent;

// CiA 402 transitions 0-16. Several triggers (7, 10, 12) or several source states (13) give one
// row each. Row order matters only as the planner's tie-break: the Switch on row of transition 3
// precedes its "3+4" Enable operation row so that the planner follows UC57 §4.2.2 (06, 07, 0F).
constexpr std::array kTable{
    Transition{0, kStart, kNotReadyToSwitchOn, E::kPowerOn},
    Transition{1, kNotReadyToSwitchOn, kSwitchOnDisabled, E::kInitialized},
    Transition{2, kSwitchOnDisabled, kReadyToSwitchOn, C::kShutdown},
    Transition{3, kReadyToSwitchOn, kSwitchedOn, C::kSwitchOn},
    Transition{3, kReadyToSwitchOn, kSwitchedOn, C::kEnableOperation},  // first half of "3+4"
    Transition{4, kSwitchedOn, kOperationEnabled, C::kEnableOperation},
    Transition{5, kOperationEnabled, kSwitchedOn, C::kDisableOperation},
    Transition{6, kSwitchedOn, kReadyToSwitchOn, C::kShutdown},
    Transition{7, kReadyToSwitchOn, kSwitchOnDisabled, C::kDisableVoltage},
    Transition{7, kReadyToSwitchOn, kSwitchOnDisabled, C::kQuickStop},
    Transition{8, kOperationEnabled, kReadyToSwitchOn, C::kShutdown},
    Transition{9, kOperationEnabled, kSwitchOnDisabled, C::kDisableVoltage},
    Transition{10, kSwitchedOn, kSwitchOnDisabled, C::kDisableVoltage},
    Transition{10, kSwitchedOn, kSwitchOnDisabled, C::kQuickStop},
    Transition{11, kOperationEnabled, kQuickStopActive, C::kQuickStop},
    Transition{12, kQuickStopActive, kSwitchOnDisabled, C::kDisableVoltage},
    Transition{12, kQuickStopActive, kSwitchOnDisabled, E::kQuickStopFinished},
    Transition{13, kNotReadyToSwitchOn, kFaultReactionActive, E::kFaultDetected},
    Transition{13, kSwitchOnDisabled, kFaultReactionActive, E::kFaultDetected},
    Transition{13, kReadyToSwitchOn, kFaultReactionActive, E::kFaultDetected},
    Transition{13, kSwitchedOn, kFaultReactionActive, E::kFaultDetected},
    Transition{13, kOperationEnabled, kFaultReactionActive, E::kFaultDetected},
    Transition{13, kQuickStopActive, kFaultReactionActive, E::kFaultDetected},
    Transition{14, kFaultReactionActive, kFault, E::kFaultReactionDone},
    Transition{15, kFault, kSwitchOnDisabled, C::kFaultReset},
    Transition{16, kQuickStopActive, kOperationEnabled, C::kEnableOperation},
};

constexpr std::size_t kStateCount = static_cast<std::size_t>(kFault) + 1;

constexpr std::size_t slot(State state) { return static_cast<std::size_t>(state); }

}  // namespace

std::string_view to_string(State state) {
  switch (state) {
    case kStart: return "Start";
    case kNotReadyToSwitchOn: return "Not ready to switch on";
    case kSwitchOnDisabled: return "Switch on disabled";
    case kReadyToSwitchOn: return "Ready to switch on";
    case kSwitchedOn: return "Switched on";
    case kOperationEnabled: return "Operation enabled";
    case kQuickStopActive: return "Quick stop active";
    case kFaultReactionActive: return "Fault reaction active";
    case kFault: return "Fault";
  }
  return "?";
}

std::string_view to_string(Command command) {
  switch (command) {
    case C::kShutdown: return "Shutdown";
    case C::kSwitchOn: return "Switch on";
    case C::kEnableOperation: return "Enable operation";
    case C::kDisableVoltage: return "Disable voltage";
    case C::kQuickStop: return "Quick stop";
    case C::kDisableOperation: return "Disable operation";
    case C::kFaultReset: return "Fault reset";
  }
  return "?";
}

std::string_view to_string(DriveEvent event) {
  switch (event) {
    case E::kPowerOn: return "power on";
    case E::kInitialized: return "initialized";
    case E::kQuickStopFinished: return "quick stop finished";
    case E::kFaultDetected: return "fault detected";
    case E::kFaultReactionDone: return "fault reaction done";
  }
  return "?";
}

StatusPattern status_pattern(State state) {
  // CiA 402 masks over bits 0-3, 5, 6 (UC57 §4.2.1 table, printed under the heading "Control Word").
  switch (state) {
    case kStart: return {0x0000, 0x0000};
    case kNotReadyToSwitchOn: return {0x004F, 0x0000};
    case kSwitchOnDisabled: return {0x004F, 0x0040};
    case kReadyToSwitchOn: return {0x006F, 0x0021};
    case kSwitchedOn: return {0x006F, 0x0023};
    case kOperationEnabled: return {0x006F, 0x0027};
    case kQuickStopActive: return {0x006F, 0x0007};
    case kFaultReactionActive: return {0x004F, 0x000F};
    case kFault: return {0x004F, 0x0008};
  }
  return {0x0000, 0x0000};
}

std::optional<State> decode_state(std::uint16_t statusword) {
  for (const State state : kDecodableStates) {
    const StatusPattern pattern = status_pattern(state);
    if ((statusword & pattern.mask) == pattern.value) return state;
  }
  return std::nullopt;
}

std::uint16_t compose_statusword(State state, std::uint16_t other_bits) {
  const StatusPattern pattern = status_pattern(state);
  return static_cast<std::uint16_t>((other_bits & ~pattern.mask) | pattern.value);
}

CommandPattern command_pattern(Command command) {
  // UC57 §4.2.1 controlword table (bits 7, 3, 2, 1, 0); bit 7 = 0 for every command but fault reset.
  switch (command) {
    case C::kShutdown: return {0x0087, 0x0006};
    case C::kSwitchOn: return {0x008F, 0x0007};
    case C::kEnableOperation: return {0x008F, 0x000F};
    case C::kDisableVoltage: return {0x0082, 0x0000};
    case C::kQuickStop: return {0x0086, 0x0002};
    case C::kDisableOperation: return {0x008F, 0x0007};
    case C::kFaultReset: return {0x0080, 0x0080};
  }
  return {0xFFFF, 0xFFFF};
}

bool matches(Command command, std::uint16_t previous_controlword, std::uint16_t controlword) {
  const CommandPattern pattern = command_pattern(command);
  if ((controlword & pattern.mask) != pattern.value) return false;
  return command != C::kFaultReset || rising_edge(previous_controlword, controlword, ControlBit::kFaultReset);
}

std::uint16_t controlword_for(Command command) { return command_pattern(command).value; }

std::uint16_t apply_command(std::uint16_t controlword, Command command) {
  return static_cast<std::uint16_t>((controlword & ~kDeviceControlBits) | controlword_for(command));
}

std::span<const Transition> transition_table() { return kTable; }

std::optional<Transition> find_command_transition(State state, std::uint16_t previous_controlword,
                                                  std::uint16_t controlword) {
  for (const Transition& row : kTable) {
    const auto* command = std::get_if<Command>(&row.trigger);
    if (row.from == state && command != nullptr && matches(*command, previous_controlword, controlword)) return row;
  }
  return std::nullopt;
}

std::optional<Transition> find_event_transition(State state, DriveEvent event) {
  for (const Transition& row : kTable) {
    const auto* trigger = std::get_if<DriveEvent>(&row.trigger);
    if (row.from == state && trigger != nullptr && *trigger == event) return row;
  }
  return std::nullopt;
}

PlanStep plan_next_command(State current, State target) {
  if (current == target) return {PlanStep::Kind::kAtTarget, Command::kShutdown, 0, current};

  // The drive leaves these states by itself (0, 1, 14); only then can a command help.
  for (const E automatic : {E::kPowerOn, E::kInitialized, E::kFaultReactionDone}) {
    if (const auto row = find_event_transition(current, automatic)) {
      return {PlanStep::Kind::kWaitForDrive, Command::kShutdown, row->number, row->to};
    }
  }

  // Breadth-first search over the command rows; first_row[s] = the row leaving `current` that
  // starts the shortest path found to s.
  std::array<const Transition*, kStateCount> first_row{};
  std::array<bool, kStateCount> visited{};
  std::array<State, kStateCount> queue{};
  std::size_t head = 0;
  std::size_t tail = 0;
  visited[slot(current)] = true;
  queue[tail++] = current;
  while (head < tail) {
    const State state = queue[head++];
    for (const Transition& row : kTable) {
      if (row.from != state || !std::holds_alternative<Command>(row.trigger) || visited[slot(row.to)]) continue;
      visited[slot(row.to)] = true;
      first_row[slot(row.to)] = state == current ? &row : first_row[slot(state)];
      if (row.to == target) {
        const Transition& step = *first_row[slot(row.to)];
        return {PlanStep::Kind::kSendCommand, std::get<Command>(step.trigger), step.number, step.to};
      }
      queue[tail++] = row.to;
    }
  }
  return {PlanStep::Kind::kUnreachable, Command::kShutdown, 0, current};
}

}  // namespace motion::cia402
