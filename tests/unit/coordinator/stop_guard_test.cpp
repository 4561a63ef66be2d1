// StopGuard on a manual clock: a row per path of its sequence (stopped, stopped again, e-stopped,
// given up, unreachable), and the deadlines it asks to be woken at.
#include "motion/coordinator/stop_guard.hpp"

#include <gtest/gtest.h>

namespace motion::coordinator {
namespace {

using std::chrono::milliseconds;
using Kind = StopGuard::Action::Kind;

struct Drive {
  bool reachable = true;
  bool moving = true;
  TimePoint reported{};  // when its last state arrived
};

struct StopGuardTest : ::testing::Test {
  StopGuard guard;
  TimePoint t0 = TimePoint{} + std::chrono::seconds(100);
  Drive drive;

  std::vector<StopGuard::Action> at(milliseconds dt) {
    return guard.process(t0 + dt, [this](const std::string&, TimePoint since) {
      return StopGuard::Observation{drive.reachable, drive.reported > since, drive.moving};
    });
  }
  void report(milliseconds dt, bool moving) {
    drive.reported = t0 + dt;
    drive.moving = moving;
  }
};

TEST_F(StopGuardTest, AStateAfterTheStopShowingStandstillResolvesIt) {
  guard.watch("x", false, t0, milliseconds(500));
  report(milliseconds(-10), false);  // a state from before the stop proves nothing
  EXPECT_TRUE(at(milliseconds(50)).empty());
  EXPECT_TRUE(guard.watching("x"));
  report(milliseconds(60), false);
  const auto done = at(milliseconds(60));
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].kind, Kind::kResolved);
  EXPECT_EQ(done[0].outcome, StopGuard::Outcome::kStopped);
  EXPECT_EQ(done[0].attempt, 1);
  EXPECT_FALSE(guard.watching("x"));
  EXPECT_EQ(guard.outcome("x"), StopGuard::Outcome::kStopped);
  EXPECT_FALSE(guard.escalated("x"));
}

TEST_F(StopGuardTest, StillMovingAfterItsAllowanceIsStoppedAgainThenEStoppedThenGivenUp) {
  guard.watch("x", false, t0, milliseconds(500));
  EXPECT_EQ(guard.next_deadline(), t0 + milliseconds(500));
  report(milliseconds(100), true);
  EXPECT_TRUE(at(milliseconds(499)).empty());
  auto second = at(milliseconds(500));
  ASSERT_EQ(second.size(), 1u);
  EXPECT_EQ(second[0].kind, Kind::kSendStop);
  EXPECT_EQ(second[0].attempt, 2);
  EXPECT_NE(second[0].text.find("axis x still reports moving 500 ms after a stop; stopping it again"),
            std::string::npos)
      << second[0].text;
  EXPECT_EQ(guard.next_deadline(), t0 + milliseconds(1000));
  report(milliseconds(900), true);
  auto third = at(milliseconds(1000));
  ASSERT_EQ(third.size(), 1u);
  EXPECT_EQ(third[0].kind, Kind::kSendEstop);
  EXPECT_EQ(third[0].attempt, 3);
  EXPECT_TRUE(guard.escalated("x"));
  report(milliseconds(1400), true);
  auto given_up = at(milliseconds(1500));
  ASSERT_EQ(given_up.size(), 1u);
  EXPECT_EQ(given_up[0].kind, Kind::kResolved);
  EXPECT_EQ(given_up[0].outcome, StopGuard::Outcome::kUnconfirmed);
  EXPECT_NE(given_up[0].text.find("after an e-stop; giving up"), std::string::npos) << given_up[0].text;
  EXPECT_FALSE(guard.next_deadline().has_value());
}

TEST_F(StopGuardTest, TheSecondStopThatTakesEndsItWithoutAnEStop) {
  guard.watch("x", false, t0, milliseconds(500));
  ASSERT_EQ(at(milliseconds(500)).size(), 1u);  // no state at all: stopped again
  report(milliseconds(700), false);
  const auto done = at(milliseconds(700));
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].outcome, StopGuard::Outcome::kStopped);
  EXPECT_EQ(done[0].attempt, 2);
  EXPECT_FALSE(guard.escalated("x"));
}

TEST_F(StopGuardTest, AnEStopIsRepeatedOnceThenGivenUp) {
  guard.watch("x", true, t0, milliseconds(300));
  report(milliseconds(200), true);
  auto again = at(milliseconds(300));
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].kind, Kind::kSendEstop);
  EXPECT_FALSE(guard.escalated("x"));  // an e-stop asked for is no escalation
  report(milliseconds(500), true);
  auto given_up = at(milliseconds(600));
  ASSERT_EQ(given_up.size(), 1u);
  EXPECT_EQ(given_up[0].outcome, StopGuard::Outcome::kUnconfirmed);
}

TEST_F(StopGuardTest, ADriveThatNeverReportsAfterItsStopsIsGivenUpAsSilent) {
  guard.watch("x", false, t0, milliseconds(200));
  report(milliseconds(-50), true);  // its last state, before the stop; nothing after
  ASSERT_EQ(at(milliseconds(200)).size(), 1u);
  ASSERT_EQ(at(milliseconds(400)).size(), 1u);
  const auto given_up = at(milliseconds(600));
  ASSERT_EQ(given_up.size(), 1u);
  EXPECT_EQ(given_up[0].outcome, StopGuard::Outcome::kSilent);
  EXPECT_NE(given_up[0].text.find("axis x still has not reported 200 ms after an e-stop"), std::string::npos)
      << given_up[0].text;
}

TEST_F(StopGuardTest, AnUnreachableAxisEndsAtOnceAndANewStopRestartsTheSequence) {
  guard.watch("x", false, t0, milliseconds(500));
  drive.reachable = false;
  auto gone = at(milliseconds(10));
  ASSERT_EQ(gone.size(), 1u);
  EXPECT_EQ(gone[0].outcome, StopGuard::Outcome::kUnreachable);
  drive.reachable = true;
  guard.watch("x", false, t0 + milliseconds(20), milliseconds(500));
  EXPECT_TRUE(guard.watching("x"));
  EXPECT_FALSE(guard.outcome("x").has_value());
}

TEST_F(StopGuardTest, AnAxisTakenOverByANewRequestIsNoLongerWatched) {
  guard.watch("x", false, t0, milliseconds(500));
  guard.forget("x");
  EXPECT_FALSE(guard.watching("x"));
  EXPECT_EQ(guard.outcome("x"), StopGuard::Outcome::kTakenOver);
  EXPECT_TRUE(at(milliseconds(600)).empty());  // no stop is repeated on the new request's motion
  guard.forget("y");                           // never watched: nothing recorded
  EXPECT_FALSE(guard.outcome("y").has_value());
}

}  // namespace
}  // namespace motion::coordinator
