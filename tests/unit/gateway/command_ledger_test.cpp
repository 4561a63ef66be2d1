// The command ledger (motion/gateway/command_ledger.hpp): the lifecycle table row by row, refused
// transitions, exactly one terminal reply per command, and the reply builder.
#include "motion/gateway/command_ledger.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace motion::gateway {
namespace {

using Reply = motionlcm::gateway_reply_t;

constexpr Lifecycle kAll[] = {Lifecycle::kLoading, Lifecycle::kArmed,  Lifecycle::kStarted,
                              Lifecycle::kDone,    Lifecycle::kFailed, Lifecycle::kStopped};

motionlcm::gateway_command_t command(std::int64_t id, std::int8_t kind = motionlcm::gateway_command_t::ARM_MOVE) {
  motionlcm::gateway_command_t c{};
  c.command_id = id;
  c.kind = kind;
  c.param.index = 0x1234;
  return c;
}

struct Fixture {
  std::vector<Reply> sent;
  CommandLedger<int> ledger{[this](Reply r) { sent.push_back(std::move(r)); }};
};

// The path from Loading to `state` through table rows (Loading itself: no step).
std::vector<Lifecycle> path_to(Lifecycle state) {
  switch (state) {
    case Lifecycle::kLoading: return {};
    case Lifecycle::kArmed: return {Lifecycle::kArmed};
    case Lifecycle::kStarted: return {Lifecycle::kArmed, Lifecycle::kStarted};
    default: return {state};
  }
}

class LifecycleRow : public ::testing::TestWithParam<LifecycleTransition> {};

// Each row: a part in `from` moves to `to`, the ledger says yes, and the part is there (or, for a
// terminal row, the command's one terminal reply went out and the ledger let go of it).
TEST_P(LifecycleRow, IsAcceptedAndLandsInItsTarget) {
  const auto row = GetParam();
  Fixture f;
  ASSERT_NE(f.ledger.add(command(7), {0, 1}), nullptr);
  for (const auto step : path_to(row.from)) ASSERT_TRUE(f.ledger.advance(7, 0, step));
  f.sent.clear();
  ASSERT_TRUE(f.ledger.advance(7, 0, row.to, error_code(ReplyError::kStopped), "why"))
      << to_string(row.from) << " -> " << to_string(row.to);
  ASSERT_NE(f.ledger.find(7), nullptr);  // node 1 still loading: the command lives on
  EXPECT_EQ(f.ledger.find(7)->state_of(0), row.to);
  EXPECT_EQ(f.ledger.find(7)->state_of(1), Lifecycle::kLoading);
  if (row.to == Lifecycle::kFailed || row.to == Lifecycle::kStopped) {
    ASSERT_EQ(f.sent.size(), 1U);  // the first failed part fails the command at once
    EXPECT_EQ(f.sent[0].status, std::int8_t{Reply::FAILED});
    EXPECT_EQ(f.sent[0].reason, "why");
  } else {
    EXPECT_TRUE(f.sent.empty());  // node 1 has not got there: no reply yet
  }
  EXPECT_EQ(f.ledger.counters().refused_transitions, 0);
}

INSTANTIATE_TEST_SUITE_P(Table, LifecycleRow, ::testing::ValuesIn(kLifecycleTable),
                         [](const auto& row) { return "Row" + std::to_string(row.param.number); });

TEST(Lifecycle, EveryPairOutsideTheTableIsRefusedAndLeavesThePartWhereItWas) {
  int refused = 0;
  for (const auto from : {Lifecycle::kLoading, Lifecycle::kArmed, Lifecycle::kStarted}) {
    for (const auto to : kAll) {
      if (find_transition(from, to)) continue;
      Fixture f;
      f.ledger.add(command(1), {0, 1});
      for (const auto step : path_to(from)) ASSERT_TRUE(f.ledger.advance(1, 0, step));
      const auto before = f.sent.size();
      EXPECT_FALSE(f.ledger.advance(1, 0, to)) << to_string(from) << " -> " << to_string(to);
      EXPECT_EQ(f.ledger.find(1)->state_of(0), from);
      EXPECT_EQ(f.sent.size(), before);
      ++refused;
    }
  }
  for (const auto from : {Lifecycle::kDone, Lifecycle::kFailed, Lifecycle::kStopped}) {
    for (const auto to : kAll)
      EXPECT_FALSE(find_transition(from, to)) << "terminal " << to_string(from) << " has a way out";
  }
  EXPECT_EQ(refused, 7);  // 3 x 6 pairs out of non-terminal states, 11 rows
}

TEST(CommandLedger, RepliesArmedStartedDoneOnceWhenTheLastPartGetsThere) {
  Fixture f;
  auto* e = f.ledger.add(command(3), {4, 9});
  ASSERT_NE(e, nullptr);
  EXPECT_TRUE(f.ledger.advance(3, 4, Lifecycle::kArmed));
  EXPECT_TRUE(f.sent.empty());
  EXPECT_TRUE(f.ledger.advance(3, 9, Lifecycle::kArmed));
  ASSERT_EQ(f.sent.size(), 1U);
  EXPECT_EQ(f.sent[0].status, std::int8_t{Reply::ARMED});
  EXPECT_EQ(f.sent[0].command_id, 3);
  EXPECT_EQ(f.sent[0].param.index, 0x1234);  // the command's parameter rides along
  f.ledger.find(3)->reply.started(1'000, "group-bg", 0.0);
  EXPECT_TRUE(f.ledger.advance_all(3, Lifecycle::kStarted));
  ASSERT_EQ(f.sent.size(), 2U);
  EXPECT_EQ(f.sent[1].status, std::int8_t{Reply::STARTED});
  EXPECT_EQ(f.sent[1].trigger_utime, 1'000);
  EXPECT_EQ(f.sent[1].start_mechanism, "group-bg");
  EXPECT_TRUE(f.ledger.advance(3, 9, Lifecycle::kDone));
  EXPECT_EQ(f.sent.size(), 2U);
  EXPECT_TRUE(f.ledger.advance(3, 4, Lifecycle::kDone, 0, "both in position"));
  ASSERT_EQ(f.sent.size(), 3U);
  EXPECT_EQ(f.sent[2].status, std::int8_t{Reply::DONE});
  EXPECT_EQ(f.sent[2].trigger_utime, 1'000);
  EXPECT_EQ(f.ledger.find(3), nullptr);  // every part ended: gone
  EXPECT_TRUE(f.ledger.find_by_node(4).empty());
}

TEST(CommandLedger, ASecondTerminalForThePartIsRefusedCountedAndNeverSent) {
  Fixture f;
  f.ledger.add(command(5), {0, 1});
  ASSERT_TRUE(f.ledger.advance(5, 0, Lifecycle::kFailed, error_code(ReplyError::kTimeout), "node 0 silent"));
  ASSERT_EQ(f.sent.size(), 1U);
  // Part 0 again (its fault and its timeout both reported): refused.
  EXPECT_FALSE(f.ledger.advance(5, 0, Lifecycle::kFailed, error_code(ReplyError::kAxisFault), "again"));
  EXPECT_FALSE(f.ledger.advance(5, 0, Lifecycle::kDone));
  // Part 1 ends too: allowed for the part, but the command's terminal reply went out already.
  EXPECT_TRUE(f.ledger.advance(5, 1, Lifecycle::kStopped, error_code(ReplyError::kStopped), "stopped"));
  EXPECT_EQ(f.sent.size(), 1U);
  EXPECT_EQ(f.sent[0].error_code, error_code(ReplyError::kTimeout));
  EXPECT_EQ(f.ledger.find(5), nullptr);
  // The command again, now that it left the ledger.
  EXPECT_FALSE(f.ledger.finish(5, Lifecycle::kDone));
  EXPECT_FALSE(f.ledger.advance_all(5, Lifecycle::kFailed));
  EXPECT_EQ(f.sent.size(), 1U);
  EXPECT_EQ(f.ledger.counters().refused_terminals, 4);
}

TEST(CommandLedger, FinishEndsEveryLivePartWithOneReplyAndReturnsTheEntry) {
  Fixture f;
  f.ledger.add(command(8, motionlcm::gateway_command_t::STOP), {2, 3}, 42);
  ASSERT_TRUE(f.ledger.advance(8, 2, Lifecycle::kDone));
  auto e = f.ledger.finish(8, Lifecycle::kDone, 0, "stopped both");
  ASSERT_TRUE(e);
  EXPECT_EQ(e->data, 42);
  EXPECT_TRUE(e->all(Lifecycle::kDone));
  ASSERT_EQ(f.sent.size(), 1U);
  EXPECT_EQ(f.sent[0].status, std::int8_t{Reply::DONE});
  EXPECT_EQ(f.sent[0].reason, "stopped both");
  EXPECT_FALSE(f.ledger.finish(8, Lifecycle::kFailed, 1, "late"));
  EXPECT_EQ(f.sent.size(), 1U);
}

TEST(CommandLedger, ARefusedPartLeavesNothingBehind) {
  Fixture f;
  // A command refused while loading (a value outside the drive's range on node 1).
  f.ledger.add(command(11), {0, 1});
  ASSERT_TRUE(f.ledger.advance(11, 0, Lifecycle::kArmed));
  auto e =
      f.ledger.finish(11, Lifecycle::kFailed, error_code(ReplyError::kOutsideLimits), "node 1: speed out of range");
  ASSERT_TRUE(e);
  EXPECT_EQ(f.ledger.find(11), nullptr);
  EXPECT_EQ(f.ledger.size(), 0U);
  EXPECT_TRUE(f.ledger.find_by_node(0).empty());
  EXPECT_TRUE(f.ledger.find_by_node(1).empty());
  ASSERT_EQ(f.sent.size(), 1U);
  EXPECT_EQ(f.sent[0].status, std::int8_t{Reply::FAILED});
  EXPECT_EQ(f.sent[0].error_code, error_code(ReplyError::kOutsideLimits));
  // The same id can come again (a retried request) and starts from scratch.
  auto* again = f.ledger.add(command(11), {1});
  ASSERT_NE(again, nullptr);
  EXPECT_EQ(again->state_of(1), Lifecycle::kLoading);
  EXPECT_FALSE(again->state_of(0));
}

TEST(CommandLedger, ADuplicateIdIsRefusedAndTheLiveCommandUntouched) {
  Fixture f;
  f.ledger.add(command(2), {0});
  ASSERT_TRUE(f.ledger.advance(2, 0, Lifecycle::kArmed));
  EXPECT_EQ(f.ledger.add(command(2), {0, 1}), nullptr);
  EXPECT_EQ(f.ledger.counters().refused_adds, 1);
  EXPECT_EQ(f.ledger.find(2)->nodes.size(), 1U);
  EXPECT_EQ(f.ledger.find(2)->state_of(0), Lifecycle::kArmed);
  f.ledger.reject(command(2), error_code(ReplyError::kMalformedRequest), "command id 2 is already in progress");
  ASSERT_EQ(f.sent.size(), 2U);  // ARMED, then the rejection
  EXPECT_EQ(f.sent[1].status, std::int8_t{Reply::FAILED});
  EXPECT_NE(f.ledger.find(2), nullptr);
}

TEST(CommandLedger, FindByNodeListsOnlyLiveParts) {
  Fixture f;
  f.ledger.add(command(1), {0, 1});
  f.ledger.add(command(2), {1});
  f.ledger.add(command(3), {0});
  ASSERT_TRUE(f.ledger.advance(1, 0, Lifecycle::kDone));
  EXPECT_EQ(f.ledger.find_by_node(0), (std::vector<std::int64_t>{3}));
  EXPECT_EQ(f.ledger.find_by_node(1), (std::vector<std::int64_t>{1, 2}));
}

TEST(ReplyBuilder, FillsTheFieldsItIsGivenAndNothingElse) {
  auto cmd = command(77);
  const auto r = ReplyBuilder(cmd).failed(ReplyError::kAxisOffline, "x-drive (node 5) is offline").build();
  EXPECT_EQ(r.command_id, 77);
  EXPECT_EQ(r.status, std::int8_t{Reply::FAILED});
  EXPECT_EQ(r.error_code, error_code(ReplyError::kAxisOffline));
  EXPECT_EQ(r.reason, "x-drive (node 5) is offline");
  EXPECT_EQ(r.param.index, 0x1234);
  EXPECT_EQ(r.trigger_utime, 0);
  EXPECT_TRUE(r.bus.empty());
  const auto s = ReplyBuilder(9).status(Reply::STARTED).started(5, "sync", 12.5).build();
  EXPECT_EQ(s.command_id, 9);
  EXPECT_EQ(s.start_mechanism, "sync");
  EXPECT_DOUBLE_EQ(s.predicted_skew_us, 12.5);
}

TEST(WallClock, SystemClockOfNowIsTheWallTimeNow) {
  const auto wall = or_system_clock({});
  const auto before = wall_time_us();
  const auto at = wall(SteadyClock::now());
  EXPECT_LE(before, at);
  EXPECT_LT(at - before, 1'000'000);
  const auto injected = or_system_clock([](TimePoint) { return std::int64_t{42}; });
  EXPECT_EQ(injected(TimePoint{}), 42);
}

}  // namespace
}  // namespace motion::gateway
