// Process-data codecs and settings of the UC57 driver, against derived PDO vectors (CiA 301 §7.2.2;
// mappings of the manual's §5 comm. table).
#include <gtest/gtest.h>

#include "motion/uc57_driver/node_settings.hpp"
#include "motion/uc57_driver/process_data.hpp"

namespace motion::uc57_driver {
namespace {

TEST(ProcessData, Rpdo1ControlwordTargetIsD29) {
  // D-29: 201: 1F 00 10 27 00 00 (controlword 0x001F + target 10000).
  const auto frame = encode_rpdo1(1, RpdoLayout::kControlwordTarget, {0x001F, 10000, 0, 0});
  EXPECT_EQ(can::to_cansend(frame), "201#1F0010270000");
  const auto back = decode_rpdo1(RpdoLayout::kControlwordTarget, frame.payload());
  ASSERT_TRUE(back);
  EXPECT_EQ(back->target_position, 10000);
}

TEST(ProcessData, Rpdo1ManualDefaultIsD39AndD41) {
  EXPECT_EQ(can::to_cansend(encode_rpdo1(1, RpdoLayout::kManualDefault, {0x001F, 0, 0, 1})), "201#1F000000000001");
  EXPECT_EQ(can::to_cansend(encode_rpdo1(1, RpdoLayout::kManualDefault, {0x000F, 0, -60, 3})), "201#0F00C4FFFFFF03");
}

TEST(ProcessData, TpdosDecodeD43AndD44) {
  const auto tpdo1 = decode_tpdo1(std::vector<std::uint8_t>{0x27, 0xA4, 0x04, 0x00, 0x00, 0x00, 0x06});
  ASSERT_TRUE(tpdo1);
  EXPECT_EQ(tpdo1->statusword, 0xA427);
  EXPECT_EQ(tpdo1->digital_inputs, 4U);
  EXPECT_EQ(tpdo1->mode_display, 6);
  const auto tpdo2 = decode_tpdo2(std::vector<std::uint8_t>{0x80, 0xF3, 0xFF, 0xFF, 0x3C, 0, 0, 0});
  ASSERT_TRUE(tpdo2);
  EXPECT_EQ(tpdo2->position, -3200);
  EXPECT_EQ(tpdo2->velocity_rpm, 60);
  EXPECT_FALSE(decode_tpdo1(std::vector<std::uint8_t>{0x27, 0xA4}));  // short PDOs are not processed
}

TEST(ProcessData, InputsFollowTheManualsDefaultAssignment) {
  EXPECT_EQ(inputs_from_60fd(0b010), 0b001);  // positive limit = IN1
  EXPECT_EQ(inputs_from_60fd(0b100), 0b010);  // origin = IN2
  EXPECT_EQ(inputs_from_60fd(0b001), 0b100);  // negative limit = IN3
}

}  // namespace
}  // namespace motion::uc57_driver
