// UC57 homing methods as data, the homing result from the statusword, and homing parameters.
#include <gtest/gtest.h>

#include <cstdint>
#include <set>

#include "motion/cia402/uc57_homing.hpp"
#include "motion/cia402/uc57_od.hpp"
#include "motion/cia402/words.hpp"

namespace motion::cia402::uc57 {
namespace {

TEST(Uc57Homing, SupportedMethods) {
  std::set<int> values;
  for (const HomingMethodInfo& info : homing_methods()) values.insert(static_cast<int>(info.method));
  EXPECT_EQ(values, (std::set<int>{17, 18, 24, 29, 41, 42}));  // §4.2.6 / §5.2 6098h list
  EXPECT_EQ(find_homing_method(0), nullptr);                   // 6098h default: no method
  EXPECT_EQ(find_homing_method(100), nullptr);                 // the §4.2.6 example's 0x64 (C-07)
  const OdEntry& method_object = *find_entry(index::kHomingMethod, 0);
  EXPECT_EQ(find_homing_method(static_cast<std::uint8_t>(method_object.default_value)), nullptr);
}

TEST(Uc57Homing, MethodProcedures) {
  const auto* negative_limit = find_homing_method(17);
  ASSERT_NE(negative_limit, nullptr);
  EXPECT_EQ(negative_limit->search_direction, Direction::kNegative);
  EXPECT_EQ(negative_limit->home_signal, HomeSignal::kNegativeLimit);
  EXPECT_TRUE(negative_limit->backs_off_and_locates_slowly);

  const auto* positive_limit = find_homing_method(18);
  ASSERT_NE(positive_limit, nullptr);
  EXPECT_EQ(positive_limit->search_direction, Direction::kPositive);
  EXPECT_EQ(positive_limit->home_signal, HomeSignal::kPositiveLimit);

  const auto* forward = find_homing_method(24);  // the example's "forward limit + origin" (D-50)
  ASSERT_NE(forward, nullptr);
  EXPECT_EQ(forward->search_direction, Direction::kPositive);
  EXPECT_EQ(forward->home_signal, HomeSignal::kOrigin);
  EXPECT_EQ(forward->on_limit, LimitReaction::kReverse);
  EXPECT_TRUE(forward->backs_off_and_locates_slowly);

  const auto* reverse = find_homing_method(29);  // C-17: mirrors 24
  ASSERT_NE(reverse, nullptr);
  EXPECT_EQ(reverse->search_direction, Direction::kNegative);
  EXPECT_EQ(reverse->locate_direction, Direction::kNegative);
  EXPECT_EQ(reverse->on_limit, LimitReaction::kReverse);
  EXPECT_TRUE(reverse->backs_off_and_locates_slowly);

  const auto* negative_immediate = find_homing_method(41);
  ASSERT_NE(negative_immediate, nullptr);
  EXPECT_EQ(negative_immediate->search_direction, Direction::kNegative);
  EXPECT_FALSE(negative_immediate->backs_off_and_locates_slowly);
  EXPECT_EQ(negative_immediate->on_limit, LimitReaction::kStopFailed);
  EXPECT_FALSE(negative_immediate->cia402_standard_number);

  const auto* positive_immediate = find_homing_method(42);  // C-17: stops at the positive limit
  ASSERT_NE(positive_immediate, nullptr);
  EXPECT_EQ(positive_immediate->search_direction, Direction::kPositive);
  EXPECT_EQ(positive_immediate->on_limit, LimitReaction::kStopFailed);
}

TEST(Uc57Homing, ResultFromStatusword) {
  EXPECT_EQ(homing_result(0x3027), HomingResult::kInProgress);  // running, bit 10 = 0
  EXPECT_EQ(homing_result(0xA527), HomingResult::kSucceeded);   // bit 8 + bit 10 (§4.2.6)
  EXPECT_EQ(homing_result(0x3427), HomingResult::kSucceeded);   // bit 12 + bit 10 (§7 MC_HOME)
  // C-08: bit 10 + bit 13 is "motor enabled", not a failure; without bit 8/12 home was not found.
  EXPECT_EQ(homing_result(0x2427), HomingResult::kStoppedWithoutHome);
  EXPECT_EQ(homing_result(mask(StatusBit::kHomingDone)), HomingResult::kInProgress);
}

TEST(Uc57Homing, CorrectedManualExampleParameters) {
  // D-50: method 24, 120 RPM search, 60 RPM locate, ramp 100 (ms), offset 0, 10000 pulses/rev.
  HomingRequest request;
  request.method = HomingMethod::kHomeSwitchPositive;
  request.search_speed = 20000.0;
  request.locate_speed = 10000.0;
  request.acceleration = 200000.0;  // 20000 pulses/s reached in 100 ms from standstill
  request.offset = 0.0;
  const HomingSettings settings = quantize_homing(request, kDefaultPulsesPerRevolution);
  EXPECT_EQ(settings.method, 24);
  EXPECT_EQ(settings.search_speed.native, 120);
  EXPECT_EQ(settings.locate_speed.native, 60);
  EXPECT_EQ(settings.acceleration.native, 100);
  EXPECT_DOUBLE_EQ(settings.acceleration.realized, 200000.0);
  EXPECT_EQ(settings.offset.native, 0);
  EXPECT_FALSE(settings.search_speed.clamped || settings.locate_speed.clamped || settings.acceleration.clamped);
}

TEST(Uc57Homing, ParametersAreClampedToTheHomingRanges) {
  HomingRequest request;
  request.search_speed = 1e9;  // > 1000 RPM
  request.locate_speed = 1.0;  // < 1 RPM
  request.acceleration = 1e3;
  request.offset = 2e6;  // > 1000000 pulses
  const HomingSettings settings = quantize_homing(request, kDefaultPulsesPerRevolution);
  EXPECT_EQ(settings.search_speed.native, 1000);
  EXPECT_TRUE(settings.search_speed.clamped);
  EXPECT_EQ(settings.locate_speed.native, 1);
  EXPECT_TRUE(settings.locate_speed.clamped);
  EXPECT_EQ(settings.acceleration.native, 2000);
  EXPECT_EQ(settings.offset.native, 1000000);
}

}  // namespace
}  // namespace motion::cia402::uc57
