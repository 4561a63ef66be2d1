// The simulated UC57 (services/sim/uc57) in motion, frame by frame with the manual's and derived
// frames: the profile-position handshake with its exact arrival time, halts, buffered set-points,
// profile velocity, homing, quick stop, faults with EMCY and fault reset, stall, inputs and outputs
// (bench: uc57_drive_bench.hpp).
#include "motion/cia402/uc57_homing.hpp"
#include "motion/cia402/uc57_units.hpp"
#include "motion/sim/kinematics.hpp"
#include "uc57_drive_bench.hpp"

namespace motion::sim::uc57_test {
namespace {

// Manual §4.2.4 example (P-01..P-12): relative 5000 pulses at 60 RPM with 100/100 ramps.
TEST(Uc57Sim, ProfilePositionHandshakeAndArrivalTime) {
  Drive drive;
  for (const char* request :
       {"601: 2B 40 60 00 00 00 00 00", "601: 23 83 60 00 64 00 00 00", "601: 23 84 60 00 64 00 00 00",
        "601: 23 81 60 00 3C 00 00 00", "601: 23 7A 60 00 88 13 00 00", "601: 2F 60 60 00 01 00 00 00",
        "601: 2B 40 60 00 06 00 00 00", "601: 2B 40 60 00 07 00 00 00", "601: 2B 40 60 00 0F 00 00 00",
        "601: 2B 40 60 00 4F 00 00 00"}) {
    drive.sdo_ok(request);
  }
  EXPECT_FALSE(bit(drive.statusword(), cia402::StatusBit::kSetPointAcknowledge));
  EXPECT_TRUE(bit(drive.statusword(), cia402::StatusBit::kTargetReached));  // idle
  const TimePoint start = drive.now;
  drive.sdo_ok("601: 2B 40 60 00 5F 00 00 00");  // P-12: rising edge of bit 4
  std::uint16_t status = drive.statusword();
  EXPECT_TRUE(bit(status, cia402::StatusBit::kSetPointAcknowledge));
  EXPECT_TRUE(bit(status, cia402::StatusBit::kNewSetPointEcho));
  EXPECT_FALSE(bit(status, cia402::StatusBit::kTargetReached));
  drive.sdo_ok("601: 2B 40 60 00 4F 00 00 00");  // release: ack drops
  EXPECT_FALSE(bit(drive.statusword(), cia402::StatusBit::kSetPointAcknowledge));

  // The arrival time of the exact trapezoid: start speed 200Eh = 10 RPM, ramps of 100 ms (C-02).
  const double ppr = od::kDefaultPulsesPerRevolution;
  const double v0 = od::rpm_to_pulses_per_second(10, od::kDefaultPulsesPerRevolution);
  const double vmax = od::rpm_to_pulses_per_second(60, od::kDefaultPulsesPerRevolution);
  const double accel =
      od::ramp_acceleration(od::RampUnit::kMilliseconds, 100, vmax - v0, od::kDefaultPulsesPerRevolution);
  Kinematics reference;
  reference.move_to(start, 5000, {vmax, accel, accel, v0});
  const TimePoint arrival = reference.end_time();
  ASSERT_NE(arrival, kNever);
  (void)ppr;

  drive.advance_to(arrival - 1ms);
  status = drive.statusword();
  EXPECT_TRUE(bit(status, cia402::StatusBit::kMotorRunning));
  EXPECT_FALSE(bit(status, cia402::StatusBit::kTargetReached));
  drive.advance_to(arrival);
  status = drive.statusword();
  EXPECT_TRUE(bit(status, cia402::StatusBit::kTargetReached));
  EXPECT_TRUE(bit(status, cia402::StatusBit::kInPosition));
  EXPECT_FALSE(bit(status, cia402::StatusBit::kMotorRunning));
  EXPECT_EQ(drive.deliver("601: 40 64 60 00 00 00 00 00"), Texts{"581: 43 64 60 00 88 13 00 00"});
  const auto started = drive.reports_of(kStarted);
  const auto finished = drive.reports_of(kFinished);
  ASSERT_EQ(started.size(), 1u);
  ASSERT_EQ(finished.size(), 1u);
  EXPECT_EQ(started[0].frame_utime, utime_of(start));
  EXPECT_EQ(finished[0].frame_utime, utime_of(arrival));
  EXPECT_EQ(finished[0].position, 5000);
}

// A slow move just above the start speed (12 RPM over 10 RPM) with the longest ramps (2000 ms),
// halted at every 50 ms of its run: the halt brakes at the profile's own deceleration down to the
// start speed and never passes the target, and it ends within one ramp time. (A halt that ramped
// from the present speed to rest over the whole ramp time ran far past the target when it came
// near the end: random lab seed 7085.)
TEST(Uc57Sim, HaltOfAProfilePositionMoveNeverPassesItsTarget) {
  const double v0 = od::rpm_to_pulses_per_second(10, od::kDefaultPulsesPerRevolution);
  const double vmax = od::rpm_to_pulses_per_second(12, od::kDefaultPulsesPerRevolution);
  const double accel =
      od::ramp_acceleration(od::RampUnit::kMilliseconds, 2000, vmax - v0, od::kDefaultPulsesPerRevolution);
  constexpr std::int64_t kTarget = 2500;
  Kinematics reference;
  reference.move_to(t0, kTarget, {vmax, accel, accel, v0});
  const auto run_time = reference.end_time() - t0;
  int halts = 0;
  for (auto halt_after = Duration{0}; halt_after < run_time; halt_after += 50ms) {
    Drive drive;
    for (const char* request :
         {"601: 23 83 60 00 D0 07 00 00", "601: 23 84 60 00 D0 07 00 00", "601: 23 81 60 00 0C 00 00 00",
          "601: 23 7A 60 00 C4 09 00 00", "601: 2F 60 60 00 01 00 00 00"}) {
      drive.sdo_ok(request);
    }
    drive.enable();
    drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
    const TimePoint start = drive.now;
    drive.sdo_ok("601: 2B 40 60 00 0F 00 00 00");
    drive.advance_to(start + halt_after);
    drive.sdo_ok("601: 2B 40 60 00 0F 01 00 00");  // halt (bit 8)
    const TimePoint halted = drive.now;
    drive.advance_to(halted + 2001ms);
    EXPECT_FALSE(bit(drive.statusword(), cia402::StatusBit::kMotorRunning))
        << "halted after " << halt_after.count() << " ns";
    const std::int64_t at = drive.sim().position(drive.now);
    EXPECT_LE(at, kTarget) << "halted after " << halt_after.count() << " ns";
    EXPECT_GE(at, reference.position_counts(start + halt_after) - 1);
    drive.advance_to(drive.now + 5s);
    EXPECT_EQ(drive.sim().position(drive.now), at);  // and stays there
    ++halts;
  }
  EXPECT_GT(halts, 25);  // the move runs for about 1.5 s
}

TEST(Uc57Sim, SecondSetPointIsBufferedOrReplacesWithChangeImmediately) {
  Drive drive;
  drive.sdo_ok("601: 2F 60 60 00 01 00 00 00");
  drive.enable();
  drive.sdo_ok("601: 23 7A 60 00 10 27 00 00");  // 10000
  drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
  drive.sdo_ok("601: 2B 40 60 00 0F 00 00 00");
  drive.now += 100ms;
  drive.sdo_ok("601: 23 7A 60 00 20 4E 00 00");  // 20000, buffered behind the running move
  drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
  EXPECT_TRUE(bit(drive.statusword(), cia402::StatusBit::kSetPointAcknowledge));
  drive.sdo_ok("601: 2B 40 60 00 0F 00 00 00");
  EXPECT_TRUE(bit(drive.statusword(), cia402::StatusBit::kSetPointAcknowledge));  // buffer busy
  drive.advance_to(drive.now + 20s);
  EXPECT_EQ(drive.sim().position(drive.now), 20000);
  EXPECT_FALSE(bit(drive.statusword(), cia402::StatusBit::kSetPointAcknowledge));
  EXPECT_EQ(drive.reports_of(kFinished).size(), 2u);

  // Change immediately (0x3F): the new absolute target replaces the running one.
  drive.sdo_ok("601: 23 7A 60 00 00 00 00 00");
  drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
  drive.sdo_ok("601: 2B 40 60 00 0F 00 00 00");
  drive.now += 100ms;
  drive.sdo_ok("601: 23 7A 60 00 10 27 00 00");
  drive.sdo_ok("601: 2B 40 60 00 3F 00 00 00");
  drive.advance_to(drive.now + 20s);
  EXPECT_EQ(drive.sim().position(drive.now), 10000);
}

TEST(Uc57Sim, ProfileVelocityV01ToV09) {
  Drive drive;
  for (const char* request :
       {"601: 2B 40 60 00 00 00 00 00", "601: 23 83 60 00 64 00 00 00", "601: 23 84 60 00 64 00 00 00",
        "601: 23 FF 60 00 3C 00 00 00", "601: 2F 60 60 00 03 00 00 00", "601: 2B 40 60 00 06 00 00 00",
        "601: 2B 40 60 00 07 00 00 00"}) {
    drive.sdo_ok(request);
  }
  EXPECT_TRUE(drive.reports_of(kStarted).empty());
  drive.sdo_ok("601: 2B 40 60 00 0F 00 00 00");  // V-09 starts the motor
  EXPECT_EQ(drive.reports_of(kStarted).size(), 1u);
  EXPECT_FALSE(bit(drive.statusword(), cia402::StatusBit::kTargetReached));
  drive.advance_to(drive.now + 1s);
  EXPECT_TRUE(bit(drive.statusword(), cia402::StatusBit::kTargetReached));
  EXPECT_EQ(drive.deliver("601: 40 6C 60 00 00 00 00 00"), Texts{"581: 43 6C 60 00 3C 00 00 00"});
  drive.sdo_ok("601: 23 FF 60 00 C4 FF FF FF");  // D-10: reverse
  drive.advance_to(drive.now + 1s);
  EXPECT_EQ(drive.deliver("601: 40 6C 60 00 00 00 00 00"), Texts{"581: 43 6C 60 00 C4 FF FF FF"});
  drive.sdo_ok("601: 2B 40 60 00 0F 01 00 00");  // MC_STOP: halt
  drive.advance_to(drive.now + 1s);
  EXPECT_EQ(drive.deliver("601: 40 6C 60 00 00 00 00 00"), Texts{"581: 43 6C 60 00 00 00 00 00"});
  EXPECT_TRUE(bit(drive.statusword(), cia402::kSpeedIsZero));
  EXPECT_EQ(drive.reports_of(kFinished).size(), 1u);
}

// A set-point acknowledged in profile position whose bit 4 falls only after a switch to profile
// velocity (a jog after a move the master lost track of) is not pending when profile position is
// entered again: bit 12 is the new mode's (chaos seed 50054: the gateway waited for it in vain).
TEST(Uc57Sim, ProfilePositionEnteredAgainHasNoSetPointPending) {
  Drive drive;
  for (const char* request :
       {"601: 2B 40 60 00 00 00 00 00", "601: 23 83 60 00 64 00 00 00", "601: 23 84 60 00 64 00 00 00",
        "601: 23 81 60 00 3C 00 00 00", "601: 23 7A 60 00 88 13 00 00", "601: 2F 60 60 00 01 00 00 00",
        "601: 2B 40 60 00 06 00 00 00", "601: 2B 40 60 00 07 00 00 00", "601: 2B 40 60 00 0F 00 00 00",
        "601: 2B 40 60 00 5F 00 00 00"}) {  // bit 4 rises: acknowledged, bit 4 left set
    drive.sdo_ok(request);
  }
  ASSERT_TRUE(bit(drive.statusword(), cia402::StatusBit::kSetPointAcknowledge));
  drive.sdo_ok("601: 2F 60 60 00 03 00 00 00");  // profile velocity
  drive.sdo_ok("601: 2B 40 60 00 0F 01 00 00");  // bit 4 falls here, with a halt
  drive.advance_to(drive.now + 2s);
  drive.sdo_ok("601: 2F 60 60 00 01 00 00 00");  // profile position again
  EXPECT_FALSE(bit(drive.statusword(), cia402::StatusBit::kSetPointAcknowledge));
  drive.sdo_ok("601: 2B 40 60 00 0F 00 00 00");
  drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");  // the next set-point is taken and acknowledged
  EXPECT_TRUE(bit(drive.statusword(), cia402::StatusBit::kSetPointAcknowledge));
}

// D-50: method 24 (forward origin), 120/60 RPM, ramp 100, offset 0.
TEST(Uc57Sim, HomingMethod24FindsTheOrigin) {
  Drive drive;
  for (const char* request :
       {"601: 2F 98 60 00 18 00 00 00", "601: 23 99 60 01 78 00 00 00", "601: 23 99 60 02 3C 00 00 00",
        "601: 23 9A 60 00 64 00 00 00", "601: 23 7C 60 00 00 00 00 00", "601: 2F 60 60 00 06 00 00 00"}) {
    drive.sdo_ok(request);
  }
  EXPECT_EQ(drive.deliver("601: 40 61 60 00 00 00 00 00"), Texts{"581: 4F 61 60 00 06 00 00 00"});
  drive.enable();
  drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
  EXPECT_EQ(od::homing_result(drive.statusword()), od::HomingResult::kInProgress);
  drive.advance_to(drive.now + 30s);
  const std::uint16_t status = drive.statusword();
  EXPECT_EQ(od::homing_result(status), od::HomingResult::kSucceeded);
  EXPECT_TRUE(bit(status, cia402::StatusBit::kHomingDone));
  EXPECT_TRUE(bit(status, cia402::kHomingAttained));
  EXPECT_EQ(drive.sim().position(drive.now), 0);
  EXPECT_EQ(drive.deliver("601: 40 FD 60 00 00 00 00 00"), Texts{"581: 43 FD 60 00 04 00 00 00"});  // on origin
  ASSERT_EQ(drive.reports_of(kFinished).size(), 1u);
  EXPECT_EQ(drive.reports_of(kFinished)[0].position, 0);
}

TEST(Uc57Sim, HomingWithOffsetReversalAndFailures) {
  Uc57SimOptions options;
  options.origin_position = -3000;  // behind the positive search of method 24
  Drive drive(1, options);
  drive.sdo_ok("601: 2F 98 60 00 18 00 00 00");
  drive.sdo_ok("601: 23 7C 60 00 E8 03 00 00");  // 607Ch = 1000
  drive.sdo_ok("601: 2F 60 60 00 06 00 00 00");
  drive.enable();
  drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
  drive.advance_to(drive.now + 600s);
  EXPECT_EQ(od::homing_result(drive.statusword()), od::HomingResult::kSucceeded);
  EXPECT_EQ(drive.sim().position(drive.now), -1000);  // 6064h = -607Ch at home

  // Method 42 with the origin behind: stops at the positive limit, not homed.
  Drive immediate(1, options);
  immediate.sdo_ok("601: 2F 98 60 00 2A 00 00 00");
  immediate.sdo_ok("601: 2F 60 60 00 06 00 00 00");
  immediate.enable();
  immediate.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
  immediate.advance_to(immediate.now + 600s);
  EXPECT_EQ(od::homing_result(immediate.statusword()), od::HomingResult::kStoppedWithoutHome);
  EXPECT_EQ(immediate.sim().position(immediate.now), options.positive_limit);
  EXPECT_EQ(immediate.deliver("601: 40 FD 60 00 00 00 00 00"), Texts{"581: 43 FD 60 00 02 00 00 00"});

  // An invalid method: homing error at once, no motion.
  drive.sdo_ok("601: 2B 40 60 00 0F 00 00 00");
  drive.sdo_ok("601: 2F 98 60 00 64 00 00 00");  // H-03's 100
  const auto starts = drive.reports_of(kStarted).size();
  drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
  EXPECT_EQ(od::homing_result(drive.statusword()), od::HomingResult::kStoppedWithoutHome);
  EXPECT_EQ(drive.reports_of(kStarted).size(), starts);
}

TEST(Uc57Sim, QuickStopD54) {
  Drive drive;
  drive.sdo_ok("601: 2F 60 60 00 01 00 00 00");
  drive.enable();
  drive.sdo_ok("601: 23 7A 60 00 40 42 0F 00");  // 1000000
  drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
  drive.now += 500ms;
  drive.sdo_ok("601: 2B 40 60 00 02 00 00 00");
  EXPECT_EQ(drive.sim().drive_state(), cia402::State::kQuickStopActive);
  drive.advance_to(drive.now + 5s);
  EXPECT_FALSE(bit(drive.statusword(), cia402::StatusBit::kMotorRunning));
  EXPECT_LT(drive.sim().position(drive.now), 1000000);
  EXPECT_EQ(drive.reports_of(kFinished).size(), 1u);
  drive.sdo_ok("601: 2B 40 60 00 00 00 00 00");  // transition 12
  EXPECT_EQ(drive.sim().drive_state(), cia402::State::kSwitchOnDisabled);
}

TEST(Uc57Sim, AlarmsEmcyAndFaultReset) {
  Drive drive;
  drive.take();
  drive.enable();
  motionlcm::sim_control_t alarm{};
  alarm.action = motionlcm::sim_control_t::ALARM;
  alarm.value = 1;  // Err1 overcurrent: needs a power cycle
  EXPECT_TRUE(drive.sim().control(alarm, drive.now));
  EXPECT_EQ(drive.take(), Texts{"081: 10 23 03 01 01 00 00 00"});  // D-45
  std::uint16_t status = drive.statusword();
  EXPECT_EQ(cia402::decode_state(status), cia402::State::kFault);
  EXPECT_TRUE(bit(status, cia402::StatusBit::kAlarm));
  EXPECT_EQ(drive.deliver("601: 40 3F 60 00 00 00 00 00"), Texts{"581: 4B 3F 60 00 01 00 00 00"});
  EXPECT_EQ(drive.deliver("601: 40 01 10 00 00 00 00 00"), Texts{"581: 4F 01 10 00 03 00 00 00"});
  EXPECT_EQ(drive.deliver("601: 40 03 10 01 00 00 00 00"), Texts{"581: 43 03 10 01 10 23 00 00"});
  drive.sdo_ok("601: 2B 40 60 00 00 00 00 00");
  drive.sdo_ok("601: 2B 40 60 00 80 00 00 00");  // D-52: latched, stays in Fault
  EXPECT_EQ(drive.sim().drive_state(), cia402::State::kFault);

  Drive other;
  other.take();
  alarm.value = 6;  // Err6 undervoltage: auto reset
  other.sim().control(alarm, other.now);
  EXPECT_EQ(other.take(), Texts{"081: 20 32 05 06 20 00 00 00"});
  other.sdo_ok("601: 2B 40 60 00 00 00 00 00");
  EXPECT_EQ(other.deliver("601: 2B 40 60 00 80 00 00 00"),
            (Texts{"081: 00 00 00 00 00 00 00 00", "581: 60 40 60 00 00 00 00 00"}));  // D-46
  EXPECT_EQ(other.sim().drive_state(), cia402::State::kSwitchOnDisabled);
  other.enable();
  EXPECT_EQ(other.sim().drive_state(), cia402::State::kOperationEnabled);
}

TEST(Uc57Sim, StallStopsTheMoveAndFaults) {
  Drive drive;
  drive.sdo_ok("601: 2F 60 60 00 01 00 00 00");
  drive.enable();
  drive.sdo_ok("601: 23 7A 60 00 10 27 00 00");
  drive.sdo_ok("601: 2B 40 60 00 1F 00 00 00");
  drive.take();
  drive.now += 300ms;
  motionlcm::sim_control_t stall{};
  stall.action = motionlcm::sim_control_t::STALL;
  EXPECT_TRUE(drive.sim().control(stall, drive.now));
  EXPECT_EQ(drive.take(), Texts{"081: 11 86 21 00 00 00 00 00"});
  EXPECT_EQ(cia402::decode_state(drive.statusword()), cia402::State::kFault);
  EXPECT_FALSE(bit(drive.statusword(), cia402::StatusBit::kMotorRunning));
  EXPECT_EQ(drive.reports_of(kFinished).size(), 1u);
  // Fault reset by 2011h (C-12), then the drive can be enabled again.
  drive.sdo_ok("601: 2B 11 20 00 01 00 00 00");
  EXPECT_EQ(drive.sim().drive_state(), cia402::State::kSwitchOnDisabled);
  motionlcm::sim_control_t unknown{};
  unknown.action = motionlcm::sim_control_t::CRC_ERRORS;
  EXPECT_FALSE(drive.sim().control(unknown, drive.now));
}

TEST(Uc57Sim, InputsAndOutputs) {
  Drive drive;
  drive.take();
  motionlcm::sim_control_t input{};
  input.action = motionlcm::sim_control_t::SET_INPUT;
  input.value = 3;  // IN3 = negative limit
  input.level = 1;
  EXPECT_TRUE(drive.sim().control(input, drive.now));
  EXPECT_EQ(drive.deliver("601: 40 FD 60 00 00 00 00 00"), Texts{"581: 43 FD 60 00 01 00 00 00"});
  EXPECT_EQ(drive.deliver("601: 40 03 20 00 00 00 00 00"), Texts{"581: 4B 03 20 00 04 00 00 00"});
  drive.sdo_ok("601: 2B 30 20 01 04 00 00 00");  // invert X2
  EXPECT_EQ(drive.deliver("601: 40 FD 60 00 00 00 00 00"), Texts{"581: 43 FD 60 00 00 00 00 00"});
  // OUT2 = driver status (default function): on once the motor is energised.
  EXPECT_EQ(drive.deliver("601: 40 04 20 00 00 00 00 00"), Texts{"581: 4B 04 20 00 00 00 00 00"});
  drive.enable();
  EXPECT_EQ(drive.deliver("601: 40 04 20 00 00 00 00 00"), Texts{"581: 4B 04 20 00 02 00 00 00"});
  drive.sdo_ok("601: 2B 30 20 0D 05 00 00 00");  // Y0 = output high level
  EXPECT_EQ(drive.deliver("601: 40 04 20 00 00 00 00 00"), Texts{"581: 4B 04 20 00 03 00 00 00"});
  input.value = 4;
  EXPECT_FALSE(drive.sim().control(input, drive.now));
}

}  // namespace
}  // namespace motion::sim::uc57_test
