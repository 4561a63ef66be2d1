// 7-bit packing: the manual's MCF example and vectors derived from its rule (EN §6.2, §12.2).
#include <gtest/gtest.h>

#include "hex.hpp"
#include "motion/uim242/feedback.hpp"
#include "motion/uim242/packing.hpp"

namespace motion::uim242 {
namespace {

using test::hex;

struct PackingVector {
  std::int64_t value;
  Layout layout;
  const char* bytes;
};

// Derived from EN §6.2, §12.2 (the first row is the manual's own example, EN/CN #17).
const PackingVector kVectors[] = {
    {0x8733, Layout::kU16, "02 0E 33"},
    {5000, Layout::kS16, "00 27 08"},
    {1000, Layout::kS16, "00 07 68"},
    {-1000, Layout::kS16, "03 78 18"},
    {100, Layout::kS16, "00 00 64"},
    {32767, Layout::kS16, "01 7F 7F"},
    {-32768, Layout::kS16, "02 00 00"},
    {65535, Layout::kU16, "03 7F 7F"},
    {200, Layout::kS32, "00 00 00 01 48"},
    {-200, Layout::kS32, "0F 7F 7F 7E 38"},
    {500, Layout::kS32, "00 00 00 03 74"},
    {-200000, Layout::kS32, "0F 7F 73 65 40"},
    {2000000000, Layout::kS32, "07 39 56 28 00"},
    {-2000000000, Layout::kS32, "08 46 29 58 00"},
    {2147483647, Layout::kS32, "07 7F 7F 7F 7F"},
    {-2147483647, Layout::kS32, "08 00 00 00 01"},
    {65000000, Layout::kU32, "00 1E 7F 24 40"},
    {60000, Layout::kU32, "00 00 03 54 60"},
    {1302, Layout::kU16, "00 0A 16"},
    {1232, Layout::kU16, "00 09 50"},
};

TEST(Packing, SpecVectorsRoundTrip) {
  for (const auto& v : kVectors) {
    SCOPED_TRACE(v.value);
    const std::int64_t fields[] = {v.value};
    EXPECT_EQ(encode_fields(v.layout, fields), hex(v.bytes));
    const auto decoded = decode_fields(hex(v.bytes), v.layout);
    ASSERT_TRUE(decoded.ok());
    EXPECT_EQ(decoded->front(), v.value);
  }
}

TEST(Packing, TwelveBitThresholds) {
  // ATCONL 491, ATCONH 3276, full scale 4095 (EN/CN §8.11).
  EXPECT_EQ((packed<kPacked12>(491)), (std::array<std::uint8_t, 2>{0x03, 0x6B}));
  EXPECT_EQ((packed<kPacked12>(3276)), (std::array<std::uint8_t, 2>{0x19, 0x4C}));
  EXPECT_EQ((packed<kPacked12>(4095)), (std::array<std::uint8_t, 2>{0x1F, 0x7F}));
  EXPECT_EQ(unpack(hex("19 4C")), 3276u);
}

TEST(Packing, WideSpeedEchoesLow16Bits) {
  // EN/CN #37: SPD accepts +-65535 but echoes a signed 16-bit field: +40000 reads back as -25536.
  const std::int64_t fields[] = {40000};
  const auto decoded = decode_fields(encode_fields(Layout::kS16, fields), Layout::kS16);
  EXPECT_EQ(decoded->front(), -25536);
}

TEST(Packing, IgnoresBitSevenWhenUnpacking) { EXPECT_EQ(unpack(hex("82 8E B3")), 0x8733u); }

}  // namespace
}  // namespace motion::uim242
