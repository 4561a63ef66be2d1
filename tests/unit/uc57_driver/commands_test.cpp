// Uc57Stack commands: CiA 402 enable sequence, the synchronized SYNC start, faults, SDO aborts,
// timeouts, and one terminal reply for every command kind (stop_and_state_test.cpp: stops and the
// states around a command's end; command_steps.hpp: the steps both share).
#include <gtest/gtest.h>

#include "command_steps.hpp"
#include "harness.hpp"
#include "motion/lcm/reply_error.hpp"

namespace motion::uc57_driver::testing {
namespace {

using Event = motionlcm::event_t;

std::vector<std::string> texts(const std::vector<can::Frame>& frames, std::size_t from = 0) {
  std::vector<std::string> out;
  for (std::size_t i = from; i < frames.size(); ++i) out.push_back(can::to_cansend(frames[i]));
  return out;
}

TEST(Uc57Commands, EnableSendsShutdownSwitchOnEnableOperationInRpdo1) {
  Bench bench;
  bench.start_ready();
  // Set-up's RPDO1 acceptance test (flush, test, restore) repeats the drive's own controlword: no transition.
  EXPECT_EQ(bench.node(1).controlwords, (std::vector<std::uint16_t>{0, 0, 0}));
  bench.node(1).controlwords.clear();
  enable(bench, {"a"});
  // CiA 402 transitions 2 (0x06), 3 (0x07), 4 (0x0F), each confirmed by the statusword before the next.
  const std::vector<std::uint16_t> expected{0x0006, 0x0007, 0x000F};
  EXPECT_EQ(bench.node(1).controlwords, expected);
  EXPECT_EQ(bench.node(1).state(), cia402::State::kOperationEnabled);
  EXPECT_TRUE(bench.statuses["a"].enabled);
  // They travelled in RPDO1 (controlword + target), never as SDO writes of 6040h.
  const auto frames = texts(bench.sent);
  EXPECT_NE(
      std::find_if(frames.begin(), frames.end(), [](const std::string& f) { return f.rfind("201#0600", 0) == 0; }),
      frames.end());
  EXPECT_EQ(
      std::find_if(frames.begin(), frames.end(), [](const std::string& f) { return f.rfind("601#2B406000", 0) == 0; }),
      frames.end());

  const auto disable = bench.command(Cmd::DISABLE, {"a"});
  bench.execute(disable);
  bench.run_for(std::chrono::milliseconds(300));
  EXPECT_EQ(bench.replies_of(disable.command_id).back().status, status(Reply::DONE));
  EXPECT_EQ(bench.node(1).controlwords.back(), 0x0006);  // shutdown, transition 8
}

// The coordinator checks "enabled" for the move that follows an ENABLE's DONE: the state that
// says so must go out before the DONE (the lab saw "axis c is disabled" right after it).
TEST(Uc57Commands, DoneGoesOutAfterTheStateItLeftTheAxesIn) {
  Bench bench;
  bench.start_ready();
  const auto c = bench.command(Cmd::ENABLE, {"a", "b"});
  bench.execute(c);
  bench.run_for(std::chrono::milliseconds(500));
  ASSERT_EQ(bench.replies_of(c.command_id).back().status, status(Reply::DONE));
  const std::size_t done_at = statuses_before_reply(bench, c.command_id, Reply::DONE);
  for (const std::string axis : {"a", "b"}) {
    const auto before_done = last_status_before(bench, axis, done_at);
    ASSERT_TRUE(before_done) << axis;
    EXPECT_TRUE(before_done->enabled) << axis << ": DONE went out before the enabled state";
  }
}

TEST(Uc57Commands, EnableTimesOutWhenTheDriveDoesNotSwitchOn) {
  Bench bench;
  bench.start_ready();
  bench.node(2).refuse_enable = true;
  const auto c = bench.command(Cmd::ENABLE, {"a", "b"});
  bench.execute(c);
  bench.run_for(std::chrono::seconds(2));
  ASSERT_EQ(bench.terminal_count(c.command_id), 1U);
  const auto r = bench.replies_of(c.command_id).back();
  EXPECT_EQ(r.status, status(Reply::FAILED));
  EXPECT_EQ(r.error_code, 13);
  EXPECT_NE(r.reason.find("b-drive (node 2): CiA 402 transition 3 not confirmed"), std::string::npos) << r.reason;
}

TEST(Uc57Commands, SynchronizedMoveStartsBothNodesWithOneSync) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a", "b"});
  const auto c = arm(bench, {{"a", 10000}, {"b", -3200}}, 7);
  bench.run_for(std::chrono::milliseconds(300));
  auto replies = bench.replies_of(c.command_id);
  ASSERT_EQ(replies.size(), 1U);
  EXPECT_EQ(replies[0].status, status(Reply::ARMED));
  EXPECT_EQ(bench.node(1).value(0x6081), 60);  // profile velocity by SDO
  EXPECT_EQ(bench.node(1).value(0x6060), 1);
  EXPECT_FALSE(bench.node(1).move_started_at_sync);  // armed means not started

  // The start RPDOs (bit 4 set, target inside) went out once armed (synchronous, transmission
  // type 1: applied by the next SYNC); every periodic SYNC since was masked by the armed image.
  const auto armed_frames = texts(bench.sent, 0);
  const auto last_of = [&](const std::string& prefix) {
    const auto it = std::find_if(armed_frames.rbegin(), armed_frames.rend(),
                                 [&](const std::string& f) { return f.rfind(prefix, 0) == 0; });
    return it == armed_frames.rend() ? std::string() : *it;
  };
  EXPECT_EQ(last_of("201#"), "201#1F0010270000");
  EXPECT_EQ(last_of("202#"), "202#1F0080F3FFFF");
  const std::size_t before = bench.sent.size();
  bench.stack->fire(7, bench.now);
  const auto fired = texts(bench.sent, before);
  // At the start only the SYNC goes out.
  ASSERT_EQ(fired.size(), 1U);
  EXPECT_EQ(fired[0], "080#");
  bench.settle();
  ASSERT_TRUE(bench.node(1).move_started_at_sync);
  EXPECT_EQ(bench.node(1).move_started_at_sync, bench.node(2).move_started_at_sync);

  replies = bench.replies_of(c.command_id);
  ASSERT_EQ(replies.size(), 2U);
  EXPECT_EQ(replies[1].status, status(Reply::STARTED));
  EXPECT_EQ(replies[1].start_mechanism, "sync");
  EXPECT_EQ(replies[1].predicted_skew_us, 0.0);
  EXPECT_EQ(
      replies[1].trigger_utime,
      kWallOffsetUs + std::chrono::duration_cast<std::chrono::microseconds>(bench.now.time_since_epoch()).count());

  bench.run_for(std::chrono::milliseconds(600));
  replies = bench.replies_of(c.command_id);
  ASSERT_EQ(replies.size(), 3U);
  EXPECT_EQ(replies[2].status, status(Reply::DONE));
  EXPECT_EQ(bench.node(1).value(0x6064), 10000);
  EXPECT_EQ(bench.node(2).value(0x6064), -3200);
  EXPECT_EQ(bench.statuses["b"].position_counts, -3200);
  // Bit 4 released after the acknowledge (handshake step 8).
  EXPECT_EQ(bench.node(1).controlwords.back(), 0x000F);
}

TEST(Uc57Commands, SynchronizedMoveWithTheManualsDefaultRpdo) {
  Bench bench;
  bench.node(1).pdo_remap_writable = false;
  bench.node(2).pdo_remap_writable = false;
  bench.start_ready();
  enable(bench, {"a", "b"});
  const auto c = arm(bench, {{"a", 5000}, {"b", 5000}}, 9);
  bench.run_for(std::chrono::milliseconds(300));
  EXPECT_EQ(bench.node(1).value(0x607A), 5000);  // target by SDO: no room in the default RPDO1
  const auto armed_frames = texts(bench.sent, 0);
  const auto last_rpdo = std::find_if(armed_frames.rbegin(), armed_frames.rend(),
                                      [](const std::string& f) { return f.rfind("201#", 0) == 0; });
  ASSERT_NE(last_rpdo, armed_frames.rend());
  EXPECT_EQ(*last_rpdo, "201#1F000000000001");  // D-39: CW 0x1F, 60FFh 0, 6060h 1, preloaded
  const std::size_t before = bench.sent.size();
  bench.stack->fire(9, bench.now);
  const auto fired = texts(bench.sent, before);
  ASSERT_EQ(fired.size(), 1U);
  EXPECT_EQ(fired[0], "080#");
  bench.run_for(std::chrono::milliseconds(600));
  EXPECT_EQ(bench.replies_of(c.command_id).back().status, status(Reply::DONE));
  EXPECT_EQ(bench.node(2).value(0x6064), 5000);
}

TEST(Uc57Commands, PreloadedStartSurvivesPeriodicSyncsAndADisarmWithdrawsIt) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a", "b"});
  const auto c = arm(bench, {{"a", 10000}}, 7);
  bench.run_for(std::chrono::milliseconds(300));
  ASSERT_EQ(bench.replies_of(c.command_id).size(), 1U);  // ARMED
  // Several SYNC periods with the start image waiting in the drive: each SYNC applies the armed
  // image sent right before it, and the start image goes out again right after it.
  const std::size_t mark = bench.sent.size();
  bench.run_for(std::chrono::milliseconds(500));
  const auto all = texts(bench.sent, 0);
  std::size_t syncs = 0;
  for (std::size_t i = mark; i < all.size(); ++i) {
    if (all[i] != "080#") continue;
    ++syncs;
    // The last RPDO1 of node 1 before this SYNC (all.rend() - i: the frame before index i).
    const auto before_sync = std::find_if(all.rend() - static_cast<std::ptrdiff_t>(i), all.rend(),
                                          [](const std::string& f) { return f.rfind("201#", 0) == 0; });
    ASSERT_NE(before_sync, all.rend());
    EXPECT_EQ(*before_sync, "201#0F0010270000") << "the SYNC at " << i << " would apply the start image";
  }
  EXPECT_GE(syncs, 2U);
  EXPECT_FALSE(bench.node(1).move_started_at_sync);
  // DISARM: the armed image goes out at once with the target set back to where the drive stands
  // (0), so neither the next SYNC nor a later edge starts anything.
  const auto disarm = bench.command(Cmd::DISARM, {"a"}, 7);
  bench.execute(disarm);
  bench.run_for(std::chrono::milliseconds(500));
  EXPECT_EQ(bench.replies_of(c.command_id).back().status, status(Reply::FAILED));
  EXPECT_FALSE(bench.node(1).move_started_at_sync);
  const auto after = texts(bench.sent, 0);
  const auto last =
      std::find_if(after.rbegin(), after.rend(), [](const std::string& f) { return f.rfind("201#", 0) == 0; });
  ASSERT_NE(last, after.rend());
  EXPECT_EQ(*last, "201#0F0000000000");
}

// kernel_sync: the kernel's job sends the periodic SYNC; it stops before a start image goes into a
// drive (the loop's masked SYNCs take over) and the trigger's SYNC starts it again.
TEST(Uc57Commands, KernelSyncStopsWhileAStartImageWaitsAndItsTriggerSyncStartsTheMove) {
  Bench bench(kLabYaml, {}, true);
  bench.start_ready();
  EXPECT_TRUE(bench.stack->kernel_sync_running());
  const auto count = [&](const std::string& text, std::size_t from) {
    return static_cast<std::size_t>(
        std::count(bench.wire_log.begin() + static_cast<std::ptrdiff_t>(from), bench.wire_log.end(), text));
  };
  EXPECT_EQ(count("080#", 0), 0U) << "no SYNC of the loop's while the kernel's job runs";
  EXPECT_GE(count("BCM 080#", 0), 10U);
  enable(bench, {"a", "b"});
  const std::size_t before_arm = bench.wire_log.size();
  const auto c = arm(bench, {{"a", 10000}, {"b", -3200}}, 7);
  bench.run_for(std::chrono::milliseconds(300));
  ASSERT_EQ(bench.replies_of(c.command_id).size(), 1U);  // ARMED
  const auto from_arm = [&](const std::string& text) {
    return std::find(bench.wire_log.begin() + static_cast<std::ptrdiff_t>(before_arm), bench.wire_log.end(), text);
  };
  ASSERT_NE(from_arm("201#1F0010270000"), bench.wire_log.end()) << "node 1's start image";
  EXPECT_LT(from_arm("BCM stop"), from_arm("201#1F0010270000")) << "the kernel's job stops before it goes out";
  EXPECT_EQ(std::find(from_arm("BCM stop"), bench.wire_log.end(), "BCM 080#"), bench.wire_log.end());
  EXPECT_FALSE(bench.stack->kernel_sync_running());
  EXPECT_GE(count("080#", before_arm), 2U) << "the loop's (masked) periodic SYNCs";
  EXPECT_FALSE(bench.node(1).move_started_at_sync);

  // The trigger: the start's SYNC is the kernel's restarted job (the period from it on).
  const std::size_t before_fire = bench.wire_log.size();
  bench.stack->fire(7, bench.now);
  EXPECT_EQ(
      std::vector<std::string>(bench.wire_log.begin() + static_cast<std::ptrdiff_t>(before_fire), bench.wire_log.end()),
      (std::vector<std::string>{"BCM start", "BCM 080#"}));
  bench.settle();
  ASSERT_TRUE(bench.node(1).move_started_at_sync);
  EXPECT_EQ(bench.node(1).move_started_at_sync, bench.node(2).move_started_at_sync);
  bench.run_for(std::chrono::milliseconds(600));
  EXPECT_EQ(bench.replies_of(c.command_id).back().status, status(Reply::DONE));
  EXPECT_EQ(bench.node(1).value(0x6064), 10000);
  EXPECT_EQ(bench.node(2).value(0x6064), -3200);
  EXPECT_TRUE(bench.stack->kernel_sync_running());
  // Every SYNC on the wire, the kernel's and the loop's, was counted.
  EXPECT_EQ(bench.stack->syncs_sent(), count("080#", 0) + count("BCM 080#", 0));
}

// SYNC frames sent from `from` on.
std::size_t syncs_since(const Bench& bench, std::size_t from) {
  const auto all = texts(bench.sent, from);
  return static_cast<std::size_t>(std::count(all.begin(), all.end(), std::string("080#")));
}

// a and b armed for trigger 7, the time just after a periodic SYNC (the next one a period, 50 ms at
// poll_hz 20, away). `after_sync` later a start `start_in` ahead is prepared (as when the gateway
// hears its trigger): no SYNC goes out within the quiet time before the start, the start sends
// one, and the periodic SYNC resumes. Returns the SYNCs sent from the preparation until 10 ms
// before the start.
std::size_t prepared_start_keeps_the_sync_off(Bench& bench, Duration after_sync, Duration start_in) {
  bench.start_ready();
  enable(bench, {"a", "b"});
  const auto c = arm(bench, {{"a", 10000}, {"b", -3200}}, 7);
  bench.run_for(std::chrono::milliseconds(300));
  EXPECT_EQ(bench.replies_of(c.command_id).size(), 1U);  // ARMED
  std::size_t mark = bench.sent.size();
  for (int i = 0; i < 100 && syncs_since(bench, mark) == 0; ++i) bench.run_for(std::chrono::milliseconds(1));
  EXPECT_EQ(syncs_since(bench, mark), 1U);
  bench.run_for(after_sync);
  const TimePoint start = bench.now + start_in;
  bench.stack->prepare_fire(start, bench.now);
  mark = bench.sent.size();
  bench.run_for(start - std::chrono::milliseconds(10) - bench.now);
  const std::size_t before_quiet = syncs_since(bench, mark);
  bench.run_for(start - bench.now);
  EXPECT_EQ(syncs_since(bench, mark), before_quiet) << "a periodic SYNC went out 1 ms before the start";
  bench.stack->fire(7, bench.now);
  EXPECT_EQ(syncs_since(bench, mark), before_quiet + 1);
  bench.run_for(std::chrono::milliseconds(120));
  EXPECT_GE(syncs_since(bench, mark), before_quiet + 3) << "the periodic SYNC resumes after the start";
  return before_quiet;
}

TEST(Uc57Commands, NoPeriodicSyncJustBeforeAScheduledStart) {
  Bench bench;
  // Heard 51 ms ahead: the next periodic SYNC would go out 1 ms before the start.
  EXPECT_EQ(prepared_start_keeps_the_sync_off(bench, {}, std::chrono::milliseconds(51)), 0U);
}

// A start heard more than a SYNC period ahead (a serial line's start wait lengthens the time
// between hearing and the start): the periodic SYNC that comes due first is not in the quiet time
// and goes out; the next one, due 1 ms before the start, is judged when it comes due and moved.
TEST(Uc57Commands, NoPeriodicSyncJustBeforeAStartHeardMoreThanAPeriodAhead) {
  Bench bench;
  EXPECT_EQ(prepared_start_keeps_the_sync_off(bench, std::chrono::milliseconds(20), std::chrono::milliseconds(81)), 1U)
      << "the SYNC outside the quiet time goes out";
}

// An SDO request handed over within the quiet time before a scheduled start (a PARAM_READ, a
// position poll) would put its frame and the drive's answer ahead of the start frames: it waits
// and goes out right behind the start's SYNC, and the transfer still completes. One handed over
// before the quiet time goes at once.
TEST(Uc57Commands, SdoRequestsWithinTheQuietTimeGoRightBehindTheStart) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a", "b"});
  const auto move = arm(bench, {{"a", 10000}, {"b", -3200}}, 7);
  bench.run_for(std::chrono::milliseconds(300));
  ASSERT_EQ(bench.replies_of(move.command_id).size(), 1U);  // ARMED
  bench.node(1).set_value(0x607A, 0, 10000);
  bench.node(2).set_value(0x6081, 0, 1234);
  const auto read = [&bench](const std::string& axis, std::uint16_t index) {
    auto c = bench.command(Cmd::PARAM_READ, {axis});
    c.param.space = motionlcm::param_t::CANOPEN_OBJECT;
    c.param.index = index;
    c.param.subindex = 0;
    bench.execute(c);
    return c.command_id;
  };
  const auto sdo_requests = [&bench](std::size_t from) {
    std::size_t count = 0;
    for (std::size_t i = from; i < bench.sent.size(); ++i) {
      if (!bench.sent[i].extended && bench.sent[i].id >= 0x601 && bench.sent[i].id <= 0x67F) ++count;
    }
    return count;
  };
  const TimePoint start = bench.now + std::chrono::milliseconds(20);
  bench.stack->prepare_fire(start, bench.now);
  bench.run_for(start - Uc57Stack::kQuietBeforeStart - std::chrono::microseconds(500) - bench.now);
  std::size_t mark = bench.sent.size();
  const auto early = read("a", 0x607A);  // before the quiet time: goes at once
  bench.run_for(Duration::zero());
  EXPECT_EQ(sdo_requests(mark), 1U);
  bench.run_for(std::chrono::milliseconds(1));
  EXPECT_EQ(bench.replies_of(early).back().status, status(Reply::DONE));

  mark = bench.sent.size();
  const auto held_a = read("a", 0x607A);
  bench.run_for(std::chrono::milliseconds(1));
  const auto held_b = read("b", 0x6081);
  bench.run_for(start - bench.now);
  EXPECT_EQ(sdo_requests(mark), 0U) << "an SDO request went out within the quiet time before the start";
  EXPECT_EQ(bench.terminal_count(held_a), 0U);
  const std::size_t before_fire = bench.sent.size();
  bench.stack->fire(7, bench.now);
  const auto fired = texts(bench.sent, before_fire);
  ASSERT_EQ(fired.size(), 3U) << ::testing::PrintToString(fired);
  EXPECT_EQ(fired[0], "080#") << "the start's SYNC goes first";
  EXPECT_EQ(fired[1].substr(0, 4), "601#");
  EXPECT_EQ(fired[2].substr(0, 4), "602#");
  bench.run_for(std::chrono::milliseconds(20));
  ASSERT_EQ(bench.replies_of(held_a).back().status, status(Reply::DONE)) << bench.replies_of(held_a).back().reason;
  EXPECT_EQ(bench.replies_of(held_a).back().param.value, 10000);
  ASSERT_EQ(bench.replies_of(held_b).back().status, status(Reply::DONE)) << bench.replies_of(held_b).back().reason;
  EXPECT_EQ(bench.replies_of(held_b).back().param.value, 1234);
  EXPECT_EQ(bench.replies_of(move.command_id)[1].status, status(Reply::STARTED));
}

// A start that never comes (its trigger lost): the held requests go kStartGrace after it.
TEST(Uc57Commands, SdoRequestsHeldForAStartThatNeverComesGoAfterTheGrace) {
  Bench bench;
  bench.start_ready();
  auto c = bench.command(Cmd::PARAM_READ, {"a"});
  c.param.space = motionlcm::param_t::CANOPEN_OBJECT;
  c.param.index = 0x6081;
  c.param.subindex = 0;
  const TimePoint start = bench.now + std::chrono::milliseconds(2);
  bench.stack->prepare_fire(start, bench.now);
  bench.execute(c);
  bench.run_for(start + Uc57Stack::kStartGrace - std::chrono::microseconds(200) - bench.now);
  EXPECT_EQ(bench.terminal_count(c.command_id), 0U);
  bench.run_for(std::chrono::milliseconds(5));
  ASSERT_EQ(bench.terminal_count(c.command_id), 1U);
  EXPECT_EQ(bench.replies_of(c.command_id).back().status, status(Reply::DONE));
}

TEST(Uc57Commands, FaultDuringAMoveFailsItNamingAxisAndErrorCode) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a", "b"});
  bench.node(2).motion_syncs = 100;
  const auto c = arm(bench, {{"a", 1000}, {"b", 1000}}, 0);  // trigger 0: start at once
  bench.run_for(std::chrono::milliseconds(400));
  ASSERT_EQ(bench.replies_of(c.command_id).size(), 2U);  // ARMED, STARTED
  bench.deliver(bench.node(2).inject_fault(0x2310, 0x0001));
  bench.run_for(std::chrono::milliseconds(200));
  ASSERT_EQ(bench.terminal_count(c.command_id), 1U);
  const auto r = bench.replies_of(c.command_id).back();
  EXPECT_EQ(r.status, status(Reply::FAILED));
  EXPECT_EQ(r.error_code, 5);
  EXPECT_NE(r.reason.find("b-drive (node 2): EMCY 0x2310"), std::string::npos) << r.reason;
  EXPECT_TRUE(bench.has_event(Event::EMCY));
  EXPECT_TRUE(bench.statuses["b"].fault);
  EXPECT_NE(bench.statuses["b"].fault_text.find("overcurrent"), std::string::npos) << bench.statuses["b"].fault_text;

  // FAULT_RESET: 0x00 then 0x80 (transition 15), then the axis can be enabled again.
  const auto reset = bench.command(Cmd::FAULT_RESET, {"b"});
  bench.execute(reset);
  bench.run_for(std::chrono::milliseconds(300));
  EXPECT_EQ(bench.replies_of(reset.command_id).back().status, status(Reply::DONE))
      << bench.replies_of(reset.command_id).back().reason;
  EXPECT_EQ(bench.node(2).controlwords.back(), 0x0080);
  EXPECT_EQ(bench.node(2).state(), cia402::State::kSwitchOnDisabled);
  EXPECT_FALSE(bench.statuses["b"].fault);
}

TEST(Uc57Commands, SdoAbortNamesTheObjectAndTheAbortCode) {
  Bench bench;
  bench.start_ready();
  bench.node(1).forced_aborts[FakeUc57::key(0x6081, 0)] = 0x06090030;
  auto c = bench.command(Cmd::PARAM_WRITE, {"a"});
  c.param.space = motionlcm::param_t::CANOPEN_OBJECT;
  c.param.index = 0x6081;
  c.param.subindex = 0;
  c.param.value = 5000;
  bench.execute(c);
  bench.run_for(std::chrono::milliseconds(100));
  ASSERT_EQ(bench.terminal_count(c.command_id), 1U);
  const auto r = bench.replies_of(c.command_id).back();
  EXPECT_EQ(r.status, status(Reply::FAILED));
  EXPECT_EQ(r.error_code, 12);
  EXPECT_EQ(r.reason,
            "a-drive (node 1): SDO write 0x6081:00 aborted: invalid value for parameter (download only) (0x06090030)");
  EXPECT_EQ(bench.stack->counters().sdo_aborts, 1);
}

TEST(Uc57Commands, ParamReadReturnsTheValueInTheObjectsType) {
  Bench bench;
  bench.start_ready();
  bench.node(1).set_value(0x607A, 0, -3200);
  auto c = bench.command(Cmd::PARAM_READ, {"a"});
  c.param.space = motionlcm::param_t::CANOPEN_OBJECT;
  c.param.index = 0x607A;
  c.param.subindex = -1;
  bench.execute(c);
  bench.run_for(std::chrono::milliseconds(100));
  const auto r = bench.replies_of(c.command_id).back();
  ASSERT_EQ(r.status, status(Reply::DONE)) << r.reason;
  EXPECT_EQ(r.param.value, -3200);  // I32 from the UC57 dictionary: sign-extended
}

TEST(Uc57Commands, TriggerBeforeEveryAxisIsArmedFails) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a", "b"});
  const auto c = arm(bench, {{"a", 100}, {"b", 100}}, 5);
  bench.stack->fire(5, bench.now);  // SDO set-up still under way
  bench.settle();
  ASSERT_EQ(bench.terminal_count(c.command_id), 1U);
  EXPECT_EQ(bench.replies_of(c.command_id).back().error_code, 11);
  bench.run_for(std::chrono::milliseconds(300));
  EXPECT_EQ(bench.replies_of(c.command_id).size(), 1U);  // nothing after the terminal reply
  EXPECT_FALSE(bench.node(1).move_started_at_sync);
}

TEST(Uc57Commands, MotionOnADisabledAxisIsRefused) {
  Bench bench;
  bench.start_ready();
  const auto c = arm(bench, {{"a", 100}}, 0);
  const auto r = bench.replies_of(c.command_id);
  ASSERT_EQ(r.size(), 1U);
  EXPECT_EQ(r[0].error_code, 4);
  EXPECT_NE(r[0].reason.find("a-drive (node 1) is not enabled"), std::string::npos) << r[0].reason;
}

TEST(Uc57Commands, EveryCommandKindEndsInExactlyOneTerminalReply) {
  Bench bench;
  bench.start_ready();
  enable(bench, {"a", "b"});
  const auto run = [&bench](const Cmd& c) {
    bench.execute(c);
    bench.run_for(std::chrono::milliseconds(600));
    EXPECT_EQ(bench.terminal_count(c.command_id), 1U) << "kind " << int{c.kind};
    const auto r = bench.replies_of(c.command_id);
    return r.empty() ? Reply{} : r.back();
  };
  auto jog = bench.command(Cmd::JOG, {"a"});
  jog.axes[0].velocity = -3200;
  jog.axes[0].acceleration = jog.axes[0].deceleration = 32000;
  EXPECT_EQ(run(jog).status, status(Reply::DONE));
  EXPECT_EQ(bench.node(1).value(0x60FF), -60);
  EXPECT_EQ(bench.node(1).value(0x6061), 3);
  EXPECT_EQ(run(bench.command(Cmd::STOP, {"a"})).status, status(Reply::DONE));
  EXPECT_TRUE(cia402::is_set(bench.node(1).controlwords.back(), cia402::ControlBit::kHalt));

  auto home = bench.command(Cmd::HOME, {"a"});
  home.axes[0].velocity = 3200;
  home.axes[0].acceleration = 32000;
  const auto homed = run(home);
  EXPECT_EQ(homed.status, status(Reply::DONE)) << homed.reason;
  EXPECT_EQ(bench.node(1).value(0x6098), 24);  // IN2 origin, positive direction: "forward origin"
  EXPECT_EQ(bench.node(1).value(0x6061), 6);
  EXPECT_TRUE(bench.statuses["a"].homed);

  const auto home_b = run(bench.command(Cmd::HOME, {"b"}));  // axis b has no homing configured
  EXPECT_EQ(home_b.status, status(Reply::FAILED));
  EXPECT_EQ(home_b.error_code, 17);

  auto outputs = bench.command(Cmd::SET_OUTPUTS, {"a"});
  outputs.axes[0].output_mask = 0b11;
  outputs.axes[0].output_value = 0b01;
  EXPECT_EQ(run(outputs).status, status(Reply::DONE));
  EXPECT_EQ(bench.node(1).value(0x2030, 0x0D), 5);  // OUT1 forced high
  EXPECT_EQ(bench.node(1).value(0x2030, 0x0E), 6);  // OUT2 forced low
  outputs = bench.command(Cmd::SET_OUTPUTS, {"a"});
  outputs.axes[0].output_mask = 0b100;
  EXPECT_EQ(run(outputs).error_code, 3);

  auto zero = bench.command(Cmd::SET_POSITION, {"a"});
  EXPECT_EQ(run(zero).status, status(Reply::DONE));
  EXPECT_EQ(bench.node(1).value(0x2012), 1);
  auto nonzero = bench.command(Cmd::SET_POSITION, {"a"});
  nonzero.axes[0].target_counts = 77;
  EXPECT_EQ(run(nonzero).error_code, 17);

  auto read = bench.command(Cmd::PARAM_READ, {"a"});
  read.param.space = motionlcm::param_t::CANOPEN_OBJECT;
  read.param.index = 0x1000;
  EXPECT_EQ(run(read).param.value, 0x00040192);
  auto wrong_space = bench.command(Cmd::PARAM_READ, {"a"});
  wrong_space.param.space = motionlcm::param_t::MODBUS_REGISTER;
  EXPECT_EQ(run(wrong_space).error_code, 1);

  // DISARM ends the armed move (FAILED) and itself (DONE).
  const auto armed = arm(bench, {{"b", 500}}, 42);
  bench.run_for(std::chrono::milliseconds(300));
  EXPECT_EQ(run(bench.command(Cmd::DISARM, {"b"}, 42)).status, status(Reply::DONE));
  EXPECT_EQ(bench.terminal_count(armed.command_id), 1U);
  EXPECT_EQ(bench.replies_of(armed.command_id).back().status, status(Reply::FAILED));

  EXPECT_EQ(run(bench.command(Cmd::ESTOP, {"a", "b"})).status, status(Reply::DONE));
  EXPECT_EQ(bench.node(2).state(), cia402::State::kQuickStopActive);
  EXPECT_EQ(run(bench.command(Cmd::FAULT_RESET, {"a"})).status, status(Reply::DONE));  // no fault: nothing to do
  EXPECT_EQ(run(bench.command(Cmd::ENABLE, {"b"})).status, status(Reply::DONE));       // transition 16
  EXPECT_EQ(run(bench.command(Cmd::DISABLE, {"a", "b"})).status, status(Reply::DONE));
  EXPECT_EQ(run(bench.command(99, {"a"})).error_code, 1);
  EXPECT_EQ(run(bench.command(Cmd::ENABLE, {"x"})).error_code, 2);  // a UIM342 axis
}

// What the UC57 cannot do for one axis refuses the whole command before anything goes out: a HOME
// with an offset on its second axis (random lab seed 1) zeroed the first axis (2012h) and failed.
TEST(Uc57Commands, CommandRefusedForOneAxisChangesNoOtherAxis) {
  const std::string yaml = R"(
buses:
  - {name: can0, transport: simcan:can0, bitrate: 1000000, request_timeout_ms: 50, retries: 2, poll_hz: 20}
drives:
  - {name: a-drive, family: uc57, bus: can0, node_id: 1, setup: {micro_steps: 16, current_a: 2.0, tpdo_mode: sync}}
  - {name: b-drive, family: uc57, bus: can0, node_id: 2, setup: {micro_steps: 16, current_a: 2.0, tpdo_mode: sync}}
axes:
  - {name: a, drive: a-drive, steps_per_unit: 160, limits: {min: -18, max: 46, velocity: 54, acceleration: 367},
     homing: {method: current-position, offset: 0}}
  - {name: b, drive: b-drive, steps_per_unit: 12.5, limits: {min: -220, max: 740, velocity: 384, acceleration: 1475},
     homing: {method: current-position, offset: -105.5}}
)";
  Bench bench(yaml);
  bench.start_ready();
  enable(bench, {"a", "b"});
  bench.node(1).set_value(0x6064, 0, 500);
  bench.run_for(std::chrono::milliseconds(200));
  const std::size_t frames_before = bench.sent.size();
  auto home = bench.command(Cmd::HOME, {"a", "b"});
  home.axes[1].target_counts = -1319;
  bench.execute(home);
  ASSERT_EQ(bench.terminal_count(home.command_id), 1U);
  const auto r = bench.replies_of(home.command_id).back();
  EXPECT_EQ(r.error_code, error_code(ReplyError::kUnsupported));
  EXPECT_NE(r.reason.find("b-drive (node 2): the UC57 can only zero its position"), std::string::npos) << r.reason;
  auto set_position = bench.command(Cmd::SET_POSITION, {"a", "b"});
  set_position.axes[1].target_counts = 77;
  bench.execute(set_position);
  ASSERT_EQ(bench.terminal_count(set_position.command_id), 1U);
  EXPECT_EQ(bench.replies_of(set_position.command_id).back().error_code, error_code(ReplyError::kUnsupported));
  auto outputs = bench.command(Cmd::SET_OUTPUTS, {"a", "b"});
  outputs.axes[0].output_mask = outputs.axes[0].output_value = 1;
  outputs.axes[1].output_mask = 0b100;
  bench.execute(outputs);
  ASSERT_EQ(bench.terminal_count(outputs.command_id), 1U);
  EXPECT_EQ(bench.replies_of(outputs.command_id).back().error_code, error_code(ReplyError::kOutsideLimits));
  bench.run_for(std::chrono::milliseconds(200));
  EXPECT_EQ(bench.node(1).value(0x2012), 0) << "a's position was zeroed by a refused command";
  EXPECT_EQ(bench.node(1).value(0x6064), 500);
  EXPECT_EQ(bench.statuses["a"].position_counts, 500);
  for (std::size_t i = frames_before; i < bench.sent.size(); ++i) {
    EXPECT_NE(bench.sent[i].id, 0x601u) << "an SDO went to node 1: " << can::to_cansend(bench.sent[i]);
  }
}

}  // namespace
}  // namespace motion::uc57_driver::testing
