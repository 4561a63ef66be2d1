// Modes of operation and the profile-position new-set-point handshake (UC57 §4.2.4, §7 MC_MOVABS /
// MC_MOVREL).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>

#include "motion/cia402/modes.hpp"
#include "motion/cia402/words.hpp"

namespace motion::cia402 {
namespace {

using namespace std::chrono_literals;
using Phase = NewSetPointHandshake::Phase;

const TimePoint t0 = TimePoint{} + 1h;

// Example statuswords: the §4.2.2 bits composed as assumed where the manual is silent.
constexpr std::uint16_t kIdleNotHomed = 0x2427;    // Operation enabled, bit 10 (idle), bit 13
constexpr std::uint16_t kAckedRunning = 0x7827;    // bits 11, 12, 13, 14
constexpr std::uint16_t kRunning = 0x6027;         // bits 13, 14: ack released, still moving
constexpr std::uint16_t kReachedInPlace = 0xA427;  // bits 10, 13, 15

TEST(Modes, Uc57SupportsOnlyProfilePositionVelocityHoming) {
  EXPECT_TRUE(uc57_supports(ModeOfOperation::kNoMode));
  EXPECT_TRUE(uc57_supports(ModeOfOperation::kProfilePosition));
  EXPECT_TRUE(uc57_supports(ModeOfOperation::kProfileVelocity));
  EXPECT_TRUE(uc57_supports(ModeOfOperation::kHoming));
  // C-01: the §4.2.3 table's "2 = profile velocity" is a misprint; 2 is CiA's velocity mode.
  EXPECT_FALSE(uc57_supports(ModeOfOperation::kVelocity));
  EXPECT_FALSE(uc57_supports(ModeOfOperation::kCyclicSynchronousPosition));
  EXPECT_EQ(static_cast<int>(ModeOfOperation::kProfilePosition), 1);  // P-07: 6060h := 1
  EXPECT_EQ(static_cast<int>(ModeOfOperation::kProfileVelocity), 3);  // V-06: 6060h := 3
  EXPECT_EQ(static_cast<int>(ModeOfOperation::kHoming), 6);           // H-07: 6060h := 6
}

TEST(Modes, DecodesCiAValuesOnly) {
  EXPECT_EQ(decode_mode(6), ModeOfOperation::kHoming);
  EXPECT_EQ(decode_mode(0), ModeOfOperation::kNoMode);
  EXPECT_EQ(decode_mode(5), std::nullopt);
  EXPECT_EQ(decode_mode(11), std::nullopt);
  EXPECT_EQ(decode_mode(-1), std::nullopt);
}

TEST(ProfilePositionControlword, SpecVectors) {
  EXPECT_EQ(profile_position_controlword({}, false, false), 0x000F);
  EXPECT_EQ(profile_position_controlword({}, true, false), 0x001F);                   // absolute start
  EXPECT_EQ(profile_position_controlword({.relative = true}, false, false), 0x004F);  // P-11
  EXPECT_EQ(profile_position_controlword({.relative = true}, true, false), 0x005F);   // P-12
  EXPECT_EQ(profile_position_controlword({.change_immediately = true}, false, false), 0x002F);
  EXPECT_EQ(profile_position_controlword({.change_immediately = true}, true, false), 0x003F);
  EXPECT_EQ(profile_position_controlword({true, true}, false, false), 0x006F);
  EXPECT_EQ(profile_position_controlword({true, true}, true, false), 0x007F);
  EXPECT_EQ(profile_position_controlword({}, false, true), 0x010F);  // D-53 halt
}

TEST(NewSetPointHandshake, AbsoluteMoveFollowsMcMovAbs) {
  NewSetPointHandshake handshake(500ms);
  auto out = handshake.start({}, t0);  // step 4: 0x0F
  EXPECT_EQ(out.phase, Phase::kArming);
  EXPECT_EQ(out.controlword, 0x000F);
  EXPECT_EQ(out.deadline, t0 + 500ms);

  out = handshake.on_statusword(kIdleNotHomed, t0 + 10ms);  // step 5: bit 12 = 0 -> step 6: 0x1F
  EXPECT_EQ(out.phase, Phase::kTriggered);
  EXPECT_EQ(out.controlword, 0x001F);
  EXPECT_EQ(out.deadline, t0 + 10ms + 500ms);

  out = handshake.on_statusword(kIdleNotHomed, t0 + 20ms);  // not yet acknowledged
  EXPECT_EQ(out.phase, Phase::kTriggered);
  EXPECT_EQ(out.controlword, std::nullopt);

  out = handshake.on_statusword(kAckedRunning, t0 + 30ms);  // step 7: bit 12 = 1 -> step 8: 0x0F
  EXPECT_EQ(out.phase, Phase::kReleasing);
  EXPECT_EQ(out.controlword, 0x000F);

  out = handshake.on_statusword(kRunning, t0 + 40ms);
  EXPECT_EQ(out.phase, Phase::kMoving);
  EXPECT_EQ(out.controlword, std::nullopt);
  EXPECT_EQ(out.deadline, kNever);

  out = handshake.on_statusword(kReachedInPlace, t0 + 900ms);  // step 9
  EXPECT_EQ(out.phase, Phase::kTargetReached);
}

TEST(NewSetPointHandshake, RelativeMoveUsesBitSix) {
  NewSetPointHandshake handshake;
  EXPECT_EQ(handshake.start({.relative = true}, t0).controlword, 0x004F);
  EXPECT_EQ(handshake.on_statusword(kIdleNotHomed, t0).controlword, 0x005F);
  EXPECT_EQ(handshake.on_statusword(kAckedRunning, t0).controlword, 0x004F);
}

TEST(NewSetPointHandshake, ChangeImmediatelyUsesBitFive) {
  NewSetPointHandshake handshake;
  EXPECT_EQ(handshake.start({.change_immediately = true}, t0).controlword, 0x002F);
  EXPECT_EQ(handshake.on_statusword(kIdleNotHomed, t0).controlword, 0x003F);
}

TEST(NewSetPointHandshake, WaitsForAStaleAcknowledgeToClearBeforeTheEdge) {
  NewSetPointHandshake handshake;
  handshake.start({}, t0);
  const auto out = handshake.on_statusword(kAckedRunning, t0 + 1ms);
  EXPECT_EQ(out.phase, Phase::kArming);
  EXPECT_EQ(out.controlword, std::nullopt);
}

TEST(NewSetPointHandshake, AcknowledgeTimeout) {
  NewSetPointHandshake handshake(200ms);
  handshake.start({}, t0);
  handshake.on_statusword(kIdleNotHomed, t0);
  EXPECT_EQ(handshake.on_timer(t0 + 199ms).phase, Phase::kTriggered);
  const auto out = handshake.on_timer(t0 + 200ms);
  EXPECT_EQ(out.phase, Phase::kTimedOut);
  EXPECT_EQ(out.deadline, kNever);
  EXPECT_EQ(handshake.on_statusword(kAckedRunning, t0 + 300ms).phase, Phase::kTimedOut);
}

TEST(NewSetPointHandshake, StaleStatuswordAfterTheDeadlineTimesOut) {
  NewSetPointHandshake handshake(200ms);
  handshake.start({}, t0);
  handshake.on_statusword(kIdleNotHomed, t0);
  EXPECT_EQ(handshake.on_statusword(kIdleNotHomed, t0 + 250ms).phase, Phase::kTimedOut);
}

TEST(NewSetPointHandshake, ZeroLengthMoveIsDoneWhenTheAcknowledgeDrops) {
  NewSetPointHandshake handshake;
  handshake.start({}, t0);
  handshake.on_statusword(kIdleNotHomed, t0);
  handshake.on_statusword(kAckedRunning | mask(StatusBit::kTargetReached), t0);
  EXPECT_EQ(handshake.on_statusword(kIdleNotHomed, t0).phase, Phase::kTargetReached);
}

TEST(NewSetPointHandshake, InPositionBitAloneCompletesTheMove) {
  NewSetPointHandshake handshake;
  handshake.start({}, t0);
  handshake.on_statusword(kIdleNotHomed, t0);
  handshake.on_statusword(kAckedRunning, t0);
  handshake.on_statusword(kRunning, t0);
  EXPECT_EQ(handshake.on_statusword(kRunning | mask(StatusBit::kInPosition), t0).phase, Phase::kTargetReached);
}

TEST(NewSetPointHandshake, HaltSetsBitEightInEveryWord) {
  NewSetPointHandshake handshake;
  EXPECT_EQ(handshake.set_halt(true), 0x010F);
  EXPECT_EQ(handshake.start({}, t0).controlword, 0x010F);
  EXPECT_EQ(handshake.on_statusword(kIdleNotHomed, t0).controlword, 0x011F);
  EXPECT_EQ(handshake.set_halt(false), 0x001F);
}

TEST(NewSetPointHandshake, NewSetPointWhileMovingStartsOver) {
  NewSetPointHandshake handshake;
  handshake.start({}, t0);
  handshake.on_statusword(kIdleNotHomed, t0);
  handshake.on_statusword(kAckedRunning, t0);
  handshake.on_statusword(kRunning, t0);
  const auto out = handshake.start({.change_immediately = true}, t0 + 1s);
  EXPECT_EQ(out.phase, Phase::kArming);
  EXPECT_EQ(out.controlword, 0x002F);
  EXPECT_EQ(handshake.on_statusword(kRunning, t0 + 1s).controlword, 0x003F);
}

}  // namespace
}  // namespace motion::cia402
