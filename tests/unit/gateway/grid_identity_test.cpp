// Property: a gateway_command2_t's grid integer n reaches the drive as n. The gateway turns n into
// n * step of the axis's drive model (grid_command.hpp); each family's stack converts that value
// to its native integer with the codec functions below, called as the stack calls them
// (uim342_stack_commands.cpp load_move/ramp, uim242_stack_commands.cpp, uc57_stack_start.cpp
// start_arm, adam_stack_commands.cpp arm). Over random n across each model's range and both ends,
// the native integer must be n exactly: the stacks never quantize again.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "motion/adam/units.hpp"
#include "motion/cia402/uc57_od.hpp"
#include "motion/cia402/uc57_units.hpp"
#include "motion/config/config.hpp"
#include "motion/drive_model/drive_model.hpp"
#include "motion/gateway/grid_command.hpp"
#include "motion/uim342/parameters.hpp"

namespace motion::gateway {
namespace {

using motionlcm::drive_model_t;

const char* kConfig = R"(
buses:
  - {name: can0, transport: simcan:can0}
  - {name: rs485, transport: simserial:rs485, baud: 115200}
  - {name: rs232, transport: simserial:rs232, baud: 57600}
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5, setup: {acceleration_unit: rate}}
  - {name: zd, family: uim342, bus: can0, node_id: 7, setup: {acceleration_unit: time, cut_in_speed: 300}}
  - {name: bd, family: uc57, bus: can0, node_id: 2}
  - {name: dd, family: adam-modbus, bus: rs485, node_id: 2, setup: {pulses_per_revolution: 1000, subdivision: 16}}
  - {name: ud, family: uim242, bus: rs232, node_id: 5}
axes:
  - {name: x, drive: xd, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 50, acceleration: 400}}
  - {name: z, drive: zd, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 50, acceleration: 400}}
  - {name: b, drive: bd, steps_per_unit: 27.777777777777779, limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}}
  - {name: d, drive: dd, steps_per_unit: 100, limits: {min: -100, max: 100, velocity: 40, acceleration: 200}}
  - {name: u, drive: ud, steps_per_unit: 160, limits: {min: -100, max: 100, velocity: 40, acceleration: 200}}
)";

const config::Config& lab() {
  static const config::Config config = [] {
    auto loaded = config::load_string(kConfig);
    if (!loaded.ok()) throw std::runtime_error(loaded.error_text());
    return *loaded.config;
  }();
  return config;
}

drive_model_t model_of(const std::string& axis, const DriveFacts& facts = {}) {
  auto built = drive_model::build(lab(), *lab().find_axis(axis), facts);
  if (const auto* why = std::get_if<std::string>(&built)) throw std::runtime_error(*why);
  return std::get<drive_model_t>(built);
}

// Both ends, their neighbours, and `count` random values of [min, max].
std::vector<std::int64_t> samples(std::int64_t min, std::int64_t max, int count = 3000) {
  std::vector<std::int64_t> out{min, max};
  if (max > min) out.insert(out.end(), {min + 1, max - 1});
  std::mt19937_64 random(0x5eed + static_cast<std::uint64_t>(max));
  std::uniform_int_distribution<std::int64_t> pick(min, max);
  for (int i = 0; i < count; ++i) out.push_back(pick(random));
  return out;
}

// The stack's native velocity and ramp integers for a value in counts/s (counts/s^2 for a ramp,
// at the stack's realized velocity `speed`), as each stack computes them.
struct StackConversion {
  std::function<std::int64_t(double velocity)> velocity;
  std::function<std::int64_t(double acceleration, double velocity)> ramp;
};

// Every n of the model's grids (velocity; ramps at random velocities that have a ramp) comes out
// of the stack as n. Returns how many values were checked.
int check_identity(const drive_model_t& m, const StackConversion& stack) {
  int checked = 0;
  for (const std::int64_t n : samples(m.velocity_min, m.velocity_max)) {
    EXPECT_EQ(stack.velocity(grid_velocity(m, n)), n) << m.drive << " velocity n " << n;
    ++checked;
  }
  const auto speeds = samples(m.velocity_min, m.velocity_max, 97);
  std::size_t s = 0;
  for (const std::int64_t n : samples(m.acceleration_min, m.acceleration_max)) {
    std::int64_t v = speeds[s++ % speeds.size()];
    // A ramp-time grid ramps only above ramp_from.
    while (m.acceleration_kind == drive_model_t::ACCEL_RAMP_TIME && grid_velocity(m, v) <= m.ramp_from)
      v = std::min(m.velocity_max, v * 2 + 1);
    const double velocity = grid_velocity(m, v);
    EXPECT_EQ(stack.ramp(grid_acceleration(m, n, velocity), velocity), n)
        << m.drive << " ramp n " << n << " at velocity n " << v;
    ++checked;
  }
  return checked;
}

TEST(GridIdentity, Uim342RateAndTimeModes) {
  for (const char* axis : {"x", "z"}) {
    const drive_model_t m = model_of(axis);
    const bool time = m.acceleration_kind == drive_model_t::ACCEL_RAMP_TIME;
    const auto unit = time ? uim342::AccelerationUnit::kMilliseconds : uim342::AccelerationUnit::kPulsesPerS2;
    const double cut_in = time ? 300.0 : 0.0;
    StackConversion stack{[](double v) { return std::int64_t{uim342::speed_to_pps(std::abs(v)).value()}; },
                          [&](double a, double v) {
                            const auto speed = uim342::speed_to_pps(std::abs(v)).value();
                            return std::int64_t{uim342::acceleration_to_wire(a, unit, speed, cut_in).value()};
                          }};
    EXPECT_GT(check_identity(m, stack), 6000) << axis;
  }
}

TEST(GridIdentity, Uim242) {
  const drive_model_t m = model_of("u");
  // SPD and MAC/MDE: the nearest integer (uim242_stack_commands.cpp, clamp_rate).
  StackConversion stack{[](double v) { return std::llround(std::abs(v)); },
                        [](double a, double) { return std::llround(std::abs(a)); }};
  EXPECT_GT(check_identity(m, stack), 6000);
}

// The UC57 at the resolution its gateway read back (3200, where the configuration implies the
// factory 10000) and the start speed read back, as the stack holds them (uc57_stack_params.cpp).
TEST(GridIdentity, Uc57AtTheResolutionReadBack) {
  namespace od = cia402::uc57;
  for (const std::uint32_t ppr : {3200U, 10000U, 25600U}) {
    const double start_speed = od::rpm_to_pulses_per_second(10.0, ppr);  // the stack's 200Eh, pulses/s
    DriveFacts facts;
    facts.counts_per_revolution = ppr;
    facts.start_speed_rpm = start_speed * 60.0 / ppr;
    const drive_model_t m = model_of("b", facts);
    ASSERT_EQ(m.counts_per_revolution, static_cast<std::int32_t>(ppr));
    const auto* velocity = od::find_entry(od::index::kProfileVelocity, 0);
    const auto* acceleration = od::find_entry(od::index::kProfileAcceleration, 0);
    StackConversion stack{[&](double v) { return od::quantize_speed(*velocity, v, ppr).native; },
                          [&](double a, double v) {
                            const auto speed = od::quantize_speed(*velocity, v, ppr);
                            const double change = std::max(0.0, speed.realized - start_speed);
                            return od::quantize_ramp(*acceleration, a, change, ppr).native;
                          }};
    EXPECT_GT(check_identity(m, stack), 6000) << ppr;
  }
}

TEST(GridIdentity, Adam) {
  const drive_model_t m = model_of("d");
  const auto ppr = static_cast<std::uint32_t>(m.counts_per_revolution);
  // Whole rpm (0x009A/0x00D8) and ramp times from 0 to that speed (0x0098/0x0099).
  StackConversion stack{
      [&](double v) { return std::int64_t{std::lround(adam::pps_to_rpm(v, ppr))}; },
      [&](double a, double v) {
        const double rpm = static_cast<double>(std::lround(adam::pps_to_rpm(v, ppr)));
        return std::int64_t{adam::ramp_time_ms(0, rpm, std::abs(adam::pps_to_rpm(a, ppr))).value().value};
      }};
  EXPECT_GT(check_identity(m, stack), 6000);
}

// A jog slower than a ramp-time grid's ramp_from has no ramp (the drive jumps to the speed): the
// stack gets 0, "the drive's own ramp", never a steep rate the gateway's limits would refuse
// (random lab seed 11: a UC57 jog below its start speed failed with code 3).
TEST(GridCommand, AJogAtOrBelowTheRampStartSpeedHasNoRamp) {
  namespace od = cia402::uc57;
  DriveFacts facts;
  facts.counts_per_revolution = 10000;
  facts.start_speed_rpm = 10.0;  // 1666.7 counts/s
  const drive_model_t m = model_of("b", facts);
  ASSERT_EQ(m.acceleration_kind, std::int8_t{drive_model_t::ACCEL_RAMP_TIME});
  motionlcm::gateway_command2_t jog{};
  jog.bus = "can0";
  jog.kind = motionlcm::gateway_command_t::JOG;
  jog.axes.resize(1);
  jog.axes[0].axis = "b";
  jog.axes[0].model_utime = m.utime;
  jog.axes[0].velocity = -5;  // 5 rpm, below the start speed
  jog.axes[0].acceleration = 0;
  jog.axes[0].deceleration = m.acceleration_min;
  jog.num_axes = 1;
  const auto out = from_grid(jog, [&](const std::string&) { return &m; });
  ASSERT_TRUE(std::holds_alternative<motionlcm::gateway_command_t>(out)) << std::get<GridRefusal>(out).reason;
  const auto& a = std::get<motionlcm::gateway_command_t>(out).axes.at(0);
  EXPECT_EQ(a.velocity, -5 * m.velocity_step);
  EXPECT_EQ(a.acceleration, 0.0);
  EXPECT_EQ(a.deceleration, 0.0);
  // Above it, the ramp's slope.
  jog.axes[0].velocity = -600;
  const auto above = std::get<motionlcm::gateway_command_t>(from_grid(jog, [&](const std::string&) { return &m; }));
  EXPECT_DOUBLE_EQ(above.axes[0].deceleration, (600 * m.velocity_step - m.ramp_from) /
                                                   (static_cast<double>(m.acceleration_min) * m.acceleration_step));
}

}  // namespace
}  // namespace motion::gateway
