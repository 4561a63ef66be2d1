// The command ledger's counters (LedgerCounters, motion/gateway/command_ledger.hpp) row by row of
// the lifecycle table, and the Gateway publishing them with every heartbeat (LEDGER_STATS,
// ledger_stats_t) with the commands sent again that it answered from its CommandMemory.
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include <motionlcm/ledger_stats_t.hpp>

#include "motion/gateway/command_ledger.hpp"
#include "motion/gateway/gateway.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/testing/lcm_url.hpp"

namespace motion::gateway {
namespace {

using Reply = motionlcm::gateway_reply_t;
using std::chrono::milliseconds;

motionlcm::gateway_command_t command(std::int64_t id) {
  motionlcm::gateway_command_t c{};
  c.command_id = id;
  c.kind = motionlcm::gateway_command_t::ARM_MOVE;
  return c;
}

// The path from Loading to `state` through table rows (Loading itself: no step).
std::vector<Lifecycle> path_to(Lifecycle state) {
  switch (state) {
    case Lifecycle::kLoading: return {};
    case Lifecycle::kArmed: return {Lifecycle::kArmed};
    case Lifecycle::kStarted: return {Lifecycle::kArmed, Lifecycle::kStarted};
    default: return {state};
  }
}

// Parts now by state, Loading first.
std::vector<std::int64_t> now_counts(const LedgerCounters& c) { return {c.parts.begin(), c.parts.end()}; }

class LedgerCountersRow : public ::testing::TestWithParam<LifecycleTransition> {};

// Each row: the part is counted in the state it goes to, now and in total, and leaves the counts
// of parts now with its command.
TEST_P(LedgerCountersRow, CountsThePartWhereItGoesAndForgetsItWithItsCommand) {
  const auto row = GetParam();
  std::vector<Reply> sent;
  CommandLedger<> ledger{[&sent](Reply r) { sent.push_back(std::move(r)); }};
  ASSERT_NE(ledger.add(command(7), {0, 1}), nullptr);
  EXPECT_EQ(ledger.counters().total(Lifecycle::kLoading), 2);
  EXPECT_EQ(ledger.counters().now(Lifecycle::kLoading), 2);
  const auto path = path_to(row.from);
  for (const auto step : path) ASSERT_TRUE(ledger.advance(7, 0, step));
  ASSERT_TRUE(ledger.advance(7, 0, row.to, error_code(ReplyError::kTimeout), "why"));

  const auto& c = ledger.counters();
  std::vector<std::int64_t> want(kLifecycleStates, 0);
  want[static_cast<std::size_t>(Lifecycle::kLoading)] = 1;  // node 1
  want[static_cast<std::size_t>(row.to)] += 1;              // node 0
  EXPECT_EQ(now_counts(c), want) << to_string(row.from) << " -> " << to_string(row.to);
  for (const auto s : {Lifecycle::kArmed, Lifecycle::kStarted, Lifecycle::kDone, Lifecycle::kFailed}) {
    const bool passed = s == row.to || std::find(path.begin(), path.end(), s) != path.end();
    EXPECT_EQ(c.total(s), passed ? 1 : 0) << to_string(s);
  }
  EXPECT_EQ(c.failed_as(FailureClass::kTimeout), row.to == Lifecycle::kFailed ? 1 : 0);

  // The command ends: every part not ended yet is stopped, and nothing of it is counted as there
  // any more.
  ASSERT_TRUE(ledger.finish(7, Lifecycle::kStopped).has_value());
  EXPECT_EQ(now_counts(c), std::vector<std::int64_t>(kLifecycleStates, 0));
  EXPECT_EQ(c.total(Lifecycle::kStopped), is_terminal(row.to) && row.to != Lifecycle::kStopped ? 1 : 2);
  EXPECT_EQ(c.total(Lifecycle::kLoading), 2);
}

INSTANTIATE_TEST_SUITE_P(EveryRow, LedgerCountersRow, ::testing::ValuesIn(kLifecycleTable),
                         [](const ::testing::TestParamInfo<LifecycleTransition>& row) {
                           return "Row" + std::to_string(row.param.number);
                         });

TEST(LedgerCounters, FailuresByClassReleasesRefusalsAndSums) {
  CommandLedger<> ledger{[](Reply) {}};
  const std::pair<ReplyError, FailureClass> cases[] = {
      {ReplyError::kOutsideLimits, FailureClass::kRefused}, {ReplyError::kPositionLost, FailureClass::kRefused},
      {ReplyError::kAxisFault, FailureClass::kFault},       {ReplyError::kAxisFaulted, FailureClass::kFault},
      {ReplyError::kAxisOffline, FailureClass::kOffline},   {ReplyError::kTimeout, FailureClass::kTimeout},
      {ReplyError::kDriveError, FailureClass::kOther},      {ReplyError::kNone, FailureClass::kOther},
  };
  std::int64_t id = 1;
  for (const auto& [code, cls] : cases) {
    ASSERT_NE(ledger.add(command(id), {0}), nullptr);
    ASSERT_TRUE(ledger.advance(id, 0, Lifecycle::kFailed, error_code(code), "why"));
    EXPECT_EQ(failure_class(error_code(code)), cls);
    ++id;
  }
  const auto& c = ledger.counters();
  EXPECT_EQ(c.total(Lifecycle::kFailed), 8);
  EXPECT_EQ(c.failed_as(FailureClass::kRefused), 2);
  EXPECT_EQ(c.failed_as(FailureClass::kFault), 2);
  EXPECT_EQ(c.failed_as(FailureClass::kOffline), 1);
  EXPECT_EQ(c.failed_as(FailureClass::kTimeout), 1);
  EXPECT_EQ(c.failed_as(FailureClass::kOther), 2);

  // A command let go of after its STARTED (the CAN bus driver's combining) is counted as released
  // and no longer as started.
  ASSERT_NE(ledger.add(command(50), {0, 1}), nullptr);
  ASSERT_TRUE(ledger.advance_all(50, Lifecycle::kStarted));
  EXPECT_EQ(c.now(Lifecycle::kStarted), 2);
  ledger.release(50);
  ledger.release(50);  // not there any more: nothing
  EXPECT_EQ(c.released, 1);
  EXPECT_EQ(c.now(Lifecycle::kStarted), 0);

  // Refusals are counted as before.
  ASSERT_NE(ledger.add(command(60), {0}), nullptr);
  EXPECT_EQ(ledger.add(command(60), {0}), nullptr);
  EXPECT_FALSE(ledger.advance(60, 0, Lifecycle::kLoading));
  EXPECT_FALSE(ledger.finish(61, Lifecycle::kDone).has_value());
  EXPECT_EQ(c.refused_adds, 1);
  EXPECT_EQ(c.refused_transitions, 1);
  EXPECT_EQ(c.refused_terminals, 1);

  LedgerCounters sum = c;
  sum += c;
  EXPECT_EQ(sum.total(Lifecycle::kFailed), 16);
  EXPECT_EQ(sum.failed_as(FailureClass::kOther), 4);
  EXPECT_EQ(sum.now(Lifecycle::kLoading), 2);
  EXPECT_EQ(sum.released, 2);
  EXPECT_EQ(sum.refused_adds, 2);
}

// ---- the Gateway publishes them ---------------------------------------------------------------

const char* kConfig = R"(
buses:
  - {name: can0, transport: simcan:can0}
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5}
  - {name: zd, family: uim342, bus: can0, node_id: 6}
axes:
  - {name: x, drive: xd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 1, acceleration: 1}}
  - {name: z, drive: zd, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 1, acceleration: 1}}
)";

// A driver whose commands live in a real ledger, one part per axis: an ARM_MOVE is armed at once,
// the test starts, finishes or fails it.
class LedgerDriver : public BusDriver {
 public:
  explicit LedgerDriver(GatewayOutput& out) : ledger([&out](Reply r) { out.command_reply(std::move(r)); }) {}
  void start() override {}
  void execute(const motionlcm::gateway_command_t& c) override {
    std::vector<std::size_t> nodes(c.axes.size());
    for (std::size_t i = 0; i < nodes.size(); ++i) nodes[i] = i;
    ledger.add(c, nodes);
    ledger.advance_all(c.command_id, Lifecycle::kArmed);
  }
  void fire(std::int64_t) override {}
  std::vector<motionlcm::bus_stats_t> statistics() const override { return {}; }
  bool ready() const override { return true; }
  LedgerCounters ledger_counters() const override { return ledger.counters(); }

  CommandLedger<> ledger;
};

struct GatewayLedgerFixture : ::testing::Test {
  GatewayLedgerFixture()
      : config(*config::load_string(kConfig).config),
        node(loop, {testing::unique_lcm_url(41), "LS_"}),
        health(loop, node, "gateway:can0", "gateway", milliseconds(100)),
        gateway(loop, node, health, config, "can0") {
    auto d = std::make_unique<LedgerDriver>(gateway);
    driver = d.get();
    gateway.attach(std::move(d));
    node.subscribe<Reply>(lcm::channels::kGatewayReply,
                          [this](const Reply& r, const std::string&) { replies.push_back(r); });
    node.subscribe<motionlcm::health_t>(lcm::channels::kHealth,
                                        [this](const motionlcm::health_t& h, const std::string&) {
                                          if (h.process == "gateway:can0") heartbeats.insert(h.utime);
                                        });
    node.subscribe<motionlcm::ledger_stats_t>(
        lcm::channels::kLedgerStats,
        [this](const motionlcm::ledger_stats_t& m, const std::string&) { stats.push_back(m); });
  }
  bool pump_until(const std::function<bool()>& done) {
    const auto deadline = loop.now() + milliseconds(3000);
    while (!done() && loop.now() < deadline) loop.run_once(milliseconds(5));
    return done();
  }
  // The next LEDGER_STATS published from now on.
  motionlcm::ledger_stats_t next_stats() {
    const std::size_t before = stats.size();
    EXPECT_TRUE(pump_until([&] { return stats.size() > before; }));
    return stats.empty() ? motionlcm::ledger_stats_t{} : stats.back();
  }
  static motionlcm::gateway_command_t move(std::int64_t id, const std::vector<std::string>& axes) {
    auto c = command(id);
    c.bus = "can0";
    c.utime = 1'000'000 + id;
    for (const auto& name : axes) {
      motionlcm::axis_command_t a{};
      a.axis = name;
      c.axes.push_back(a);
    }
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    return c;
  }

  config::Config config;
  EventLoop loop;
  lcm::Node node;
  lcm::HealthPublisher health;
  Gateway gateway;
  LedgerDriver* driver = nullptr;
  std::vector<Reply> replies;
  std::set<std::int64_t> heartbeats;
  std::vector<motionlcm::ledger_stats_t> stats;
};

TEST_F(GatewayLedgerFixture, PublishesTheLedgerWithEveryHeartbeatAsCommandsGoThroughIt) {
  auto first = next_stats();
  EXPECT_EQ(first.process, "gateway:can0");
  EXPECT_EQ(first.bus, "can0");
  EXPECT_EQ(first.accepted, 0);

  // A move of two axes: two parts armed, then started, then done.
  node.publish(lcm::channels::gateway_command("can0"), move(1, {"x", "z"}));
  ASSERT_TRUE(pump_until([&] { return !replies.empty(); }));
  auto s = next_stats();
  EXPECT_EQ(s.now_armed, 2);
  EXPECT_EQ(s.accepted, 2);
  EXPECT_EQ(s.armed, 2);
  // The coordinator heard no reply and sends it again: answered with ARMED, not run again.
  node.publish(lcm::channels::gateway_command("can0"), move(1, {"x", "z"}));
  ASSERT_TRUE(pump_until([&] { return replies.size() == 2; }));
  ASSERT_TRUE(driver->ledger.advance_all(1, Lifecycle::kStarted));
  s = next_stats();
  EXPECT_EQ(s.now_armed, 0);
  EXPECT_EQ(s.now_started, 2);
  ASSERT_TRUE(driver->ledger.advance_all(1, Lifecycle::kDone));
  // A move of one axis that times out while armed.
  node.publish(lcm::channels::gateway_command("can0"), move(2, {"x"}));
  ASSERT_TRUE(pump_until([&] { return !replies.empty() && replies.back().command_id == 2; }));
  ASSERT_EQ(replies.back().status, std::int8_t{Reply::ARMED}) << replies.back().reason;
  ASSERT_TRUE(driver->ledger.advance(2, 0, Lifecycle::kFailed, error_code(ReplyError::kTimeout), "no answer"));

  s = next_stats();
  EXPECT_EQ(s.now_loading + s.now_armed + s.now_started + s.now_done + s.now_failed + s.now_stopped, 0);
  EXPECT_EQ(s.accepted, 3);
  EXPECT_EQ(s.armed, 3);
  EXPECT_EQ(s.started, 2);
  EXPECT_EQ(s.done, 2);
  EXPECT_EQ(s.failed, 1);
  EXPECT_EQ(s.failed_timeout, 1);
  EXPECT_EQ(s.failed_refused + s.failed_fault + s.failed_offline + s.failed_other, 0);
  EXPECT_EQ(s.stopped, 0);
  EXPECT_EQ(s.repeats_answered, 1);
  EXPECT_EQ(s.repeats_unanswered, 0);
  EXPECT_EQ(s.refused_transitions + s.refused_terminals + s.refused_adds, 0);
  // Every LEDGER_STATS went out with a heartbeat of the gateway (its utime is the heartbeat's).
  // LCM drops a datagram whose channel has no subscriber yet when it arrives: the heartbeat the
  // gateway publishes while the fixture is being built may be gone while its LEDGER_STATS, a
  // moment later, is not. From the first heartbeat heard on, every one is heard.
  ASSERT_FALSE(heartbeats.empty());
  for (const auto& m : stats) {
    if (m.utime < *heartbeats.begin()) continue;
    EXPECT_TRUE(heartbeats.contains(m.utime)) << m.utime;
  }
}

}  // namespace
}  // namespace motion::gateway
