// CiA 402 transition table: one test per transition number (drive side), statusword decoding of
// every state, controlword commands, and path planning from every state (master side).
#include <gtest/gtest.h>
#include <initializer_list>

#include <algorithm>
#include <cstdint>
#include <tuple>
#include <vector>

#include "motion/cia402/state_machine.hpp"
#include "motion/cia402/words.hpp"

namespace motion::cia402 {
namespace {

using enum State;

// The drive's reaction to `controlword` (previous word 0x0000 unless given): the transition
// number and the new state, or nullopt when it stays.
std::optional<std::pair<int, State>> drive(State from, std::uint16_t controlword, std::uint16_t previous = 0x0000) {
  const auto row = find_command_transition(from, previous, controlword);
  if (!row) return std::nullopt;
  return std::pair<int, State>{row->number, row->to};
}

std::optional<std::pair<int, State>> drive_event(State from, DriveEvent event) {
  const auto row = find_event_transition(from, event);
  if (!row) return std::nullopt;
  return std::pair<int, State>{row->number, row->to};
}

using Row = std::pair<int, State>;

// ---- The table must hold exactly the rows these tests expect (so a new row needs a test). ----
TEST(TransitionTable, HoldsExactlyTheCiA402Rows) {
  struct Expected {
    int number;
    State from;
    State to;
    Trigger trigger;
  };
  const std::vector<Expected> expected = {
      {0, kStart, kNotReadyToSwitchOn, DriveEvent::kPowerOn},
      {1, kNotReadyToSwitchOn, kSwitchOnDisabled, DriveEvent::kInitialized},
      {2, kSwitchOnDisabled, kReadyToSwitchOn, Command::kShutdown},
      {3, kReadyToSwitchOn, kSwitchedOn, Command::kSwitchOn},
      {3, kReadyToSwitchOn, kSwitchedOn, Command::kEnableOperation},
      {4, kSwitchedOn, kOperationEnabled, Command::kEnableOperation},
      {5, kOperationEnabled, kSwitchedOn, Command::kDisableOperation},
      {6, kSwitchedOn, kReadyToSwitchOn, Command::kShutdown},
      {7, kReadyToSwitchOn, kSwitchOnDisabled, Command::kDisableVoltage},
      {7, kReadyToSwitchOn, kSwitchOnDisabled, Command::kQuickStop},
      {8, kOperationEnabled, kReadyToSwitchOn, Command::kShutdown},
      {9, kOperationEnabled, kSwitchOnDisabled, Command::kDisableVoltage},
      {10, kSwitchedOn, kSwitchOnDisabled, Command::kDisableVoltage},
      {10, kSwitchedOn, kSwitchOnDisabled, Command::kQuickStop},
      {11, kOperationEnabled, kQuickStopActive, Command::kQuickStop},
      {12, kQuickStopActive, kSwitchOnDisabled, Command::kDisableVoltage},
      {12, kQuickStopActive, kSwitchOnDisabled, DriveEvent::kQuickStopFinished},
      {13, kNotReadyToSwitchOn, kFaultReactionActive, DriveEvent::kFaultDetected},
      {13, kSwitchOnDisabled, kFaultReactionActive, DriveEvent::kFaultDetected},
      {13, kReadyToSwitchOn, kFaultReactionActive, DriveEvent::kFaultDetected},
      {13, kSwitchedOn, kFaultReactionActive, DriveEvent::kFaultDetected},
      {13, kOperationEnabled, kFaultReactionActive, DriveEvent::kFaultDetected},
      {13, kQuickStopActive, kFaultReactionActive, DriveEvent::kFaultDetected},
      {14, kFaultReactionActive, kFault, DriveEvent::kFaultReactionDone},
      {15, kFault, kSwitchOnDisabled, Command::kFaultReset},
      {16, kQuickStopActive, kOperationEnabled, Command::kEnableOperation},
  };
  const auto table = transition_table();
  ASSERT_EQ(table.size(), expected.size());
  for (std::size_t i = 0; i < table.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(table[i].number, expected[i].number);
    EXPECT_EQ(table[i].from, expected[i].from);
    EXPECT_EQ(table[i].to, expected[i].to);
    EXPECT_EQ(table[i].trigger, expected[i].trigger);
  }
}

// ---- One test per transition number, through the drive-side lookups. ----
TEST(TransitionTable, T00_PowerOnEntersNotReadyToSwitchOn) {
  EXPECT_EQ(drive_event(kStart, DriveEvent::kPowerOn), (Row{0, kNotReadyToSwitchOn}));
}

TEST(TransitionTable, T01_InitialisationDoneEntersSwitchOnDisabled) {
  EXPECT_EQ(drive_event(kNotReadyToSwitchOn, DriveEvent::kInitialized), (Row{1, kSwitchOnDisabled}));
  EXPECT_EQ(drive(kNotReadyToSwitchOn, 0x0006), std::nullopt);  // no command leaves it
}

TEST(TransitionTable, T02_ShutdownFromSwitchOnDisabled) {
  EXPECT_EQ(drive(kSwitchOnDisabled, 0x0006), (Row{2, kReadyToSwitchOn}));  // M-03
  EXPECT_EQ(drive(kSwitchOnDisabled, 0x000E), (Row{2, kReadyToSwitchOn}));  // bit 3 is "X"
  EXPECT_EQ(drive(kSwitchOnDisabled, 0x0007), std::nullopt);
}

TEST(TransitionTable, T03_SwitchOnFromReadyToSwitchOn) {
  EXPECT_EQ(drive(kReadyToSwitchOn, 0x0007), (Row{3, kSwitchedOn}));  // M-04
  // "3+4": 0x0F in Ready to switch on goes through Switched on, where it triggers 4.
  EXPECT_EQ(drive(kReadyToSwitchOn, 0x000F), (Row{3, kSwitchedOn}));
  EXPECT_EQ(drive(kSwitchedOn, 0x000F, 0x000F), (Row{4, kOperationEnabled}));
}

TEST(TransitionTable, T04_EnableOperationFromSwitchedOn) {
  EXPECT_EQ(drive(kSwitchedOn, 0x000F), (Row{4, kOperationEnabled}));  // M-05
  EXPECT_EQ(drive(kSwitchedOn, 0x001F), (Row{4, kOperationEnabled}));  // mode bits do not matter
}

TEST(TransitionTable, T05_DisableOperationFromOperationEnabled) {
  EXPECT_EQ(drive(kOperationEnabled, 0x0007), (Row{5, kSwitchedOn}));
}

TEST(TransitionTable, T06_ShutdownFromSwitchedOn) { EXPECT_EQ(drive(kSwitchedOn, 0x0006), (Row{6, kReadyToSwitchOn})); }

TEST(TransitionTable, T07_DisableVoltageOrQuickStopFromReadyToSwitchOn) {
  EXPECT_EQ(drive(kReadyToSwitchOn, 0x0000), (Row{7, kSwitchOnDisabled}));
  EXPECT_EQ(drive(kReadyToSwitchOn, 0x0005), (Row{7, kSwitchOnDisabled}));  // bit 1 = 0: disable voltage
  EXPECT_EQ(drive(kReadyToSwitchOn, 0x0002), (Row{7, kSwitchOnDisabled}));  // quick stop
  EXPECT_EQ(drive(kReadyToSwitchOn, 0x0006), std::nullopt);                 // shutdown: stays
}

TEST(TransitionTable, T08_ShutdownFromOperationEnabled) {
  EXPECT_EQ(drive(kOperationEnabled, 0x0006), (Row{8, kReadyToSwitchOn}));
}

TEST(TransitionTable, T09_DisableVoltageFromOperationEnabled) {
  EXPECT_EQ(drive(kOperationEnabled, 0x0000), (Row{9, kSwitchOnDisabled}));
  EXPECT_EQ(drive(kOperationEnabled, 0x000D), (Row{9, kSwitchOnDisabled}));
}

TEST(TransitionTable, T10_DisableVoltageOrQuickStopFromSwitchedOn) {
  EXPECT_EQ(drive(kSwitchedOn, 0x0000), (Row{10, kSwitchOnDisabled}));
  EXPECT_EQ(drive(kSwitchedOn, 0x000A), (Row{10, kSwitchOnDisabled}));  // quick stop, bit 3 "X"
}

TEST(TransitionTable, T11_QuickStopFromOperationEnabled) {
  EXPECT_EQ(drive(kOperationEnabled, 0x0002), (Row{11, kQuickStopActive}));  // D-54
  EXPECT_EQ(drive(kOperationEnabled, 0x000B), (Row{11, kQuickStopActive}));
}

TEST(TransitionTable, T12_DisableVoltageOrQuickStopEndFromQuickStopActive) {
  EXPECT_EQ(drive(kQuickStopActive, 0x0000), (Row{12, kSwitchOnDisabled}));
  EXPECT_EQ(drive_event(kQuickStopActive, DriveEvent::kQuickStopFinished), (Row{12, kSwitchOnDisabled}));
  EXPECT_EQ(drive(kQuickStopActive, 0x0002), std::nullopt);  // quick stop again: stays
}

TEST(TransitionTable, T13_FaultFromEveryPoweredOrUnpoweredState) {
  for (const State state :
       {kNotReadyToSwitchOn, kSwitchOnDisabled, kReadyToSwitchOn, kSwitchedOn, kOperationEnabled, kQuickStopActive}) {
    SCOPED_TRACE(to_string(state));
    EXPECT_EQ(drive_event(state, DriveEvent::kFaultDetected), (Row{13, kFaultReactionActive}));
  }
  EXPECT_EQ(drive_event(kFaultReactionActive, DriveEvent::kFaultDetected), std::nullopt);
  EXPECT_EQ(drive_event(kFault, DriveEvent::kFaultDetected), std::nullopt);
}

TEST(TransitionTable, T14_FaultReactionDoneEntersFault) {
  EXPECT_EQ(drive_event(kFaultReactionActive, DriveEvent::kFaultReactionDone), (Row{14, kFault}));
  EXPECT_EQ(drive(kFaultReactionActive, 0x0080), std::nullopt);  // no command acts during the reaction
}

TEST(TransitionTable, T15_FaultResetOnRisingEdgeOnly) {
  EXPECT_EQ(drive(kFault, 0x0080, 0x0000), (Row{15, kSwitchOnDisabled}));  // MC_RESET: bit 7 0 -> 1
  EXPECT_EQ(drive(kFault, 0x008F, 0x000F), (Row{15, kSwitchOnDisabled}));  // other bits "X"
  EXPECT_EQ(drive(kFault, 0x0080, 0x0080), std::nullopt);                  // level, no edge
  EXPECT_EQ(drive(kFault, 0x0000, 0x0080), std::nullopt);                  // falling edge
  EXPECT_EQ(drive(kFault, 0x0006), std::nullopt);                          // other commands: stays
  EXPECT_EQ(drive(kFault, 0x000F), std::nullopt);
}

TEST(TransitionTable, T16_EnableOperationFromQuickStopActive) {
  EXPECT_EQ(drive(kQuickStopActive, 0x000F), (Row{16, kOperationEnabled}));
}

TEST(TransitionTable, BitSevenHighIsNoDeviceCommand) {
  // With bit 7 = 1 only fault reset is defined; in Operation enabled it has no row.
  EXPECT_EQ(drive(kOperationEnabled, 0x0087, 0x0007), std::nullopt);
  EXPECT_EQ(drive(kSwitchOnDisabled, 0x0086, 0x0080), std::nullopt);
}

TEST(TransitionTable, AtMostOneCommandRowMatchesAnyControlword) {
  for (const State state : kDecodableStates) {
    for (std::uint32_t word = 0; word <= 0x01FF; ++word) {
      for (const std::uint16_t previous : {std::uint16_t{0x0000}, std::uint16_t{0x0080}}) {
        const auto count =
            std::count_if(transition_table().begin(), transition_table().end(), [&](const Transition& row) {
              const auto* command = std::get_if<Command>(&row.trigger);
              return row.from == state && command != nullptr &&
                     matches(*command, previous, static_cast<std::uint16_t>(word));
            });
        ASSERT_LE(count, 1) << to_string(state) << " word 0x" << std::hex << word;
      }
    }
  }
}

// ---- Controlword commands (UC57 §4.2.1 / §4.2.2) ----
TEST(Controlword, CommandValues) {
  EXPECT_EQ(controlword_for(Command::kShutdown), 0x0006);
  EXPECT_EQ(controlword_for(Command::kSwitchOn), 0x0007);
  EXPECT_EQ(controlword_for(Command::kEnableOperation), 0x000F);
  EXPECT_EQ(controlword_for(Command::kDisableVoltage), 0x0000);
  EXPECT_EQ(controlword_for(Command::kQuickStop), 0x0002);
  EXPECT_EQ(controlword_for(Command::kDisableOperation), 0x0007);
  EXPECT_EQ(controlword_for(Command::kFaultReset), 0x0080);
}

TEST(Controlword, ApplyCommandKeepsModeBits) {
  EXPECT_EQ(apply_command(0x0150, Command::kEnableOperation), 0x015F);  // halt + relative + set-point kept
  EXPECT_EQ(apply_command(0x008F, Command::kShutdown), 0x0006);         // bit 7 is device control
}

// ---- Statusword decoding (UC57 §4.2.1 patterns; example words of the §4.2.2 bits, composed as assumed) ----
TEST(Statusword, DecodesEveryState) {
  const std::vector<std::pair<std::uint16_t, State>> cases = {
      {0x0000, kNotReadyToSwitchOn},
      {0x0020, kNotReadyToSwitchOn},  // bit 5 "X"
      {0x0040, kSwitchOnDisabled},
      {0x0060, kSwitchOnDisabled},
      {0x0021, kReadyToSwitchOn},
      {0x0031, kReadyToSwitchOn},  // bit 4 (voltage) ignored
      {0x0023, kSwitchedOn},
      {0x2023, kSwitchedOn},
      {0x0027, kOperationEnabled},
      {0x2427, kOperationEnabled},
      {0x7827, kOperationEnabled},
      {0xA427, kOperationEnabled},
      {0xA527, kOperationEnabled},
      {0x0237, kOperationEnabled},  // D-04
      {0x0007, kQuickStopActive},
      {0x2007, kQuickStopActive},
      {0x000F, kFaultReactionActive},
      {0x002F, kFaultReactionActive},
      {0x0008, kFault},
      {0x0088, kFault},
      {0x0028, kFault},
  };
  for (const auto& [word, state] : cases) { EXPECT_EQ(decode_state(word), state) << "0x" << std::hex << word; }
}

TEST(Statusword, UndefinedPatternsDecodeToNothing) {
  for (const std::uint16_t word : std::initializer_list<std::uint16_t>{0x0001, 0x0003, 0x0041, 0x0067, 0x0048}) {
    EXPECT_EQ(decode_state(word), std::nullopt) << "0x" << std::hex << word;
  }
}

TEST(Statusword, PatternsAreMutuallyExclusive) {
  for (std::uint32_t word = 0; word <= 0xFFFF; ++word) {
    int matching = 0;
    for (const State state : kDecodableStates) {
      const StatusPattern pattern = status_pattern(state);
      matching += (word & pattern.mask) == pattern.value ? 1 : 0;
    }
    ASSERT_LE(matching, 1) << "0x" << std::hex << word;
  }
}

TEST(Statusword, ComposeRoundTripsAndKeepsOtherBits) {
  for (const State state : kDecodableStates) {
    for (const std::uint16_t other : std::initializer_list<std::uint16_t>{0x0000, 0xFFFF, 0xA500, 0x0290}) {
      const std::uint16_t word = compose_statusword(state, other);
      EXPECT_EQ(decode_state(word), state);
      EXPECT_EQ(word & ~status_pattern(state).mask & 0xFFFF, other & ~status_pattern(state).mask & 0xFFFF);
    }
  }
  // UC57 §4.2.2 short form: 6041h bits 3..0 after 0x00 / 0x06 / 0x07 / 0x0F.
  EXPECT_EQ(compose_statusword(kSwitchOnDisabled) & 0xF, 0b0000);
  EXPECT_EQ(compose_statusword(kReadyToSwitchOn) & 0xF, 0b0001);
  EXPECT_EQ(compose_statusword(kSwitchedOn) & 0xF, 0b0011);
  EXPECT_EQ(compose_statusword(kOperationEnabled) & 0xF, 0b0111);
  EXPECT_EQ(compose_statusword(kSwitchedOn, mask(StatusBit::kMotorEnabled)),
            0x2023);  // example word (composition assumed)
}

// ---- Path planning (master side) ----
struct Walk {
  std::vector<std::uint16_t> controlwords;  // sent
  std::vector<int> transitions;             // taken, in order
  State final_state;
};

// Runs the planner against the table's drive-side behaviour until the target (or a dead end).
Walk walk(State from, State target) {
  Walk result{{}, {}, from};
  std::uint16_t previous = 0x0000;
  for (int guard = 0; guard < 10; ++guard) {
    const PlanStep step = plan_next_command(result.final_state, target);
    if (step.kind == PlanStep::Kind::kAtTarget || step.kind == PlanStep::Kind::kUnreachable) break;
    std::optional<Transition> row;
    if (step.kind == PlanStep::Kind::kWaitForDrive) {
      for (const DriveEvent event : {DriveEvent::kPowerOn, DriveEvent::kInitialized, DriveEvent::kFaultReactionDone}) {
        if (!row) row = find_event_transition(result.final_state, event);
      }
    } else {
      const std::uint16_t word = controlword_for(step.command);
      result.controlwords.push_back(word);
      row = find_command_transition(result.final_state, previous, word);
      previous = word;
    }
    if (!row) break;
    EXPECT_EQ(row->number, step.transition);
    EXPECT_EQ(row->to, step.next);
    result.transitions.push_back(row->number);
    result.final_state = row->to;
  }
  return result;
}

TEST(Planner, FromEveryStateToOperationEnabled) {
  struct Case {
    State from;
    std::vector<std::uint16_t> controlwords;
    std::vector<int> transitions;
  };
  const std::vector<Case> cases = {
      {kStart, {0x06, 0x07, 0x0F}, {0, 1, 2, 3, 4}},
      {kNotReadyToSwitchOn, {0x06, 0x07, 0x0F}, {1, 2, 3, 4}},
      {kSwitchOnDisabled, {0x06, 0x07, 0x0F}, {2, 3, 4}},  // UC57 §4.2.2 M-03..M-05
      {kReadyToSwitchOn, {0x07, 0x0F}, {3, 4}},
      {kSwitchedOn, {0x0F}, {4}},
      {kOperationEnabled, {}, {}},
      {kQuickStopActive, {0x0F}, {16}},
      {kFaultReactionActive, {0x80, 0x06, 0x07, 0x0F}, {14, 15, 2, 3, 4}},
      {kFault, {0x80, 0x06, 0x07, 0x0F}, {15, 2, 3, 4}},  // D-52
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(to_string(c.from));
    const Walk w = walk(c.from, kOperationEnabled);
    EXPECT_EQ(w.final_state, kOperationEnabled);
    EXPECT_EQ(w.controlwords, c.controlwords);
    EXPECT_EQ(w.transitions, c.transitions);
  }
}

TEST(Planner, FromEveryStateToSwitchOnDisabled) {
  struct Case {
    State from;
    std::vector<std::uint16_t> controlwords;
    std::vector<int> transitions;
  };
  const std::vector<Case> cases = {
      {kStart, {}, {0, 1}},
      {kNotReadyToSwitchOn, {}, {1}},
      {kSwitchOnDisabled, {}, {}},
      {kReadyToSwitchOn, {0x00}, {7}},
      {kSwitchedOn, {0x00}, {10}},
      {kOperationEnabled, {0x00}, {9}},
      {kQuickStopActive, {0x00}, {12}},
      {kFaultReactionActive, {0x80}, {14, 15}},
      {kFault, {0x80}, {15}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(to_string(c.from));
    const Walk w = walk(c.from, kSwitchOnDisabled);
    EXPECT_EQ(w.final_state, kSwitchOnDisabled);
    EXPECT_EQ(w.controlwords, c.controlwords);
    EXPECT_EQ(w.transitions, c.transitions);
  }
}

TEST(Planner, QuickStopIsReachedThroughOperationEnabled) {
  const Walk w = walk(kSwitchOnDisabled, kQuickStopActive);
  EXPECT_EQ(w.controlwords, (std::vector<std::uint16_t>{0x06, 0x07, 0x0F, 0x02}));
  EXPECT_EQ(w.final_state, kQuickStopActive);
}

TEST(Planner, StatesOnlyTheDriveEntersAreUnreachable) {
  for (const State target : {kStart, kNotReadyToSwitchOn, kFaultReactionActive, kFault}) {
    EXPECT_EQ(plan_next_command(kOperationEnabled, target).kind, PlanStep::Kind::kUnreachable) << to_string(target);
  }
  EXPECT_EQ(plan_next_command(kFault, kFault).kind, PlanStep::Kind::kAtTarget);
}

}  // namespace
}  // namespace motion::cia402
