#include "motion/simbus/wire.hpp"

#include <gtest/gtest.h>

#include <array>
#include <vector>

namespace motion::simbus::wire {
namespace {

std::vector<std::uint8_t> encoded(const Message& m) {
  std::array<std::uint8_t, kMaxMessageSize> buffer{};
  const std::size_t n = encode(m, buffer);
  return {buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n)};
}

can::Frame sample_frame() {
  can::Frame f = *can::Frame::make(0x04280095, true, std::vector<std::uint8_t>{0x01, 0x02, 0x03});
  f.timestamp_us = 1'700'000'000'123'456;
  return f;
}

// A batch of both formats, an RTR frame among them, and every data length.
FrameBatch sample_batch() {
  FrameBatch b;
  b.frames[0] = sample_frame();
  b.frames[0].timestamp_us = 0;  // a batch carries none
  b.frames[1] = *can::Frame::make(0x080, false, {});
  b.frames[2] = *can::Frame::make(0x7FF, false, std::vector<std::uint8_t>{1, 2, 3, 4, 5, 6, 7, 8});
  b.frames[3] = *can::Frame::make(0x123, false, {});
  b.frames[3].rtr = true;
  b.frames[3].dlc = 4;
  b.count = 4;
  return b;
}

TEST(Wire, EveryMessageRoundTrips) {
  can::Frame rtr = *can::Frame::make(0x123, false, {});
  rtr.rtr = true;
  rtr.dlc = 4;
  const std::vector<Message> messages{
      Hello{kProtocolVersion, true, "gateway can0"},
      Welcome{kProtocolVersion, 7, 500'000, "lab"},
      FrameMessage{sample_frame(), false},
      FrameMessage{rtr, true},
      SetOwnEcho{true},
      BusEventMessage{can::BusEvent{can::BusState::kBusOff, 0x40, "bus-off"}},
      TxRejected{0x1FFFFFFF, true},
      sample_batch(),
  };
  for (const Message& m : messages) {
    const auto bytes = encoded(m);
    ASSERT_FALSE(bytes.empty()) << m.index();
    const auto back = decode(bytes);
    ASSERT_TRUE(back.has_value()) << m.index();
    EXPECT_EQ(*back, m) << m.index();
  }
}

TEST(Wire, FrameLayoutIsFixed) {
  // type 3, flags (extended), dlc, reserved, id LE, timestamp LE, data.
  const auto bytes = encoded(FrameMessage{sample_frame(), false});
  ASSERT_EQ(bytes.size(), 16u + 3u);
  EXPECT_EQ(bytes[0], 3);
  EXPECT_EQ(bytes[1], 0x01);
  EXPECT_EQ(bytes[2], 3);
  EXPECT_EQ(bytes[4], 0x95);
  EXPECT_EQ(bytes[7], 0x04);
  EXPECT_EQ(bytes[16], 0x01);
  // An RTR frame carries its DLC but no data bytes.
  can::Frame rtr = *can::Frame::make(0x123, false, {});
  rtr.rtr = true;
  rtr.dlc = 8;
  EXPECT_EQ(encoded(FrameMessage{rtr, false}).size(), 16u);
}

// `bytes` with the byte at `at` set to `value`.
std::vector<std::uint8_t> with_byte(std::vector<std::uint8_t> bytes, std::size_t at, std::uint8_t value) {
  bytes.at(at) = value;
  return bytes;
}

// A datagram cut short by one byte, or longer by one, is no message.
void expect_exact_length_only(std::vector<std::uint8_t> bytes) {
  EXPECT_FALSE(decode({bytes.data(), bytes.size() - 1}).has_value());
  bytes.push_back(0);
  EXPECT_FALSE(decode(bytes).has_value());
}

TEST(Wire, MalformedDatagramsAreRejected) {
  const auto bytes = encoded(FrameMessage{sample_frame(), false});
  EXPECT_FALSE(decode({}).has_value());
  EXPECT_FALSE(decode(std::vector<std::uint8_t>{0x7F}).has_value());  // unknown type
  expect_exact_length_only(bytes);
  EXPECT_FALSE(decode(with_byte(bytes, 2, 9)).has_value());                          // dlc 9
  EXPECT_FALSE(decode(with_byte(bytes, 1, 0x80)).has_value());                       // unknown flag
  EXPECT_FALSE(decode(with_byte(bytes, 1, 0)).has_value());                          // standard, but 29 bits
  EXPECT_FALSE(decode(std::vector<std::uint8_t>{4, 2}).has_value());                 // echo flag 2
  EXPECT_FALSE(decode(std::vector<std::uint8_t>{5, 9, 0, 0, 0, 0, 0}).has_value());  // state 9
}

TEST(Wire, ABatchHasAFixedLayoutAndUpTo16Frames) {
  // type 7, count, then per frame: flags, dlc, id LE, data (none for RTR).
  const auto bytes = encoded(sample_batch());
  ASSERT_EQ(bytes.size(), 2u + (6 + 3) + (6 + 0) + (6 + 8) + (6 + 0));
  EXPECT_EQ(bytes[0], 7);
  EXPECT_EQ(bytes[1], 4);
  EXPECT_EQ(bytes[2], 0x01);  // extended
  EXPECT_EQ(bytes[3], 3);
  EXPECT_EQ(bytes[4], 0x95);
  EXPECT_EQ(bytes[8], 0x01);   // first data byte
  EXPECT_EQ(bytes[31], 0x02);  // the RTR frame's flags
  EXPECT_EQ(bytes[32], 4);     // its dlc, no data bytes
  // 16 frames of 8 bytes and 29 bits fit a message; 17 or none are no batch.
  FrameBatch full;
  for (auto& f : full.frames) f = *can::Frame::make(0x1FFFFFFF, true, std::vector<std::uint8_t>(8, 0xAA));
  full.count = kMaxBatchFrames;
  const auto full_bytes = encoded(full);
  EXPECT_EQ(full_bytes.size(), 2u + 16 * 14);
  EXPECT_LE(full_bytes.size(), kMaxMessageSize);
  EXPECT_EQ(std::get<FrameBatch>(*decode(full_bytes)), full);
  FrameBatch none;
  EXPECT_TRUE(encoded(none).empty());
  auto too_many = full_bytes;
  too_many[1] = 17;
  EXPECT_FALSE(decode(too_many).has_value());
  auto zero = full_bytes;
  zero[1] = 0;
  EXPECT_FALSE(decode(zero).has_value());
}

TEST(Wire, MalformedBatchesAreRejected) {
  const auto bytes = encoded(sample_batch());
  expect_exact_length_only(bytes);
  EXPECT_FALSE(decode(with_byte(bytes, 1, 5)).has_value());            // a frame announced that is not there
  EXPECT_FALSE(decode(with_byte(bytes, 2, 0x01 | 0x04)).has_value());  // own echo: hub -> endpoint only
  EXPECT_FALSE(decode(with_byte(bytes, 3, 9)).has_value());            // dlc 9
  EXPECT_FALSE(decode(with_byte(bytes, 2, 0)).has_value());            // standard, but 29 bits
  FrameBatch invalid = sample_batch();
  invalid.frames[2].dlc = 9;
  std::array<std::uint8_t, kMaxMessageSize> buffer{};
  EXPECT_EQ(encode(invalid, buffer), 0u);
}

TEST(Wire, EncodeRefusesInvalidFramesAndSmallBuffers) {
  can::Frame f = sample_frame();
  f.dlc = 9;
  std::array<std::uint8_t, kMaxMessageSize> buffer{};
  EXPECT_EQ(encode(FrameMessage{f, false}, buffer), 0u);
  std::array<std::uint8_t, 10> small{};
  EXPECT_EQ(encode(FrameMessage{sample_frame(), false}, small), 0u);
}

TEST(Wire, LongTextsAreTruncated) {
  const std::string long_text(1000, 'x');
  const auto bytes = encoded(BusEventMessage{can::BusEvent{can::BusState::kErrorActive, 0, long_text}});
  ASSERT_FALSE(bytes.empty());
  EXPECT_LE(bytes.size(), kMaxMessageSize);
  const auto back = decode(bytes);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(std::get<BusEventMessage>(*back).event.text, std::string(kMaxText, 'x'));
}

}  // namespace
}  // namespace motion::simbus::wire
