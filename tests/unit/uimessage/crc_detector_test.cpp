// CrcDetector (docs/protocols.md, UIMessage row 1): the send side follows the CRC coverage of the
// gateway's frames; while nothing has come back it switches coverage after a run of unanswered
// frames, so a gateway that drops frames of the other coverage is still found; a configured
// coverage never changes.
#include "motion/uimessage/crc_detector.hpp"

#include <gtest/gtest.h>

namespace motion::uimessage {
namespace {

using uim342::CrcCoverage;

TEST(UiMessageCrcDetector, StartsWithTheManualsCoverageAndFollowsTheFirstReply) {
  CrcDetector detector(CrcCoverage::kStartToAux, true);
  EXPECT_FALSE(detector.configured());
  EXPECT_FALSE(detector.detected());
  EXPECT_EQ(detector.next_send(), CrcCoverage::kStartToAux);
  EXPECT_NE(detector.describe().find("not known yet"), std::string::npos) << detector.describe();
  // A gateway that takes our 13 bytes but answers over 12 (UIROBOT's software): follow the answer.
  EXPECT_TRUE(detector.on_received(CrcCoverage::kIdToAux));
  EXPECT_TRUE(detector.detected());
  EXPECT_EQ(detector.next_send(), CrcCoverage::kIdToAux);
  EXPECT_FALSE(detector.on_received(CrcCoverage::kIdToAux)) << "nothing new to report";
  EXPECT_EQ(detector.describe(), "ID..d8 (12 bytes), detected from the gateway's frames");
  EXPECT_EQ(detector.blind_switches(), 0u);
}

TEST(UiMessageCrcDetector, AMatchingFirstReplyIsReportedOnceAndChangesNothing) {
  CrcDetector detector(CrcCoverage::kStartToAux, true);
  EXPECT_EQ(detector.next_send(), CrcCoverage::kStartToAux);
  EXPECT_TRUE(detector.on_received(CrcCoverage::kStartToAux));  // decided: worth one report
  EXPECT_FALSE(detector.on_received(CrcCoverage::kStartToAux));
  EXPECT_EQ(detector.next_send(), CrcCoverage::kStartToAux);
  EXPECT_EQ(detector.describe(), "SM..d8 (13 bytes), detected from the gateway's frames");
}

TEST(UiMessageCrcDetector, UnansweredFramesSwitchCoverageUntilSomethingComesBack) {
  // A gateway checking 12 bytes drops our 13-byte frames silently: after 4 unanswered frames the
  // detector tries 12, after 4 more 13 again, and so on.
  CrcDetector detector(CrcCoverage::kStartToAux, true, 4);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(detector.next_send(), CrcCoverage::kStartToAux) << i;
  for (int i = 0; i < 4; ++i) EXPECT_EQ(detector.next_send(), CrcCoverage::kIdToAux) << i;
  EXPECT_EQ(detector.next_send(), CrcCoverage::kStartToAux);
  EXPECT_EQ(detector.blind_switches(), 2u);
  // The gateway answers (over 12): that coverage from now on, and silence changes nothing any more
  // (the drives may simply be off).
  EXPECT_TRUE(detector.on_received(CrcCoverage::kIdToAux));
  for (int i = 0; i < 20; ++i) EXPECT_EQ(detector.next_send(), CrcCoverage::kIdToAux) << i;
  EXPECT_EQ(detector.blind_switches(), 2u);
}

TEST(UiMessageCrcDetector, AnAnswerResetsTheUnansweredRun) {
  CrcDetector detector(CrcCoverage::kStartToAux, true, 4);
  for (int i = 0; i < 3; ++i) detector.next_send();
  detector.on_received(CrcCoverage::kStartToAux);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(detector.next_send(), CrcCoverage::kStartToAux) << i;
}

TEST(UiMessageCrcDetector, AGatewayReplacedByOneOfTheOtherCoverageIsFollowed) {
  CrcDetector detector(CrcCoverage::kStartToAux, true);
  detector.on_received(CrcCoverage::kStartToAux);
  EXPECT_TRUE(detector.on_received(CrcCoverage::kIdToAux)) << "a change is reported";
  EXPECT_EQ(detector.next_send(), CrcCoverage::kIdToAux);
}

TEST(UiMessageCrcDetector, AConfiguredCoverageIsTrustedWhateverComesBack) {
  CrcDetector detector(CrcCoverage::kIdToAux, false, 4);
  EXPECT_TRUE(detector.configured());
  for (int i = 0; i < 20; ++i) EXPECT_EQ(detector.next_send(), CrcCoverage::kIdToAux) << i;
  EXPECT_FALSE(detector.on_received(CrcCoverage::kStartToAux));
  EXPECT_EQ(detector.next_send(), CrcCoverage::kIdToAux);
  EXPECT_EQ(detector.blind_switches(), 0u);
  EXPECT_EQ(detector.describe(), "ID..d8 (12 bytes), configured (uimessage_crc)");
}

}  // namespace
}  // namespace motion::uimessage
