// Speed, ramp and position conversions with quantization and range checks.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "motion/adam/units.hpp"

namespace motion::adam {
namespace {

TEST(AdamUnits, RpmAndPulsesPerSecond) {
  EXPECT_DOUBLE_EQ(rpm_to_pps(300.0, 4000), 20000.0);  // default speed at default subdivision
  EXPECT_DOUBLE_EQ(pps_to_rpm(20000.0, 4000), 300.0);
  EXPECT_DOUBLE_EQ(rpm_to_pps(1.0, 200), 200.0 / 60.0);
}

TEST(AdamUnits, SpeedQuantization) {
  struct Case {
    const char* what;
    Result<Quantized<std::int32_t>> result;
    std::int32_t value;
    double realized;
  };
  const Case ok[] = {
      {"300 rpm", target_speed(300.0), 30000, 300.0},
      {"1234.56 rpm", target_speed(1234.56), 123456, 1234.56},
      {"0.004 rpm rounds to 0", target_speed(0.004), 0, 0.0},
      {"0.005 rpm rounds away", target_speed(0.005), 1, 0.01},
      {"-300 rpm", target_speed(-300.0), -30000, -300.0},
      {"max", target_speed(9999.99), 999999, 9999.99},
      // 1000 pulses/s at 4000 pulses/rev = 15 rpm exactly.
      {"1000 pps", target_speed_from_pps(1000.0, 4000), 1500, 1000.0},
      // 1001 pps = 15.015 rpm → 1502 (15.02 rpm) → 1001.333… pps realized.
      {"1001 pps", target_speed_from_pps(1001.0, 4000), 1502, 15.02 * 4000 / 60},
  };
  for (const auto& c : ok) {
    ASSERT_TRUE(c.result.ok()) << c.what;
    EXPECT_EQ(c.result.value().value, c.value) << c.what;
    EXPECT_NEAR(c.result.value().realized, c.realized, 1e-9) << c.what;
  }
  EXPECT_EQ(target_speed(10000.0).error(), AdamErrc::kValueOutOfRange);
  EXPECT_EQ(target_speed(std::nan("")).error(), AdamErrc::kNonFinite);
  EXPECT_EQ(target_speed_from_pps(1000.0, 100).error(), AdamErrc::kInvalidSubdivision);
}

TEST(AdamUnits, WholeRpmRegisters) {
  EXPECT_EQ(working_speed(600.4).value(), (Quantized<std::uint16_t>{600, 600.0}));
  EXPECT_EQ(working_speed(1000.0).value().value, 1000);
  EXPECT_EQ(working_speed(1000.6).error(), AdamErrc::kValueOutOfRange);
  EXPECT_EQ(working_speed(-1.0).error(), AdamErrc::kValueOutOfRange);
  EXPECT_EQ(start_speed(300.0).value().value, 300);
  EXPECT_EQ(start_speed(301.0).error(), AdamErrc::kValueOutOfRange);
  EXPECT_EQ(stop_speed(1000.0).value().value, 1000);
  EXPECT_EQ(jog_speed(511.0).value().value, 511);
  EXPECT_EQ(jog_speed(512.0).error(), AdamErrc::kValueOutOfRange);
}

TEST(AdamUnits, RampTimes) {
  // 0 → 300 rpm at 1000 rpm/s: 300 ms, exact.
  const auto exact = ramp_time_ms(0.0, 300.0, 1000.0);
  ASSERT_TRUE(exact.ok());
  EXPECT_EQ(exact.value().value, 300);
  EXPECT_DOUBLE_EQ(exact.value().realized, 1000.0);
  // Default start speed 50 → 300 rpm at 700 rpm/s: 357.14 ms → 357 ms → 700.28 rpm/s.
  const auto rounded = ramp_time_ms(50.0, 300.0, 700.0);
  ASSERT_TRUE(rounded.ok());
  EXPECT_EQ(rounded.value().value, 357);
  EXPECT_NEAR(rounded.value().realized, 250.0 / 0.357, 1e-9);
  // Deceleration is symmetric in the speeds.
  EXPECT_EQ(ramp_time_ms(300.0, 50.0, 700.0).value().value, 357);
  EXPECT_EQ(ramp_time_ms(100.0, 100.0, 5.0).value(), (Quantized<std::uint16_t>{0, 0.0}));
  EXPECT_EQ(ramp_time_ms(0.0, 1000.0, 10.0).error(), AdamErrc::kValueOutOfRange);  // 100 s > 65.535 s
  EXPECT_EQ(ramp_time_ms(0.0, 300.0, 0.0).error(), AdamErrc::kValueOutOfRange);
  EXPECT_EQ(ramp_time_ms(0.0, std::numeric_limits<double>::infinity(), 1.0).error(), AdamErrc::kNonFinite);
  EXPECT_DOUBLE_EQ(ramp_rate_rpm_per_s(0.0, 300.0, 120), 2500.0);  // defaults with start speed 0
}

TEST(AdamUnits, PositionsAndSubdivision) {
  const auto one_rev = pulses_from_revolutions(1.0, 4000);
  ASSERT_TRUE(one_rev.ok());
  EXPECT_EQ(one_rev.value().value, 4000);
  const auto quarter_step = pulses_from_revolutions(-0.00010, 4000);  // -0.4 pulse → 0
  EXPECT_EQ(quarter_step.value().value, 0);
  EXPECT_EQ(pulses_from_revolutions(-25.0, 4000).value().value, -100000);
  EXPECT_EQ(pulses_from_revolutions(1e6, 4000).error(), AdamErrc::kValueOutOfRange);
  EXPECT_EQ(check_subdivision(199).error(), AdamErrc::kInvalidSubdivision);
  EXPECT_EQ(check_subdivision(1'000'001).error(), AdamErrc::kInvalidSubdivision);
  EXPECT_EQ(check_subdivision(200).value(), 200U);
  const std::error_code ec = AdamErrc::kInvalidSubdivision;
  EXPECT_STREQ(ec.category().name(), "adam");
}

}  // namespace
}  // namespace motion::adam
