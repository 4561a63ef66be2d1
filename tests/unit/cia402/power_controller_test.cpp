// PowerController: the master's stateful walk through the table, with statusword confirmation,
// state-switch timeouts and the fault-reset rising edge.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <vector>

#include "motion/cia402/power_controller.hpp"
#include "motion/cia402/words.hpp"

namespace motion::cia402 {
namespace {

using namespace std::chrono_literals;
using enum State;
using Outcome = PowerController::Outcome;

std::vector<std::uint16_t> sent(const PowerController::Action& action) {
  return {action.controlwords().begin(), action.controlwords().end()};
}

const TimePoint t0 = TimePoint{} + 1h;

TEST(PowerController, EnablesLikeTheManualSequence) {
  // UC57 §4.2.2 M-02..M-05: 0x06 -> 0x07 -> 0x0F, each confirmed by 6041h bits 3..0.
  PowerController controller;
  controller.request(kOperationEnabled, t0);

  auto action = controller.on_statusword(0x0040, t0);
  EXPECT_EQ(action.outcome, Outcome::kInProgress);
  EXPECT_EQ(sent(action), (std::vector<std::uint16_t>{0x0006}));
  EXPECT_EQ(action.transition, 2);
  EXPECT_EQ(action.deadline, t0 + 1s);

  // Same state again before the deadline: nothing is resent, the deadline stays.
  action = controller.on_statusword(0x0040, t0 + 10ms);
  EXPECT_EQ(action.outcome, Outcome::kInProgress);
  EXPECT_TRUE(sent(action).empty());
  EXPECT_EQ(action.deadline, t0 + 1s);

  action = controller.on_statusword(0x0021, t0 + 20ms);
  EXPECT_EQ(sent(action), (std::vector<std::uint16_t>{0x0007}));
  EXPECT_EQ(action.deadline, t0 + 20ms + 1s);
  action = controller.on_statusword(0x2023, t0 + 30ms);
  EXPECT_EQ(sent(action), (std::vector<std::uint16_t>{0x000F}));
  action = controller.on_statusword(0x2427, t0 + 40ms);
  EXPECT_EQ(action.outcome, Outcome::kReached);
  EXPECT_TRUE(sent(action).empty());
  EXPECT_EQ(action.deadline, kNever);
  EXPECT_EQ(controller.target(), std::nullopt);
  EXPECT_EQ(controller.last_controlword(), 0x000F);
}

TEST(PowerController, IdleWithoutRequest) {
  PowerController controller;
  const auto action = controller.on_statusword(0x0040, t0);
  EXPECT_EQ(action.outcome, Outcome::kIdle);
  EXPECT_TRUE(sent(action).empty());
  EXPECT_EQ(action.observed, kSwitchOnDisabled);
  EXPECT_EQ(controller.on_timer(t0 + 1h).outcome, Outcome::kIdle);
}

TEST(PowerController, TimesOutWhenTheStateDoesNotChange) {
  PowerController controller(PowerController::Config{200ms});
  controller.request(kOperationEnabled, t0);
  EXPECT_EQ(controller.on_statusword(0x0040, t0).deadline, t0 + 200ms);
  EXPECT_EQ(controller.on_timer(t0 + 199ms).outcome, Outcome::kInProgress);
  EXPECT_EQ(controller.on_timer(t0 + 200ms).outcome, Outcome::kTimedOut);
  EXPECT_EQ(controller.target(), std::nullopt);
  EXPECT_EQ(controller.deadline(), kNever);
}

TEST(PowerController, StaleStatuswordAtTheDeadlineTimesOut) {
  PowerController controller(PowerController::Config{200ms});
  controller.request(kSwitchOnDisabled, t0);
  EXPECT_EQ(sent(controller.on_statusword(0x0027, t0)), (std::vector<std::uint16_t>{0x0000}));  // 9
  EXPECT_EQ(controller.on_statusword(0x0027, t0 + 250ms).outcome, Outcome::kTimedOut);
}

TEST(PowerController, FaultResetIsARisingEdgeConfirmedByTheStatusword) {
  PowerController controller(PowerController::Config{500ms});
  controller.request(kOperationEnabled, t0);
  ASSERT_EQ(controller.last_controlword(), 0x0000);  // bit 7 already low: one word is enough
  auto action = controller.on_statusword(0x0088, t0);
  EXPECT_EQ(sent(action), (std::vector<std::uint16_t>{0x0080}));
  EXPECT_EQ(action.transition, 15);
  // Still in Fault: wait for the confirmation, do not resend.
  EXPECT_TRUE(sent(controller.on_statusword(0x0088, t0 + 100ms)).empty());
  // Confirmed (Switch on disabled): continue with bit 7 back at 0.
  action = controller.on_statusword(0x0040, t0 + 200ms);
  EXPECT_EQ(sent(action), (std::vector<std::uint16_t>{0x0006}));
}

TEST(PowerController, FaultResetTakesBitSevenLowFirst) {
  PowerController controller;
  controller.note_controlword_sent(0x0080);  // e.g. an earlier reset attempt
  controller.request(kSwitchOnDisabled, t0);
  const auto action = controller.on_statusword(0x0008, t0);
  EXPECT_EQ(sent(action), (std::vector<std::uint16_t>{0x0000, 0x0080}));  // MC_RESET steps 1, 2
  EXPECT_EQ(controller.last_controlword(), 0x0080);
}

TEST(PowerController, UnconfirmedFaultResetTimesOutAndARetryMakesANewEdge) {
  PowerController controller(PowerController::Config{300ms});
  controller.request(kSwitchOnDisabled, t0);
  EXPECT_EQ(sent(controller.on_statusword(0x0088, t0)), (std::vector<std::uint16_t>{0x0080}));
  EXPECT_EQ(controller.on_statusword(0x0088, t0 + 300ms).outcome, Outcome::kTimedOut);  // latched alarm
  controller.request(kSwitchOnDisabled, t0 + 1s);
  EXPECT_EQ(sent(controller.on_statusword(0x0088, t0 + 1s)), (std::vector<std::uint16_t>{0x0000, 0x0080}));
}

TEST(PowerController, ReplansWhenAFaultInterrupts) {
  PowerController controller;
  controller.request(kOperationEnabled, t0);
  EXPECT_EQ(sent(controller.on_statusword(0x0021, t0)), (std::vector<std::uint16_t>{0x0007}));
  EXPECT_EQ(sent(controller.on_statusword(0x000F, t0 + 5ms)), std::vector<std::uint16_t>{});  // reaction: wait (14)
  EXPECT_EQ(sent(controller.on_statusword(0x0008, t0 + 9ms)), (std::vector<std::uint16_t>{0x0080}));
}

TEST(PowerController, WaitsForAutomaticTransitionsWithADeadline) {
  PowerController controller(PowerController::Config{100ms});
  controller.request(kOperationEnabled, t0);
  auto action = controller.on_statusword(0x0000, t0);  // Not ready to switch on
  EXPECT_EQ(action.outcome, Outcome::kInProgress);
  EXPECT_TRUE(sent(action).empty());
  EXPECT_EQ(action.transition, 1);
  EXPECT_EQ(action.deadline, t0 + 100ms);
  EXPECT_EQ(sent(controller.on_statusword(0x0040, t0 + 50ms)), (std::vector<std::uint16_t>{0x0006}));
}

TEST(PowerController, UndecodableStatuswordWaitsUntilTheDeadline) {
  PowerController controller(PowerController::Config{100ms});
  controller.request(kOperationEnabled, t0);
  auto action = controller.on_statusword(0x0001, t0);
  EXPECT_EQ(action.outcome, Outcome::kInProgress);
  EXPECT_EQ(action.observed, std::nullopt);
  EXPECT_EQ(action.deadline, t0 + 100ms);
  EXPECT_EQ(controller.on_statusword(0x0001, t0 + 100ms).outcome, Outcome::kTimedOut);
}

TEST(PowerController, UnreachableTargetIsRefused) {
  PowerController controller;
  controller.request(kFault, t0);
  EXPECT_EQ(controller.on_statusword(0x0027, t0).outcome, Outcome::kUnreachable);
  EXPECT_EQ(controller.target(), std::nullopt);
}

TEST(PowerController, AlreadyAtTarget) {
  PowerController controller;
  controller.request(kSwitchOnDisabled, t0);
  EXPECT_EQ(controller.on_statusword(0x0040, t0).outcome, Outcome::kReached);
}

// Closed loop against a drive that follows the table: from every state the controller reaches
// Operation enabled, and every controlword it sends triggers exactly the awaited transition.
TEST(PowerController, ClosedLoopFromEveryStateReachesOperationEnabled) {
  for (const State start : kDecodableStates) {
    SCOPED_TRACE(to_string(start));
    PowerController controller;
    State drive = start;
    std::uint16_t drive_previous_controlword = 0x0000;
    TimePoint now = t0;
    controller.request(kOperationEnabled, now);
    Outcome outcome = Outcome::kInProgress;
    for (int step = 0; step < 12 && outcome == Outcome::kInProgress; ++step) {
      now += 10ms;
      const auto action = controller.on_statusword(compose_statusword(drive), now);
      outcome = action.outcome;
      for (const std::uint16_t word : action.controlwords()) {
        if (const auto row = find_command_transition(drive, drive_previous_controlword, word)) drive = row->to;
        drive_previous_controlword = word;
      }
      if (action.controlwords().empty() && outcome == Outcome::kInProgress) {
        for (const DriveEvent event : {DriveEvent::kInitialized, DriveEvent::kFaultReactionDone}) {
          if (const auto row = find_event_transition(drive, event)) drive = row->to;
        }
      }
    }
    EXPECT_EQ(outcome, Outcome::kReached);
    EXPECT_EQ(drive, kOperationEnabled);
  }
}

}  // namespace
}  // namespace motion::cia402
