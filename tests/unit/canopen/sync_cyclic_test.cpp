// SyncProducer in cyclic mode (sync.hpp): the schedule changes it hands to a cyclic sender (the
// kernel's CAN_BCM in the gateway) on a manual clock, and sent() counting the SYNCs seen.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "frame_text.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/sync.hpp"

namespace motion::canopen {
namespace {

using namespace std::chrono_literals;

// What the producer asked of the sender and of the loop's sink, in order.
struct Recorder {
  std::vector<std::string> calls;
  bool refuse = false;

  SyncCyclicSender sender() {
    return {[this](const can::Frame& frame, Duration period) {
              calls.push_back("start " + test::to_text(frame) + " every " +
                              std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(period).count()) +
                              " ms");
              return !refuse;
            },
            [this] { calls.push_back("stop"); },
            [this](Duration interval) {
              calls.push_back("retime " +
                              std::to_string(std::chrono::duration_cast<std::chrono::microseconds>(interval).count()) +
                              " us");
              return !refuse;
            }};
  }
  FrameSink sink() {
    return [this](const can::Frame& frame) { calls.push_back("loop " + test::to_text(frame)); };
  }
  std::vector<std::string> take() { return std::exchange(calls, {}); }
};

using Calls = std::vector<std::string>;

class CyclicSync : public ::testing::Test {
 protected:
  Recorder rec;
  SyncProducer producer{rec.sink(), {10ms, 0, kSyncCobId}};
  const TimePoint t0 = TimePoint{} + 1h;

  void SetUp() override { producer.use_cyclic_sender(rec.sender()); }
  // Started at t0; the sender took over at t0 + 10 ms and its first SYNC was seen then.
  void sender_running_with_one_sync_seen() {
    producer.start(t0);
    producer.process(t0 + 10ms);
    producer.on_cyclic_sync(t0 + 10ms);
    producer.process(t0 + 10ms);
    rec.take();
  }
};

TEST_F(CyclicSync, StartsTheSenderAtTheFirstDeadlineAndCountsTheSyncsSeen) {
  EXPECT_TRUE(producer.cyclic_capable());
  EXPECT_EQ(producer.start(t0), t0 + 10ms);
  EXPECT_EQ(producer.process(t0 + 9ms), t0 + 10ms);
  EXPECT_TRUE(rec.take().empty()) << "nothing before the first deadline";
  // The deadline: the sender starts (its first SYNC goes out at once); no loop SYNC.
  EXPECT_EQ(producer.process(t0 + 10ms), kNever);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 10 ms"}));
  EXPECT_TRUE(producer.cyclic());
  EXPECT_EQ(producer.sent(), 0U) << "counted when seen on the wire, not when handed over";
  // Each SYNC seen makes the loop's cycle due at once; process() runs it and waits again.
  producer.on_cyclic_sync(t0 + 10ms + 40us);
  EXPECT_EQ(producer.sent(), 1U);
  EXPECT_EQ(producer.next_deadline(), t0 + 10ms + 40us);
  EXPECT_EQ(producer.process(t0 + 10ms + 60us), kNever);
  // The kernel's SYNCs drift (each period re-armed from when its timer ran): counted as seen,
  // however far from the nominal grid.
  for (int k = 1; k <= 250; ++k) producer.on_cyclic_sync(t0 + 10ms + k * 10'020us);
  EXPECT_EQ(producer.sent(), 251U);
  EXPECT_EQ(producer.skipped(), 0U) << "the kernel never skips";
  for (const auto& call : rec.take()) EXPECT_EQ(call.rfind("retime", 0), 0U) << call << ": the loop sends nothing";
}

TEST_F(CyclicSync, TheSendersMeanLatenessIsTakenOutOfItsInterval) {
  producer.start(t0);
  producer.process(t0 + 10ms);
  rec.take();
  // The kernel's SYNCs come 300 us late each period (its timer re-arms from when it ran).
  TimePoint seen = t0 + 10ms;
  const auto see = [&](int n, Duration gap) {
    for (int k = 0; k < n; ++k) {
      seen += gap;
      producer.on_cyclic_sync(seen);
    }
  };
  see(SyncProducer::kDriftWindow, 10'300us);
  EXPECT_TRUE(rec.take().empty()) << "a whole window first";
  see(1, 10'300us);
  EXPECT_EQ(rec.take(), (Calls{"retime 9700 us"}));
  EXPECT_EQ(producer.cyclic_interval(), 9700us);
  // On period now: nothing to change.
  see(SyncProducer::kDriftWindow, 10ms);
  EXPECT_TRUE(rec.take().empty());
  // A restart (trigger_now) keeps the learned interval; a huge lateness is clamped to half the period.
  producer.trigger_now(seen);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 9 ms"})) << "9.7 ms, printed in whole ms";
  see(SyncProducer::kDriftWindow + 1, 30ms);
  EXPECT_EQ(rec.take(), (Calls{"retime 5000 us"}));
  EXPECT_EQ(producer.sent(), 3U * SyncProducer::kDriftWindow + 2U);
}

TEST_F(CyclicSync, TriggerNowRestartsTheSenderWithOneSyncNow) {
  producer.start(t0);
  producer.process(t0 + 10ms);
  producer.on_cyclic_sync(t0 + 10ms);
  rec.take();
  // The synchronized start: one SYNC now and the period restarted from it, by the sender.
  EXPECT_EQ(producer.trigger_now(t0 + 14ms), t0 + 10ms) << "the seen SYNC's cycle is still due";
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 10 ms"}));
  EXPECT_EQ(producer.process(t0 + 14ms), kNever);
  producer.on_cyclic_sync(t0 + 14ms + 30us);
  EXPECT_EQ(producer.sent(), 2U);
  EXPECT_TRUE(rec.take().empty());
}

TEST_F(CyclicSync, StopStopsTheSenderAtOnceAndStartResumesAPeriodLater) {
  producer.start(t0);
  producer.process(t0 + 10ms);
  rec.take();
  producer.stop();
  EXPECT_EQ(rec.take(), (Calls{"stop"}));
  EXPECT_FALSE(producer.cyclic());
  EXPECT_EQ(producer.next_deadline(), kNever);
  // A SYNC sent before the stop and read after it still counts, and makes no cycle due.
  producer.on_cyclic_sync(t0 + 20ms);
  EXPECT_EQ(producer.sent(), 1U);
  EXPECT_EQ(producer.process(t0 + 25ms), kNever);
  producer.stop();
  EXPECT_TRUE(rec.take().empty()) << "stopping a stopped producer asks nothing";
  // Started again: a period later the sender starts again.
  EXPECT_EQ(producer.start(t0 + 30ms), t0 + 40ms);
  EXPECT_TRUE(rec.take().empty());
  EXPECT_EQ(producer.process(t0 + 40ms), kNever);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 10 ms"}));
  // start() while the sender runs (a scheduled start's quiet time): stopped now, again a period later.
  EXPECT_EQ(producer.start(t0 + 42ms), t0 + 52ms);
  EXPECT_EQ(rec.take(), (Calls{"stop"}));
  EXPECT_EQ(producer.process(t0 + 52ms), kNever);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 10 ms"}));
}

TEST_F(CyclicSync, HoldHandsThePeriodToTheLoopAndBack) {
  sender_running_with_one_sync_seen();
  // Held (a start image waits in a drive): the sender stops now; the loop sends the next SYNC a
  // period after the last one seen, and keeps the period.
  producer.hold_cyclic(true, t0 + 13ms);
  EXPECT_EQ(rec.take(), (Calls{"stop"}));
  EXPECT_EQ(producer.next_deadline(), t0 + 20ms);
  EXPECT_EQ(producer.process(t0 + 20ms), t0 + 30ms);
  EXPECT_EQ(producer.trigger_now(t0 + 24ms), t0 + 34ms) << "held: trigger_now is the loop's";
  EXPECT_EQ(rec.take(), (Calls{"loop 080:", "loop 080:"}));
  EXPECT_EQ(producer.sent(), 3U);
  // Released: the sender takes the period over at the loop's next deadline.
  producer.hold_cyclic(false, t0 + 25ms);
  EXPECT_TRUE(rec.take().empty());
  EXPECT_EQ(producer.process(t0 + 34ms), kNever);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 10 ms"}));
  // Held when the latest SYNC seen is more than a period old: the loop waits a whole period.
  producer.hold_cyclic(true, t0 + 60ms);
  EXPECT_EQ(rec.take(), (Calls{"stop"}));
  EXPECT_EQ(producer.next_deadline(), t0 + 70ms);
}

TEST_F(CyclicSync, ANewPeriodRestartsTheSenderAPeriodAfterItsLastSync) {
  sender_running_with_one_sync_seen();
  // Longer: the sender stops now; the loop starts it again 40 ms after the last SYNC seen.
  producer.set_period(40ms, t0 + 12ms);
  EXPECT_EQ(rec.take(), (Calls{"stop"}));
  EXPECT_EQ(producer.next_deadline(), t0 + 50ms);
  EXPECT_EQ(producer.process(t0 + 49ms), t0 + 50ms);
  EXPECT_TRUE(rec.take().empty());
  EXPECT_EQ(producer.process(t0 + 50ms), kNever);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 40 ms"}));
  producer.on_cyclic_sync(t0 + 50ms);
  producer.process(t0 + 50ms);
  // Shorter, with the new period already past since the last SYNC: at once.
  producer.set_period(5ms, t0 + 60ms);
  EXPECT_EQ(rec.take(), (Calls{"stop"}));
  EXPECT_EQ(producer.process(t0 + 60ms), kNever);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 5 ms"}));
  EXPECT_THROW(producer.set_period(0ms, t0 + 61ms), std::invalid_argument);
}

TEST_F(CyclicSync, RefusedStartFallsBackToTheLoopAndTriesAgain) {
  rec.refuse = true;
  producer.start(t0);
  EXPECT_EQ(producer.process(t0 + 10ms), t0 + 20ms);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 10 ms", "loop 080:"}));
  EXPECT_FALSE(producer.cyclic());
  EXPECT_EQ(producer.sent(), 1U);
  rec.refuse = false;
  EXPECT_EQ(producer.process(t0 + 20ms), kNever);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 10 ms"}));
  // A refused restart leaves no job behind.
  rec.refuse = true;
  producer.trigger_now(t0 + 25ms);
  EXPECT_EQ(rec.take(), (Calls{"start 080: every 10 ms", "stop", "loop 080:"}));
  EXPECT_EQ(producer.next_deadline(), t0 + 35ms);
}

TEST(CyclicSyncModes, CounterAperiodicAndStoppedProducersKeepTheLoop) {
  Recorder rec;
  SyncProducer counted(rec.sink(), {10ms, 4, kSyncCobId});
  counted.use_cyclic_sender(rec.sender());
  EXPECT_FALSE(counted.cyclic_capable()) << "a counter changes every SYNC's payload";
  const TimePoint t0 = TimePoint{} + 1h;
  counted.start(t0);
  counted.process(t0 + 10ms);
  EXPECT_EQ(rec.take(), (Calls{"loop 080: 01"}));

  SyncProducer aperiodic(rec.sink(), {});
  aperiodic.use_cyclic_sender(rec.sender());
  EXPECT_FALSE(aperiodic.cyclic_capable());
  aperiodic.start(t0);
  aperiodic.trigger_now(t0);
  EXPECT_EQ(rec.take(), (Calls{"loop 080:"}));

  SyncProducer stopped(rec.sink(), {10ms, 0, kSyncCobId});
  stopped.use_cyclic_sender(rec.sender());
  stopped.trigger_now(t0);  // a single SYNC of a stopped producer: no job to leave running
  EXPECT_EQ(rec.take(), (Calls{"loop 080:"}));
  EXPECT_EQ(stopped.sent(), 1U);
}

TEST(CyclicSyncModes, WithoutSenderNothingChanges) {
  Recorder rec;
  SyncProducer producer(rec.sink(), {10ms, 0, kSyncCobId});
  const TimePoint t0 = TimePoint{} + 1h;
  producer.start(t0);
  EXPECT_EQ(producer.process(t0 + 10ms), t0 + 20ms);
  EXPECT_EQ(rec.take(), (Calls{"loop 080:"}));
  // A sender taken away while it runs: stopped, and the loop goes on a period after its last SYNC.
  producer.use_cyclic_sender(rec.sender());
  producer.process(t0 + 20ms);
  producer.on_cyclic_sync(t0 + 20ms);
  rec.take();
  producer.use_cyclic_sender({});
  EXPECT_EQ(rec.take(), (Calls{"stop"}));
  EXPECT_EQ(producer.next_deadline(), t0 + 20ms) << "the seen SYNC's cycle";
  EXPECT_EQ(producer.process(t0 + 21ms), t0 + 30ms);
  EXPECT_EQ(producer.process(t0 + 30ms), t0 + 40ms);
  EXPECT_EQ(rec.take(), (Calls{"loop 080:"}));
}

}  // namespace
}  // namespace motion::canopen
