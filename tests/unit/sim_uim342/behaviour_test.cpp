// Behaviour of the simulated UIM342 beyond single frames: motion timing against the shared
// kinematics, group/global BG, refusals and error reports (§2.3), notifications, fault injection,
// input logic (§4), persistence over SY[1].
#include <gtest/gtest.h>

#include <chrono>

#include "motion/sim/kinematics.hpp"
#include "sim_support.hpp"

namespace motion::sim {
namespace {

using namespace test;
namespace u = uim342;
namespace rq = uim342::request;
using C = motionlcm::sim_control_t;
using FC = u::FunctionCode;

// Rates in pulse/s^2, no cut-in: the profiles below have round-number timings.
config::Drive plain_drive(int node = 5, int group = 20) {
  return uim342_drive("d" + std::to_string(node), node, group, {{"auto_enable", true}, {"cut_in_speed", 0LL}});
}

void prepare_ptp(Bench& b, std::int32_t relative, std::int32_t speed, std::uint32_t ramp = 1000) {
  b.send(rq::set_acceleration(ramp));
  b.send(rq::set_deceleration(ramp));
  b.send(rq::set_relative_position(relative));
  b.send(rq::set_ptp_speed(speed));
}

// The one frame the drive answered with, read as an error report.
u::ErrorRecord error_of(Bench& b, const std::vector<can::Frame>& frames) {
  EXPECT_EQ(frames.size(), 1U);
  if (frames.empty()) return {};
  const auto reply = b.decode(frames.front());
  EXPECT_EQ(reply.function, FC::kER);
  const auto* record = std::get_if<u::ErrorRecord>(&reply.body);
  return record ? *record : u::ErrorRecord{};
}

void expect_error(Bench& b, const u::Instruction& instruction, u::DriveErrc expected) {
  const auto record = error_of(b, b.send(instruction));
  EXPECT_EQ(record.code, static_cast<std::uint8_t>(expected)) << u::to_string(instruction);
  EXPECT_EQ(record.control_word, instruction.control_word()) << u::to_string(instruction);
  EXPECT_EQ(record.sub_index, instruction.sub_index().value_or(0)) << u::to_string(instruction);
}

std::int32_t signed_value(Bench& b, const u::Instruction& get) {
  const auto reply = b.decode(b.exchange(get));
  const auto* v = std::get_if<u::Signed>(&reply.body);
  EXPECT_NE(v, nullptr) << u::to_string(get);
  return v ? v->value : 0;
}

u::MotionStatus motion_status(Bench& b) {
  const auto reply = b.decode(b.exchange(rq::get(u::MotionStatusIndex::kStatus)));
  return std::get<u::MotionStatus>(reply.body);
}

// ---- Motion -------------------------------------------------------------------------------------

// §5.9, §5.7 (variant micro_steps_apply: after_restart, the default): MT[0] written while the
// driver is on reads back but lives in RAM only and is gone after a restart; written with the
// driver off it is stored, and the motor runs at it after the restart (SY[1]), not before.
TEST(SimUim342Setup, MicroStepsApplyOnlyAfterStoringWithTheDriverOffAndARestart) {
  Bench b(plain_drive());
  ASSERT_EQ(b.sim->applied_micro_steps(), 16);
  b.exchange(rq::driver_on(true));
  b.exchange(rq::set(u::MotorDriver::kMicrostepping, 32));
  EXPECT_EQ(std::get<u::IndexedWord>(b.decode(b.exchange(rq::get(u::MotorDriver::kMicrostepping))).body).value, 32);
  EXPECT_EQ(b.sim->applied_micro_steps(), 16) << "a RAM value does not move the motor";
  EXPECT_TRUE(b.send(rq::system(u::SystemOperation::kReboot)).empty());
  EXPECT_EQ(std::get<u::IndexedWord>(b.decode(b.exchange(rq::get(u::MotorDriver::kMicrostepping))).body).value, 16)
      << "RAM lost";
  b.exchange(rq::driver_on(false));
  b.exchange(rq::set(u::MotorDriver::kMicrostepping, 32));
  EXPECT_EQ(b.sim->applied_micro_steps(), 16) << "stored, not yet applied";
  EXPECT_TRUE(b.send(rq::system(u::SystemOperation::kReboot)).empty());
  EXPECT_EQ(std::get<u::IndexedWord>(b.decode(b.exchange(rq::get(u::MotorDriver::kMicrostepping))).body).value, 32);
  EXPECT_EQ(b.sim->applied_micro_steps(), 32);
}

// Variant immediately: a written MT[0] moves the motor at once; the shaft position (full steps)
// is continuous across the change.
TEST(SimUim342Setup, MicroStepsApplyAtOnceUnderTheImmediateVariant) {
  Bench b(plain_drive(), {}, MicroStepsApply::kImmediately);
  b.exchange(rq::set(u::MotorDriver::kMicrostepping, 32));
  EXPECT_EQ(b.sim->applied_micro_steps(), 32);
  EXPECT_DOUBLE_EQ(b.sim->shaft_full_steps(b.now), 0.0);
}

TEST(SimUim342Motion, PtpReachesTheTargetAtTheKinematicsTime) {
  Bench b(plain_drive());
  prepare_ptp(b, 2000, 1000);
  const auto ack = b.send(rq::begin(), 1'700'000'000'000'000);
  ASSERT_EQ(ack.size(), 1U);
  EXPECT_EQ(b.decode(ack[0]).function, FC::kBG);

  // Accelerate 1 s (500), cruise 1 s (1000), decelerate 1 s (500).
  Kinematics reference;
  reference.move_to(b.t0, 2000, Profile{1000, 1000, 1000, 0});
  ASSERT_EQ(b.reports_of(started()).size(), 1U);
  EXPECT_EQ(b.reports_of(started())[0].frame_utime, 1'700'000'000'000'000);
  EXPECT_EQ(b.reports_of(started())[0].target, 2000);

  EXPECT_EQ(b.advance_to(b.at(1.5)), reference.end_time());  // the next deadline is the arrival
  EXPECT_EQ(signed_value(b, rq::get(FC::kPA)), 1000);
  EXPECT_EQ(signed_value(b, rq::get(FC::kSP)), 1000);
  EXPECT_TRUE(b.reports_of(finished()).empty());

  b.settle();
  EXPECT_EQ(b.now, reference.end_time());
  EXPECT_NEAR(std::chrono::duration<double>(b.now - b.t0).count(), 3.0, 1e-6);
  ASSERT_EQ(b.reports_of(finished()).size(), 1U);
  EXPECT_EQ(b.reports_of(finished())[0].position, 2000);
  EXPECT_EQ(signed_value(b, rq::get(FC::kPA)), 2000);
  EXPECT_EQ(signed_value(b, rq::get(FC::kPR)), 2000);
  const auto status = motion_status(b);
  EXPECT_TRUE(status.has(u::StatusFlag::kStopped));
  EXPECT_TRUE(status.has(u::StatusFlag::kInPosition));
}

TEST(SimUim342Motion, RampTimesInMillisecondsFollowIc4) {
  Bench b(uim342_drive("t", 5, 0,
                       {{"auto_enable", true}, {"cut_in_speed", 0LL}, {"acceleration_unit", std::string("time")}}));
  prepare_ptp(b, 4000, 2000, 1000);  // 1000 ms ramps to 2000 pulse/s = 2000 pulse/s^2
  b.send(rq::begin());
  Kinematics reference;
  reference.move_to(b.t0, 4000, Profile{2000, 2000, 2000, 0});
  b.settle();
  EXPECT_EQ(b.now, reference.end_time());  // 1 s + 1 s + 1 s
}

TEST(SimUim342Motion, JogThenStopWithStopDecelerationRefusesBgWhileStopping) {
  Bench b(plain_drive());
  b.send(rq::set_stop_deceleration(2000));
  b.send(rq::set_jog_velocity(-2000));
  b.send(rq::begin());
  b.advance_to(b.at(3.0));
  EXPECT_EQ(signed_value(b, rq::get(FC::kJV)), -2000);
  EXPECT_EQ(b.reports_of(started()).size(), 1U);
  b.send(rq::stop());
  expect_error(b, rq::begin(), u::DriveErrc::kBgDuringEmergencyStop);
  b.advance_to(b.at(3.5));
  EXPECT_EQ(signed_value(b, rq::get(FC::kSP)), -1000);  // SD = 2000 pulse/s^2 for 0.5 s
  b.settle();
  EXPECT_EQ(b.now, b.at(4.0));
  EXPECT_EQ(b.reports_of(finished()).size(), 1U);
  EXPECT_FALSE(motion_status(b).has(u::StatusFlag::kInPosition));  // a stop is not an arrival
  EXPECT_EQ(b.send(rq::begin()).size(), 1U);                       // BG allowed again
}

TEST(SimUim342Motion, GroupBgStartsEveryDriveOfTheGroupFromOneFrame) {
  Bench x(plain_drive(5, 20));
  Bench y(plain_drive(6, 20));
  Bench z(plain_drive(7, 21));
  for (Bench* b : {&x, &y, &z}) prepare_ptp(*b, 1000, 1000);

  const can::Frame group_bg = encode(20, rq::begin(), 42'000'000);
  const auto x_ack = x.deliver(group_bg);
  const auto y_ack = y.deliver(group_bg);
  EXPECT_TRUE(z.deliver(group_bg).empty());
  ASSERT_EQ(x_ack.size(), 1U);
  ASSERT_EQ(y_ack.size(), 1U);
  EXPECT_EQ(x_ack[0].id, 0x05200016U);  // each answers with its own node ID
  EXPECT_EQ(y.decode(y_ack[0]).function, FC::kBG);
  for (Bench* b : {&x, &y}) {
    ASSERT_EQ(b->reports_of(started()).size(), 1U);
    EXPECT_EQ(b->reports_of(started())[0].frame_utime, 42'000'000);
    EXPECT_TRUE(b->sim->moving(b->at(0.5)));
  }
  EXPECT_TRUE(z.reports_of(started()).empty());

  // The global ID 0 reaches the third drive too; no ACK was asked for.
  const auto global = z.deliver(encode(u::kGlobalId, rq::without_ack(rq::begin()), 43'000'000));
  EXPECT_TRUE(global.empty());
  ASSERT_EQ(z.reports_of(started()).size(), 1U);
  EXPECT_EQ(z.reports_of(started())[0].frame_utime, 43'000'000);
}

TEST(SimUim342Motion, FramesForOthersAndNonSimpleCanFramesAreIgnored) {
  Bench b(plain_drive(5, 20));
  EXPECT_TRUE(b.deliver(encode(6, rq::get(FC::kMO))).empty());
  EXPECT_TRUE(b.deliver(*can::Frame::make(0x605, false, std::vector<std::uint8_t>{0x40, 0x00, 0x10, 0x00})).empty());
  EXPECT_TRUE(b.deliver(reply_row("06 15 01 01")).empty());  // another drive's ACK to the host
  EXPECT_EQ(b.deliver(encode(20, rq::get(FC::kMO))).size(), 1U);
}

TEST(SimUim342Motion, RelativeMovesCountFromThePositionAtBg) {
  Bench b(plain_drive());
  prepare_ptp(b, 1000, 1000);
  b.send(rq::begin());
  b.settle();
  b.send(rq::begin());  // PR is still 1000: another 1000 from here
  b.settle();
  EXPECT_EQ(signed_value(b, rq::get(FC::kPA)), 2000);
  b.send(rq::set_absolute_position(500));
  b.send(rq::begin());
  b.settle();
  EXPECT_EQ(b.sim->position(b.now), 500);
  EXPECT_EQ(b.reports_of(finished()).size(), 3U);
}

// ---- Refusals -------------------------------------------------------------------------------------

TEST(SimUim342Errors, BgWithTheDriverOffIsRefusedEvenWithoutAck) {
  Bench b(uim342_drive("off", 5));  // IC[0] = 0: the driver stays off after power-up
  EXPECT_FALSE(b.sim->driver_on());
  b.send(rq::set_jog_velocity(1000));
  expect_error(b, rq::begin(), u::DriveErrc::kBgWhileDriverOff);
  expect_error(b, rq::without_ack(rq::begin()), u::DriveErrc::kBgWhileDriverOff);
  EXPECT_TRUE(b.reports_of(started()).empty());
  b.send(rq::driver_on(true));
  EXPECT_EQ(b.send(rq::begin()).size(), 1U);
  EXPECT_EQ(b.reports_of(started()).size(), 1U);
  b.send(rq::driver_on(false));  // switching off ends the motion
  EXPECT_FALSE(b.sim->moving(b.now));
  EXPECT_EQ(b.reports_of(finished()).size(), 1U);
}

TEST(SimUim342Errors, MalformedInstructionsAreSyntaxErrors) {
  Bench b(plain_drive());
  const auto unknown = error_of(b, b.deliver(instruction_row("05 82 00")));  // no function 0x02
  EXPECT_EQ(unknown.code, 0x32);
  EXPECT_EQ(unknown.control_word, 0x82);
  EXPECT_EQ(error_of(b, b.deliver(instruction_row("05 95 02 01 00"))).code, 0x32);  // MO with DL 2
  EXPECT_EQ(error_of(b, b.deliver(instruction_row("05 AE 02 02 00"))).code, 0x32);  // DV with DL 2
  EXPECT_TRUE(b.deliver(instruction_row("05 0B 00")).empty());                      // ML without ACK: ignored
}

TEST(SimUim342Errors, SubIndexAndValueErrors) {
  Bench b(plain_drive());
  expect_error(b, rq::get(static_cast<u::ProtocolParameter>(6)), u::DriveErrc::kSubIndexError);
  expect_error(b, rq::get_error(7), u::DriveErrc::kSubIndexError);
  expect_error(b, rq::get(static_cast<u::DesiredValue>(9)), u::DriveErrc::kSubIndexError);
  expect_error(b, rq::set(static_cast<u::InformationEnable>(5), true), u::DriveErrc::kSubIndexError);
  expect_error(b, rq::set(u::MotorDriver::kMicrostepping, 3), u::DriveErrc::kDataError);
  expect_error(b, rq::set(u::ProtocolParameter::kNodeId, 127), u::DriveErrc::kDataError);
  expect_error(b, rq::set_acceleration(0), u::DriveErrc::kDataError);
  expect_error(b, rq::set_backlash(70000), u::DriveErrc::kDataError);
  expect_error(b, rq::select_group(u::ParameterGroup::kReserved), u::DriveErrc::kDataError);
  expect_error(b, rq::set_trigger(u::InputPort::kIn1, 60002), u::DriveErrc::kDataError);
  // MO=2 is not encodable through the typed constructors: the raw row.
  EXPECT_EQ(error_of(b, b.deliver(instruction_row("05 95 01 02"))).code, 0x33);
  // The history keeps the earlier errors: ER[10] is the latest, ER[11] the one before.
  const auto latest = b.decode(b.exchange(rq::get_error(10)));
  const auto before = b.decode(b.exchange(rq::get_error(11)));
  EXPECT_EQ(std::get<u::ErrorRecord>(latest.body).code, 0x33);
  EXPECT_EQ(std::get<u::ErrorRecord>(latest.body).control_word, 0x95);
  EXPECT_EQ(std::get<u::ErrorRecord>(before.body).control_word, 0xB5);
  EXPECT_TRUE(motion_status(b).has(u::StatusFlag::kError));
}

TEST(SimUim342Errors, StateChecks) {
  Bench b(plain_drive());
  expect_error(b, rq::set_ptp_speed(1000), u::DriveErrc::kSyntaxError);  // "#50": PR/PA first
  expect_error(b, rq::set_stop_deceleration(999), u::DriveErrc::kSdLessThanDc);
  expect_error(b, rq::set_deceleration(2'000'000), u::DriveErrc::kSdLessThanDc);
  prepare_ptp(b, 100000, 1000);
  b.send(rq::begin());
  b.advance_to(b.at(1.0));
  expect_error(b, rq::set_origin(), u::DriveErrc::kOgWhileRunning);
  expect_error(b, rq::set_jog_velocity(5), u::DriveErrc::kNotAllowedWhileRunning);
  expect_error(b, rq::set(u::MotorDriver::kWorkingCurrent, 20), u::DriveErrc::kNotAllowedWhileRunning);
  expect_error(b, rq::set(u::ProtocolParameter::kGroupId, 30), u::DriveErrc::kNotAllowedWhileRunning);
  EXPECT_EQ(b.send(rq::set_absolute_position(10)).size(), 1U);  // a new PTP target is fine
}

TEST(SimUim342Errors, NoAckBitMeansNoReplyButTheSetIsDone) {
  Bench b(plain_drive());
  EXPECT_TRUE(b.send(rq::without_ack(rq::get(FC::kMO))).empty());
  EXPECT_TRUE(b.send(rq::without_ack(rq::set_acceleration(1234))).empty());
  EXPECT_EQ(std::get<u::Unsigned>(b.decode(b.exchange(rq::get(FC::kAC))).body).value, 1234U);
}

// ---- Faults and notifications ----------------------------------------------------------------------

TEST(SimUim342Faults, StallStopsAndHoldsOrSwitchesTheDriverOff) {
  Bench b(plain_drive());
  b.send(rq::set_jog_velocity(1000));
  b.send(rq::begin());
  b.advance_to(b.at(2.0));
  EXPECT_TRUE(b.sim->control(control(C::STALL), b.now));
  const auto sent = b.take();
  ASSERT_EQ(sent.size(), 1U);
  EXPECT_EQ(sent[0], reply_row("05 5A 05 00 1D 00 00 00"));
  EXPECT_FALSE(b.sim->moving(b.now));
  EXPECT_TRUE(b.sim->driver_on());  // IL[16] = 0: hold
  EXPECT_EQ(b.reports_of(finished()).size(), 1U);
  const auto status = motion_status(b);
  EXPECT_TRUE(status.has(u::StatusFlag::kStalled));
  b.send(rq::clear_motion_status());
  EXPECT_FALSE(motion_status(b).has(u::StatusFlag::kStalled));

  b.send(rq::set_stall_behaviour(u::StallBehaviour::kDriverOff));
  b.send(rq::begin());
  b.sim->control(control(C::STALL), b.now);
  EXPECT_FALSE(b.sim->driver_on());
}

TEST(SimUim342Faults, AlarmsAndUnsupportedControls) {
  Bench b(plain_drive());
  b.send(rq::set_jog_velocity(1000));
  b.send(rq::begin());
  b.advance_to(b.at(2.0));
  EXPECT_TRUE(b.sim->control(control(C::ALARM, 0x1B), b.now));  // upper limit: SD stop
  EXPECT_EQ(b.take().size(), 1U);
  b.settle();
  EXPECT_FALSE(b.sim->moving(b.now));
  EXPECT_TRUE(b.sim->control(control(C::ALARM, 0x0A), b.now));  // emergency stop and lock
  b.take();
  expect_error(b, rq::begin(), u::DriveErrc::kBgDuringEmergencyStop);
  EXPECT_TRUE(motion_status(b).has(u::StatusFlag::kLocked));
  EXPECT_FALSE(b.sim->control(control(C::ALARM, 0), b.now));
  EXPECT_FALSE(b.sim->control(control(C::CRC_ERRORS, 1), b.now));
  EXPECT_FALSE(b.sim->control(control(C::SET_INPUT, 4, 1), b.now));
  b.send(rq::system(u::SystemOperation::kReboot));  // the lock lasts until a reboot
  EXPECT_FALSE(motion_status(b).has(u::StatusFlag::kLocked));
}

TEST(SimUim342Faults, InputNotificationsOnlyWhenEnabled) {
  Bench b(plain_drive());
  EXPECT_TRUE(b.sim->control(control(C::SET_INPUT, 2, 1), b.now));
  EXPECT_TRUE(b.take().empty());
  b.send(rq::set(u::InformationEnable::kIn2Change, true));
  b.sim->control(control(C::SET_INPUT, 2, 1), b.now);  // no change: nothing
  EXPECT_TRUE(b.take().empty());
  b.sim->control(control(C::SET_INPUT, 2, 0), b.now);
  const auto sent = b.take();
  ASSERT_EQ(sent.size(), 1U);
  EXPECT_EQ(sent[0], reply_row("05 5A 01 03"));
}

TEST(SimUim342Faults, PositionReachedNotificationOnlyWhenEnabled) {
  Bench b(plain_drive());
  prepare_ptp(b, 100, 1000);
  b.send(rq::begin());
  b.settle();
  EXPECT_TRUE(b.take().empty());
  b.send(rq::set(u::InformationEnable::kPositionReached, true));
  b.send(rq::begin());
  b.settle();
  const auto sent = b.take();
  ASSERT_EQ(sent.size(), 1U);
  EXPECT_EQ(sent[0], reply_row("05 5A 08 29 00 00 00 C8 00 00 00"));  // at 200
}

// ---- Input logic (§4) --------------------------------------------------------------------------

TEST(SimUim342Inputs, FallingEdgeSetsOriginAndDeceleratesLikeAHomeSwitch) {
  Bench b(plain_drive());
  b.send(rq::set_input_logic(u::InputPort::kIn1, {u::InputAction::kOriginThenDecelerateStop, true}, {}));
  b.send(rq::select_group(u::ParameterGroup::kIn1Falling));
  b.send(rq::set_deceleration(4000));
  b.sim->control(control(C::SET_INPUT, 1, 1), b.now);
  b.send(rq::set_jog_velocity(-2000));
  b.send(rq::begin());
  b.advance_to(b.at(5.0));
  b.sim->control(control(C::SET_INPUT, 1, 0), b.now);  // the switch
  EXPECT_EQ(b.sim->position(b.now), 0);
  b.settle();
  EXPECT_EQ(b.now, b.at(5.5));              // 2000 pulse/s at 4000 pulse/s^2
  EXPECT_EQ(b.sim->position(b.now), -500);  // stopped past the new origin
}

TEST(SimUim342Inputs, RelativeMoveOnRisingEdgeWithItsOwnParameterGroup) {
  Bench b(plain_drive());
  b.send(rq::set_input_logic(u::InputPort::kIn2, {}, {u::InputAction::kRelative, true}));
  b.send(rq::select_group(u::ParameterGroup::kIn2Rising));
  b.send(rq::set_relative_position(300));
  b.send(rq::select_group(u::ParameterGroup::kIn2Rising));
  b.send(rq::set_ptp_speed(1000));  // group SP: no "#50" check, DV[2] untouched
  EXPECT_EQ(std::get<u::IndexedSigned>(b.decode(b.exchange(rq::get(u::DesiredValue::kSpeed))).body).value, 0);
  auto c = control(C::SET_INPUT, 2, 1);
  c.utime = 777;
  b.sim->control(c, b.now);
  ASSERT_EQ(b.reports_of(started()).size(), 1U);
  EXPECT_EQ(b.reports_of(started())[0].frame_utime, 777);
  b.settle();
  EXPECT_EQ(b.sim->position(b.now), 300);
}

TEST(SimUim342Inputs, LowPassFilterAndOneTimeTrigger) {
  Bench b(plain_drive());
  b.send(rq::set(u::InformationEnable::kIn1Change, true));
  b.send(rq::set_trigger(u::InputPort::kIn1, 100));
  b.sim->control(control(C::SET_INPUT, 1, 1), b.now);
  EXPECT_TRUE(b.take().empty());
  EXPECT_EQ(b.advance_to(b.at(0.05)), b.at(0.1));
  b.sim->control(control(C::SET_INPUT, 1, 0), b.now);  // a glitch shorter than the filter
  EXPECT_EQ(b.advance_to(b.at(0.2)), kNever);
  EXPECT_TRUE(b.take().empty());
  b.sim->control(control(C::SET_INPUT, 1, 1), b.now);
  b.advance_to(b.at(0.3));
  EXPECT_EQ(b.take().size(), 1U);

  // One-time: the first edge runs the action, then the port's actions are gone.
  b.send(rq::set_trigger(u::InputPort::kIn1, u::kTriggerOneTime));
  b.send(rq::set_input_logic(u::InputPort::kIn1, {u::InputAction::kDriverOff, true}, {}));
  b.sim->control(control(C::SET_INPUT, 1, 0), b.now);
  EXPECT_FALSE(b.sim->driver_on());
  const auto il = std::get<u::InputActions>(b.decode(b.exchange(rq::get_input_logic(0))).body);
  EXPECT_EQ(il.falling.action, u::InputAction::kNone);
}

// ---- Persistence and reboot --------------------------------------------------------------------

TEST(SimUim342Reboot, ParametersSetWithTheDriverOnAreLostAtReboot) {
  Bench b(plain_drive());
  b.send(rq::set_acceleration(500));  // driver on: RAM only (§5.14)
  b.send(rq::system(u::SystemOperation::kReboot));
  EXPECT_EQ(std::get<u::Unsigned>(b.decode(b.exchange(rq::get(FC::kAC))).body).value, 1000U);
  b.send(rq::driver_on(false));
  b.send(rq::set_acceleration(500));  // driver off: EEPROM
  b.send(rq::system(u::SystemOperation::kReboot));
  EXPECT_EQ(std::get<u::Unsigned>(b.decode(b.exchange(rq::get(FC::kAC))).body).value, 500U);
}

TEST(SimUim342Reboot, FactoryDefaultsRestoreTheSetUpButKeepTheAddress) {
  Bench b(plain_drive());
  b.send(rq::driver_on(false));
  b.send(rq::set_acceleration(500));
  b.send(rq::set(u::ProtocolParameter::kGroupId, 33));
  b.send(rq::system(u::SystemOperation::kRestoreFactoryDefaults));
  EXPECT_EQ(std::get<u::Unsigned>(b.decode(b.exchange(rq::get(FC::kAC))).body).value, 1000U);
  EXPECT_EQ(std::get<u::IndexedByte>(b.decode(b.exchange(rq::get(u::ProtocolParameter::kGroupId))).body).value, 33);
  EXPECT_TRUE(b.sim->driver_on());  // auto_enable of the set-up
}

TEST(SimUim342Reboot, NodeIdChangesAtTheNextReboot) {
  Bench b(plain_drive());
  b.send(rq::set(u::ProtocolParameter::kNodeId, 9));
  EXPECT_EQ(b.sim->node_id(), 5);
  b.send(rq::system(u::SystemOperation::kReboot));
  EXPECT_EQ(b.sim->node_id(), 9);
  b.node = 9;
  EXPECT_EQ(b.exchange(rq::get(FC::kMO)).id, 0x09200015U);
}

TEST(SimUim342Reboot, AutoEnableWaitsForTheMt3Delay) {
  Bench b(plain_drive());
  b.send(rq::driver_on(false));
  b.send(rq::set(u::MotorDriver::kAutoEnableDelayMs, 500));
  b.send(rq::system(u::SystemOperation::kReboot));
  EXPECT_FALSE(b.sim->driver_on());
  EXPECT_EQ(b.advance_to(b.now), b.at(0.5));
  b.advance_to(b.at(0.5));
  EXPECT_TRUE(b.sim->driver_on());
}

TEST(SimUim342Identity, DerivedFromTheConfiguration) {
  const auto id = uim342_identity(uim342_drive("i", 7, 0, {{"current_a", 3.0}}), 500000);
  EXPECT_EQ(id.model_bytes[1], 0x28);  // 342C04: 4.0 A peak covers 3.0 A
  EXPECT_EQ(id.bit_rate_code, 2);
  EXPECT_EQ(id.serial & 0xFFU, 7U);
}

}  // namespace
}  // namespace motion::sim
