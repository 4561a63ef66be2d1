#include "motion/core/bytes.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace motion::bytes {
namespace {

TEST(Bytes, ReadsLittleEndianAndRejectsShortInput) {
  const std::vector<std::uint8_t> in{0x78, 0x56, 0x34, 0x12, 0xFF};
  EXPECT_EQ(read_le<std::uint32_t>(in), 0x12345678u);
  EXPECT_EQ((read_le<std::uint16_t>(in, 3)), 0xFF12u);
  EXPECT_FALSE((read_le<std::uint32_t>(in, 2)).has_value());
  EXPECT_FALSE((read_le<std::uint8_t>(in, 5)).has_value());
  EXPECT_FALSE((read_le<std::uint8_t>(in, 9)).has_value());
}

TEST(Bytes, SignExtendsShortSignedFields) {
  // MS[1] of the UIM342 carries a 24-bit signed speed.
  const std::vector<std::uint8_t> minus_two{0xFE, 0xFF, 0xFF};
  EXPECT_EQ((read_le<std::int32_t, 3>(minus_two)), -2);
  const std::vector<std::uint8_t> plus{0xFE, 0xFF, 0x7F};
  EXPECT_EQ((read_le<std::int32_t, 3>(plus)), 0x7FFFFE);
}

TEST(Bytes, BigEndianRoundTrip) {
  std::vector<std::uint8_t> out(4);
  ASSERT_TRUE(write_be<std::uint32_t>(out, 0, 0xA1B2C3D4u));
  EXPECT_EQ(out, (std::vector<std::uint8_t>{0xA1, 0xB2, 0xC3, 0xD4}));
  EXPECT_EQ(read_be<std::uint32_t>(out), 0xA1B2C3D4u);
  EXPECT_FALSE(write_be<std::uint32_t>(out, 1, 0u));
  EXPECT_EQ((read_be<std::int16_t>(out, 0)), static_cast<std::int16_t>(0xA1B2));
}

TEST(Bytes, WriteLittleEndianFillsExactlyNBytes) {
  std::vector<std::uint8_t> out(5, 0xEE);
  ASSERT_TRUE((write_le<std::int32_t, 3>(out, 1, -2)));
  EXPECT_EQ(out, (std::vector<std::uint8_t>{0xEE, 0xFE, 0xFF, 0xFF, 0xEE}));
}

}  // namespace
}  // namespace motion::bytes
