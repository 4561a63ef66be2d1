// Identifier layout (manual §2.5 "CAN-ID for SimpleCAN3.0", its formulas applied to the Instruction
// Set Summary CWs).
#include <gtest/gtest.h>

#include <cstdint>

#include "motion/uim342/identifier.hpp"
#include "motion/uim342/instructions.hpp"
#include "motion/uim342/message.hpp"
#include "support.hpp"

namespace motion::uim342 {
namespace {

// The manual's formulas, transcribed literally (§2.5), as an independent oracle.
std::uint32_t manual_master_can_id(std::uint32_t consumer, std::uint32_t cw) {
  const std::uint32_t sid = ((consumer << 1) & 0x003F) | 0x0100;
  const std::uint32_t eid = (((consumer << 1) & 0x00C0) << 8) | cw;
  return (sid << 18) | eid;
}
std::uint32_t manual_received_producer(std::uint32_t can_id) {
  const std::uint32_t sid = can_id >> 18;
  const std::uint32_t eid = can_id & 0x3FFFF;
  return ((eid >> 11) & 0x0060) | ((sid >> 6) & 0x001F);
}

TEST(Uim342Identifier, ManualWorkedExampleMo1ToNode5) {
  // §2.5: SID 0x010A, EID 0x0095, CAN-ID 0x04280095, DLC 1, data 01.
  const auto id = encode_can_id({kMasterId, 5, 0x95});
  ASSERT_TRUE(id.ok());
  EXPECT_EQ(*id, 0x04280095u);
  EXPECT_EQ(split_can_id(*id), (SidEid{0x010A, 0x0095}));
  const auto f = instruction_frame(5, request::driver_on(true));
  ASSERT_TRUE(f.ok()) << f.error().message();
  EXPECT_EQ(*f, test::frame(0x04280095, "01"));
  EXPECT_EQ(can::to_cansend(*f), "04280095#01");
}

struct DerivedId {
  CanIdFields fields;
  std::uint16_t sid;
  std::uint32_t eid;
  std::uint32_t can_id;
};

// Identifiers derived from the §2.5 formulas (not printed in the manual), including IDs above 31
// (high ID bits in the EID).
constexpr DerivedId kDerived[] = {
    {{4, 5, 0x95}, 0x10A, 0x00095, 0x04280095},   {{5, 4, 0x15}, 0x148, 0x00015, 0x05200015},
    {{5, 4, 0x5A}, 0x148, 0x0005A, 0x0520005A},   {{4, 0, 0x16}, 0x100, 0x00016, 0x04000016},
    {{4, 100, 0x95}, 0x108, 0x0C095, 0x0420C095}, {{100, 4, 0x15}, 0x108, 0x30015, 0x04230015},
    {{4, 127, 0x95}, 0x13E, 0x0C095, 0x04F8C095},
};

TEST(Uim342Identifier, DerivedVectors) {
  for (const auto& v : kDerived) {
    SCOPED_TRACE(v.can_id);
    const auto id = encode_can_id(v.fields);
    ASSERT_TRUE(id.ok());
    EXPECT_EQ(*id, v.can_id);
    EXPECT_EQ(split_can_id(v.can_id), (SidEid{v.sid, v.eid}));
    EXPECT_EQ(join_can_id({v.sid, v.eid}), v.can_id);
    const auto back = decode_can_id(v.can_id);
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(*back, v.fields);
  }
}

TEST(Uim342Identifier, HighIdBitsOfProducerAndConsumer) {
  // Consumer 100 = 0b1100100: low bits 00100 -> bits 23..19, high bits 11 -> bits 15..14.
  EXPECT_EQ(*encode_can_id({4, 100, 0}), 0x0420C000u);
  // Producer 100: low bits -> 28..24, high bits -> 17..16.
  EXPECT_EQ(*encode_can_id({100, 4, 0}), 0x04230000u);
  // Each high bit on its own.
  EXPECT_EQ(*encode_can_id({0, 32, 0}), 0x00004000u);
  EXPECT_EQ(*encode_can_id({0, 64, 0}), 0x00008000u);
  EXPECT_EQ(*encode_can_id({32, 0, 0}), 0x00010000u);
  EXPECT_EQ(*encode_can_id({64, 0, 0}), 0x00020000u);
  EXPECT_EQ(*encode_can_id({127, 127, 0xFF}), 0x1FFBC0FFu);
}

TEST(Uim342Identifier, AgreesWithManualFormulasForEveryIdPair) {
  for (unsigned consumer = 0; consumer <= kMaxId; ++consumer) {
    for (const unsigned cw : {0x00u, 0x95u, 0xFFu}) {
      const auto id = encode_can_id({kMasterId, static_cast<std::uint8_t>(consumer), static_cast<std::uint8_t>(cw)});
      ASSERT_TRUE(id.ok());
      ASSERT_EQ(*id, manual_master_can_id(consumer, cw)) << consumer;
    }
  }
  for (unsigned producer = 0; producer <= kMaxId; ++producer) {
    for (unsigned consumer = 0; consumer <= kMaxId; ++consumer) {
      const CanIdFields fields{static_cast<std::uint8_t>(producer), static_cast<std::uint8_t>(consumer), 0x2E};
      const auto id = encode_can_id(fields);
      ASSERT_TRUE(id.ok());
      ASSERT_EQ(manual_received_producer(*id), producer);
      const auto back = decode_can_id(*id);
      ASSERT_TRUE(back.ok());
      ASSERT_EQ(*back, fields);
    }
  }
}

struct CheatSheetRow {
  FunctionCode function;
  std::uint32_t no_ack_id;      // 0 = the form does not exist
  std::uint32_t ack_id;         // 0 = the form does not exist
  std::uint32_t reply_id;       // reply of the get (or only) form; 0 = none
  std::uint32_t set_reply_id;   // reply of the set form when it differs (DV)
  std::uint32_t global_ack_id;  // 0 = not listed
};

// Identifiers from the §2.5 formulas for every CW of the Instruction Set Summary (node 5, master 4).
constexpr CheatSheetRow kCheatSheet[] = {
    {FunctionCode::kPP, 0x04280001, 0x04280081, 0x05200001, 0, 0x04000081},
    {FunctionCode::kIC, 0x04280006, 0x04280086, 0x05200006, 0, 0x04000086},
    {FunctionCode::kIE, 0x04280007, 0x04280087, 0x05200007, 0, 0x04000087},
    {FunctionCode::kML, 0, 0x0428008B, 0x0520000B, 0, 0x0400008B},
    {FunctionCode::kSN, 0x0428000C, 0x0428008C, 0x0520000C, 0, 0x0400008C},
    {FunctionCode::kER, 0x0428000F, 0x0428008F, 0x0520000F, 0, 0x0400008F},
    {FunctionCode::kMT, 0x04280010, 0x04280090, 0x05200010, 0, 0x04000090},
    {FunctionCode::kMS, 0x04280011, 0x04280091, 0x05200011, 0, 0x04000091},
    {FunctionCode::kMO, 0x04280015, 0x04280095, 0x05200015, 0, 0x04000095},
    {FunctionCode::kBG, 0x04280016, 0x04280096, 0x05200016, 0, 0x04000096},
    {FunctionCode::kST, 0x04280017, 0x04280097, 0x05200017, 0, 0x04000097},
    {FunctionCode::kMF, 0x04280018, 0x04280098, 0x05200018, 0, 0x04000098},
    {FunctionCode::kAC, 0x04280019, 0x04280099, 0x05200019, 0, 0x04000099},
    {FunctionCode::kDC, 0x0428001A, 0x0428009A, 0x0520001A, 0, 0x0400009A},
    {FunctionCode::kSS, 0x0428001B, 0x0428009B, 0x0520001B, 0, 0x0400009B},
    {FunctionCode::kSD, 0x0428001C, 0x0428009C, 0x0520001C, 0, 0x0400009C},
    {FunctionCode::kJV, 0x0428001D, 0x0428009D, 0x0520001D, 0x0520002E, 0x0400009D},
    {FunctionCode::kSP, 0x0428001E, 0x0428009E, 0x0520001E, 0x0520002E, 0x0400009E},
    {FunctionCode::kPR, 0x0428001F, 0x0428009F, 0x0520001F, 0x0520002E, 0x0400009F},
    {FunctionCode::kPA, 0x04280020, 0x042800A0, 0x05200020, 0x0520002E, 0x040000A0},
    {FunctionCode::kOG, 0x04280021, 0x042800A1, 0x05200021, 0, 0x040000A1},
    {FunctionCode::kBL, 0x0428002D, 0x042800AD, 0x0520002D, 0, 0x040000AD},
    {FunctionCode::kDV, 0x0428002E, 0x042800AE, 0x0520002E, 0, 0x040000AE},
    {FunctionCode::kIL, 0x04280034, 0x042800B4, 0x05200034, 0, 0x040000B4},
    {FunctionCode::kTG, 0x04280035, 0x042800B5, 0x05200035, 0, 0x040000B5},
    {FunctionCode::kDI, 0x04280037, 0x042800B7, 0x05200037, 0, 0x040000B7},
    {FunctionCode::kQE, 0x0428003D, 0x042800BD, 0x0520003D, 0, 0x040000BD},
    {FunctionCode::kRT, 0, 0, 0x0520005A, 0, 0},
    {FunctionCode::kSY, 0x0428007E, 0, 0, 0, 0},
};

TEST(Uim342Identifier, CheatSheet) {
  EXPECT_EQ(std::size(kCheatSheet), instruction_table().size() + 1);  // + RT
  for (const auto& row : kCheatSheet) {
    SCOPED_TRACE(std::string(mnemonic(row.function)));
    const auto* forms = find_forms(row.function);
    if (row.function != FunctionCode::kRT) {
      ASSERT_NE(forms, nullptr);
      EXPECT_EQ(row.no_ack_id != 0, forms->ack_forms != AckForms::kAckOnly);
      EXPECT_EQ(row.ack_id != 0, forms->ack_forms != AckForms::kNoAckOnly);
      EXPECT_EQ(row.reply_id != 0, forms->reply != Layout::kNone);
      EXPECT_EQ(row.set_reply_id, forms->set_ack == row.function ? 0u : *encode_can_id({5, 4, code(forms->set_ack)}));
    }
    if (row.no_ack_id != 0) { EXPECT_EQ(*encode_can_id({4, 5, control_word(row.function, false)}), row.no_ack_id); }
    if (row.ack_id != 0) { EXPECT_EQ(*encode_can_id({4, 5, control_word(row.function, true)}), row.ack_id); }
    if (row.reply_id != 0) { EXPECT_EQ(*encode_can_id({5, 4, code(row.function)}), row.reply_id); }
    if (row.global_ack_id != 0) {
      EXPECT_EQ(*encode_can_id({4, kGlobalId, control_word(row.function, true)}), row.global_ack_id);
    }
  }
}

TEST(Uim342Identifier, IdKinds) {
  EXPECT_EQ(classify_id(0), IdKind::kGlobal);
  EXPECT_EQ(classify_id(1), IdKind::kMaster);
  EXPECT_EQ(classify_id(kMasterId), IdKind::kMaster);
  EXPECT_EQ(classify_id(5), IdKind::kNodeOrGroup);
  EXPECT_EQ(classify_id(126), IdKind::kNodeOrGroup);
  EXPECT_EQ(classify_id(127), IdKind::kUnassignable);
  EXPECT_EQ(classify_id(128), IdKind::kOutOfRange);
  EXPECT_FALSE(is_valid_node_id(4));
  EXPECT_TRUE(is_valid_node_id(5));
  EXPECT_TRUE(is_valid_node_id(126));
  EXPECT_FALSE(is_valid_node_id(127));
}

TEST(Uim342Identifier, RejectsOutOfRangeIdsAndForeignIdentifiers) {
  EXPECT_EQ(encode_can_id({128, 5, 0}).error(), CodecErrc::kIdOutOfRange);
  EXPECT_EQ(encode_can_id({4, 200, 0}).error(), CodecErrc::kIdOutOfRange);
  EXPECT_EQ(decode_can_id(0x20000000).error(), CodecErrc::kIdentifierOutOfRange);
  EXPECT_EQ(decode_can_id(0x04280095 | (1u << 18)).error(), CodecErrc::kReservedBitsSet);
  EXPECT_EQ(decode_can_id(0x04280095 | (1u << 8)).error(), CodecErrc::kReservedBitsSet);
  EXPECT_EQ(decode_can_id(0x04280095 | (1u << 13)).error(), CodecErrc::kReservedBitsSet);
}

TEST(Uim342Identifier, CanCarriage) {
  const auto decoded = decode_can(test::frame(0x05200015, "01"));
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(decoded->address, (CanAddress{5, 4}));
  EXPECT_EQ(decoded->message.control_word, 0x15);
  EXPECT_EQ(test::hex(decoded->message.payload()), "01");

  can::Frame standard = test::frame(0x04280095, "01");
  standard.extended = false;
  standard.id = 0x123;
  EXPECT_EQ(decode_can(standard).error(), CodecErrc::kNotExtendedFrame);
  can::Frame remote = test::frame(0x04280095, "");
  remote.rtr = true;
  EXPECT_EQ(decode_can(remote).error(), CodecErrc::kRemoteFrame);
  can::Frame long_dlc = test::frame(0x04280095, "");
  long_dlc.dlc = 9;
  EXPECT_EQ(decode_can(long_dlc).error(), CodecErrc::kLengthOutOfRange);

  Message too_long;
  too_long.length = 9;
  EXPECT_EQ(encode_can({host_to(5), too_long}).error(), CodecErrc::kLengthOutOfRange);
  EXPECT_EQ(encode_can({host_to(128), Message{}}).error(), CodecErrc::kIdOutOfRange);
  const std::uint8_t nine[9] = {};
  EXPECT_EQ(Message::make(0x95, nine).error(), CodecErrc::kLengthOutOfRange);
}

}  // namespace
}  // namespace motion::uim342
