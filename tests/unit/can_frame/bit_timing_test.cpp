#include "motion/can_frame/bit_timing.hpp"
#include "motion/can_frame/load_meter.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <string_view>
#include <vector>

namespace motion::can {
namespace {

using std::chrono::microseconds;

can::Frame frame(std::uint32_t id, bool extended, std::vector<std::uint8_t> payload) {
  return can::Frame::make(id, extended, payload).value();
}

can::Frame remote(std::uint32_t id, bool extended, std::uint8_t dlc) {
  can::Frame f = frame(id, extended, {});
  f.rtr = true;
  f.dlc = dlc;
  return f;
}

TEST(BitTiming, Crc15MatchesTheCatalogueCheckValue) {
  // CRC-15/CAN check value (reveng catalogue): "123456789" -> 0x059E.
  constexpr std::string_view kCheck = "123456789";
  std::vector<std::uint8_t> bytes(kCheck.begin(), kCheck.end());
  EXPECT_EQ(crc15_bytes(bytes), 0x059E);
  // The bitwise form agrees with the bytewise one.
  std::vector<std::uint8_t> bits;
  for (const std::uint8_t b : bytes) {
    for (int i = 7; i >= 0; --i) bits.push_back(static_cast<std::uint8_t>((b >> i) & 1));
  }
  EXPECT_EQ(crc15(bits), 0x059E);
}

TEST(BitTiming, AllZeroStandardFrameWithoutData) {
  // 000#: SOF, id 00000000000, RTR 0, IDE 0, r0 0, DLC 0000 = 19 dominant bits, and the CRC of
  // all-zero input is 0: 34 zeros. A stuff bit follows every 5th: 00000[1]00000[1]00000[1]
  // 00000[1]00000[1]00000[1]0000 -> 6 stuff bits. 34 + 6 + 10 trailer + 3 IFS = 53.
  const FrameBits bits = frame_bits(frame(0x000, false, {}));
  EXPECT_EQ(bits.crc, 0);
  EXPECT_EQ(bits.unstuffed, 34u);
  EXPECT_EQ(bits.stuff, 6u);
  EXPECT_EQ(bits.total, 53u);
  EXPECT_EQ(bits.to_end_of_frame(), 50u);
}

TEST(BitTiming, AllZeroPayloadStandardFrame) {
  // 000#0000000000000000: SOF+id+RTR+IDE+r0 = 15 zeros, DLC 1000, 64 zero data bits,
  // CRC 0x145B = 001010001011011. Stuffed (stuff bits in brackets):
  //   00000[1]00000[1]00000[1] 1 00000[1]00000[1] ... 0000 1010001011011
  // 15 header zeros -> 3 stuff bits; then 69 zeros (DLC tail 000, 64 data bits, the CRC's
  // leading 00) -> 13 stuff bits, 4 zeros left over; the CRC tail has no run of five. 16 in all.
  // 98 + 16 + 13 = 127 bits.
  const FrameBits bits = frame_bits(frame(0x000, false, std::vector<std::uint8_t>(8, 0)));
  EXPECT_EQ(bits.crc, 0x145B);
  EXPECT_EQ(bits.unstuffed, 98u);
  EXPECT_EQ(bits.stuff, 16u);
  EXPECT_EQ(bits.total, 127u);
}

TEST(BitTiming, ExtendedFrameWithOneDataByte) {
  // 04280095#01: base id 0x10A, id extension 0x00095. Unstuffed, field by field:
  //   SOF 0 | base id 00100001010 | SRR 1 | IDE 1 | extension 000000000010010101 | RTR 0 |
  //   r1 r0 00 | DLC 0001 | data 00000001 | CRC 0x3706 = 011011100000110   (62 bits)
  // Stuffed (inserted bits in brackets):
  //   000100001010 11 00000[1]00000[1]10010101 000 00[1]01 00000[1]001 0110111 00000[1]110
  // -> 5 stuff bits. 62 + 5 + 10 trailer + 3 IFS = 80 bits.
  const FrameBits bits = frame_bits(frame(0x04280095, true, {0x01}));
  EXPECT_EQ(bits.crc, 0x3706);
  EXPECT_EQ(bits.unstuffed, 62u);
  EXPECT_EQ(bits.stuff, 5u);
  EXPECT_EQ(bits.total, 80u);
}

TEST(BitTiming, AllOnesStandardFrameAndRemoteFrame) {
  // 7FF#FFFFFFFFFFFFFFFF: runs of ones, one stuff bit per five: 15 stuff bits, 126 bits.
  EXPECT_EQ(frame_bits(frame(0x7FF, false, std::vector<std::uint8_t>(8, 0xFF))).total, 126u);
  // 123#R (DLC 0): 0 00100100011 1 0 0 0000 + CRC 0x1B9D, one run of five -> 1 stuff bit.
  const FrameBits rtr = frame_bits(remote(0x123, false, 0));
  EXPECT_EQ(rtr.unstuffed, 34u);
  EXPECT_EQ(rtr.stuff, 1u);
  EXPECT_EQ(rtr.total, 48u);
  // An RTR frame carries its DLC but no data: same length as DLC 0 apart from the DLC bits.
  EXPECT_EQ(frame_bits(remote(0x123, false, 8)).unstuffed, 34u);
}

TEST(BitTiming, LengthsStayWithinTheClassicBounds) {
  // Unstuffed 47 + 8n (standard) / 67 + 8n (extended); at most (34 + 8n - 1) / 4 stuff bits.
  for (std::uint8_t dlc = 0; dlc <= 8; ++dlc) {
    for (const bool extended : {false, true}) {
      for (const std::uint8_t fill : {std::uint8_t{0x00}, std::uint8_t{0xFF}, std::uint8_t{0x55}, std::uint8_t{0x0F}}) {
        const can::Frame f = frame(extended ? 0x1ABCDEF0 : 0x555, extended, std::vector<std::uint8_t>(dlc, fill));
        const FrameBits bits = frame_bits(f);
        const std::uint32_t base = (extended ? 67u : 47u) + 8u * dlc;
        const std::uint32_t stuffed_region = base - 13u;
        EXPECT_EQ(bits.unstuffed + kTrailerBits + kInterframeBits, base);
        EXPECT_LE(bits.stuff, (stuffed_region - 1) / 4);
      }
    }
  }
}

TEST(BitTiming, DurationsAtCommonBitrates) {
  const can::Frame f = frame(0x000, false, {});  // 53 bits
  EXPECT_EQ(frame_duration(f, 125'000), microseconds(53 * 8));
  EXPECT_EQ(frame_duration(f, 500'000), microseconds(53 * 2));
  EXPECT_EQ(frame_duration(f, 1'000'000), microseconds(53));
  // Rounded on the total, not per bit: 3 bits at 3 Mbit/s is exactly 1 us.
  EXPECT_EQ(bits_duration(3, 3'000'000), microseconds(1));
}

TEST(BitTiming, LowestIdentifierWinsArbitration) {
  EXPECT_TRUE(wins_arbitration(frame(0x100, false, {}), frame(0x101, false, {})));
  EXPECT_FALSE(wins_arbitration(frame(0x101, false, {}), frame(0x100, false, {})));
  EXPECT_TRUE(wins_arbitration(frame(0x00000001, true, {}), frame(0x00000002, true, {})));
  // Equal arbitration fields: nobody wins (the bus keeps submission order).
  EXPECT_FALSE(wins_arbitration(frame(0x100, false, {1}), frame(0x100, false, {2})));
}

TEST(BitTiming, StandardBeatsExtendedWithTheSameBaseId) {
  // 0x123 vs 0x048C0000 (base id 0x123): the standard RTR/IDE bits are dominant where the
  // extended frame sends recessive SRR/IDE.
  const can::Frame standard = frame(0x123, false, {});
  const can::Frame extended = frame(0x123u << 18, true, {});
  EXPECT_TRUE(wins_arbitration(standard, extended));
  EXPECT_TRUE(wins_arbitration(remote(0x123, false, 0), extended));  // even as an RTR frame
  // But a lower base id wins regardless of format.
  EXPECT_TRUE(wins_arbitration(frame(0x122u << 18, true, {}), standard));
  EXPECT_TRUE(wins_arbitration(extended, frame(0x124, false, {})));
}

TEST(BitTiming, DataFrameBeatsRemoteFrameWithTheSameId) {
  EXPECT_TRUE(wins_arbitration(frame(0x123, false, {}), remote(0x123, false, 0)));
  EXPECT_TRUE(wins_arbitration(frame(0x1234567, true, {}), remote(0x1234567, true, 0)));
  EXPECT_FALSE(wins_arbitration(remote(0x123, false, 0), frame(0x123, false, {})));
}

}  // namespace
}  // namespace motion::can

// Bus load from the frames an endpoint saw: exact wire bits over one-second windows.
namespace motion::can {
namespace {

TEST(LoadMeter, IsTheWireTimeOfTheFramesOverTheWindowAndFallsWhenTheBusGoesQuiet) {
  using std::chrono::milliseconds;
  Frame f{};
  f.id = 0x123;
  f.dlc = 8;
  const std::uint32_t bits = LoadMeter::nominal_bits(f);
  EXPECT_EQ(bits, 111u);  // 47 + 64: SOF..IFS without stuff bits
  EXPECT_LE(bits, frame_bits(f).total);
  LoadMeter meter(125000);
  const TimePoint t0{};
  EXPECT_EQ(meter.load(t0), 0.0);
  // 500 frames in the first second (one every 2 ms), then the frame that closes the window.
  for (int i = 0; i < 500; ++i) meter.add(f, t0 + milliseconds(2 * i));
  meter.add(f, t0 + milliseconds(1000));
  const double expected = 500.0 * bits / 125000.0;
  EXPECT_NEAR(meter.load(t0 + milliseconds(1000)), expected, 1e-9);
  EXPECT_NEAR(meter.load(t0 + milliseconds(1999)), expected, 1e-9);
  // Quiet from there: the open window (one frame) averages over its growing length.
  EXPECT_NEAR(meter.load(t0 + milliseconds(3000)), bits / (125000.0 * 2.0), 1e-9);
  EXPECT_LT(meter.load(t0 + milliseconds(60000)), 1e-4);
  LoadMeter unknown;  // no bit rate: no load
  unknown.add(f, t0);
  unknown.add(f, t0 + milliseconds(1500));
  EXPECT_EQ(unknown.load(t0 + milliseconds(1500)), 0.0);
}

}  // namespace
}  // namespace motion::can
