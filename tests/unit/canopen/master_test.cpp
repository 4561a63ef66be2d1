// NMT master / heartbeat consumer (CiA 301 §7.2.8, UC57 manual §4.1.2: boot-up, heartbeat states,
// loss) and the Master facade that routes frames to its services.
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <vector>

#include "frame_text.hpp"
#include "motion/canopen/master.hpp"
#include "motion/canopen/nmt_master.hpp"

namespace motion::canopen {
namespace {

using namespace std::chrono_literals;
using test::frame;

const TimePoint t0 = TimePoint{} + 1h;

class NmtMasterTest : public ::testing::Test {
 protected:
  NmtMasterTest() : master_([this](const can::Frame& f) { sent_.push_back(f); }) {
    master_.on_event([this](const NodeEvent& e) { events_.push_back(e); });
  }
  std::vector<can::Frame> sent_;
  std::vector<NodeEvent> events_;
  NmtMaster master_;
};

TEST_F(NmtMasterTest, SendsTheManualStartFrame) {
  master_.send(NmtCommand::kStart, kAllNodes);
  master_.send(NmtCommand::kEnterPreOperational, 1);
  EXPECT_EQ(test::to_texts(sent_), (std::vector<std::string>{"000: 01 00", "000: 80 01"}));
}

TEST_F(NmtMasterTest, BootUpThenHeartbeatStates) {
  EXPECT_TRUE(master_.on_frame(frame("701: 00"), t0));  // D-17
  ASSERT_EQ(events_.size(), 1u);
  EXPECT_EQ(events_[0].kind, NodeEventKind::kBootUp);
  EXPECT_EQ(master_.state(1), NmtState::kPreOperational);
  EXPECT_TRUE(master_.on_frame(frame("701: 7F"), t0 + 1s));  // same state: no event
  EXPECT_EQ(events_.size(), 1u);
  EXPECT_TRUE(master_.on_frame(frame("701: 05"), t0 + 2s));  // D-18
  ASSERT_EQ(events_.size(), 2u);
  EXPECT_EQ(events_[1].kind, NodeEventKind::kStateChanged);
  EXPECT_EQ(events_[1].previous, NmtState::kPreOperational);
  EXPECT_EQ(events_[1].state, NmtState::kOperational);
}

TEST_F(NmtMasterTest, HeartbeatLossAndRecovery) {
  master_.monitor(1, 1500ms);
  master_.on_frame(frame("701: 00"), t0);
  EXPECT_EQ(master_.next_deadline(), kNever);  // boot-up does not arm (1017h is 0 at boot)
  master_.on_frame(frame("701: 05"), t0 + 100ms);
  EXPECT_EQ(master_.next_deadline(), t0 + 1600ms);
  master_.on_frame(frame("701: 05"), t0 + 1100ms);
  EXPECT_EQ(master_.process(t0 + 1600ms), t0 + 2600ms);
  EXPECT_FALSE(master_.lost(1));
  EXPECT_EQ(master_.process(t0 + 2600ms), kNever);
  EXPECT_TRUE(master_.lost(1));
  EXPECT_FALSE(master_.state(1));
  EXPECT_EQ(events_.back().kind, NodeEventKind::kHeartbeatLost);
  master_.on_frame(frame("701: 05"), t0 + 3s);
  EXPECT_EQ(events_.back().kind, NodeEventKind::kHeartbeatRecovered);
  EXPECT_FALSE(master_.lost(1));
}

TEST_F(NmtMasterTest, BootUpOfAConfiguredNodeIsAReboot) {
  master_.mark_configured(1);
  EXPECT_TRUE(master_.configured(1));
  master_.on_frame(frame("701: 00"), t0);
  EXPECT_EQ(events_.back().kind, NodeEventKind::kRebooted);
  EXPECT_FALSE(master_.configured(1));
}

TEST_F(NmtMasterTest, IgnoresOtherFramesAndConsumesBadHeartbeats) {
  EXPECT_FALSE(master_.on_frame(frame("581: 60 40 60 00 00 00 00 00"), t0));
  EXPECT_TRUE(master_.on_frame(frame("701: 05 00"), t0));  // malformed: consumed, no event
  EXPECT_TRUE(events_.empty());
}

TEST(Master, RoutesFramesToItsServicesAndTheRestToTheHandler) {
  std::vector<can::Frame> sent;
  Master master([&](const can::Frame& f) { sent.push_back(f); });
  std::vector<can::Frame> unhandled;
  master.on_unhandled([&](const can::Frame& f, TimePoint) { unhandled.push_back(f); });
  std::vector<EmcyEvent> emcy;
  master.emcy().on_event([&](const EmcyEvent& e) { emcy.push_back(e); });

  std::optional<std::error_code> done;
  master.sdo().upload(1, {0x6041, 0}, [&](std::error_code e, std::span<const std::uint8_t>) { done = e; });
  EXPECT_EQ(master.process(t0), t0 + 500ms);
  EXPECT_EQ(test::to_texts(sent), std::vector<std::string>{"601: 40 41 60 00 00 00 00 00"});
  master.on_frame(frame("581: 4B 41 60 00 37 02 00 00"), t0);
  ASSERT_TRUE(done);
  EXPECT_FALSE(*done);

  master.on_frame(frame("701: 00"), t0);
  EXPECT_EQ(master.nmt().state(1), NmtState::kPreOperational);
  master.on_frame(frame("081: 10 23 03 01 01 00 00 00"), t0);
  EXPECT_EQ(emcy.size(), 1u);
  master.on_frame(frame("181: 37 02 00 00 00 00 01"), t0);
  ASSERT_EQ(unhandled.size(), 1u);
  EXPECT_EQ(unhandled[0], frame("181: 37 02 00 00 00 00 01"));

  EXPECT_EQ(master.sync(), nullptr);
  master.configure_sync({10ms, 0, kSyncCobId});
  ASSERT_NE(master.sync(), nullptr);
  master.sync()->start(t0);
  EXPECT_EQ(master.process(t0), t0 + 10ms);
  sent.clear();
  master.process(t0 + 10ms);
  EXPECT_EQ(test::to_texts(sent), std::vector<std::string>{"080:"});
}

}  // namespace
}  // namespace motion::canopen
