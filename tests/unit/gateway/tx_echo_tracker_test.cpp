// TxEchoTracker: our frames' echoes recognised in send order, start frames dated by their echo.
#include "motion/gateway/tx_echo_tracker.hpp"

#include <gtest/gtest.h>

namespace motion::gateway {
namespace {

using Started = std::vector<std::pair<std::int64_t, std::int64_t>>;

can::Frame frame(const char* text, std::int64_t timestamp_us = 0) {
  can::Frame f = *can::parse_cansend(text);
  f.timestamp_us = timestamp_us;
  return f;
}

TEST(TxEchoTracker, EchoesAreOursInOrderAndDateTheirStartFrames) {
  TxEchoTracker t;
  Started started;
  t.sent(frame("601#40"));
  t.sent(frame("080#"));
  ASSERT_TRUE(t.mark_start(7, frame("080#")));
  t.sent(frame("201#1F"));
  EXPECT_FALSE(t.working());
  EXPECT_TRUE(t.awaiting(7));
  EXPECT_FALSE(t.on_receive(frame("581#60", 90), 0, started)) << "another node's frame";
  EXPECT_TRUE(t.on_receive(frame("601#40", 100), 0, started));
  EXPECT_TRUE(started.empty());
  EXPECT_TRUE(t.working());
  EXPECT_TRUE(t.on_receive(frame("080#", 212), 0, started));
  EXPECT_EQ(started, (Started{{7, 212}}));
  EXPECT_FALSE(t.awaiting(7));
  started.clear();
  EXPECT_TRUE(t.on_receive(frame("201#1F", 0), 555, started)) << "no timestamp: the receive time";
  EXPECT_TRUE(started.empty());
  EXPECT_EQ(t.echoes(), 3u);
}

TEST(TxEchoTracker, ASequentialStartIsDatedByItsFirstFrameOnceAllAreBack) {
  TxEchoTracker t;
  Started started;
  t.sent(frame("00A80005#"));
  t.mark_start(9, frame("00A80005#"));
  t.sent(frame("00A80006#"));
  t.mark_start(9, frame("00A80006#"));
  EXPECT_TRUE(t.on_receive(frame("00A80005#", 300), 0, started));
  EXPECT_TRUE(started.empty()) << "one start frame still on its way";
  EXPECT_TRUE(t.on_receive(frame("00A80006#", 420), 0, started));
  EXPECT_EQ(started, (Started{{9, 300}}));
}

TEST(TxEchoTracker, AnEchoThatNeverCameIsForgottenWithItsStart) {
  TxEchoTracker t;
  Started started;
  t.sent(frame("080#"));
  t.mark_start(3, frame("080#"));
  t.sent(frame("601#40"));
  EXPECT_TRUE(t.on_receive(frame("601#40", 50), 0, started));  // the SYNC before it was lost
  EXPECT_FALSE(t.awaiting(3));
  EXPECT_TRUE(started.empty());
  EXPECT_FALSE(t.on_receive(frame("080#", 60), 0, started)) << "forgotten: now someone else's";
}

TEST(TxEchoTracker, ATransportWithoutEchoDisablesItAfterTheLimit) {
  TxEchoTracker t(4);
  Started started;
  for (int i = 0; i < 5; ++i) t.sent(frame("601#40"));
  EXPECT_TRUE(t.disabled());
  EXPECT_FALSE(t.working());
  EXPECT_FALSE(t.mark_start(1, frame("601#40")));
  EXPECT_FALSE(t.on_receive(frame("601#40"), 0, started));
}

}  // namespace
}  // namespace motion::gateway
