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

TEST(Wire, MalformedDatagramsAreRejected) {
  auto bytes = encoded(FrameMessage{sample_frame(), false});
  EXPECT_FALSE(decode({}).has_value());
  EXPECT_FALSE(decode(std::vector<std::uint8_t>{0x7F}).has_value());   // unknown type
  EXPECT_FALSE(decode({bytes.data(), bytes.size() - 1}).has_value());  // short data
  auto longer = bytes;
  longer.push_back(0);
  EXPECT_FALSE(decode(longer).has_value());  // trailing byte
  auto bad_dlc = bytes;
  bad_dlc[2] = 9;
  EXPECT_FALSE(decode(bad_dlc).has_value());
  auto bad_flags = bytes;
  bad_flags[1] = 0x80;
  EXPECT_FALSE(decode(bad_flags).has_value());
  auto bad_id = bytes;
  bad_id[1] = 0;  // standard, but the id has 29 bits
  EXPECT_FALSE(decode(bad_id).has_value());
  EXPECT_FALSE(decode(std::vector<std::uint8_t>{4, 2}).has_value());                 // echo flag 2
  EXPECT_FALSE(decode(std::vector<std::uint8_t>{5, 9, 0, 0, 0, 0, 0}).has_value());  // state 9
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
