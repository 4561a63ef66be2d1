#include "motion/can_frame/frame.hpp"

#include <gtest/gtest.h>

namespace motion::can {
namespace {

TEST(CanFrame, ParsesCansendExtendedStandardAndRtr) {
  const auto ext = parse_cansend("04280095#01");
  ASSERT_TRUE(ext);
  EXPECT_TRUE(ext->extended);
  EXPECT_EQ(ext->id, 0x04280095u);
  EXPECT_EQ(ext->dlc, 1);
  EXPECT_EQ(ext->data[0], 0x01);

  const auto std_frame = parse_cansend("601#40.41.60.00");
  ASSERT_TRUE(std_frame);
  EXPECT_FALSE(std_frame->extended);
  EXPECT_EQ(std_frame->id, 0x601u);
  EXPECT_EQ(std_frame->dlc, 4);
  EXPECT_EQ(std_frame->data[1], 0x41);

  const auto rtr = parse_cansend("123#R");
  ASSERT_TRUE(rtr);
  EXPECT_TRUE(rtr->rtr);
  EXPECT_EQ(rtr->dlc, 0);
}

TEST(CanFrame, RejectsMalformedCansend) {
  EXPECT_FALSE(parse_cansend("12#00"));                   // id of neither 3 nor 8 digits
  EXPECT_FALSE(parse_cansend("800#00"));                  // 11-bit id out of range
  EXPECT_FALSE(parse_cansend("20000000#00"));             // 29-bit id out of range
  EXPECT_FALSE(parse_cansend("123#0"));                   // odd nibble
  EXPECT_FALSE(parse_cansend("123#000102030405060708"));  // 9 bytes
  EXPECT_FALSE(parse_cansend("123#GG"));
  EXPECT_FALSE(parse_cansend("123"));
}

TEST(CanFrame, CandumpLineRoundTrip) {
  auto f = parse_cansend("04280095#01");
  ASSERT_TRUE(f);
  f->timestamp_us = 1700000000123456;
  const std::string line = to_candump_line(*f, "can0");
  EXPECT_EQ(line, "(1700000000.123456) can0 04280095#01");
  const auto back = parse_candump_line(line);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->interface, "can0");
  EXPECT_EQ(back->timestamp_us, 1700000000123456);
  EXPECT_EQ(back->frame, *f);
}

TEST(CanFrame, MakeRejectsOversizedIdAndPayload) {
  const std::uint8_t nine[9] = {};
  EXPECT_FALSE(Frame::make(0x123, false, nine));
  EXPECT_FALSE(Frame::make(0x800, false, {}));
  EXPECT_TRUE(Frame::make(0x1FFFFFFF, true, {}));
}

}  // namespace
}  // namespace motion::can
