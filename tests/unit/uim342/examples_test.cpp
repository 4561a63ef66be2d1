// Every example frame of the manual (§2.5, §5.1-§5.28), transcribed from the manual (normalized
// rows; "corrected rows" where the manual's printing is self-contradictory, with the printed row
// checked separately below). Each row: the typed value must encode to exactly these bytes and
// identifier, and the frame must decode back to the typed value. Each ACK row is also classified
// against the instruction row before it (§2.1).
#include <gtest/gtest.h>

#include <string>
#include <variant>
#include <vector>

#include "motion/uim342/instructions.hpp"
#include "motion/uim342/matching.hpp"
#include "support.hpp"

namespace motion::uim342 {
namespace {

using FC = FunctionCode;
namespace rq = request;

struct Example {
  const char* what;
  std::uint32_t can_id;
  const char* row;  // ID CW DL d0..d7
  std::variant<Instruction, Reply> typed;
  bool acknowledges_previous = true;  // ACK rows: matches the instruction row before it
};

Reply ack(FC f, Body body) { return {f, body}; }

std::vector<Example> manual_examples() {
  const EdgeAction origin_decel_at_power_up{InputAction::kOriginThenDecelerateStop, false};
  const EdgeAction none_wait{InputAction::kNone, true};
  return {
      // §5.1 PP
      {"get PP[8]", 0x04280081, "05 81 01 08 00 00 00 00 00 00 00", rq::get(ProtocolParameter::kGroupId)},
      {"PP[8] = 10", 0x05200001, "05 01 02 08 0A 00 00 00 00 00 00", ack(FC::kPP, IndexedByte{8, 10})},
      {"PP[5]=2", 0x04280081, "05 81 02 05 02 00 00 00 00 00 00", rq::set(ProtocolParameter::kBitRate, 2)},
      {"PP[5] = 2", 0x05200001, "05 01 02 05 02 00 00 00 00 00 00", ack(FC::kPP, IndexedByte{5, 2})},
      // §5.2 IC
      {"get IC[0]", 0x04280086, "05 86 01 00 00 00 00 00 00 00 00", rq::get(InitialConfig::kAutoDriverOn)},
      {"IC[0] = 1", 0x05200006, "05 06 03 00 01 00 00 00 00 00 00", ack(FC::kIC, IndexedWord{0, 1})},
      {"IC[6]=1", 0x04280086, "05 86 03 06 01 00 00 00 00 00 00", rq::set(InitialConfig::kClosedLoop, 1)},
      {"IC[6] = 1", 0x05200006, "05 06 03 06 01 00 00 00 00 00 00", ack(FC::kIC, IndexedWord{6, 1})},
      // §5.3 IE
      {"get IE[0]", 0x04280087, "05 87 01 00 00 00 00 00 00 00 00", rq::get(InformationEnable::kIn1Change)},
      {"IE[0] = 1", 0x05200007, "05 07 03 00 01 00 00 00 00 00 00", ack(FC::kIE, IndexedWord{0, 1})},
      {"IE[1]=1", 0x04280087, "05 87 03 01 01 00 00 00 00 00 00", rq::set(InformationEnable::kIn2Change, true)},
      {"IE[1] = 1", 0x05200007, "05 07 03 01 01 00 00 00 00 00 00", ack(FC::kIE, IndexedWord{1, 1})},
      // §5.4 ML
      {"get ML", 0x0428008B, "05 8B 00 00 00 00 00 00 00 00 00", rq::get(FC::kML)},
      {"ML 342XS", 0x0520000B, "05 0B 08 20 0A 11 00 00 00 00 00",
       ack(FC::kML, ModelInfo{{0x20, 0x0A, 0x11, 0x00}, 0, 0})},
      // §5.5 SN
      {"get SN", 0x0428008C, "05 8C 00 00 00 00 00 00 00 00 00", rq::get(FC::kSN)},
      {"SN", 0x0520000C, "05 0C 08 01 02 03 04 05 06 07 08", ack(FC::kSN, SerialNumber{67305985, 1541, 2055})},
      // §5.6 ER
      {"get ER[0]", 0x0428008F, "05 8F 01 00 00 00 00 00 00 00 00", rq::get_error(0)},
      {"ER[0]: 0x33 on PP[5]", 0x0520000F, "05 0F 06 00 33 81 05 00 00 00 00",
       ack(FC::kER, ErrorRecord{0, 0x33, 0x81, 5, {0, 0}})},
      {"ER[0]=0", 0x0428008F, "05 8F 02 00 00 00 00 00 00 00 00", rq::clear_error(0)},
      {"ER[0] cleared", 0x0520000F, "05 0F 06 00 00 00 00 00 00 00 00", ack(FC::kER, ErrorRecord{})},
      // §5.7 QE (get row corrected: DL 1, as the description says)
      {"get QE[4]", 0x042800BD, "05 BD 01 04 00 00 00 00 00 00 00", rq::get(QuadratureEncoder::kCountsPerRevolution)},
      {"QE[4] = 3200", 0x0520003D, "05 3D 03 04 80 0C 00 00 00 00 00", ack(FC::kQE, IndexedWord{4, 3200})},
      {"QE[0]=1000", 0x042800BD, "05 BD 03 00 E8 03 00 00 00 00 00",
       rq::set(QuadratureEncoder::kLinesPerRevolution, 1000)},
      {"QE[0] = 1000", 0x0520003D, "05 3D 03 00 E8 03 00 00 00 00 00", ack(FC::kQE, IndexedWord{0, 1000})},
      // §5.8 SY
      {"SY[1]", 0x0428007E, "05 7E 01 01 00 00 00 00 00 00 00", rq::system(SystemOperation::kReboot)},
      // §5.9 MT (set row corrected: DL 3, as its ACK shows)
      {"get MT[1]", 0x04280090, "05 90 01 01 00 00 00 00 00 00 00", rq::get(MotorDriver::kWorkingCurrent)},
      {"MT[1] = 28", 0x05200010, "05 10 03 01 1C 00 00 00 00 00 00", ack(FC::kMT, IndexedWord{1, 28})},
      {"MT[0]=16", 0x04280090, "05 90 03 00 10 00 00 00 00 00 00", rq::set(MotorDriver::kMicrostepping, 16)},
      {"MT[0] = 16", 0x05200010, "05 10 03 00 10 00 00 00 00 00 00", ack(FC::kMT, IndexedWord{0, 16})},
      // §5.10 MO
      {"get MO", 0x04280095, "05 95 00 00 00 00 00 00 00 00 00", rq::get(FC::kMO)},
      {"MO = 1", 0x05200015, "05 15 01 01 00 00 00 00 00 00 00", ack(FC::kMO, Byte{1})},
      {"MO=0", 0x04280095, "05 95 01 00 00 00 00 00 00 00 00", rq::driver_on(false)},
      {"MO = 0", 0x05200015, "05 15 01 00 00 00 00 00 00 00 00", ack(FC::kMO, Byte{0})},
      // §5.11 BG, §5.12 ST
      {"BG", 0x04280096, "05 96 00 00 00 00 00 00 00 00 00", rq::begin()},
      {"BG ack", 0x05200016, "05 16 04 00 00 00 00 00 00 00 00", ack(FC::kBG, Empty{})},
      {"ST", 0x04280097, "05 97 00 00 00 00 00 00 00 00 00", rq::stop()},
      {"ST ack", 0x05200017, "05 17 00 00 00 00 00 00 00 00 00", ack(FC::kST, Empty{})},
      // §5.13 MF
      {"MF=3", 0x04280098, "05 98 01 03 00 00 00 00 00 00 00", rq::select_group(ParameterGroup::kIn1Falling)},
      {"MF = 3", 0x05200018, "05 18 01 03 00 00 00 00 00 00 00", ack(FC::kMF, Byte{3})},
      // §5.14 AC (set row corrected: DL 4, as its ACK shows)
      {"get AC", 0x04280099, "05 99 00 00 00 00 00 00 00 00 00", rq::get(FC::kAC)},
      {"AC = 1000", 0x05200019, "05 19 04 E8 03 00 00 00 00 00 00", ack(FC::kAC, Unsigned{1000})},
      {"AC=500", 0x04280099, "05 99 04 F4 01 00 00 00 00 00 00", rq::set_acceleration(500)},
      {"AC = 500", 0x05200019, "05 19 04 F4 01 00 00 00 00 00 00", ack(FC::kAC, Unsigned{500})},
      // §5.15 DC
      {"get DC", 0x0428009A, "05 9A 00 00 00 00 00 00 00 00 00", rq::get(FC::kDC)},
      {"DC = 1000", 0x0520001A, "05 1A 04 E8 03 00 00 00 00 00 00", ack(FC::kDC, Unsigned{1000})},
      {"DC=1001", 0x0428009A, "05 9A 04 E9 03 00 00 00 00 00 00", rq::set_deceleration(1001)},
      {"DC = 1001", 0x0520001A, "05 1A 04 E9 03 00 00 00 00 00 00", ack(FC::kDC, Unsigned{1001})},
      // §5.16 SS
      {"get SS", 0x0428009B, "05 9B 00 00 00 00 00 00 00 00 00", rq::get(FC::kSS)},
      {"SS = 1000", 0x0520001B, "05 1B 04 E8 03 00 00 00 00 00 00", ack(FC::kSS, Unsigned{1000})},
      {"SS=1001", 0x0428009B, "05 9B 04 E9 03 00 00 00 00 00 00", rq::set_cut_in_speed(1001)},
      {"SS = 1001", 0x0520001B, "05 1B 04 E9 03 00 00 00 00 00 00", ack(FC::kSS, Unsigned{1001})},
      // §5.17 SD
      {"get SD", 0x0428009C, "05 9C 00 00 00 00 00 00 00 00 00", rq::get(FC::kSD)},
      {"SD = 1600000", 0x0520001C, "05 1C 04 00 6A 18 00 00 00 00 00", ack(FC::kSD, Unsigned{1'600'000})},
      {"SD=1600000", 0x0428009C, "05 9C 04 00 6A 18 00 00 00 00 00", rq::set_stop_deceleration(1'600'000)},
      {"SD = 1600000 ack", 0x0520001C, "05 1C 04 00 6A 18 00 00 00 00 00", ack(FC::kSD, Unsigned{1'600'000})},
      // §5.18 JV
      {"get JV", 0x0428009D, "05 9D 00 00 00 00 00 00 00 00 00", rq::get(FC::kJV)},
      {"JV speed 1000", 0x0520001D, "05 1D 04 E8 03 00 00 00 00 00 00", ack(FC::kJV, Signed{1000})},
      {"JV=-1000", 0x0428009D, "05 9D 04 18 FC FF FF 00 00 00 00", rq::set_jog_velocity(-1000)},
      {"DV[2] = -1000", 0x0520002E, "05 2E 05 02 18 FC FF FF 00 00 00", ack(FC::kDV, IndexedSigned{2, -1000})},
      // §5.19 SP
      {"get SP", 0x0428009E, "05 9E 00 00 00 00 00 00 00 00 00", rq::get(FC::kSP)},
      {"SP speed -1000", 0x0520001E, "05 1E 04 18 FC FF FF 00 00 00 00", ack(FC::kSP, Signed{-1000})},
      {"SP=1000", 0x0428009E, "05 9E 04 E8 03 00 00 00 00 00 00", rq::set_ptp_speed(1000)},
      {"DV[2] = 1000", 0x0520002E, "05 2E 05 02 E8 03 00 00 00 00 00", ack(FC::kDV, IndexedSigned{2, 1000})},
      // §5.20 PR (set row corrected: CW 9F, its ACK is DV[3])
      {"get PR", 0x0428009F, "05 9F 00 00 00 00 00 00 00 00 00", rq::get(FC::kPR)},
      {"PR -1000", 0x0520001F, "05 1F 04 18 FC FF FF 00 00 00 00", ack(FC::kPR, Signed{-1000})},
      {"PR=1000", 0x0428009F, "05 9F 04 E8 03 00 00 00 00 00 00", rq::set_relative_position(1000)},
      {"DV[3] = 1000", 0x0520002E, "05 2E 05 03 E8 03 00 00 00 00 00", ack(FC::kDV, IndexedSigned{3, 1000})},
      // §5.21 PA
      {"get PA", 0x042800A0, "05 A0 00 00 00 00 00 00 00 00 00", rq::get(FC::kPA)},
      {"PA -1000", 0x05200020, "05 20 04 18 FC FF FF 00 00 00 00", ack(FC::kPA, Signed{-1000})},
      {"PA=1000", 0x042800A0, "05 A0 04 E8 03 00 00 00 00 00 00", rq::set_absolute_position(1000)},
      {"DV[4] = 1000", 0x0520002E, "05 2E 05 04 E8 03 00 00 00 00 00", ack(FC::kDV, IndexedSigned{4, 1000})},
      // §5.22 OG
      {"OG", 0x042800A1, "05 A1 00 00 00 00 00 00 00 00 00", rq::set_origin()},
      {"OG ack", 0x05200021, "05 21 00 00 00 00 00 00 00 00 00", ack(FC::kOG, Empty{})},
      // §5.23 BL
      {"get BL", 0x042800AD, "05 AD 00 00 00 00 00 00 00 00 00", rq::get(FC::kBL)},
      {"BL = 1000", 0x0520002D, "05 2D 04 E8 03 00 00 00 00 00 00", ack(FC::kBL, Unsigned{1000})},
      {"BL=1001", 0x042800AD, "05 AD 04 E9 03 00 00 00 00 00 00", rq::set_backlash(1001)},
      {"BL = 1001", 0x0520002D, "05 2D 04 E9 03 00 00 00 00 00 00", ack(FC::kBL, Unsigned{1001})},
      // §5.24 MS
      {"get MS[0]", 0x04280091, "05 91 01 00 00 00 00 00 00 00 00", rq::get(MotionStatusIndex::kStatus)},
      {"MS[0]", 0x05200011, "05 11 08 00 3D 03 00 18 FC FF FF", ack(FC::kMS, MotionStatus{0x3D, 0x03, -1000})},
      {"MS[0]=0", 0x04280091, "05 91 02 00 00 00 00 00 00 00 00", rq::clear_motion_status()},
      {"MS[0] cleared", 0x05200011, "05 11 08 00 3D 01 00 00 00 00 00", ack(FC::kMS, MotionStatus{0x3D, 0x01, 0})},
      // §5.25 DV
      {"get DV[2]", 0x042800AE, "05 AE 01 02 00 00 00 00 00 00 00", rq::get(DesiredValue::kSpeed)},
      {"DV[2] = 1000 (get)", 0x0520002E, "05 2E 05 02 E8 03 00 00 00 00 00", ack(FC::kDV, IndexedSigned{2, 1000})},
      // §5.26 IL
      {"get IL[0]", 0x042800B4, "05 B4 01 00 00 00 00 00 00 00 00", rq::get_input_logic(0)},
      {"IL[0] = 06 80", 0x05200034, "05 34 03 00 06 80 00 00 00 00 00",
       ack(FC::kIL, InputActions{0, origin_decel_at_power_up, none_wait})},
      {"IL[0]=06 80", 0x042800B4, "05 B4 03 00 06 80 00 00 00 00 00",
       rq::set_input_logic(InputPort::kIn1, origin_decel_at_power_up, none_wait)},
      {"IL[0] echo", 0x05200034, "05 34 03 00 06 80 00 00 00 00 00",
       ack(FC::kIL, InputActions{0, origin_decel_at_power_up, none_wait})},
      // §5.27 TG: the printed get ACK has d0 = 00 instead of the echo 01: decoded as printed,
      // and it does not match the TG[1] request.
      {"get TG[1]", 0x042800B5, "05 B5 01 01 00 00 00 00 00 00 00", rq::get_trigger(InputPort::kIn2)},
      {"TG ack as printed", 0x05200035, "05 35 03 00 00 00 00 00 00 00 00", ack(FC::kTG, IndexedWord{0, 0}), false},
      {"TG[0]=100", 0x042800B5, "05 B5 03 00 64 00 00 00 00 00 00", rq::set_trigger(InputPort::kIn1, 100)},
      {"TG[0] = 100", 0x05200035, "05 35 03 00 64 00 00 00 00 00 00", ack(FC::kTG, IndexedWord{0, 100})},
      // §5.28 DI
      {"get DI", 0x042800B7, "05 B7 00 00 00 00 00 00 00 00 00", rq::get(FC::kDI)},
      {"DI in 03 out 00", 0x05200037, "05 37 04 03 00 00 00 00 00 00 00", ack(FC::kDI, DigitalIo{0x03, 0x00})},
      {"DI=1", 0x042800B7, "05 B7 04 01 01 00 00 00 00 00 00", rq::set_outputs(1)},
      {"DI in 03 out 01", 0x05200037, "05 37 04 03 01 00 00 00 00 00 00", ack(FC::kDI, DigitalIo{0x03, 0x01})},
  };
}

TEST(Uim342ManualExamples, EncodeAndDecodeEveryRow) {
  const auto examples = manual_examples();
  // The manual's §5.1-§5.28 print 95 example rows (PP 4, IC 4, IE 4, ML 2, SN 2, ER 4, QE 4, SY 1,
  // MT 4, MO 4, BG 2, ST 2, MF 2, AC/DC/SS/SD/JV/SP/PR/PA 4 each, OG 2, BL 4, MS 4, DV 2, IL 4,
  // TG 4, DI 4): every one of them is a row here.
  EXPECT_EQ(examples.size(), 95u);
  const Instruction* previous = nullptr;
  for (const auto& ex : examples) {
    SCOPED_TRACE(std::string(ex.what) + " | " + ex.row);
    const auto row = test::parse_row(ex.row);
    const auto expected_frame = test::frame_of(ex.can_id, row);
    ASSERT_EQ(row.id, 5);
    if (const auto* inst = std::get_if<Instruction>(&ex.typed)) {
      const auto frame = instruction_frame(row.id, *inst);
      ASSERT_TRUE(frame.ok()) << frame.error().message();
      EXPECT_EQ(can::to_cansend(*frame), can::to_cansend(expected_frame));
      const auto decoded = decode_instruction_frame(expected_frame);
      ASSERT_TRUE(decoded.ok()) << decoded.error().message();
      EXPECT_EQ(decoded->address, (CanAddress{kMasterId, 5}));
      EXPECT_EQ(decoded->instruction, *inst) << to_string(decoded->instruction);
      previous = inst;
    } else {
      const auto& reply = std::get<Reply>(ex.typed);
      const auto frame = reply_frame(row.id, reply);
      ASSERT_TRUE(frame.ok()) << frame.error().message();
      EXPECT_EQ(can::to_cansend(*frame), can::to_cansend(expected_frame));
      const auto decoded = decode_reply_frame(expected_frame);
      ASSERT_TRUE(decoded.ok()) << decoded.error().message();
      EXPECT_EQ(decoded->address, (CanAddress{5, kMasterId}));
      EXPECT_EQ(decoded->reply, reply) << to_string(decoded->reply);
      ASSERT_NE(previous, nullptr);
      EXPECT_EQ(classify_reply(*previous, row.message),
                ex.acknowledges_previous ? ReplyKind::kAck : ReplyKind::kUnrelated);
    }
  }
}

TEST(Uim342ManualExamples, DecodedMeaningOfSelectedRows) {
  // ML: 342XS; MS[0]: PTP, driver on, IN1-3 high, OP1 low, stopped, in position.
  const auto ml = decode_reply(test::parse_row("05 0B 08 20 0A 11 00 00 00 00 00").message);
  ASSERT_TRUE(ml.ok());
  EXPECT_EQ(std::get<ModelInfo>(ml->body).model(), Model::kUim342xs);
  EXPECT_EQ((ModelInfo{{0x22, 0x50, 0x19, 0x00}, 0, 0}).model(), Model::kUim342h08);
  EXPECT_EQ((ModelInfo{{0x22, 0x51, 0x19, 0x00}, 0, 0}).model(), Model::kUnknown);

  const auto ms = decode_reply(test::parse_row("05 11 08 00 3D 03 00 18 FC FF FF").message);
  ASSERT_TRUE(ms.ok());
  const auto& status = std::get<MotionStatus>(ms->body);
  EXPECT_EQ(status.mode(), MotionMode::kPtp);
  EXPECT_TRUE(status.has(IoStatusBit::kDriverOn));
  EXPECT_TRUE(status.has(IoStatusBit::kIn1));
  EXPECT_TRUE(status.has(IoStatusBit::kIn2));
  EXPECT_TRUE(status.has(IoStatusBit::kIn3));
  EXPECT_FALSE(status.has(IoStatusBit::kOp1));
  EXPECT_TRUE(status.has(StatusFlag::kStopped));
  EXPECT_TRUE(status.has(StatusFlag::kInPosition));
  EXPECT_FALSE(status.has(StatusFlag::kStalled));
  EXPECT_FALSE(status.has(StatusFlag::kLocked));
  EXPECT_FALSE(status.has(StatusFlag::kError));
  EXPECT_EQ(status.relative_position, -1000);

  const auto er = decode_reply(test::parse_row("05 0F 06 00 33 81 05 00 00 00 00").message);
  ASSERT_TRUE(er.ok());
  const auto& record = std::get<ErrorRecord>(er->body);
  EXPECT_EQ(record.error(), DriveErrc::kDataError);
  EXPECT_EQ(record.failed_function(), FC::kPP);
  EXPECT_EQ(record.sub_index, 5);

  const auto di = std::get<DigitalIo>(decode_reply(test::parse_row("05 37 04 03 01 00 00").message)->body);
  EXPECT_TRUE(di.input(InputPort::kIn1));
  EXPECT_TRUE(di.input(InputPort::kIn2));
  EXPECT_FALSE(di.input(InputPort::kIn3));
  EXPECT_TRUE(di.op1());

  EXPECT_EQ(bits_per_second(BitRate::kKbps500), 500'000u);
}

// §2.5 "More examples": CAN-ID + data as printed. Positive 32-bit values appear with 2 bytes
// (§5.18-§5.21 define 4): they decode (zero-extended); this library always encodes 4 bytes.
struct CanExample {
  std::uint32_t can_id;
  const char* data;
  Instruction typed;
  const char* encoded;  // what encode produces
};

TEST(Uim342ManualExamples, DirectCanExamples) {
  const CanExample examples[] = {
      {0x04280095, "01", request::driver_on(true), "01"},
      {0x04280095, "00", request::driver_on(false), "00"},
      {0x0428009D, "10 27", request::set_jog_velocity(10000), "10 27 00 00"},
      {0x0428009D, "F0 D8 FF FF", request::set_jog_velocity(-10000), "F0 D8 FF FF"},
      {0x04280096, "", request::begin(), ""},
      {0x04280097, "", request::stop(), ""},
      {0x0428009F, "80 0C", request::set_relative_position(3200), "80 0C 00 00"},
      {0x0428009F, "80 F3 FF FF", request::set_relative_position(-3200), "80 F3 FF FF"},
      {0x042800A0, "80 0C", request::set_absolute_position(3200), "80 0C 00 00"},
      {0x042800A0, "80 F3 FF FF", request::set_absolute_position(-3200), "80 F3 FF FF"},
      {0x0428009E, "80 0C", request::set_ptp_speed(3200), "80 0C 00 00"},
  };
  for (const auto& ex : examples) {
    SCOPED_TRACE(to_string(ex.typed));
    const auto decoded = decode_instruction_frame(test::frame(ex.can_id, ex.data));
    ASSERT_TRUE(decoded.ok()) << decoded.error().message();
    EXPECT_EQ(decoded->instruction, ex.typed);
    EXPECT_EQ(decoded->address, (CanAddress{4, 5}));
    const auto frame = instruction_frame(5, ex.typed);
    ASSERT_TRUE(frame.ok());
    EXPECT_EQ(*frame, test::frame(ex.can_id, ex.encoded));
  }
}

// The rows as the manual prints them where they contradict the text: what they
// decode to under the DL rule, so nobody "fixes" the table back to them by accident.
TEST(Uim342ManualExamples, PrintedMisprintsDecodeAsTheirDlSays) {
  // §5.7: QE get printed with DL 04 and one data byte: no QE form has DL 4.
  EXPECT_EQ(decode_instruction(test::parse_row("05 BD 04 04 00 00 00").message).error(), CodecErrc::kWrongLength);
  // §5.9: MT set printed with DL 01 (d1 = 10 is padding): it is the get of MT[0].
  const auto mt = decode_instruction(Message{0x90, 1, {0x00, 0x10}});
  ASSERT_TRUE(mt.ok());
  EXPECT_EQ(*mt, request::get(MotorDriver::kMicrostepping));
  // §5.14: AC set printed with DL 00: it is "get AC".
  const auto ac = decode_instruction(Message{0x99, 0, {0xF4, 0x01}});
  ASSERT_TRUE(ac.ok());
  EXPECT_EQ(*ac, request::get(FC::kAC));
  // §5.20: PR set printed with CW 9E: it is SP=1000, whose ACK (DV[2]) is not the printed DV[3].
  const auto pr = decode_instruction(test::parse_row("05 9E 04 E8 03 00 00 00 00 00 00").message);
  ASSERT_TRUE(pr.ok());
  EXPECT_EQ(*pr, request::set_ptp_speed(1000));
  EXPECT_EQ(classify_reply(*pr, test::parse_row("05 2E 05 03 E8 03 00 00 00 00 00").message), ReplyKind::kUnrelated);
}

TEST(Uim342ManualExamples, MnemonicNotation) {
  EXPECT_EQ(to_string(request::set(ProtocolParameter::kBitRate, 2)), "PP[5]=2");
  EXPECT_EQ(to_string(request::get(ProtocolParameter::kGroupId)), "PP[8]");
  EXPECT_EQ(to_string(request::get(FC::kMO)), "MO");
  EXPECT_EQ(to_string(request::driver_on(true)), "MO=1");
  EXPECT_EQ(to_string(request::set_jog_velocity(-1000)), "JV=-1000");
  EXPECT_EQ(to_string(request::begin()), "BG");
  EXPECT_EQ(to_string(request::without_ack(request::begin())), "BG (no ACK)");
  EXPECT_EQ(to_string(request::system(SystemOperation::kReboot)), "SY[1]");
  EXPECT_EQ(to_string(request::clear_motion_status()), "MS[0]=0");
  EXPECT_EQ(to_string(request::set_input_logic(InputPort::kIn1, {InputAction::kOriginThenDecelerateStop, false},
                                               {InputAction::kNone, true})),
            "IL[0]=0x06,0x80");
  EXPECT_EQ(to_string(Reply{FC::kDV, IndexedSigned{2, -1000}}), "DV[2]: -1000");
  EXPECT_EQ(to_string(error_report(DriveErrc::kDataError, 0x81, 5)),
            "ER[0]: 0x33 on CW 0x81 [5] (instruction data error (0x33))");
}

}  // namespace
}  // namespace motion::uim342
