// UIMessages out of a byte stream (manual §2.6, Appendix-1): frames split anywhere, line noise with
// false SM/EM bytes, corrupt CRCs, the two coverages and strict acceptance; and the mapping between
// the UIMessage ID and the producer/consumer of the CAN frame (§2.5, §2.6).
#include <gtest/gtest.h>

#include <vector>

#include "motion/uim342/uimessage_stream.hpp"
#include "support.hpp"

namespace motion::uim342 {
namespace {

// MO ACK from node 5 (ON), CRC computed with the Appendix-1 routine (not printed in the manual):
// variant A (SM..d8) and B (ID..d8).
constexpr const char* kAckA = "AA 05 15 01 01 00 00 00 00 00 00 00 00 8E 15 CC";
constexpr const char* kAckB = "AA 05 15 01 01 00 00 00 00 00 00 00 00 71 57 CC";
// Derived (§2.6, Appendix-1 CRC): JV=-1000 with ACK to node 5, variant A: data bytes that look like
// nothing special.
constexpr const char* kJvA = "AA 05 9D 04 18 FC FF FF 00 00 00 00 00 AE 26 CC";

std::vector<DecodedUiMessage> drain(UiMessageStream& stream) {
  std::vector<DecodedUiMessage> out;
  while (auto m = stream.next()) out.push_back(*m);
  return out;
}

TEST(Uim342UiMessageStream, FramesSplitAnywhereComeOutWhole) {
  std::vector<std::uint8_t> line;
  for (const auto* frame : {kAckA, kJvA, kAckB}) {
    const auto bytes = test::hex_bytes(frame);
    line.insert(line.end(), bytes.begin(), bytes.end());
  }
  for (std::size_t chunk : {std::size_t{1}, std::size_t{5}, std::size_t{16}, std::size_t{17}, line.size()}) {
    SCOPED_TRACE(chunk);
    UiMessageStream stream;
    std::vector<DecodedUiMessage> got;
    for (std::size_t at = 0; at < line.size(); at += chunk) {
      stream.feed(std::span(line).subspan(at, std::min(chunk, line.size() - at)));
      for (auto& m : drain(stream)) got.push_back(m);
      EXPECT_LT(stream.buffered(), kUiMessageSize);
    }
    ASSERT_EQ(got.size(), 3u);
    EXPECT_EQ(got[0].message.id, 5);
    EXPECT_EQ(got[0].message.message.control_word, 0x15);
    EXPECT_EQ(got[0].crc, CrcCoverage::kStartToAux);
    EXPECT_EQ(got[1].message.message.control_word, 0x9D);
    EXPECT_EQ(got[1].message.message.length, 4);
    EXPECT_EQ(got[2].crc, CrcCoverage::kIdToAux);
    EXPECT_EQ(stream.counters().frames, 3u);
    EXPECT_EQ(stream.counters().discarded_bytes, 0u);
  }
}

TEST(Uim342UiMessageStream, ResynchronizesAfterNoiseWithFalseStartAndEndBytes) {
  UiMessageStream stream;
  // An SM whose EM position falls inside the real frame, then an 0xAD start, then a lone EM.
  const auto noise = test::hex_bytes("AA 00 00 AD 00 CC 00");
  stream.feed(noise);
  EXPECT_TRUE(drain(stream).empty());
  stream.feed(test::hex_bytes(kAckA));
  const auto got = drain(stream);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].message.message.control_word, 0x15);
  EXPECT_EQ(stream.counters().discarded_bytes, noise.size());
  EXPECT_EQ(stream.counters().crc_errors, 0u);
  EXPECT_EQ(stream.buffered(), 0u);
}

TEST(Uim342UiMessageStream, CorruptCrcIsCountedAndAFrameStartingInsideItIsFound) {
  UiMessageStream stream;
  auto corrupt = test::hex_bytes(kAckA);
  corrupt[4] = 0x00;
  stream.feed(corrupt);
  stream.feed(test::hex_bytes(kAckB));
  const auto got = drain(stream);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].crc, CrcCoverage::kIdToAux);
  EXPECT_EQ(stream.counters().crc_errors, 1u);
  EXPECT_EQ(stream.counters().discarded_bytes, kUiMessageSize);

  // A real frame that starts inside a shorter corrupt one is not lost: the candidate gives up
  // only its first byte.
  UiMessageStream overlapped;
  auto torn = test::hex_bytes(kAckA);
  torn.resize(6);  // a frame cut off after 6 bytes (the line dropped the rest)
  overlapped.feed(torn);
  overlapped.feed(test::hex_bytes(kJvA));
  const auto found = drain(overlapped);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].message.message.control_word, 0x9D);
  EXPECT_EQ(overlapped.counters().discarded_bytes, 6u);
}

TEST(Uim342UiMessageStream, StrictAcceptanceAndMalformedLength) {
  UiMessageStream strict(CrcAcceptance::kStartToAux);
  strict.feed(test::hex_bytes(kAckB));
  strict.feed(test::hex_bytes(kAckA));
  const auto got = drain(strict);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].crc, CrcCoverage::kStartToAux);
  EXPECT_EQ(strict.counters().crc_errors, 1u);

  UiMessageStream stream;
  stream.feed(test::hex_bytes("AD 05 15 09 00 00 00 00 00 00 00 00 00 00 00 CC"));  // DL 9
  EXPECT_TRUE(drain(stream).empty());
  EXPECT_EQ(stream.counters().malformed, 1u);
  stream.clear();
  EXPECT_EQ(stream.buffered(), 0u);
}

TEST(Uim342UiMessageMapping, TheIdIsTheDrivesSideOfTheExchange) {
  // Host instruction MO=1 to node 5: CAN 0x04280095 (§2.3) <-> UIMessage ID 5.
  const CanMessage mo{host_to(5), *Message::make(0x95, std::vector<std::uint8_t>{1})};
  const auto ui = instruction_to_ui(mo);
  ASSERT_TRUE(ui.ok());
  EXPECT_EQ(ui->id, 5);
  EXPECT_EQ(test::hex(*encode_ui_message(*ui)), "AA 05 95 01 01 00 00 00 00 00 00 00 00 27 D7 CC");
  EXPECT_EQ(instruction_from_ui(*ui), mo);
  EXPECT_EQ(encode_can(instruction_from_ui(*ui))->id, 0x04280095u);
  // An instruction from another producer has no UIMessage form.
  EXPECT_EQ(instruction_to_ui({{6, 5}, mo.message}).error(), CodecErrc::kProducerNotHost);

  // Drive frame: MO ACK from node 100 -> master 4 is 0x04230015 (derived from the §2.5 layout).
  const CanMessage ack{drive_to_host(100), *Message::make(0x15, std::vector<std::uint8_t>{1})};
  const auto up = drive_message_to_ui(ack);
  EXPECT_EQ(up.id, 100);
  EXPECT_EQ(drive_message_from_ui(up), ack);
  EXPECT_EQ(encode_can(drive_message_from_ui(up))->id, 0x04230015u);
}

}  // namespace
}  // namespace motion::uim342
