// The manual's remaining example frames: real-time notifications (§2.4 table, §5.29), the error
// report (§2.3 / §5.6), the UIMessage gateway framing (§2.6, Appendix-1 CRC; derived vectors
// computed with the manual's CRC routine), reply matching (§2.1, §2.3), and what the decoders
// must refuse (bounds, trailing bytes, foreign identifiers).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "motion/uim342/matching.hpp"
#include "motion/uim342/notifications.hpp"
#include "motion/uim342/parameters.hpp"
#include "motion/uim342/uimessage.hpp"
#include "support.hpp"

namespace motion::uim342 {
namespace {

using FC = FunctionCode;

// §2.4: printed rows normalized to `ID CW DL d0..d7` (surplus padding column dropped; DL rules,
// §2.1).
struct NotificationExample {
  const char* row;
  Notification typed;
};

TEST(Uim342Notifications, EveryManualRowEncodesAndDecodes) {
  const NotificationExample examples[] = {
      {"05 5A 05 00 0A 00 00 00 00 00 00", AlarmNotification{AlarmCode::kEmergencyStopLock}},
      {"05 5A 05 00 19 00 00 00 00 00 00", AlarmNotification{AlarmCode::kSpeedOverLimit}},
      {"05 5A 05 00 1A 00 00 00 00 00 00", AlarmNotification{AlarmCode::kBelowLowerLimit}},
      {"05 5A 05 00 1B 00 00 00 00 00 00", AlarmNotification{AlarmCode::kAboveUpperLimit}},
      {"05 5A 05 00 1D 00 00 00 00 00 00", AlarmNotification{AlarmCode::kStall}},
      {"05 5A 05 00 1E 00 00 00 00 00 00", AlarmNotification{AlarmCode::kEncoderError}},
      {"05 5A 05 00 1F 00 00 00 00 00 00", AlarmNotification{AlarmCode::kEncoderBatteryLow}},
      {"05 5A 01 01 00 00 00 00 00 00 00", InputEdgeNotification{InputPort::kIn1, Edge::kFalling}},
      {"05 5A 01 02 00 00 00 00 00 00 00", InputEdgeNotification{InputPort::kIn1, Edge::kRising}},
      {"05 5A 01 03 00 00 00 00 00 00 00", InputEdgeNotification{InputPort::kIn2, Edge::kFalling}},
      {"05 5A 01 04 00 00 00 00 00 00 00", InputEdgeNotification{InputPort::kIn2, Edge::kRising}},
      {"05 5A 01 05 00 00 00 00 00 00 00", InputEdgeNotification{InputPort::kIn3, Edge::kFalling}},
      {"05 5A 01 06 00 00 00 00 00 00 00", InputEdgeNotification{InputPort::kIn3, Edge::kRising}},
      // "05 5A 08 29 00 00 00 p0 p1 p2 p3" with p = 3200.
      {"05 5A 08 29 00 00 00 80 0C 00 00", PositionReachedNotification{3200}},
  };
  for (const auto& ex : examples) {
    SCOPED_TRACE(ex.row);
    const auto row = test::parse_row(ex.row);
    const auto expected = test::frame_of(0x0520005A, row);
    const auto frame = notification_frame(row.id, ex.typed);
    ASSERT_TRUE(frame.ok());
    EXPECT_EQ(can::to_cansend(*frame), can::to_cansend(expected));
    const auto decoded = decode_notification(row.message);
    ASSERT_TRUE(decoded.ok()) << decoded.error().message();
    EXPECT_EQ(*decoded, ex.typed);
    const auto any = decode_drive_message(row.message);
    ASSERT_TRUE(any.ok());
    EXPECT_TRUE(std::holds_alternative<Notification>(*any));
  }
}

TEST(Uim342Notifications, GatingAndNegativePositions) {
  EXPECT_EQ(enabled_by(InputEdgeNotification{InputPort::kIn3, Edge::kRising}), InformationEnable::kIn3Change);
  EXPECT_EQ(enabled_by(PositionReachedNotification{0}), InformationEnable::kPositionReached);
  EXPECT_EQ(enabled_by(AlarmNotification{AlarmCode::kStall}), std::nullopt);
  const auto m = encode(PositionReachedNotification{-1000});
  EXPECT_EQ(test::hex(m.payload()), "29 00 00 00 18 FC FF FF");
  EXPECT_EQ(describe(AlarmCode::kStall), "motor stall detected");
  EXPECT_EQ(describe(static_cast<AlarmCode>(0x77)), "unknown alarm 0x77");
}

TEST(Uim342Notifications, RefusesWrongLengthsAndUnknownCodes) {
  // Trailing bytes: an input edge is exactly DL 1, an alarm DL 5, PTP finished DL 8.
  EXPECT_EQ(decode_notification(test::parse_row("05 5A 02 01 00").message).error(), CodecErrc::kWrongLength);
  EXPECT_EQ(decode_notification(test::parse_row("05 5A 06 00 1D 00 00 00 00").message).error(),
            CodecErrc::kWrongLength);
  EXPECT_EQ(decode_notification(test::parse_row("05 5A 04 29 00 00 00").message).error(), CodecErrc::kWrongLength);
  EXPECT_EQ(decode_notification(test::parse_row("05 5A 00").message).error(), CodecErrc::kWrongLength);
  EXPECT_EQ(decode_notification(test::parse_row("05 5A 01 07").message).error(), CodecErrc::kUnknownNotification);
  EXPECT_EQ(decode_notification(test::parse_row("05 15 01 01").message).error(), CodecErrc::kNotANotification);
}

// §2.3 / §5.6: the error report "PP[5]=N data illegal", ID 0x0520000F.
TEST(Uim342ErrorReport, ManualExampleAndCategory) {
  const auto expected = test::frame(0x0520000F, "00 33 81 05 00 00");
  const auto frame = reply_frame(5, error_report(DriveErrc::kDataError, 0x81, 5));
  ASSERT_TRUE(frame.ok());
  EXPECT_EQ(*frame, expected);
  const auto decoded = decode_reply_frame(expected);
  ASSERT_TRUE(decoded.ok());
  const auto& record = std::get<ErrorRecord>(decoded->reply.body);
  EXPECT_EQ(record.error(), DriveErrc::kDataError);
  EXPECT_EQ(std::string(record.error().category().name()), "uim342");
  EXPECT_EQ(record.error().message(), "instruction data error (0x33)");
  // The report belongs to the pending PP[5]=2 (d2 masked to 7 bits), not to a pending MO.
  const auto message = decode_can(expected)->message;
  EXPECT_EQ(classify_reply(request::set(ProtocolParameter::kBitRate, 2), message), ReplyKind::kErrorReport);
  EXPECT_EQ(classify_reply(request::driver_on(true), message), ReplyKind::kUnrelated);
  // An empty ER slot is "no error".
  EXPECT_FALSE(ErrorRecord{}.error());
  for (const int code : {0x32, 0x33, 0x34, 0x3C, 0x3D, 0x3E, 0x3F, 0x41})
    EXPECT_TRUE(is_known_drive_error(static_cast<std::uint8_t>(code)));
  EXPECT_FALSE(is_known_drive_error(0x40));
}

TEST(Uim342Matching, ReplyKeysOfSetsAndGets) {
  EXPECT_EQ(ack_key(request::set_absolute_position(1)), (ExpectedReply{FC::kDV, 4}));
  EXPECT_EQ(ack_key(request::set_relative_position(1)), (ExpectedReply{FC::kDV, 3}));
  EXPECT_EQ(ack_key(request::set_ptp_speed(1)), (ExpectedReply{FC::kDV, 2}));
  EXPECT_EQ(ack_key(request::set_jog_velocity(1)), (ExpectedReply{FC::kDV, 2}));
  EXPECT_EQ(ack_key(request::get(FC::kPA)), (ExpectedReply{FC::kPA, std::nullopt}));
  EXPECT_EQ(ack_key(request::get(MotionStatusIndex::kKinematics)), (ExpectedReply{FC::kMS, 1}));
  EXPECT_EQ(ack_key(request::system(SystemOperation::kReboot)), std::nullopt);
  EXPECT_EQ(expected_reply(request::without_ack(request::begin())), std::nullopt);
  // A notification may arrive between a request and its ACK; the sub-index selects the ACK.
  const auto ms1 = request::get(MotionStatusIndex::kKinematics);
  EXPECT_EQ(classify_reply(ms1, test::parse_row("05 5A 01 01").message), ReplyKind::kNotification);
  EXPECT_EQ(classify_reply(ms1, test::parse_row("05 11 08 00 3D 03 00 18 FC FF FF").message), ReplyKind::kUnrelated);
  EXPECT_EQ(classify_reply(ms1, test::parse_row("05 11 08 01 00 00 00 18 FC FF FF").message), ReplyKind::kAck);
}

TEST(Uim342Decoding, RefusesForeignAndMalformedFrames) {
  // Standard frames, RTR frames, reserved identifier bits: not SimpleCAN.
  auto standard = test::frame(0x0520000F, "");
  standard.extended = false;
  standard.id = 0x181;
  EXPECT_EQ(decode_can(standard).error(), CodecErrc::kNotExtendedFrame);
  auto remote = test::frame(0x05200015, "");
  remote.rtr = true;
  EXPECT_EQ(decode_can(remote).error(), CodecErrc::kRemoteFrame);
  EXPECT_EQ(decode_reply_frame(test::frame(0x05200015 | (1u << 10), "01")).error(), CodecErrc::kReservedBitsSet);
  // Trailing bytes: MO ACK is DL 1, MS ACK DL 8, BG ACK DL 4.
  EXPECT_EQ(decode_reply_frame(test::frame(0x05200015, "01 00")).error(), CodecErrc::kWrongLength);
  EXPECT_EQ(decode_reply_frame(test::frame(0x05200011, "00 3D 03 00 18 FC FF")).error(), CodecErrc::kWrongLength);
  EXPECT_EQ(decode_reply_frame(test::frame(0x05200016, "00 00 00 00 00")).error(), CodecErrc::kWrongLength);
  EXPECT_EQ(decode_instruction_frame(test::frame(0x04280095, "01 00")).error(), CodecErrc::kWrongLength);
  // A drive frame never carries the ACK bit; unknown function codes are refused.
  EXPECT_EQ(decode_reply_frame(test::frame(0x05200095, "01")).error(), CodecErrc::kAckBitInReply);
  EXPECT_EQ(decode_reply_frame(test::frame(0x05200002, "")).error(), CodecErrc::kUnknownFunction);
  // MS sub-index 2 does not exist.
  EXPECT_EQ(decode_reply_frame(test::frame(0x05200011, "02 00 00 00 00 00 00 00")).error(),
            CodecErrc::kUnknownSubIndex);
  // More than 8 bytes cannot become a message.
  const std::vector<std::uint8_t> nine(9, 0);
  EXPECT_EQ(Message::make(0x15, nine).error(), CodecErrc::kLengthOutOfRange);
  // ML exists only with the ACK bit, SY only without.
  EXPECT_EQ(decode_instruction(test::parse_row("05 0B 00").message).error(), CodecErrc::kAckFormNotSupported);
  EXPECT_EQ(encode(Instruction{FC::kSY, Operation::kSet, true, Index{1}}).error(), CodecErrc::kAckFormNotSupported);
  // The typed body must match the form.
  EXPECT_EQ(encode(Instruction{FC::kPA, Operation::kSet, true, Unsigned{1}}).error(), CodecErrc::kBodyMismatch);
}

// Derived vectors, variant A (manual §2.6: CRC over 0xAA..d8) and variant B (ID..d8, gateways in
// the field).
struct UiExample {
  const char* variant_a;
  const char* variant_b;
  std::uint8_t id;
  Instruction instruction;  // ignored for drive replies (reply_row set)
  const char* reply_row = nullptr;
};

TEST(Uim342UiMessage, ComputedVectorsBothCoverages) {
  const UiExample examples[] = {
      {"AA 05 95 01 01 00 00 00 00 00 00 00 00 27 D7 CC", "AA 05 95 01 01 00 00 00 00 00 00 00 00 D8 95 CC", 5,
       request::driver_on(true)},
      {"AA 05 15 01 01 00 00 00 00 00 00 00 00 8E 15 CC",
       "AA 05 15 01 01 00 00 00 00 00 00 00 00 71 57 CC",
       5,
       {},
       "05 15 01 01"},
      {"AA 05 8B 00 00 00 00 00 00 00 00 00 00 1B AA CC", "AA 05 8B 00 00 00 00 00 00 00 00 00 00 E4 E8 CC", 5,
       request::get(FC::kML)},
      {"AA 05 96 00 00 00 00 00 00 00 00 00 00 74 C6 CC", "AA 05 96 00 00 00 00 00 00 00 00 00 00 8B 84 CC", 5,
       request::begin()},
      {"AA 00 16 00 00 00 00 00 00 00 00 00 00 D1 08 CC", "AA 00 16 00 00 00 00 00 00 00 00 00 00 2E 4A CC", 0,
       request::without_ack(request::begin())},
      {"AA 05 9D 04 18 FC FF FF 00 00 00 00 00 AE 26 CC", "AA 05 9D 04 18 FC FF FF 00 00 00 00 00 51 64 CC", 5,
       request::set_jog_velocity(-1000)},
      {"AA 05 81 02 05 02 00 00 00 00 00 00 00 25 31 CC", "AA 05 81 02 05 02 00 00 00 00 00 00 00 DA 73 CC", 5,
       request::set(ProtocolParameter::kBitRate, 2)},
      {"AA 05 91 01 00 00 00 00 00 00 00 00 00 3F 77 CC", "AA 05 91 01 00 00 00 00 00 00 00 00 00 C0 35 CC", 5,
       request::get(MotionStatusIndex::kStatus)},
  };
  for (const auto& ex : examples) {
    SCOPED_TRACE(ex.variant_a);
    Message message;
    if (ex.reply_row) {
      message = test::parse_row(ex.reply_row).message;
    } else {
      message = *encode(ex.instruction);
    }
    const UiMessage ui{ex.id, message, 0};
    EXPECT_EQ(test::hex(*encode_ui_message(ui)), ex.variant_a);
    EXPECT_EQ(test::hex(*encode_ui_message(ui, CrcCoverage::kIdToAux)), ex.variant_b);
    for (const auto* text : {ex.variant_a, ex.variant_b}) {
      const auto bytes = test::hex_bytes(text);
      const auto decoded = decode_ui_message(bytes);
      ASSERT_TRUE(decoded.ok()) << decoded.error().message();
      EXPECT_EQ(decoded->message, ui);
    }
    EXPECT_EQ(decode_ui_message(test::hex_bytes(ex.variant_a), CrcAcceptance::kStartToAux)->crc,
              CrcCoverage::kStartToAux);
    EXPECT_EQ(decode_ui_message(test::hex_bytes(ex.variant_b), CrcAcceptance::kIdToAux)->crc, CrcCoverage::kIdToAux);
    EXPECT_EQ(decode_ui_message(test::hex_bytes(ex.variant_b), CrcAcceptance::kStartToAux).error(), CodecErrc::kBadCrc);
  }
}

TEST(Uim342UiMessage, CrcCheckValueAndRejections) {
  const std::string check = "123456789";
  const std::vector<std::uint8_t> bytes(check.begin(), check.end());
  EXPECT_EQ(crc16_modbus(bytes), 0x4B37);

  auto good = test::hex_bytes("AA 05 95 01 01 00 00 00 00 00 00 00 00 27 D7 CC");
  auto longer = good;
  longer.push_back(0x00);  // trailing byte
  EXPECT_EQ(decode_ui_message(longer).error(), CodecErrc::kBadFrameSize);
  EXPECT_EQ(decode_ui_message(std::span(good).first(15)).error(), CodecErrc::kBadFrameSize);
  auto bad_start = good;
  bad_start[0] = 0xAB;
  EXPECT_EQ(decode_ui_message(bad_start).error(), CodecErrc::kBadStartByte);
  auto bad_end = good;
  bad_end[15] = 0xCD;
  EXPECT_EQ(decode_ui_message(bad_end).error(), CodecErrc::kBadEndByte);
  auto bad_crc = good;
  bad_crc[4] = 0x00;
  EXPECT_EQ(decode_ui_message(bad_crc).error(), CodecErrc::kBadCrc);
  // 0xAD: no CRC, not checked.
  const auto unchecked = encode_ui_message_without_crc({5, *encode(request::driver_on(true)), 0});
  ASSERT_TRUE(unchecked.ok());
  EXPECT_EQ(test::hex(*unchecked), "AD 05 95 01 01 00 00 00 00 00 00 00 00 00 00 CC");
  const auto decoded = decode_ui_message(*unchecked);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(decoded->crc, std::nullopt);
}

TEST(Uim342Parameters, RangesAndUnits) {
  EXPECT_FALSE(check_instruction(request::set(MotorDriver::kMicrostepping, 16)));
  EXPECT_EQ(check_instruction(request::set(MotorDriver::kMicrostepping, 12)), DriveErrc::kDataError);
  EXPECT_EQ(check_instruction(request::set(ProtocolParameter::kBitRate, 7)), DriveErrc::kDataError);
  EXPECT_EQ(check_instruction(request::get(InformationEnable::kIn1Change)), std::error_code{});
  EXPECT_EQ(check_instruction(Instruction{FC::kIE, Operation::kGet, true, Index{5}}), DriveErrc::kSubIndexError);
  EXPECT_EQ(*current_to_wire(2.0), 20);
  EXPECT_FALSE(current_to_wire(9.0).ok());
  EXPECT_EQ(counts_per_revolution(16), 3200u);
  EXPECT_EQ(*acceleration_to_wire(1000.0, AccelerationUnit::kPulsesPerS2), 1000u);
  // Time unit: ramp from the 200 pps cut-in speed to 3200 pps at 1000 pps^2 takes 3 s.
  EXPECT_EQ(*acceleration_to_wire(1000.0, AccelerationUnit::kMilliseconds, 3200.0, 200.0), 3000u);
}

}  // namespace
}  // namespace motion::uim342
