// Status (§8.4) and alarm (§8.52) decoding.
#include <gtest/gtest.h>

#include "motion/adam/status.hpp"

namespace motion::adam {
namespace {

TEST(AdamStatus, DerivedStatusReplies) {
  struct Case {
    const char* what;
    std::uint32_t raw;
    MotionPhase phase;
    bool in_position, moving, enable_input_high;
    std::uint8_t inputs;
  };
  const Case cases[] = {
      {"idle in position", 0x00001000, MotionPhase::kIdle, true, false, false, 0},
      {"cruising", 0x00000300, MotionPhase::kCruising, false, true, false, 0},
      {"accelerating", 0x00000100, MotionPhase::kAccelerating, false, true, false, 0},
      {"decelerating", 0x00000200, MotionPhase::kDecelerating, false, true, false, 0},
      {"X1 input, running", 0x00000302, MotionPhase::kCruising, false, true, false, 0x02},
      {"in position, X16 high", 0x00011000, MotionPhase::kIdle, true, false, true, 0},
      {"idle but not in position", 0x00000000, MotionPhase::kIdle, false, true, false, 0},
  };
  for (const auto& c : cases) {
    const DriveStatus s = decode_status(c.raw);
    EXPECT_EQ(s.phase, c.phase) << c.what;
    EXPECT_EQ(s.in_position, c.in_position) << c.what;
    EXPECT_EQ(s.moving(), c.moving) << c.what;
    EXPECT_EQ(s.enable_input_high, c.enable_input_high) << c.what;
    EXPECT_EQ(s.inputs, c.inputs) << c.what;
    EXPECT_EQ(encode_status(s), c.raw) << c.what;
  }
  EXPECT_EQ(decode_status(0x1000, 0x0001), decode_status(0x00011000U));  // registers 0x0006, 0x0007
}

TEST(AdamStatus, EveryFlagHasItsBit) {
  struct Case {
    unsigned bit;
    bool DriveStatus::*flag;
  };
  const Case cases[] = {
      {10, &DriveStatus::deviation_exceeded}, {11, &DriveStatus::reminder_x11},       {12, &DriveStatus::in_position},
      {13, &DriveStatus::negative_limit},     {14, &DriveStatus::positive_limit},     {15, &DriveStatus::at_home},
      {16, &DriveStatus::enable_input_high},  {17, &DriveStatus::reminder_x17},       {18, &DriveStatus::reminder_x18},
      {19, &DriveStatus::reminder_x19},       {20, &DriveStatus::deviation_negative},
  };
  for (const auto& c : cases) {
    const DriveStatus s = decode_status(1U << c.bit);
    EXPECT_TRUE(s.*c.flag) << c.bit;
    DriveStatus expected;
    expected.*c.flag = true;
    EXPECT_EQ(s, expected) << c.bit;
  }
  for (unsigned n = 0; n < 8; ++n) EXPECT_TRUE(decode_status(1U << n).input(n));
  EXPECT_TRUE(decode_status(1U << 13).at_limit());
  EXPECT_EQ(decode_status(kStatusReservedMask), DriveStatus{});  // reserved bits ignored
}

TEST(AdamAlarms, CodesHistoryAndManualTexts) {
  const AlarmState example = decode_alarms(0x0003);  // §8.52: under-voltage now, no history
  EXPECT_EQ(example.current, AlarmCode::kUnderVoltage);
  EXPECT_TRUE(example.active());
  EXPECT_EQ(example.history, (std::array<AlarmCode, 3>{}));

  const AlarmState h = decode_alarms(0xA41C);
  EXPECT_EQ(h.current, static_cast<AlarmCode>(12));
  EXPECT_EQ(h.history,
            (std::array<AlarmCode, 3>{AlarmCode::kOverCurrent, AlarmCode::kPhaseAOpen, AlarmCode::kEncoderError}));
  EXPECT_EQ(encode_alarms(h), 0xA41C);
  EXPECT_FALSE(decode_alarms(0xFFF0).active());

  const std::pair<AlarmCode, std::string_view> texts[] = {
      {AlarmCode::kNone, "Normal"},
      {AlarmCode::kOverCurrent, "Over-current"},
      {AlarmCode::kOverVoltage, "Over-voltage"},
      {AlarmCode::kUnderVoltage, "Under-voltage"},
      {AlarmCode::kPhaseAOpen, "Phase A open circuit"},
      {AlarmCode::kPhaseBOpen, "Phase B open circuit"},
      {AlarmCode::kPositionError, "offset pulses or others"},
      {AlarmCode::kInternal24vFault, "internal 24V offset"},
      {AlarmCode::kPhaseAVoltage, "AI voltage error"},
      {AlarmCode::kPhaseBVoltage, "BI voltage error"},
      {AlarmCode::kEncoderError, "Encoder error"},
      {static_cast<AlarmCode>(11), "Unknown alarm"},
  };
  for (const auto& [code, text] : texts) EXPECT_EQ(alarm_text(code), text);
}

}  // namespace
}  // namespace motion::adam
