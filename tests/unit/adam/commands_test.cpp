// Command words and bit fields against the manual's bit-field examples (§8) and ranges.
#include <gtest/gtest.h>

#include "hex.hpp"
#include "motion/adam/commands.hpp"

namespace motion::adam {
namespace {

using test::to_hex;

TEST(AdamCommands, EnumValuesAreTheManualsCodes) {
  EXPECT_EQ(static_cast<std::uint16_t>(VelocityCommand::kRampedStop), 0);
  EXPECT_EQ(static_cast<std::uint16_t>(VelocityCommand::kRunForward), 1);
  EXPECT_EQ(static_cast<std::uint16_t>(VelocityCommand::kEmergencyStop), 256);
  EXPECT_EQ(static_cast<std::uint16_t>(VelocityCommand::kRunReverse), 257);
  EXPECT_EQ(static_cast<std::uint16_t>(EnableCommand::kEnable), 0);
  EXPECT_EQ(static_cast<std::uint16_t>(EnableCommand::kRelease), 1);
  EXPECT_EQ(static_cast<std::uint16_t>(EnableCommand::kRestart), 0x0100);
  EXPECT_EQ(static_cast<std::uint16_t>(SaveCommand::kSave), 1);
  EXPECT_EQ(static_cast<std::uint16_t>(SaveCommand::kRestoreFactory), 0);
  EXPECT_EQ(static_cast<std::uint16_t>(WorkingMode::kIoControl), 3);
  EXPECT_EQ(static_cast<std::uint16_t>(MoveCommand::kAbsolutePreempting), 0x00E8);
  EXPECT_EQ(static_cast<std::uint16_t>(MoveCommand::kRelativePreempting), 0x00DE);
}

TEST(AdamCommands, JogWord) {
  struct Case {
    JogCommand command;
    std::uint16_t word;
  };
  const Case cases[] = {
      {{Rotation::kCw, 50, StopMethod::kDecelerate, true}, 0x0C81},   // §8.65② example
      {{Rotation::kCw, 50, StopMethod::kDecelerate, false}, 0x0C80},  // ramped stop (5.4)
      {{Rotation::kCw, 50, StopMethod::kImmediate, false}, 0x0CA0},   // immediate stop (5.4)
      {{Rotation::kCcw, 511, StopMethod::kImmediate, true}, 0xFFE1},
  };
  for (const auto& c : cases) {
    const auto word = encode(c.command);
    ASSERT_TRUE(word.ok());
    EXPECT_EQ(word.value(), c.word);
    EXPECT_EQ(decode_jog(c.word), c.command);
  }
  EXPECT_EQ(encode(JogCommand{Rotation::kCw, 512, StopMethod::kDecelerate, true}).error(), AdamErrc::kValueOutOfRange);
}

TEST(AdamCommands, HomingWord) {
  const HomingCommand example{Travel::kReverse, 200, StopMethod::kImmediate, 10};  // §8.48: 0xB22A
  ASSERT_TRUE(encode(example).ok());
  EXPECT_EQ(encode(example).value(), 0xB22A);
  EXPECT_EQ(decode_homing(0xB22A), example);
  EXPECT_EQ(example.secondary_speed_code * kSecondaryHomeRpmPerCode, 50);
  EXPECT_EQ(encode(HomingCommand{Travel::kForward, 0, StopMethod::kDecelerate, 32}).error(),
            AdamErrc::kValueOutOfRange);
}

TEST(AdamCommands, TorqueWord) {
  const TorqueCommand example{Travel::kForward, 500, true};  // §8.49: 0x03E9
  ASSERT_TRUE(encode(example).ok());
  EXPECT_EQ(encode(example).value(), 0x03E9);
  EXPECT_EQ(decode_torque(0x03E9), example);
  EXPECT_EQ(encode(TorqueCommand{Travel::kForward, 16384, true}).error(), AdamErrc::kValueOutOfRange);
}

TEST(AdamCommands, TableExecuteWord) {
  struct Case {
    TableExecute command;
    std::uint16_t word;
  };
  const Case cases[] = {
      {{TableEntryKind::kAbsolute, PointerArithmetic::kSubtract, 1}, 0x1001},  // §8.54 example
      {{TableEntryKind::kAbsolute, PointerArithmetic::kAdd, 0}, 0x0000},       // broadcast recipe
      {{TableEntryKind::kRelative, PointerArithmetic::kAdd, 4095}, 0x8FFF},
  };
  for (const auto& c : cases) {
    ASSERT_TRUE(encode(c.command).ok());
    EXPECT_EQ(encode(c.command).value(), c.word);
    EXPECT_EQ(decode_table_execute(c.word), c.command);
  }
  EXPECT_EQ(decode_table_execute(0x2000), std::nullopt);  // arithmetic 2: undefined
  EXPECT_EQ(encode(TableExecute{TableEntryKind::kAbsolute, PointerArithmetic::kAdd, 4096}).error(),
            AdamErrc::kValueOutOfRange);
}

TEST(AdamCommands, InputPairs) {
  // §8.47: NPN negative limit X0, positive limit X1 → 0x3031. §8.48: NPN home on X2 → 0x0032.
  const InputPair limits{{true, true, 0}, {true, true, 1}};
  const InputPair home{{false, false, 0}, {true, true, 2}};
  EXPECT_EQ(encode(limits).value(), 0x3031);
  EXPECT_EQ(encode(home).value(), 0x0032);
  EXPECT_EQ(decode_input_pair(0x3031), limits);
  EXPECT_EQ(decode_input_pair(0x0032), home);
  EXPECT_EQ(encode(InputPair{{true, true, 16}, {}}).error(), AdamErrc::kValueOutOfRange);
}

TEST(AdamCommands, PositionReminders) {
  struct Case {
    PositionReminder reminder;
    std::uint32_t raw;
  };
  const Case cases[] = {
      {{ReminderComparison::kAtOrAbove, -500}, 0x7FFFFE0C},        // §8.53 X11
      {{ReminderComparison::kBelow, 5000}, 0x80001388},            // §8.53 X17
      {{ReminderComparison::kAtOrAbove, 1073741823}, 0x3FFFFFFF},  // default X17…X19
      {{ReminderComparison::kBelow, -1073741824}, 0xC0000000},
  };
  for (const auto& c : cases) {
    ASSERT_TRUE(encode(c.reminder).ok());
    EXPECT_EQ(encode(c.reminder).value(), c.raw);
    EXPECT_EQ(decode_reminder(c.raw), c.reminder);
  }
  EXPECT_EQ(encode(PositionReminder{ReminderComparison::kBelow, 1073741824}).error(), AdamErrc::kValueOutOfRange);
}

TEST(AdamCommands, BaudCodes) {
  EXPECT_EQ(baud_rate(BaudCode::kB115200), 115200U);
  EXPECT_EQ(baud_rate(BaudCode::kB56000), 56000U);
  EXPECT_EQ(baud_rate(BaudCode::kB57600), 57600U);
  EXPECT_EQ(baud_rate(static_cast<BaudCode>(16)), std::nullopt);
  EXPECT_EQ(baud_code(9600), BaudCode::kB9600);
  EXPECT_EQ(static_cast<int>(*baud_code(9600)), 6);  // §8.6 example writes 6 for 9600
  EXPECT_EQ(baud_code(256000), std::nullopt);        // in the §2 table, but no code exists
}

TEST(AdamCommands, BuildersProduceTheManualsFrames) {
  const auto jog = encode(JogCommand{Rotation::kCw, 50, StopMethod::kDecelerate, true});
  EXPECT_EQ(to_hex(rtu::encode_request(write16(1, Reg::kJogCommand, jog.value())).value()), "01 06 00 CA 0C 81 6C 94");
  EXPECT_EQ(to_hex(rtu::encode_request(move(1, MoveCommand::kTimedRunMs, -6400)).value()),
            "01 10 00 CC 00 02 04 E7 00 FF FF C8 AE");                                        // §8.65③
  EXPECT_EQ(to_hex(rtu::encode_request(clear_alarm(1)).value()), "01 06 00 A4 00 00 C8 29");  // §8.52 corrected
  const auto reminder = encode(PositionReminder{ReminderComparison::kBelow, 5000});
  EXPECT_EQ(to_hex(rtu::encode_request(write32(1, Reg::kReminderX17, reminder.value())).value()),
            "01 10 00 C2 00 02 04 13 88 80 00 9B 48");  // §8.53
  EXPECT_EQ(read(1, Reg::kSubdivision), (rtu::Request{1, rtu::ReadRegisters{0x0024, 2}}));
}

}  // namespace
}  // namespace motion::adam
