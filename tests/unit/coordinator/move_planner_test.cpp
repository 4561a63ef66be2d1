#include "motion/coordinator/move_planner.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "motion/adam/registers.hpp"
#include "motion/adam/units.hpp"
#include "motion/adam_driver/adam_stack.hpp"
#include "motion/cia402/uc57_od.hpp"
#include "motion/cia402/uc57_units.hpp"
#include "motion/drive_model/drive_model.hpp"
#include "motion/uim242/instruction.hpp"
#include "motion/uim342/parameters.hpp"

namespace motion::coordinator {
namespace {

using planner::DriveMotion;
using planner::DriveQuantizer;
using planner::DriveSetting;

const char* kConfig = R"(
buses:
  - {name: can0, transport: simcan:can0}
  - {name: rs485, transport: simserial:rs485, baud: 115200}
  - {name: rs232, transport: simserial:rs232, baud: 57600}
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5, setup: {acceleration_unit: rate}}
  - {name: yd, family: uim342, bus: can0, node_id: 6, setup: {acceleration_unit: time}}
  - {name: zd, family: uim342, bus: can0, node_id: 7, setup: {acceleration_unit: time, cut_in_speed: 300}}
  - {name: ad, family: uc57, bus: can0, node_id: 1, setup: {micro_steps: 16}}
  - {name: bd, family: uc57, bus: can0, node_id: 2}
  - {name: cd, family: adam-modbus, bus: rs485, node_id: 1, setup: {subdivision: 16}}
  - {name: dd, family: adam-modbus, bus: rs485, node_id: 2, setup: {pulses_per_revolution: 1000, subdivision: 16}}
  - {name: ed, family: adam-modbus, bus: rs485, node_id: 3}
  - {name: ud, family: uim242, bus: rs232, node_id: 5}
axes:
  - {name: x, drive: xd, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 50, acceleration: 400}}
  - {name: y, drive: yd, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 50, acceleration: 400}}
  - {name: z, drive: zd, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 50, acceleration: 400}}
  - {name: a, drive: ad, steps_per_unit: 8.888888888888889, limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}}
  - {name: b, drive: bd, steps_per_unit: 27.777777777777779, limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}}
  - {name: c, drive: cd, steps_per_unit: 320, limits: {min: -100, max: 100, velocity: 40, acceleration: 200}}
  - {name: d, drive: dd, steps_per_unit: 100, limits: {min: -100, max: 100, velocity: 40, acceleration: 200}}
  - {name: e, drive: ed, steps_per_unit: 400, limits: {min: -100, max: 100, velocity: 40, acceleration: 200}}
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

const config::Drive& drive(const std::string& name) { return *lab().find_drive(name); }

using drive_model::assumed_pulses_per_revolution;
std::uint32_t assumed_pulses_per_revolution(const config::Config&, const config::Drive& d) {
  return assumed_pulses_per_revolution(d);
}

// The model the gateway publishes for `axis` (given what its stack read), as the coordinator gets it.
motionlcm::drive_model_t model_of(const std::string& axis, const gateway::DriveFacts& facts = {}) {
  auto model = drive_model::build(lab(), *lab().find_axis(axis), facts);
  if (auto* why = std::get_if<std::string>(&model)) throw std::runtime_error(*why);
  return std::get<motionlcm::drive_model_t>(model);
}

std::shared_ptr<const DriveQuantizer> quantizer_of_model(const motionlcm::drive_model_t& model) {
  auto q = quantizer_from_model(model);
  if (auto* why = std::get_if<std::string>(&q)) throw std::runtime_error(*why);
  return std::get<std::shared_ptr<const DriveQuantizer>>(q);
}

// The quantizer of drive `name` ("xd": axis "x"), from its gateway's model.
std::shared_ptr<const DriveQuantizer> quantizer(const std::string& name) {
  return quantizer_of_model(model_of(name.substr(0, 1)));
}

// Plan inputs with each axis's quantizer from its model.
std::vector<PlanInput> with_models(std::vector<PlanInput> inputs) {
  for (auto& in : inputs) in.quantizer = quantizer(in.axis + "d");
  return inputs;
}

// Desired motions in counts: slow, medium, fast, and awkward ratios.
std::vector<DriveMotion> desired_motions(double scale) {
  return {{0.37 * scale, 2.1 * scale, 1.3 * scale},
          {1.0 * scale, 8.0 * scale, 8.0 * scale},
          {3.3333 * scale, 11.7 * scale, 29.0 * scale},
          {7.77 * scale, 3.9 * scale, 50.1 * scale}};
}

std::vector<DriveSetting> candidates_of(const DriveQuantizer& q, double scale) {
  std::vector<DriveSetting> out;
  for (const auto& m : desired_motions(scale)) q.candidates(m, 2, out);
  return out;
}

void expect_relative(double actual, double expected, const std::string& what) {
  EXPECT_NEAR(actual, expected, std::abs(expected) * 1e-12) << what;
}

// ---- ADAM: adam_stack ARM_MOVE programs target_speed_from_pps and ramp_time_ms(0, rpm, rate) ----

// What adam_stack.cpp writes for a realized motion (0x00D8, 0x0098, 0x0099) and what it realizes.
struct AdamProgrammed {
  planner::NativeMotion native;
  DriveMotion realized;
};
AdamProgrammed adam_programs(const DriveMotion& m, std::uint32_t ppr) {
  // Whole rpm, as AdamStack::arm_move writes it to 0x009A and 0x00D8.
  const long rpm_whole = std::lround(adam::pps_to_rpm(m.velocity_counts_per_s, ppr));
  const double rpm = static_cast<double>(rpm_whole);
  const auto accel = adam::ramp_time_ms(0, rpm, std::abs(adam::pps_to_rpm(m.acceleration_counts_per_s2, ppr)));
  const auto decel = adam::ramp_time_ms(0, rpm, std::abs(adam::pps_to_rpm(m.deceleration_counts_per_s2, ppr)));
  EXPECT_TRUE(accel && decel);
  return {{rpm_whole, accel.value().value, decel.value().value},
          {adam::rpm_to_pps(rpm, ppr), adam::rpm_to_pps(accel.value().realized, ppr),
           adam::rpm_to_pps(decel.value().realized, ppr)}};
}

TEST(DriveQuantizers, AdamPulsesPerRevolutionFollowTheGatewaysSetupRule) {
  EXPECT_EQ(assumed_pulses_per_revolution(lab(), drive("cd")), 3200u);  // 200 x subdivision 16
  EXPECT_EQ(assumed_pulses_per_revolution(lab(), drive("dd")), 1000u);  // pulses_per_revolution wins
  EXPECT_EQ(assumed_pulses_per_revolution(lab(), drive("ed")), adam::kDefaultSubdivision);  // drive keeps its own
  // The gateway's start-up write of 0x0024 is the same number.
  const auto settings = adam_driver::settings_from_config(lab(), *lab().find_bus("rs485"));
  ASSERT_EQ(settings.drives.size(), 3u);
  for (const auto& d : settings.drives) {
    std::optional<std::uint32_t> written;
    for (const auto& [reg, words] : d.setup_writes) {
      if (reg == adam::address(adam::Reg::kSubdivision)) written = adam::decode32(words.at(0), words.at(1));
    }
    if (d.drive == "ed") {
      EXPECT_FALSE(written) << "no set-up: the drive keeps its subdivision";
    } else {
      ASSERT_TRUE(written) << d.drive;
      EXPECT_EQ(*written, assumed_pulses_per_revolution(lab(), drive(d.drive))) << d.drive;
    }
  }
}

TEST(DriveQuantizers, AdamRealizedValuesAreWhatAdamStackProgramsExactly) {
  for (const std::string name : {"cd", "dd", "ed"}) {
    const std::uint32_t ppr = assumed_pulses_per_revolution(lab(), drive(name));
    const auto q = quantizer(name);
    // 1 rpm is ppr/60 counts/s: around 0.5..400 rpm.
    const auto settings = candidates_of(*q, ppr / 60.0 * 10.0);
    ASSERT_GT(settings.size(), 20u) << name;
    for (const auto& s : settings) {
      const auto programmed = adam_programs(s.realized, ppr);
      const std::string what = name + " v=" + std::to_string(s.realized.velocity_counts_per_s);
      EXPECT_EQ(programmed.native, s.native) << what;
      expect_relative(programmed.realized.velocity_counts_per_s, s.realized.velocity_counts_per_s, what);
      expect_relative(programmed.realized.acceleration_counts_per_s2, s.realized.acceleration_counts_per_s2, what);
      expect_relative(programmed.realized.deceleration_counts_per_s2, s.realized.deceleration_counts_per_s2, what);
    }
  }
}

// ---- UC57: uc57_stack start_arm programs quantize_speed(6081h) and quantize_ramp(6083h/6084h) ----

TEST(DriveQuantizers, Uc57RealizedValuesAreWhatTheStackProgramsExactly) {
  namespace od = cia402::uc57;
  EXPECT_EQ(assumed_pulses_per_revolution(lab(), drive("ad")), 3200u);
  EXPECT_EQ(assumed_pulses_per_revolution(lab(), drive("bd")), od::kDefaultPulsesPerRevolution);
  const auto& velocity = *od::find_entry(od::index::kProfileVelocity, 0);
  const auto& acceleration = *od::find_entry(od::index::kProfileAcceleration, 0);
  const auto& deceleration = *od::find_entry(od::index::kProfileDeceleration, 0);
  const auto start_rpm = static_cast<double>(od::find_entry(od::index::kStartSpeed, 0)->default_value);
  for (const std::string name : {"ad", "bd"}) {
    const std::uint32_t ppr = assumed_pulses_per_revolution(lab(), drive(name));
    const double start_speed = od::rpm_to_pulses_per_second(start_rpm, ppr);
    const auto settings = candidates_of(*quantizer(name), ppr / 60.0 * 30.0);  // ~10..250 rpm
    ASSERT_GT(settings.size(), 20u) << name;
    for (const auto& s : settings) {
      const std::string what = name + " v=" + std::to_string(s.realized.velocity_counts_per_s);
      const auto speed = od::quantize_speed(velocity, s.realized.velocity_counts_per_s, ppr);
      const double change = std::max(0.0, speed.realized - start_speed);
      const auto accel = od::quantize_ramp(acceleration, s.realized.acceleration_counts_per_s2, change, ppr);
      const auto decel = od::quantize_ramp(deceleration, s.realized.deceleration_counts_per_s2, change, ppr);
      EXPECT_FALSE(speed.clamped || accel.clamped || decel.clamped) << what;
      EXPECT_EQ((planner::NativeMotion{speed.native, accel.native, decel.native}), s.native) << what;
      expect_relative(speed.realized, s.realized.velocity_counts_per_s, what);
      expect_relative(accel.realized, s.realized.acceleration_counts_per_s2, what);
      expect_relative(decel.realized, s.realized.deceleration_counts_per_s2, what);
      EXPECT_GT(speed.realized, start_speed) << what << ": no ramp at or below the start speed";
    }
  }
}

// ---- UIM342: speed_to_pps and acceleration_to_wire for the node's IC[4] and cut-in speed ----

TEST(DriveQuantizers, Uim342RealizedValuesAreWhatTheStackProgramsExactly) {
  struct Case {
    std::string drive;
    uim342::AccelerationUnit unit;
    double cut_in;
  };
  for (const auto& c :
       {Case{"xd", uim342::AccelerationUnit::kPulsesPerS2, 0}, Case{"yd", uim342::AccelerationUnit::kMilliseconds, 0},
        Case{"zd", uim342::AccelerationUnit::kMilliseconds, 300}}) {
    const auto settings = candidates_of(*quantizer(c.drive), 4000.0);
    ASSERT_GT(settings.size(), 20u) << c.drive;
    for (const auto& s : settings) {
      const std::string what = c.drive + " v=" + std::to_string(s.realized.velocity_counts_per_s);
      const auto speed = uim342::speed_to_pps(s.realized.velocity_counts_per_s);
      ASSERT_TRUE(speed) << what;
      const auto accel = uim342::acceleration_to_wire(s.realized.acceleration_counts_per_s2, c.unit, *speed, c.cut_in);
      const auto decel = uim342::acceleration_to_wire(s.realized.deceleration_counts_per_s2, c.unit, *speed, c.cut_in);
      ASSERT_TRUE(accel && decel) << what;
      EXPECT_EQ((planner::NativeMotion{*speed, *accel, *decel}), s.native) << what;
      expect_relative(uim342::acceleration_from_wire(*accel, c.unit, *speed, c.cut_in),
                      s.realized.acceleration_counts_per_s2, what);
      expect_relative(uim342::acceleration_from_wire(*decel, c.unit, *speed, c.cut_in),
                      s.realized.deceleration_counts_per_s2, what);
    }
  }
}

TEST(DriveQuantizers, Uim242RealizedValuesAreIntegerSpdMacMdeTheControllerAccepts) {
  const auto settings = candidates_of(*quantizer("ud"), 4000.0);
  ASSERT_GT(settings.size(), 20u);
  for (const auto& s : settings) {
    const std::string what = "v=" + std::to_string(s.realized.velocity_counts_per_s);
    // What uim242_stack writes: SPD v (pulse/s), MAC a, MDE d (pulse/s^2, value mode).
    EXPECT_EQ(s.native.velocity, static_cast<std::int64_t>(s.realized.velocity_counts_per_s)) << what;
    EXPECT_EQ(s.native.acceleration, static_cast<std::int64_t>(s.realized.acceleration_counts_per_s2)) << what;
    EXPECT_EQ(s.native.deceleration, static_cast<std::int64_t>(s.realized.deceleration_counts_per_s2)) << what;
    EXPECT_FALSE(uim242::validate({uim242::Mnemonic::kSPD, false, s.native.velocity, false})) << what;
    EXPECT_FALSE(uim242::validate({uim242::Mnemonic::kMAC, false, s.native.acceleration, false})) << what;
    EXPECT_FALSE(uim242::validate({uim242::Mnemonic::kMDE, false, s.native.deceleration, false})) << what;
  }
  // Beyond SPD's 65535 pulse/s the grid stops at the controller's maximum.
  std::vector<DriveSetting> fast;
  quantizer("ud")->candidates({100000.0, 1000.0, 1000.0}, 2, fast);
  for (const auto& s : fast) EXPECT_LE(s.native.velocity, 65535) << s.native.velocity;
}

// ---- The model: what the gateway read from the drive wins over the configuration ----

// A UC57 configured without a resolution (the coordinator used to assume the factory 10000) whose
// 2006h reads 3200 and 200Eh 20 rpm: the model and its grid are at 3200 pulses/rev, and the
// realized values are what the stack programs at the resolution it read.
TEST(DriveModel, Uc57ModelCarriesTheResolutionReadFromTheDrive) {
  namespace od = cia402::uc57;
  const auto assumed = model_of("b");
  EXPECT_EQ(assumed.resolution_source, std::int8_t{motionlcm::drive_model_t::RESOLUTION_CONFIGURED});
  EXPECT_EQ(assumed.counts_per_revolution, 10000);
  const auto model = model_of("b", {3200u, 20.0, {}});
  EXPECT_EQ(model.resolution_source, std::int8_t{motionlcm::drive_model_t::RESOLUTION_READ_BACK});
  EXPECT_EQ(model.counts_per_revolution, 3200);
  EXPECT_EQ(model.assumed_counts_per_revolution, 10000);
  EXPECT_DOUBLE_EQ(model.velocity_step, 3200 / 60.0);
  EXPECT_DOUBLE_EQ(model.ramp_from, 20 * 3200 / 60.0);
  EXPECT_EQ(model.acceleration_kind, std::int8_t{motionlcm::drive_model_t::ACCEL_RAMP_TIME});
  EXPECT_DOUBLE_EQ(model.acceleration_step, 0.001);
  ASSERT_EQ(model.num_starts, 1);
  EXPECT_EQ(model.start_kinds[0], std::int8_t{motionlcm::drive_model_t::START_CANOPEN_SYNC});
  EXPECT_EQ(model.start_addresses[0], 0x80);
  // A SYNC (11-bit id, no data) at 500 kbit/s: 47 bits plus stuff bits, 2 us each.
  EXPECT_GE(model.start_wire_us[0], 94.0);
  EXPECT_LE(model.start_wire_us[0], 110.0);

  const auto& velocity = *od::find_entry(od::index::kProfileVelocity, 0);
  const auto& acceleration = *od::find_entry(od::index::kProfileAcceleration, 0);
  std::vector<DriveSetting> settings;
  for (const auto& m : desired_motions(3200 / 60.0 * 40.0)) quantizer_of_model(model)->candidates(m, 2, settings);
  ASSERT_GT(settings.size(), 20u);
  for (const auto& s : settings) {
    const auto speed = od::quantize_speed(velocity, s.realized.velocity_counts_per_s, 3200);
    const auto accel =
        od::quantize_ramp(acceleration, s.realized.acceleration_counts_per_s2, speed.realized - model.ramp_from, 3200);
    EXPECT_EQ(speed.native, s.native.velocity);
    EXPECT_EQ(accel.native, s.native.acceleration);
    expect_relative(speed.realized, s.realized.velocity_counts_per_s, "velocity");
    expect_relative(accel.realized, s.realized.acceleration_counts_per_s2, "acceleration");
  }
}

TEST(DriveModel, StartMechanismsAndTheirWireTimes) {
  // ADAM: the broadcast 0x00DD write, 8 bytes of 10 bits (8N1) at 115200 baud.
  const auto c = model_of("c");
  ASSERT_EQ(c.num_starts, 1);
  EXPECT_EQ(c.start_kinds[0], std::int8_t{motionlcm::drive_model_t::START_ADAM_BROADCAST});
  EXPECT_NEAR(c.start_wire_us[0], 8 * 10 / 115200.0 * 1e6, 0.01);
  // UIM242: the global gSPD 65535; (12 characters) and the per-controller SPD at 57600 baud.
  const auto u = model_of("u");
  ASSERT_EQ(u.num_starts, 2);
  EXPECT_EQ(u.start_kinds[0], std::int8_t{motionlcm::drive_model_t::START_UIM242_GLOBAL});
  EXPECT_EQ(u.start_kinds[1], std::int8_t{motionlcm::drive_model_t::START_SINGLE});
  EXPECT_GT(u.start_wire_us[0], u.start_wire_us[1]);
  // A UIM242 that does not hold a move loaded at speed 0 crawls into it first (docs/protocols.md
  // UIM242 #3): `ADR 5;`, `SPD -1;`, `STP -2147483647;` and their answers on the line.
  gateway::DriveFacts crawling;
  crawling.crawl_start = true;
  const auto uc = model_of("u", crawling);
  ASSERT_EQ(uc.num_starts, 3);
  EXPECT_EQ(uc.start_kinds[2], std::int8_t{motionlcm::drive_model_t::START_UIM242_CRAWL});
  EXPECT_EQ(uc.start_addresses[2], uc.node_id);
  EXPECT_GT(uc.start_wire_us[2], 2 * uc.start_wire_us[0]) << "three instructions and three answers";
  EXPECT_LT(uc.start_wire_us[2], 10000.0);
  EXPECT_EQ(uc.start_wire_us[0], u.start_wire_us[0]) << "the start it joins is the same gSPD";
  // UIM342 without a group: BG to its node; an extended frame without data (67 bits and stuff
  // bits) at 500 kbit/s.
  const auto x = model_of("x");
  ASSERT_EQ(x.num_starts, 1);
  EXPECT_EQ(x.start_kinds[0], std::int8_t{motionlcm::drive_model_t::START_SINGLE});
  EXPECT_EQ(x.start_addresses[0], 5);
  EXPECT_GE(x.start_wire_us[0], 134.0);
  EXPECT_LE(x.start_wire_us[0], 160.0);
  EXPECT_EQ(x.resolution_source, std::int8_t{motionlcm::drive_model_t::RESOLUTION_UNKNOWN});
}

TEST(DriveModel, UnusableModelsAreRefusedWithTheReason) {
  const auto base = model_of("x");
  auto why = [](const motionlcm::drive_model_t& m) {
    auto q = quantizer_from_model(m);
    return std::holds_alternative<std::string>(q) ? std::get<std::string>(q) : std::string("usable");
  };
  EXPECT_EQ(why(base), "usable");
  auto m = base;
  m.velocity_step = 0;
  EXPECT_NE(why(m).find("velocity step"), std::string::npos) << why(m);
  m = base;
  m.acceleration_max = 0;
  EXPECT_NE(why(m).find("acceleration range 1..0 is empty"), std::string::npos) << why(m);
  m = base;
  m.acceleration_kind = 9;
  EXPECT_NE(why(m).find("unknown acceleration kind 9"), std::string::npos) << why(m);
  m = base;
  m.ramp_from = -1;
  EXPECT_NE(why(m).find("ramp start speed"), std::string::npos) << why(m);
  // The planner refuses an axis without a quantizer, naming it.
  auto result = make_move_planner()({{"x", config::Family::kUim342, 0, 100, 1000, 1000}}, 1.0, 1.0);
  ASSERT_TRUE(std::holds_alternative<std::string>(result));
  EXPECT_EQ(std::get<std::string>(result), "axis x has no drive model");
}

// The plan follows the model: the same move of b at the read 3200 pulses/rev and at the assumed
// 10000 realizes different speeds, each a whole rpm at its own resolution.
TEST(MovePlanner, PlansWithTheResolutionOfTheModel) {
  const auto planner = make_move_planner();
  const double v = 360 * 27.777777777777779;
  const double a = 1440 * 27.777777777777779;
  for (const std::uint32_t ppr : {3200u, 10000u}) {
    PlanInput in{"b", config::Family::kUc57, 0, 20000, v, a};
    in.quantizer = quantizer_of_model(model_of("b", {ppr, 10.0, {}}));
    auto result = planner({in}, 0.5, 0.5);
    ASSERT_TRUE(std::holds_alternative<MovePlan>(result)) << std::get<std::string>(result);
    const double rpm = std::get<MovePlan>(result).axes.at(0).velocity * 60.0 / ppr;
    EXPECT_NEAR(rpm, std::round(rpm), 1e-9) << ppr;
  }
}

// A velocity scale the request validation lets through ((0, 1]) but far below any speed a drive
// runs (found by the fuzz target coordinator_sequences: 4.9e-324 made durations infinite and the
// planner's duration bucketing converted NaN to an index, undefined behaviour). The scale shapes
// the plan; each drive realizes its nearest setting within its limits: a finite plan at the
// drive's slowest speeds (or a refusal naming the axis), for every family.
TEST(MovePlanner, AVelocityScaleBelowEveryDrivesSpeedGivesAFinitePlanWithinTheLimits) {
  const auto planner = make_move_planner();
  for (const double scale : {std::numeric_limits<double>::denorm_min(), 1e-300, 1e-12}) {
    for (const PlanInput& one : with_models({{"x", config::Family::kUim342, 0, 64000, 50 * 640, 400 * 640},
                                             {"a", config::Family::kUc57, 0, 3200, 3200, 12800},
                                             {"c", config::Family::kAdamModbus, 0, 16000, 40 * 320, 200 * 320},
                                             {"u", config::Family::kUim242, 0, 4000, 40 * 160, 200 * 160}})) {
      auto result = planner({one}, scale, 1.0);
      if (auto* why = std::get_if<std::string>(&result)) {
        EXPECT_NE(why->find(one.axis), std::string::npos) << *why;
        continue;
      }
      const auto& plan = std::get<MovePlan>(result);
      ASSERT_EQ(plan.axes.size(), 1u);
      const AxisPlan& a = plan.axes[0];
      EXPECT_EQ(a.target_counts, one.target_counts);
      EXPECT_TRUE(a.velocity > 0 && a.velocity <= one.max_velocity) << one.axis << " " << a.velocity;
      EXPECT_TRUE(a.acceleration > 0 && a.acceleration <= one.max_acceleration) << one.axis << " " << a.acceleration;
      EXPECT_TRUE(a.deceleration > 0 && a.deceleration <= one.max_acceleration) << one.axis << " " << a.deceleration;
      EXPECT_TRUE(std::isfinite(plan.duration_s) && std::isfinite(plan.predicted_skew_us)) << one.axis;
    }
  }
}

// ---- The planner as the coordinator runs it ----

TEST(MovePlanner, EveryFamilysPlanIsRepresentableAndArrivalsAgree) {
  const auto planner = make_move_planner();
  std::vector<PlanInput> in{{"x", config::Family::kUim342, 0, 64000, 50 * 640, 400 * 640},
                            {"y", config::Family::kUim342, 1000, -12345, 50 * 640, 400 * 640},
                            {"a", config::Family::kUc57, 0, 3200, 3200, 12800},
                            {"c", config::Family::kAdamModbus, 0, 16000, 40 * 320, 200 * 320},
                            {"u", config::Family::kUim242, 0, 4000, 40 * 160, 200 * 160}};
  auto result = planner(with_models(in), 1.0, 1.0);
  ASSERT_TRUE(std::holds_alternative<MovePlan>(result)) << std::get<std::string>(result);
  const auto& plan = std::get<MovePlan>(result);
  ASSERT_EQ(plan.axes.size(), 5u);
  EXPECT_EQ(plan.axes[0].target_counts, 64000);
  EXPECT_EQ(plan.axes[1].target_counts, -12345);
  // UIM342 SP is an integer pulse/s; rate-mode AC/DC are integer pulse/s^2.
  EXPECT_EQ(plan.axes[0].velocity, std::round(plan.axes[0].velocity));
  EXPECT_EQ(plan.axes[0].acceleration, std::round(plan.axes[0].acceleration));
  EXPECT_EQ(plan.axes[1].velocity, std::round(plan.axes[1].velocity));
  // UC57 6081h whole rpm at 3200 pulses/rev; ADAM whole rpm too (0x009A and 0x00D8 both hold it).
  const double a_rpm = plan.axes[2].velocity * 60.0 / 3200.0;
  EXPECT_NEAR(a_rpm, std::round(a_rpm), 1e-9);
  const double c_rpm = plan.axes[3].velocity * 60.0 / 3200.0;
  EXPECT_NEAR(c_rpm, std::round(c_rpm), 1e-9);
  const auto c = adam_programs({plan.axes[3].velocity, plan.axes[3].acceleration, plan.axes[3].deceleration}, 3200);
  expect_relative(c.realized.velocity_counts_per_s, plan.axes[3].velocity, "c velocity");
  expect_relative(c.realized.acceleration_counts_per_s2, plan.axes[3].acceleration, "c acceleration");
  // UIM242 SPD integer pulse/s, MAC/MDE integer pulse/s^2.
  EXPECT_EQ(plan.axes[4].velocity, std::round(plan.axes[4].velocity));
  EXPECT_EQ(plan.axes[4].acceleration, std::round(plan.axes[4].acceleration));
  // The slowest axis sets the time; every axis arrives within the predicted spread.
  EXPECT_GT(plan.duration_s, 0.5);
  for (const auto& a : plan.axes)
    EXPECT_NEAR(a.duration_s, plan.duration_s, plan.predicted_skew_us * 1e-6 + 1e-9) << a.axis;
  EXPECT_LT(plan.predicted_skew_us, 5000.0);
}

TEST(MovePlanner, ZeroLimitIsAPlanningError) {
  auto result = make_move_planner()(with_models({{"x", config::Family::kUim342, 0, 100, 0, 1000}}), 1.0, 1.0);
  ASSERT_TRUE(std::holds_alternative<std::string>(result));
  EXPECT_NE(std::get<std::string>(result).find("x"), std::string::npos) << std::get<std::string>(result);
}

// Short and slow moves of a UC57 axis: its start speed 200Eh (10 rpm, 533 counts/s at 3200
// pulses/rev) is above the synchronized speed these moves want, and ramps exist only above it.
TEST(MovePlanner, ShortAndSlowUc57MovesArePlannedWithinTheLimits) {
  const auto planner = make_move_planner();
  const double a_velocity = 360 * 8.888888888888889;
  const double a_acceleration = 1440 * 8.888888888888889;
  for (const std::int64_t distance : {1, 2, 9, 18, 36, 44}) {  // 0.1 to 5 degrees
    for (const double scale : {1.0, 0.5, 0.1}) {
      auto result = planner(
          with_models({{"a", config::Family::kUc57, 177, 177 + distance, a_velocity, a_acceleration}}), scale, scale);
      ASSERT_TRUE(std::holds_alternative<MovePlan>(result))
          << distance << " counts at scale " << scale << ": " << std::get<std::string>(result);
      const auto& a = std::get<MovePlan>(result).axes.at(0);
      EXPECT_EQ(a.target_counts, 177 + distance);
      EXPECT_GT(a.velocity, 10 * 3200 / 60.0) << "the drive has no ramp at or below its start speed";
      EXPECT_LE(a.velocity, a_velocity);
      EXPECT_LE(a.acceleration, a_acceleration);
      EXPECT_LE(a.deceleration, a_acceleration);
    }
  }
  // With a long partner move, the UC57 axis stretches its ramps toward the partner's duration.
  std::vector<PlanInput> in{{"x", config::Family::kUim342, 0, 6400, 50 * 640, 400 * 640},
                            {"a", config::Family::kUc57, 0, 9, a_velocity, a_acceleration}};
  auto paired = planner(with_models(in), 0.5, 0.5);
  ASSERT_TRUE(std::holds_alternative<MovePlan>(paired)) << std::get<std::string>(paired);
  const auto& plan = std::get<MovePlan>(paired);
  EXPECT_LT(plan.axes[1].acceleration, a_acceleration);
  EXPECT_GE(plan.predicted_skew_us, 0.0);
}

}  // namespace
}  // namespace motion::coordinator
