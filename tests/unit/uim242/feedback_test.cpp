// Feedback frames: the manuals' rows (EN/CN §6.2, §12.2, #6, #17, #22) and replies derived from the
// §12.3 layouts.
#include <gtest/gtest.h>

#include "hex.hpp"
#include "motion/uim242/feedback.hpp"

namespace motion::uim242 {
namespace {

using test::hex;

Frame parsed(std::string_view bytes) {
  auto f = parse_frame(hex(bytes));
  EXPECT_TRUE(f.ok()) << bytes << ": " << f.error().message();
  return f.ok() ? *f : Frame{};
}

Instruction instruction(std::string_view text) {
  auto in = parse_instruction(text);
  EXPECT_TRUE(in.ok()) << text;
  return in.ok() ? *in : Instruction{};
}

std::vector<std::int64_t> fields_of(const Frame& f, Layout layout) {
  auto v = decode_fields(f.data, layout);
  EXPECT_TRUE(v.ok());
  return v.ok() ? *v : std::vector<std::int64_t>{};
}

TEST(Feedback, McfAckEN17CN17) {
  const Frame f = parsed("AA 05 B0 02 0E 33 FF");
  EXPECT_EQ(f.header, Header::kAck);
  EXPECT_EQ(f.node, 5);
  EXPECT_EQ(f.message_id, message::kMcf);
  EXPECT_TRUE(reply_matches(f, instruction("MCF34611")));
  EXPECT_EQ(fields_of(f, Layout::kU16), std::vector<std::int64_t>{0x8733});
  EXPECT_EQ(serialize(f), hex("AA 05 B0 02 0E 33 FF"));
}

TEST(Feedback, S1FallingNotificationEN122) {
  const auto n = as_notification(parsed("CC 05 A0 FF"));
  ASSERT_TRUE(n.has_value());
  EXPECT_EQ(n->node, 5);
  EXPECT_EQ(n->event, Event::kS1Falling);
  EXPECT_EQ(serialize(make_notification(*n)), hex("CC 05 A0 FF"));
}

TEST(Feedback, ValueErrorCN6) {
  const auto e = as_error(parsed("EE 66 FF"));
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->code, make_error_code(ErrorCode::kValueError));
  EXPECT_FALSE(e->node.has_value());
  EXPECT_EQ(serialize(make_error(ErrorCode::kValueError)), hex("EE 66 FF"));
  // The form with an id, not in EN/CN §6.2, is accepted too.
  const auto with_id = as_error(parsed("EE 05 65 FF"));
  ASSERT_TRUE(with_id.has_value());
  EXPECT_EQ(with_id->node, 5);
  EXPECT_EQ(with_id->code, make_error_code(ErrorCode::kSyntaxError));
}

TEST(Feedback, ModelReplyTemplateEN22) {
  // CC [ID] DE 18 02 [CUR] [asb] u16: 2.0 A, encoder + closed loop + advanced, 3 sensor ports, fw 1302.
  const Frame f = parsed("CC 05 DE 18 02 14 73 00 0A 16 FF");
  EXPECT_TRUE(reply_matches(f, instruction("MDL 5")));
  EXPECT_EQ(fields_of(f, Layout::kModel), (std::vector<std::int64_t>{0x18, 0x02, 20, 0x73, 1302}));
}

TEST(Feedback, StoAckAndRtcnTemplates) {
  EXPECT_TRUE(reply_matches(parsed("AA 05 D1 FF"), instruction("STO 2")));
  EXPECT_TRUE(reply_matches(parsed("AA 05 D1 FF"), instruction("STO")));
  // CN 10-byte A8: closed-loop flag + position; EN 4-byte A8.
  const Notification cn{5, Event::kDisplacementComplete, true, -200};
  EXPECT_EQ(serialize(make_notification(cn)), hex("CC 05 A8 01 0F 7F 7F 7E 38 FF"));
  EXPECT_EQ(as_notification(parsed("CC 05 A8 01 0F 7F 7F 7E 38 FF")), cn);
  const auto en = as_notification(parsed("CC 05 A8 FF"));
  ASSERT_TRUE(en.has_value());
  EXPECT_FALSE(en->position.has_value());
  // A frame that is a reply, not an RTCN.
  EXPECT_FALSE(as_notification(parsed("CC 05 B2 00 27 08 FF")).has_value());
}

struct DerivedReply {
  const char* instruction;
  const char* reply;
  std::vector<std::int64_t> fields;
};

TEST(Feedback, DerivedRepliesSpec63) {
  const DerivedReply rows[] = {
      {"SPD 5000", "AA 05 B5 00 27 08 FF", {5000}},
      {"SPD -1000", "AA 05 B5 03 78 18 FF", {-1000}},
      {"STP 200", "AA 05 B6 00 00 00 01 48 FF", {200}},
      {"STP -200", "AA 05 B6 0F 7F 7F 7E 38 FF", {-200}},
      {"QER 500", "AA 05 C2 00 03 74 FF", {500}},
      {"SQT 150", "AA 05 B8 00 00 00 01 16 FF", {150}},
      {"ENA 1000", "AA 05 A0 00 07 68 FF", {1000}},
      {"MAC 300", "AA 05 B1 00 00 00 00 02 2C FF", {0, 300}},
      {"ACR 30", "AA 05 BA 1E FF", {30}},
      {"DOU 1", "AA 05 C1 01 FF", {1}},
      {"STGx C8 00 00", "AA 05 C9 00 01 48 00 00 00 00 00 00 FF", {200, 0, 0}},
      {"MCF 32769", "AA 05 B0 02 00 01 FF", {32769}},                         // §8.11
      {"SCF", "AA 05 C0 00 00 00 00 2A 03 6B 19 4C FF", {0x2A, 491, 3276}},   // after §8.11
      {"SCF", "AA 05 C0 00 50 00 04 0A 00 00 00 00 FF", {0x0A00020A, 0, 0}},  // after §8.10 + §10.5
  };
  for (const auto& row : rows) {
    SCOPED_TRACE(row.instruction);
    const auto in = instruction(row.instruction);
    const auto form = reply_form(in);
    EXPECT_EQ(serialize(make_reply(form, 5, row.fields)), hex(row.reply));
    const Frame f = parsed(row.reply);
    EXPECT_TRUE(reply_matches(f, in));
    EXPECT_EQ(fields_of(f, form.layout), row.fields);
  }
}

TEST(Feedback, QecAndSqtRepliesCollideG14) {
  const Frame f = parsed("AA 05 B8 00 00 00 01 16 FF");
  EXPECT_TRUE(reply_matches(f, instruction("SQT 150")));
  EXPECT_TRUE(reply_matches(f, instruction("QEC 150")));
}

TEST(Feedback, OrgRepliesBothStylesG13) {
  const auto org = instruction("ORG");
  EXPECT_TRUE(reply_matches(parsed("CC 05 B0 00 00 00 00 00 FF"), org));  // CN
  EXPECT_TRUE(reply_matches(parsed("AA 05 B7 00 00 00 00 00 FF"), org));  // EN
  EXPECT_FALSE(reply_matches(parsed("AA 05 B0 00 00 00 00 00 FF"), org));
}

TEST(Feedback, BasicAckOfTheMacroSpec63) {
  // `{CUR 20; MCS 16; SPD 5000; ENA; };` from reset: enabled, DIR +, MCS 16, 2.0 A, 5000 pps.
  const Frame f = parsed("AA 05 3F 14 00 27 08 00 00 00 00 00 FF");
  EXPECT_FALSE(f.message_id.has_value());
  const auto s = decode_status(f);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(*s, (Status{false, true, true, 16, 20, 5000, 0}));
  EXPECT_TRUE(reply_matches(f, instruction("")));
  EXPECT_TRUE(reply_matches(f, instruction("ENA")));
  EXPECT_EQ(serialize(make_status_frame(Header::kAck, 5, *s)), hex("AA 05 3F 14 00 27 08 00 00 00 00 00 FF"));
}

TEST(Feedback, FbkStatusSpec63) {
  const Frame f = parsed("CC 05 60 0A 03 78 18 0F 7F 7F 7E 38 FF");
  EXPECT_TRUE(reply_matches(f, instruction("FBK")));
  const auto s = decode_status(f);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(*s, (Status{true, true, false, 1, 10, -1000, -200}));
}

TEST(Feedback, GatewayFramesEXT2501) {
  EXPECT_TRUE(reply_matches(parsed("AA 06 D0 FF"), instruction("ADR 6")));
  EXPECT_TRUE(reply_matches(parsed("AA 01 AD FF"), instruction("gSPD 0")));
  EXPECT_TRUE(reply_matches(parsed("CC 01 AD FF"), instruction("gORG")));
  EXPECT_TRUE(reply_matches(parsed("AA 07 DD FF"), instruction("SET 7")));
  EXPECT_TRUE(reply_matches(parsed("CC 02 D0 05 06 00 00 00 00 00 00 FF"), instruction("gREG")));
  const Frame greeting = parsed("AA AB AC 19 01 00 00 00 00 00 01 02 FF");
  const auto g = as_greeting(greeting);
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->version_high, 1);
  EXPECT_EQ(serialize(make_greeting(*g)), hex("AA AB AC 19 01 00 00 00 00 00 01 02 FF"));
  EXPECT_TRUE(reply_matches(greeting, instruction("ABC")));
}

TEST(Feedback, MalformedFrames) {
  EXPECT_EQ(parse_frame(hex("05 B0 FF")).error(), make_error_code(CodecErrc::kBadHeader));
  EXPECT_EQ(parse_frame(hex("AA 05 B0")).error(), make_error_code(CodecErrc::kBadTerminator));
  EXPECT_EQ(parse_frame(hex("AA FF")).error(), make_error_code(CodecErrc::kFrameTooShort));
  EXPECT_EQ(parse_frame(hex("AA 05 B0 02 8E 33 FF")).error(), make_error_code(CodecErrc::kNotSevenBit));
  EXPECT_EQ(decode_status(parsed("AA 05 3F 14 FF")).error(), make_error_code(CodecErrc::kWrongLength));
  EXPECT_FALSE(reply_matches(parsed("AA 05 B5 00 27 FF"), instruction("SPD 5000")));  // short data
}

TEST(Feedback, FeTerminatorMeansMoreFollow) {
  const Frame f = parsed("CC 05 A0 FE");
  EXPECT_TRUE(f.more_follows);
  EXPECT_EQ(serialize(f), hex("CC 05 A0 FE"));
}

// ---- Framer --------------------------------------------------------------------------------

std::vector<std::vector<std::uint8_t>> feed_in_pieces(FeedbackFramer& framer, const std::vector<std::uint8_t>& bytes,
                                                      std::size_t piece) {
  std::vector<std::vector<std::uint8_t>> out;
  for (std::size_t i = 0; i < bytes.size(); i += piece) {
    const auto n = std::min(piece, bytes.size() - i);
    for (auto& f : framer.push(std::span(bytes).subspan(i, n))) out.push_back(std::move(f));
  }
  return out;
}

TEST(FeedbackFramer, FramesArriveInAnyChunking) {
  const auto stream = hex("AA 05 B0 02 0E 33 FF CC 05 A0 FF EE 66 FF AA 05 3F 14 00 27 08 00 00 00 00 00 FF");
  for (std::size_t piece = 1; piece <= stream.size(); ++piece) {
    SCOPED_TRACE(piece);
    FeedbackFramer framer;
    const auto frames = feed_in_pieces(framer, stream, piece);
    ASSERT_EQ(frames.size(), 4u);
    EXPECT_EQ(frames[1], hex("CC 05 A0 FF"));
    EXPECT_EQ(frames[3].size(), 13u);
    EXPECT_EQ(framer.noise_bytes(), 0u);
  }
}

TEST(FeedbackFramer, SkipsNoiseBeforeAHeader) {
  FeedbackFramer framer;
  const auto frames = framer.push(hex("00 13 7F FF 05 CC 05 A0 FF"));
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0], hex("CC 05 A0 FF"));
  EXPECT_EQ(framer.noise_bytes(), 5u);
}

TEST(FeedbackFramer, StallIdEqualToAckHeaderIsNotAFrameStartG16) {
  FeedbackFramer framer;
  const auto frames = framer.push(hex("CC 05 AA FF"));
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(as_notification(*parse_frame(frames[0]))->event, Event::kStall);
}

TEST(FeedbackFramer, LostTerminatorResyncsAtTheNextHeader) {
  FeedbackFramer framer;
  // The first frame lost its FF: the CC after its data starts the next frame.
  const auto frames = framer.push(hex("AA 05 B0 02 0E CC 05 A0 FF"));
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0], hex("CC 05 A0 FF"));
}

TEST(FeedbackFramer, OversizeFrameIsDroppedAndScanResumes) {
  FeedbackFramer framer;
  std::vector<std::uint8_t> stream = hex("AA 05");
  stream.insert(stream.end(), 20, 0x11);
  const auto tail = hex("EE 65 FF");
  stream.insert(stream.end(), tail.begin(), tail.end());
  const auto frames = framer.push(stream);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0], tail);
  EXPECT_EQ(framer.oversize_frames(), 1u);
}

}  // namespace
}  // namespace motion::uim242
