// UC57 unit conversions and quantization against the manual's worked examples (§4.2.4-§4.2.6) and
// derived values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>

#include "motion/cia402/uc57_od.hpp"
#include "motion/cia402/uc57_units.hpp"

namespace motion::cia402::uc57 {
namespace {

const OdEntry& object(std::uint16_t index, std::uint8_t subindex = 0) { return *find_entry(index, subindex); }

constexpr std::uint32_t kPpr = kDefaultPulsesPerRevolution;  // 10000, 2006h default 13

TEST(Uc57Units, MicrosteppingTable) {
  EXPECT_EQ(pulses_per_revolution(kDefaultSubdivisionCode), 10000U);  // §5.1 default 13
  EXPECT_EQ(pulses_per_revolution(4), 3200U);                         // D-57
  EXPECT_EQ(pulses_per_revolution(0), 200U);
  EXPECT_EQ(pulses_per_revolution(7), 25600U);
  EXPECT_EQ(pulses_per_revolution(8), 1000U);
  EXPECT_EQ(pulses_per_revolution(15), 40000U);
  EXPECT_EQ(pulses_per_revolution(16), std::nullopt);
  EXPECT_EQ(subdivision_code(3200), 4);
  EXPECT_EQ(subdivision_code(256), std::nullopt);  // C-14: no "1-256 subdivisions"
  for (std::uint16_t code = 0; code < 16; ++code) EXPECT_EQ(subdivision_code(*pulses_per_revolution(code)), code);
  EXPECT_EQ(object(index::kMicrostepping).max + 1, static_cast<std::int64_t>(kPulsesPerRevolutionByCode.size()));
}

TEST(Uc57Units, SetupSubdivisionRule) {
  using Status = SetupSubdivision::Status;
  EXPECT_EQ(setup_subdivision(std::nullopt, std::nullopt).status, Status::kNotSet);
  const auto from_micro_steps = setup_subdivision(std::nullopt, 16);  // 200 x 16 = 3200 pulses/rev
  EXPECT_EQ(from_micro_steps.status, Status::kCode);
  EXPECT_EQ(from_micro_steps.code, 4);
  EXPECT_EQ(from_micro_steps.pulses, 3200);
  EXPECT_TRUE(from_micro_steps.from_micro_steps);
  const auto pulses_win = setup_subdivision(1000, 16);  // pulses_per_revolution wins over micro_steps
  EXPECT_EQ(pulses_win.status, Status::kCode);
  EXPECT_EQ(pulses_win.code, 8);
  EXPECT_FALSE(pulses_win.from_micro_steps);
  EXPECT_EQ(setup_subdivision(std::nullopt, 256).status, Status::kNotInTable);  // C-14: 51200 is no 2006h code
  EXPECT_EQ(setup_subdivision(0, std::nullopt).status, Status::kOutOfRange);
  EXPECT_EQ(setup_subdivision(std::int64_t{1} << 32, std::nullopt).status, Status::kOutOfRange);
}

TEST(Uc57Units, PositionAndSpeed) {
  EXPECT_DOUBLE_EQ(pulses_to_revolutions(5000, kPpr),
                   0.5);  // 2006h default 10000 pulses/rev (manual §5.1): 5000 = half a revolution
  EXPECT_DOUBLE_EQ(rpm_to_pulses_per_second(60, kPpr),
                   10000.0);  // derived from §5.1/§5.2 units: 60 RPM = 10000 pulses/s
  EXPECT_DOUBLE_EQ(pulses_per_second_to_rpm(10000.0, kPpr), 60.0);
  EXPECT_DOUBLE_EQ(rpm_to_pulses_per_second(120, 3200), 6400.0);
  EXPECT_DOUBLE_EQ(rpm_to_pulses_per_second(-60, kPpr), -10000.0);  // D-10: 60FFh = -60 reverses
}

TEST(Uc57Units, RunCurrent) {
  EXPECT_DOUBLE_EQ(run_current_amperes_rms(15), 1.5);  // 2005h default
  EXPECT_DOUBLE_EQ(run_current_amperes_rms(1), 0.1);
  EXPECT_DOUBLE_EQ(run_current_amperes_rms(25), 2.5);
}

// Manual §4.2.4 example (P-03..P-06): ramps 100 ("100 ms"), 60 RPM, start speed 10 RPM (200Eh
// default), 5000 pulses, 10000 pulses/rev.
TEST(Uc57Units, RampSettingUnderBothReadings) {
  const double start = rpm_to_pulses_per_second(10, kPpr);   // 1666.67 pulses/s
  const double cruise = rpm_to_pulses_per_second(60, kPpr);  // 10000 pulses/s
  EXPECT_NEAR(ramp_acceleration(RampUnit::kMilliseconds, 100, cruise - start, kPpr), 83333.333, 1e-3);
  EXPECT_DOUBLE_EQ(ramp_acceleration(RampUnit::kRevolutionsPerSecondSquared, 100, cruise - start, kPpr), 1.0e6);
  EXPECT_TRUE(std::isinf(ramp_acceleration(RampUnit::kMilliseconds, 100, 0.0, kPpr)));
}

TEST(Uc57Units, TheoreticalTotalPulseCountOfTheManualExample) {
  const double start = rpm_to_pulses_per_second(10, kPpr);
  const double cruise = rpm_to_pulses_per_second(60, kPpr);
  // ms reading: each ramp covers (v0 + vmax)/2 * 0.1 s = 583.33 pulses.
  const double a_ms = ramp_acceleration(RampUnit::kMilliseconds, 100, cruise - start, kPpr);
  EXPECT_NEAR(full_speed_move_pulses(start, cruise, a_ms, a_ms), 1166.667, 1e-3);
  // rev/s^2 reading: (vmax^2 - v0^2) / (2 * 1e6) per ramp = 48.61 pulses.
  const double a_rev = ramp_acceleration(RampUnit::kRevolutionsPerSecondSquared, 100, 0, kPpr);
  EXPECT_NEAR(full_speed_move_pulses(start, cruise, a_rev, a_rev), 97.222, 1e-3);
  // Either way the example's 5000 pulses reach the set maximum speed.
  EXPECT_LT(full_speed_move_pulses(start, cruise, a_ms, a_ms), 5000.0);
}

TEST(Uc57Quantize, SpeedToRpm) {
  const OdEntry& profile_velocity = object(index::kProfileVelocity);
  auto q = quantize_speed(profile_velocity, 10000.0, kPpr);  // P-05: 60 RPM exactly
  EXPECT_EQ(q.native, 60);
  EXPECT_DOUBLE_EQ(q.realized, 10000.0);
  EXPECT_FALSE(q.clamped);

  q = quantize_speed(profile_velocity, 10100.0, kPpr);  // 60.6 RPM
  EXPECT_EQ(q.native, 61);
  EXPECT_NEAR(q.realized, 10166.667, 1e-3);
  q = quantize_speed(profile_velocity, 10100.0, kPpr, Rounding::kNotAbove);
  EXPECT_EQ(q.native, 60);
  EXPECT_DOUBLE_EQ(q.realized, 10000.0);

  q = quantize_speed(profile_velocity, 20000.0, kPpr);  // D-03: 120 RPM
  EXPECT_EQ(q.native, 120);

  q = quantize_speed(profile_velocity, 100.0, kPpr);  // 0.6 RPM < 5 RPM minimum
  EXPECT_EQ(q.native, 5);
  EXPECT_TRUE(q.clamped);
  q = quantize_speed(profile_velocity, 1e9, kPpr);
  EXPECT_EQ(q.native, 1000);
  EXPECT_TRUE(q.clamped);
}

TEST(Uc57Quantize, SignedTargetVelocity) {
  const OdEntry& target_velocity = object(index::kTargetVelocity);
  auto q = quantize_speed(target_velocity, -10000.0, kPpr);  // D-10: -60 RPM
  EXPECT_EQ(q.native, -60);
  EXPECT_DOUBLE_EQ(q.realized, -10000.0);
  q = quantize_speed(target_velocity, -10100.0, kPpr, Rounding::kNotAbove);  // magnitude not above
  EXPECT_EQ(q.native, -60);
  q = quantize_speed(target_velocity, 0.0, kPpr);
  EXPECT_EQ(q.native, 0);
  EXPECT_FALSE(q.clamped);
}

TEST(Uc57Quantize, RampAsMilliseconds) {
  const OdEntry& acceleration = object(index::kProfileAcceleration);
  const double change = rpm_to_pulses_per_second(60, kPpr) - rpm_to_pulses_per_second(10, kPpr);
  auto q = quantize_ramp(acceleration, 83333.3333333, change, kPpr);  // the manual's 100 ms
  EXPECT_EQ(q.native, 100);
  EXPECT_NEAR(q.realized, 83333.333, 1e-3);

  q = quantize_ramp(acceleration, 80000.0, change, kPpr);  // 104.17 ms
  EXPECT_EQ(q.native, 104);
  EXPECT_GT(q.realized, 80000.0);
  q = quantize_ramp(acceleration, 80000.0, change, kPpr, RampUnit::kMilliseconds, Rounding::kNotAbove);
  EXPECT_EQ(q.native, 105);
  EXPECT_LE(q.realized, 80000.0);
  EXPECT_NEAR(q.realized, change / 0.105, 1e-6);

  q = quantize_ramp(acceleration, 1e12, change, kPpr);  // faster than 1 ms
  EXPECT_EQ(q.native, 1);
  EXPECT_TRUE(q.clamped);
  q = quantize_ramp(acceleration, 1.0, change, kPpr);  // slower than 2000 ms
  EXPECT_EQ(q.native, 2000);
  EXPECT_TRUE(q.clamped);
  EXPECT_NEAR(q.realized, change / 2.0, 1e-9);

  q = quantize_ramp(acceleration, 5000.0, 0.0, kPpr);  // cruise at the start speed: no ramp
  EXPECT_EQ(q.native, 1);
  EXPECT_TRUE(std::isinf(q.realized));
}

TEST(Uc57Quantize, RampAsRevolutionsPerSecondSquared) {
  const OdEntry& deceleration = object(index::kProfileDeceleration);
  constexpr auto kRev = RampUnit::kRevolutionsPerSecondSquared;
  auto q = quantize_ramp(deceleration, 1.0e6, 0.0, kPpr, kRev);
  EXPECT_EQ(q.native, 100);
  EXPECT_DOUBLE_EQ(q.realized, 1.0e6);
  q = quantize_ramp(deceleration, 1.0551e6, 0.0, kPpr, kRev);  // 105.51 rev/s^2
  EXPECT_EQ(q.native, 106);
  q = quantize_ramp(deceleration, 1.0551e6, 0.0, kPpr, kRev, Rounding::kNotAbove);
  EXPECT_EQ(q.native, 105);
  EXPECT_DOUBLE_EQ(q.realized, 1.05e6);
  q = quantize_ramp(deceleration, 1000.0, 0.0, kPpr, kRev);  // 0.1 rev/s^2 < 1
  EXPECT_EQ(q.native, 1);
  EXPECT_TRUE(q.clamped);
}

TEST(Uc57Quantize, Position) {
  auto q = quantize_position(object(index::kTargetPosition), 5000.4);  // P-06
  EXPECT_EQ(q.native, 5000);
  EXPECT_DOUBLE_EQ(q.realized, 5000.0);
  q = quantize_position(object(index::kTargetPosition), -3200.0);  // D-02
  EXPECT_EQ(q.native, -3200);
  q = quantize_position(object(index::kTargetPosition), 2e6);
  EXPECT_EQ(q.native, 1000000);
  EXPECT_TRUE(q.clamped);
  q = quantize_position(object(index::kHomeOffset), -1.5e6);  // C-05: +-1000000
  EXPECT_EQ(q.native, -1000000);
  EXPECT_TRUE(q.clamped);
}

}  // namespace
}  // namespace motion::cia402::uc57
