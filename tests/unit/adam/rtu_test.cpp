// Modbus RTU codec: CRC known answers, derived vectors not in the manual (frames libmodbus
// 3.1.6 produced, status replies, broadcasts, exception frames), framing errors, timing.
#include <gtest/gtest.h>

#include <variant>

#include "hex.hpp"
#include "motion/adam/commands.hpp"
#include "motion/adam/registers.hpp"
#include "motion/adam/rtu.hpp"

namespace motion::adam {
namespace {

using test::hex;
using test::to_hex;
using namespace std::chrono_literals;

TEST(AdamRtuCrc, KnownAnswers) {
  struct Case {
    const char* body;
    std::uint16_t crc;
  };
  const Case cases[] = {
      {"01 03 00 00 00 01", 0x0A84},           // standard check, sent 84 0A
      {"01 03 00 02 00 02", 0xCB65},           // §8.2 example request, sent 65 CB (§6 note)
      {"31 32 33 34 35 36 37 38 39", 0x4B37},  // CRC-16/MODBUS catalogue check ("123456789")
      {"", 0xFFFF},                            // initial value, no final XOR
  };
  for (const auto& c : cases) EXPECT_EQ(rtu::crc16(hex(c.body)), c.crc) << c.body;
  static_assert(rtu::crc16(std::array<std::uint8_t, 6>{1, 3, 0, 0, 0, 1}) == 0x0A84);
}

TEST(AdamRtuCrc, AppendedLowByteFirst) {
  auto frame = hex("01 03 00 00 00 01");
  rtu::append_crc(frame);
  EXPECT_EQ(to_hex(frame), "01 03 00 00 00 01 84 0A");
  EXPECT_TRUE(rtu::crc_ok(frame));
  frame[7] ^= 0x01;
  EXPECT_FALSE(rtu::crc_ok(frame));
}

// ---- Derived vectors (not in the manual): requests (master → drive) ------------------------------

struct RequestVector {
  const char* what;
  rtu::Request request;
  const char* frame;
};

TEST(AdamRtuDerived, RequestsEncodeAndDecodeExactly) {
  const RequestVector vectors[] = {
      {"read position node 1", read(1, Reg::kPosition), "01 03 00 04 00 02 85 CA"},
      {"read position node 2", read(2, Reg::kPosition), "02 03 00 04 00 02 85 F9"},
      {"read position node 64", read(64, Reg::kPosition), "40 03 00 04 00 02 8A DB"},
      {"read position+status", {1, rtu::ReadRegisters{0x0004, 4}}, "01 03 00 04 00 04 05 C8"},
      {"read status node 1", read(1, Reg::kStatus), "01 03 00 06 00 02 24 0A"},
      {"read status node 2", read(2, Reg::kStatus), "02 03 00 06 00 02 24 39"},
      {"read speed rpm", read(1, Reg::kSpeedRpm), "01 03 00 19 00 01 55 CD"},
      {"read 32-bit speed", read(1, Reg::kSpeedCentiRpm), "01 03 00 D6 00 02 25 F3"},
      {"read profile block", {1, rtu::ReadRegisters{0x0096, 5}}, "01 03 00 96 00 05 65 E5"},
      {"read hardware version", read(1, Reg::kHardwareVersion), "01 03 00 00 00 02 C4 0B"},
      {"read firmware version", read(1, Reg::kFirmwareVersion), "01 03 00 02 00 02 65 CB"},
      {"read encoder lines", read(1, Reg::kEncoderLines), "01 03 00 0F 00 01 B4 09"},
      {"absolute +100000", move(1, MoveCommand::kAbsoluteAtStandstill, 100000),
       "01 10 00 D0 00 02 04 86 A0 00 01 16 59"},
      {"absolute -100000", move(1, MoveCommand::kAbsoluteAtStandstill, -100000),
       "01 10 00 D0 00 02 04 79 60 FF FE 27 C1"},
      {"absolute +100000 preempting", move(1, MoveCommand::kAbsolutePreempting, 100000),
       "01 10 00 E8 00 02 04 86 A0 00 01 14 EB"},
      {"relative +4000", move(1, MoveCommand::kRelativeAtStandstill, 4000), "01 10 00 CE 00 02 04 0F A0 00 00 7D 45"},
      {"relative -4000 preempting", move(1, MoveCommand::kRelativePreempting, -4000),
       "01 10 00 DE 00 02 04 F0 60 FF FF 4D D1"},
      {"target speed 1234.56 rpm", write32(1, Reg::kTargetSpeed, 123456), "01 10 00 D8 00 02 04 E2 40 00 01 09 39"},
      {"working speed 600 rpm", write16(1, Reg::kWorkingSpeed, 600), "01 06 00 9A 02 58 A9 7F"},
      {"enable", command(1, EnableCommand::kEnable), "01 06 00 D4 00 00 C9 F2"},
      {"release", command(1, EnableCommand::kRelease), "01 06 00 D4 00 01 08 32"},
      {"ramped stop", command(1, VelocityCommand::kRampedStop), "01 06 00 C8 00 00 08 34"},
      {"run forward", command(1, VelocityCommand::kRunForward), "01 06 00 C8 00 01 C9 F4"},
      {"emergency stop", command(1, VelocityCommand::kEmergencyStop), "01 06 00 C8 01 00 09 A4"},
      {"run reverse", command(1, VelocityCommand::kRunReverse), "01 06 00 C8 01 01 C8 64"},
      {"jog stop ramped", write16(1, Reg::kJogCommand, 0x0C80), "01 06 00 CA 0C 80 AD 54"},
      {"jog stop immediate", write16(1, Reg::kJogCommand, 0x0CA0), "01 06 00 CA 0C A0 AC 8C"},
      {"preset position 0", move(1, MoveCommand::kPresetPosition, 0), "01 10 00 D2 00 02 04 00 00 00 00 7F 2A"},
      {"save", command(1, SaveCommand::kSave), "01 06 00 DC 00 01 89 F0"},
      {"restore factory", command(1, SaveCommand::kRestoreFactory), "01 06 00 DC 00 00 48 30"},
      {"stop program", command(1, ProgramCommand::kStop), "01 06 00 DB 00 00 F9 F1"},
      {"restart", command(1, EnableCommand::kRestart), "01 06 00 D4 01 00 C8 62"},
      // Broadcasts (address 0), never answered.
      {"bc run forward", command(0, VelocityCommand::kRunForward), "00 06 00 C8 00 01 C8 25"},
      {"bc ramped stop", command(0, VelocityCommand::kRampedStop), "00 06 00 C8 00 00 09 E5"},
      {"bc emergency stop", command(0, VelocityCommand::kEmergencyStop), "00 06 00 C8 01 00 08 75"},
      {"bc absolute +100000", move(0, MoveCommand::kAbsoluteAtStandstill, 100000),
       "00 10 00 D0 00 02 04 86 A0 00 01 12 A5"},
      {"bc absolute -100000 preempting", move(0, MoveCommand::kAbsolutePreempting, -100000),
       "00 10 00 E8 00 02 04 79 60 FF FE 21 8F"},
      {"bc relative +4000", move(0, MoveCommand::kRelativeAtStandstill, 4000),
       "00 10 00 CE 00 02 04 0F A0 00 00 79 B9"},
      {"bc timed run 1000 ms", move(0, MoveCommand::kTimedRunMs, 1000), "00 10 00 CC 00 02 04 03 E8 00 00 7B 26"},
      {"bc execute table", write16(0, Reg::kTableExecute, 0), "00 06 00 DD 00 00 18 21"},
      {"bc run program", command(0, ProgramCommand::kRun), "00 06 00 DB 00 01 39 E0"},
      {"bc working speed 300", write16(0, Reg::kWorkingSpeed, 300), "00 06 00 9A 01 2C A8 79"},
  };
  for (const auto& v : vectors) {
    const auto encoded = rtu::encode_request(v.request);
    ASSERT_TRUE(encoded.ok()) << v.what;
    EXPECT_EQ(to_hex(encoded.value()), v.frame) << v.what;
    const auto parsed = rtu::decode_request(hex(v.frame));
    ASSERT_TRUE(std::holds_alternative<rtu::Request>(parsed)) << v.what;
    EXPECT_EQ(std::get<rtu::Request>(parsed), v.request) << v.what;
    EXPECT_FALSE(check_request(v.request.pdu).has_value()) << v.what;
    const bool silent = rtu::is_broadcast(v.request) || std::string_view{v.what} == "restart";
    EXPECT_EQ(expects_reply(v.request), !silent) << v.what;
  }
}

TEST(AdamRtuDerived, RawRequestForLibmodbusHasNoCrc) {
  // modbus_send_raw_request() appends the CRC itself: 00 10 00 D0 00 02 04 86 A0 00 01 (+ 12 A5).
  const auto raw = rtu::encode_request_without_crc(move(0, MoveCommand::kAbsoluteAtStandstill, 100000));
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ(to_hex(raw.value()), "00 10 00 D0 00 02 04 86 A0 00 01");
}

// ---- Derived vectors (not in the manual): replies (drive → master) -------------------------------

struct ReplyVector {
  const char* what;
  rtu::Request request;
  const char* frame;
  rtu::ResponsePdu expected;
};

TEST(AdamRtuDerived, RepliesDecodeAgainstTheirRequests) {
  using V = std::vector<std::uint16_t>;
  const auto values = [](V v) { return rtu::ResponsePdu{rtu::ReadRegistersReply{std::move(v)}}; };
  const auto ack = [](std::uint16_t start) { return rtu::ResponsePdu{rtu::WriteRegistersReply{start, 2}}; };
  const auto position = read(1, Reg::kPosition);
  const auto status = read(1, Reg::kStatus);
  const ReplyVector vectors[] = {
      {"position 100000", position, "01 03 04 86 A0 00 01 12 99", values({0x86A0, 0x0001})},
      {"position 0", position, "01 03 04 00 00 00 00 FA 33", values({0, 0})},
      {"position -8000", position, "01 03 04 E0 C0 FF FF CC 7F", values({0xE0C0, 0xFFFF})},
      {"position -100000", position, "01 03 04 79 60 FF FE 23 01", values({0x7960, 0xFFFE})},
      {"position 4000", position, "01 03 04 0F A0 00 00 F9 05", values({0x0FA0, 0})},
      {"position+status",
       {1, rtu::ReadRegisters{4, 4}},
       "01 03 08 86 A0 00 01 10 00 00 00 84 97",
       values({0x86A0, 1, 0x1000, 0})},
      {"status idle in position", status, "01 03 04 10 00 00 00 FE F3", values({0x1000, 0})},
      {"status cruising", status, "01 03 04 03 00 00 00 FA 77", values({0x0300, 0})},
      {"status accelerating", status, "01 03 04 01 00 00 00 FB CF", values({0x0100, 0})},
      {"status decelerating", status, "01 03 04 02 00 00 00 FB 8B", values({0x0200, 0})},
      {"status X1 running", status, "01 03 04 03 02 00 00 5B B7", values({0x0302, 0})},
      {"status X16 high", status, "01 03 04 10 00 00 01 3F 33", values({0x1000, 1})},
      {"speed -300 rpm", read(1, Reg::kSpeedRpm), "01 03 02 FE D4 F8 7B", values({0xFED4})},
      {"speed -30000 centi", read(1, Reg::kSpeedCentiRpm), "01 03 04 8A D0 FF FF D0 62", values({0x8AD0, 0xFFFF})},
      {"profile block",
       {1, rtu::ReadRegisters{0x96, 5}},
       "01 03 0A 00 32 00 32 00 78 00 78 01 2C 5A 4A",
       values({50, 50, 120, 120, 300})},
      {"hardware version", read(1, Reg::kHardwareVersion), "01 03 04 37 31 00 30 A5 9C", values({0x3731, 0x0030})},
      {"firmware version", read(1, Reg::kFirmwareVersion), "01 03 04 30 31 00 35 64 EB", values({0x3031, 0x0035})},
      {"encoder lines", read(1, Reg::kEncoderLines), "01 03 02 03 E8 B8 FA", values({1000})},
      {"ack absolute", move(1, MoveCommand::kAbsoluteAtStandstill, 100000), "01 10 00 D0 00 02 40 31", ack(0xD0)},
      {"ack absolute -100000", move(1, MoveCommand::kAbsoluteAtStandstill, -100000), "01 10 00 D0 00 02 40 31",
       ack(0xD0)},
      {"ack absolute preempting", move(1, MoveCommand::kAbsolutePreempting, 100000), "01 10 00 E8 00 02 C1 FC",
       ack(0xE8)},
      {"ack relative", move(1, MoveCommand::kRelativeAtStandstill, 4000), "01 10 00 CE 00 02 20 37", ack(0xCE)},
      {"ack relative preempting", move(1, MoveCommand::kRelativePreempting, -4000), "01 10 00 DE 00 02 21 F2",
       ack(0xDE)},
      {"ack target speed", write32(1, Reg::kTargetSpeed, 123456), "01 10 00 D8 00 02 C1 F3", ack(0xD8)},
      {"ack preset", move(1, MoveCommand::kPresetPosition, 0), "01 10 00 D2 00 02 E1 F1", ack(0xD2)},
      {"echo working speed", write16(1, Reg::kWorkingSpeed, 600), "01 06 00 9A 02 58 A9 7F",
       rtu::WriteRegister{0x9A, 600}},
      // Exceptions (not in the manual; standard Modbus frames).
      {"exception 03/02", read(1, Reg::kPosition), "01 83 02 C0 F1",
       rtu::ExceptionReply{0x03, rtu::ExceptionCode::kIllegalDataAddress}},
      {"exception 06/02", write16(1, Reg::kWorkingSpeed, 1), "01 86 02 C3 A1",
       rtu::ExceptionReply{0x06, rtu::ExceptionCode::kIllegalDataAddress}},
      {"exception 06/03", write16(1, Reg::kWorkingSpeed, 1), "01 86 03 02 61",
       rtu::ExceptionReply{0x06, rtu::ExceptionCode::kIllegalDataValue}},
      {"exception 10/02", write32(1, Reg::kTargetSpeed, 1), "01 90 02 CD C1",
       rtu::ExceptionReply{0x10, rtu::ExceptionCode::kIllegalDataAddress}},
  };
  for (const auto& v : vectors) {
    const auto decoded = rtu::decode_response(hex(v.frame), v.request);
    ASSERT_TRUE(decoded.ok()) << v.what << ": " << decoded.error().message();
    EXPECT_EQ(decoded.value(), (rtu::Response{v.request.unit, v.expected})) << v.what;
    EXPECT_EQ(to_hex(rtu::encode_response(decoded.value())), v.frame) << v.what;
  }
  EXPECT_EQ(to_hex(rtu::encode_exception(1, 0x01, rtu::ExceptionCode::kIllegalFunction)), "01 81 01 81 90");
}

TEST(AdamRtuDerived, DecodedValuesMatchTheStatedMeaning) {
  EXPECT_EQ(decode32_signed(0x86A0, 0x0001), 100000);
  EXPECT_EQ(decode32_signed(0xE0C0, 0xFFFF), -8000);
  EXPECT_EQ(decode32_signed(0x7960, 0xFFFE), -100000);
  EXPECT_EQ(decode32_signed(0x8AD0, 0xFFFF), -30000);
  EXPECT_EQ(decode16_signed(0xFED4), -300);
}

// ---- Response matching ---------------------------------------------------------------------------

TEST(AdamRtuResponse, MismatchesAreRejected) {
  const auto position = read(1, Reg::kPosition);
  struct Case {
    const char* what;
    rtu::Request request;
    const char* frame;
    rtu::FrameErrc error;
  };
  const Case cases[] = {
      {"other unit", read(2, Reg::kPosition), "01 03 04 86 A0 00 01 12 99", rtu::FrameErrc::kUnexpectedResponse},
      {"wrong count", {1, rtu::ReadRegisters{4, 4}}, "01 03 04 86 A0 00 01 12 99", rtu::FrameErrc::kByteCountMismatch},
      {"other function", write16(1, Reg::kWorkingSpeed, 600), "01 03 04 86 A0 00 01 12 99",
       rtu::FrameErrc::kUnexpectedResponse},
      {"echo differs", write16(1, Reg::kWorkingSpeed, 601), "01 06 00 9A 02 58 A9 7F",
       rtu::FrameErrc::kUnexpectedResponse},
      {"ack other start", move(1, MoveCommand::kAbsolutePreempting, 1), "01 10 00 D0 00 02 40 31",
       rtu::FrameErrc::kUnexpectedResponse},
      {"exception for other fc", position, "01 86 02 C3 A1", rtu::FrameErrc::kUnexpectedResponse},
      {"unknown function", position, "01 04 02 00 00 B9 30", rtu::FrameErrc::kUnsupportedFunction},
      {"odd byte count", position, "01 03 01 00 F0 48", rtu::FrameErrc::kByteCountMismatch},
  };
  for (const auto& c : cases) {
    auto frame = hex(c.frame);
    ASSERT_TRUE(rtu::crc_ok(frame)) << c.what;
    EXPECT_EQ(rtu::decode_response(frame, c.request).error(), c.error) << c.what;
  }
}

// ---- Framing errors ------------------------------------------------------------------------------

std::vector<std::uint8_t> with_crc(std::vector<std::uint8_t> body) {
  rtu::append_crc(body);
  return body;
}

TEST(AdamRtuFraming, MalformedFramesAreDiscardedWithTheReason) {
  struct Case {
    const char* what;
    std::vector<std::uint8_t> frame;
    rtu::FrameErrc error;
  };
  const Case cases[] = {
      {"empty", {}, rtu::FrameErrc::kTooShort},
      {"3 bytes", hex("01 03 00"), rtu::FrameErrc::kTooShort},
      {"257 bytes", std::vector<std::uint8_t>(257, 0), rtu::FrameErrc::kTooLong},
      {"bad crc", hex("01 03 00 04 00 02 85 CB"), rtu::FrameErrc::kBadCrc},
      // A stray byte after a valid frame shifts the CRC window by one. For a stray 0x00 the CRC
      // STILL matches (CRC-16/MODBUS over frame+CRC is 0, so the CRC over frame+CRC-low-byte is
      // 0x00<CRC high>, exactly the last two bytes read low first): only the layout check catches
      // it. Any other stray byte fails the CRC.
      {"stray 0x00 after valid frame", hex("01 03 00 04 00 02 85 CA 00"), rtu::FrameErrc::kTrailingBytes},
      {"stray 0x55 after valid frame", hex("01 03 00 04 00 02 85 CA 55"), rtu::FrameErrc::kBadCrc},
      {"fc03 trailing byte inside crc", with_crc(hex("01 03 00 04 00 02 00")), rtu::FrameErrc::kTrailingBytes},
      {"fc06 truncated", with_crc(hex("01 06 00 9A 02")), rtu::FrameErrc::kTruncated},
      {"fc10 truncated values", with_crc(hex("01 10 00 D0 00 02 04 86 A0 00")), rtu::FrameErrc::kTruncated},
      {"fc10 trailing", with_crc(hex("01 10 00 D0 00 02 04 86 A0 00 01 FF")), rtu::FrameErrc::kTrailingBytes},
      {"fc10 no byte count", with_crc(hex("01 10 00 D0 00 02")), rtu::FrameErrc::kTruncated},
      {"broadcast read", with_crc(hex("00 03 00 04 00 02")), rtu::FrameErrc::kBroadcastRead},
  };
  for (const auto& c : cases) {
    const auto parsed = rtu::decode_request(c.frame);
    ASSERT_TRUE(std::holds_alternative<rtu::FrameErrc>(parsed)) << c.what;
    EXPECT_EQ(std::get<rtu::FrameErrc>(parsed), c.error) << c.what;
  }
  EXPECT_EQ(rtu::decode_response(hex("01 03 04 86 A0 00 01 12")).error(), rtu::FrameErrc::kBadCrc);
  EXPECT_EQ(rtu::decode_response(with_crc(hex("01 03 04 86 A0 00 01 00"))).error(), rtu::FrameErrc::kTrailingBytes);
  EXPECT_EQ(rtu::decode_response(with_crc(hex("01 83 02 00"))).error(), rtu::FrameErrc::kTrailingBytes);
}

TEST(AdamRtuFraming, WellFramedButInvalidRequestsGetExceptions) {
  struct Case {
    const char* what;
    std::vector<std::uint8_t> frame;
    rtu::ExceptionCode code;
  };
  const Case cases[] = {
      {"fc 01 (no coils on this drive)", with_crc(hex("01 01 00 00 00 08")), rtu::ExceptionCode::kIllegalFunction},
      {"fc 04 (not used by this drive)", with_crc(hex("01 04 00 04 00 02")), rtu::ExceptionCode::kIllegalFunction},
      {"fc 0x83 as a request", with_crc(hex("01 83 00 00")), rtu::ExceptionCode::kIllegalFunction},
      {"read quantity 0", with_crc(hex("01 03 00 04 00 00")), rtu::ExceptionCode::kIllegalDataValue},
      {"read quantity 126", with_crc(hex("01 03 00 04 00 7E")), rtu::ExceptionCode::kIllegalDataValue},
      {"read past 0xFFFF", with_crc(hex("01 03 FF FF 00 02")), rtu::ExceptionCode::kIllegalDataAddress},
      {"fc10 byte count != 2 qty", with_crc(hex("01 10 00 D0 00 02 02 86 A0")), rtu::ExceptionCode::kIllegalDataValue},
      {"fc10 quantity 0", with_crc(hex("01 10 00 D0 00 00 00")), rtu::ExceptionCode::kIllegalDataValue},
  };
  for (const auto& c : cases) {
    const auto parsed = rtu::decode_request(c.frame);
    ASSERT_TRUE(std::holds_alternative<rtu::RejectedRequest>(parsed)) << c.what;
    const auto& rejected = std::get<rtu::RejectedRequest>(parsed);
    EXPECT_EQ(rejected.code, c.code) << c.what;
    EXPECT_EQ(rejected.unit, 1) << c.what;
    EXPECT_EQ(rejected.function, c.frame[1]) << c.what;
  }
}

TEST(AdamRtuEncode, InvalidRequestsAreRefused) {
  EXPECT_EQ(rtu::encode_request(read(0, Reg::kPosition)).error(), rtu::FrameErrc::kBroadcastRead);
  EXPECT_EQ(rtu::encode_request(read(248, Reg::kPosition)).error(), rtu::FrameErrc::kInvalidUnit);
  EXPECT_EQ(rtu::encode_request({1, rtu::ReadRegisters{0, 0}}).error(), rtu::FrameErrc::kInvalidQuantity);
  EXPECT_EQ(rtu::encode_request({1, rtu::ReadRegisters{0, 126}}).error(), rtu::FrameErrc::kInvalidQuantity);
  EXPECT_EQ(rtu::encode_request({1, rtu::WriteRegisters{0, {}}}).error(), rtu::FrameErrc::kInvalidQuantity);
  EXPECT_EQ(rtu::encode_request({1, rtu::WriteRegisters{0, std::vector<std::uint16_t>(124, 0)}}).error(),
            rtu::FrameErrc::kInvalidQuantity);
  EXPECT_TRUE(rtu::encode_request({1, rtu::WriteRegisters{0, std::vector<std::uint16_t>(123, 0)}}).ok());
}

TEST(AdamRtuErrors, CategoriesAreNamedAndConvertible) {
  const std::error_code ec = rtu::ExceptionCode::kIllegalDataAddress;
  EXPECT_STREQ(ec.category().name(), "modbus");
  EXPECT_EQ(ec.value(), 2);
  EXPECT_EQ(ec.message(), "illegal data address");
  const std::error_code fe = rtu::FrameErrc::kBadCrc;
  EXPECT_STREQ(fe.category().name(), "modbus_rtu");
  EXPECT_EQ(fe.message(), "CRC mismatch");
  EXPECT_NE(ec, std::error_code(rtu::FrameErrc::kTooLong));  // same value 2, different category
}

TEST(AdamRtuFraming, RequestSizeFromHeader) {
  EXPECT_EQ(rtu::request_frame_size(hex("01")), std::nullopt);
  EXPECT_EQ(rtu::request_frame_size(hex("01 03")), 8U);
  EXPECT_EQ(rtu::request_frame_size(hex("01 06")), 8U);
  EXPECT_EQ(rtu::request_frame_size(hex("01 10 00 D0 00 02")), std::nullopt);
  EXPECT_EQ(rtu::request_frame_size(hex("01 10 00 D0 00 02 04")), 13U);
  EXPECT_EQ(rtu::request_frame_size(hex("01 10 01 F4 00 30 60")), 105U);  // §8.54 bulk frame
  EXPECT_EQ(rtu::request_frame_size(hex("01 04 00 00")), std::nullopt);
}

TEST(AdamRtuTiming, CharacterTimeAndSilence) {
  struct Case {
    rtu::SerialFormat format;
    std::chrono::nanoseconds character, t1_5, t3_5;
  };
  const Case cases[] = {
      // 9600 8N1: 10 bits = 1041666.7 ns (rounded up); t3.5 = 35 bits = 3645833.3 ns.
      {{9600, rtu::Parity::kNone, 8, 1}, 1041667ns, 1562500ns, 3645834ns},
      // 19200 8E1: 11 bits = 572916.7 ns; still computed (fixed values only ABOVE 19200).
      {{19200, rtu::Parity::kEven, 8, 1}, 572917ns, 859375ns, 2005209ns},
      // 115200 8N1 (drive default): 86805.6 ns per character, t3.5 fixed 1.75 ms.
      {{115200, rtu::Parity::kNone, 8, 1}, 86806ns, 750us, 1750us},
      {{38400, rtu::Parity::kNone, 8, 2}, 286459ns, 750us, 1750us},
  };
  for (const auto& c : cases) {
    const auto t = rtu::frame_timing(c.format);
    EXPECT_EQ(t.character, c.character) << c.format.baud;
    EXPECT_EQ(t.t1_5, c.t1_5) << c.format.baud;
    EXPECT_EQ(t.t3_5, c.t3_5) << c.format.baud;
  }
  // 8-byte request at 115200 8N1: 80 bits = 694444.4 ns.
  EXPECT_EQ(rtu::transmission_time({}, 8), 694445ns);
}

}  // namespace
}  // namespace motion::adam
