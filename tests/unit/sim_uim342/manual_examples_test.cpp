// The manual's example frames (§2.4, §2.5, §5.1-§5.28; normalized rows, and corrected rows where
// the printing contradicts the text) played against the simulator: each instruction row must
// produce exactly the ACK row, byte for byte and with the reply identifier (producer = node 5,
// consumer = host 4).
// The drive is set up so that its state matches the one the manual's examples show (node 5,
// group 10, IC[0] = 1, 2.8 A, 16 micro-steps, BL 1000, model 342XS, serial 01 02 03 04 ...).
#include <gtest/gtest.h>

#include <string_view>

#include "sim_support.hpp"

namespace motion::sim {
namespace {

using namespace test;
namespace u = uim342;
namespace rq = uim342::request;

config::Drive manual_drive() {
  return uim342_drive("x", 5, 10,
                      {{"auto_enable", true}, {"current_a", 2.8}, {"micro_steps", 16LL}, {"backlash", 1000LL}});
}

Uim342Identity manual_identity() {
  Uim342Identity id;
  id.model_bytes = {0x20, 0x0A, 0x11, 0x00};  // 342XS, firmware 0 as in the §5.4 example
  id.firmware = 0;
  id.serial = 0x04030201;
  id.manufacturer = 0x0605;
  id.vendor = 0x0807;
  return id;
}

class ManualExamples : public ::testing::Test {
 protected:
  Bench bench{manual_drive(), manual_identity()};

  // One INST row in, exactly the ACK row out.
  void expect_ack(std::string_view instruction, std::string_view ack) {
    const auto replies = bench.deliver(instruction_row(instruction));
    ASSERT_EQ(replies.size(), 1U) << "INST " << instruction;
    EXPECT_EQ(replies[0], reply_row(ack)) << "INST " << instruction << "\n got  " << can::to_cansend(replies[0])
                                          << "\n want " << can::to_cansend(reply_row(ack));
  }
  void run(const u::Instruction& instruction) { bench.send(instruction); }
  void ptp_to(std::int32_t target) {
    run(rq::set_absolute_position(target));
    run(rq::set_ptp_speed(2000));
    run(rq::begin());
    bench.settle();
    bench.take();
  }
};

TEST_F(ManualExamples, ReplyIdentifiersAreProducer5ToHost4) {
  const auto replies = bench.deliver(instruction_row("05 95 00"));
  ASSERT_EQ(replies.size(), 1U);
  EXPECT_EQ(replies[0].id, 0x05200015U);  // §2.5 layout, producer 5, consumer 4: MO ACK from node 5
  EXPECT_TRUE(replies[0].extended);
}

TEST_F(ManualExamples, ProtocolParameters) {
  expect_ack("05 81 01 08 00 00 00 00 00 00 00", "05 01 02 08 0A 00 00 00 00 00 00");  // PP[8] = 10
  expect_ack("05 81 02 05 02 00 00 00 00 00 00", "05 01 02 05 02 00 00 00 00 00 00");  // PP[5]=2
}

TEST_F(ManualExamples, InitialConfigurationAndInformationEnable) {
  expect_ack("05 86 01 00 00 00 00 00 00 00 00", "05 06 03 00 01 00 00 00 00 00 00");  // IC[0] = 1
  expect_ack("05 86 03 06 01 00 00 00 00 00 00", "05 06 03 06 01 00 00 00 00 00 00");  // IC[6]=1
  run(rq::set(u::InformationEnable::kIn1Change, true));
  expect_ack("05 87 01 00 00 00 00 00 00 00 00", "05 07 03 00 01 00 00 00 00 00 00");  // IE[0] = 1
  expect_ack("05 87 03 01 01 00 00 00 00 00 00",
             "05 07 03 01 01 00 00 00 00 00 00");  // IE[1]=1 (§5.3: the byte, not the caption)
}

TEST_F(ManualExamples, ModelAndSerialNumber) {
  expect_ack("05 8B 00 00 00 00 00 00 00 00 00", "05 0B 08 20 0A 11 00 00 00 00 00");
  expect_ack("05 8C 00 00 00 00 00 00 00 00 00", "05 0C 08 01 02 03 04 05 06 07 08");
}

TEST_F(ManualExamples, ErrorReportAndErrorHistory) {
  // PP[5]=7 is illegal: the report is the frame the ER[0] example reads back (§5.6, §2.3).
  expect_ack("05 81 02 05 07", "05 0F 06 00 33 81 05 00 00 00 00");
  expect_ack("05 8F 01 00 00 00 00 00 00 00 00", "05 0F 06 00 33 81 05 00 00 00 00");  // get ER[0]
  expect_ack("05 8F 02 00 00 00 00 00 00 00 00", "05 0F 06 00 00 00 00 00 00 00 00");  // ER[0]=0
  expect_ack("05 8F 01 00", "05 0F 06 00 00 00 00 00 00");
}

TEST_F(ManualExamples, EncoderAndDriverParameters) {
  expect_ack("05 BD 01 04 00 00 00 00 00 00 00", "05 3D 03 04 80 0C 00 00 00 00 00");  // QE[4] = 3200 (§5.7 get, DL 1)
  expect_ack("05 BD 03 00 E8 03 00 00 00 00 00", "05 3D 03 00 E8 03 00 00 00 00 00");  // QE[0]=1000
  expect_ack("05 90 01 01 00 00 00 00 00 00 00", "05 10 03 01 1C 00 00 00 00 00 00");  // MT[1] = 2.8 A
  expect_ack("05 90 03 00 10 00 00 00 00 00 00", "05 10 03 00 10 00 00 00 00 00 00");  // MT[0]=16 (§5.9 set, DL 3)
}

TEST_F(ManualExamples, MotorDriverOnOff) {
  expect_ack("05 95 00 00 00 00 00 00 00 00 00", "05 15 01 01 00 00 00 00 00 00 00");  // on (IC[0] = 1)
  expect_ack("05 95 01 00 00 00 00 00 00 00 00", "05 15 01 00 00 00 00 00 00 00 00");  // MO=0
  EXPECT_FALSE(bench.sim->driver_on());
  expect_ack("05 95 01 01", "05 15 01 01");  // §2.5: MO=1
  EXPECT_TRUE(bench.sim->driver_on());
}

TEST_F(ManualExamples, RampsCutInStopDecelerationBacklash) {
  expect_ack("05 99 00 00 00 00 00 00 00 00 00", "05 19 04 E8 03 00 00 00 00 00 00");  // AC = 1000
  expect_ack("05 99 04 F4 01 00 00 00 00 00 00", "05 19 04 F4 01 00 00 00 00 00 00");  // AC=500 (§5.14 set, DL 4)
  expect_ack("05 9A 00 00 00 00 00 00 00 00 00", "05 1A 04 E8 03 00 00 00 00 00 00");  // DC = 1000
  expect_ack("05 9A 04 E9 03 00 00 00 00 00 00", "05 1A 04 E9 03 00 00 00 00 00 00");  // DC=1001
  expect_ack("05 9B 00 00 00 00 00 00 00 00 00", "05 1B 04 E8 03 00 00 00 00 00 00");  // SS = 1000
  expect_ack("05 9B 04 E9 03 00 00 00 00 00 00", "05 1B 04 E9 03 00 00 00 00 00 00");  // SS=1001
  expect_ack("05 9C 00 00 00 00 00 00 00 00 00", "05 1C 04 00 6A 18 00 00 00 00 00");  // SD = 1 600 000
  expect_ack("05 9C 04 00 6A 18 00 00 00 00 00", "05 1C 04 00 6A 18 00 00 00 00 00");  // SD=1 600 000
  expect_ack("05 AD 00 00 00 00 00 00 00 00 00", "05 2D 04 E8 03 00 00 00 00 00 00");  // BL = 1000
  expect_ack("05 AD 04 E9 03 00 00 00 00 00 00", "05 2D 04 E9 03 00 00 00 00 00 00");  // BL=1001
}

TEST_F(ManualExamples, ParameterFrameSelectsAGroupForOneInstruction) {
  expect_ack("05 98 01 03 00 00 00 00 00 00 00", "05 18 01 03 00 00 00 00 00 00 00");  // MF=3
  expect_ack("05 99 04 88 13 00 00", "05 19 04 88 13 00 00");                          // AC=5000 into group 3
  expect_ack("05 98 00", "05 18 01 00");                                               // MF is back to 0
  expect_ack("05 99 00", "05 19 04 E8 03 00 00");                                      // group 0 untouched
  run(rq::select_group(u::ParameterGroup::kIn1Falling));
  expect_ack("05 99 00", "05 19 04 88 13 00 00");
}

TEST_F(ManualExamples, JogVelocityAndActualSpeed) {
  expect_ack("05 9D 04 18 FC FF FF 00 00 00 00", "05 2E 05 02 18 FC FF FF 00 00 00");  // JV=-1000 -> DV[2]
  expect_ack("05 96 00 00 00 00 00 00 00 00 00", "05 16 04 00 00 00 00 00 00 00 00");  // BG
  bench.advance_to(bench.at(1.0));
  expect_ack("05 9E 00 00 00 00 00 00 00 00 00", "05 1E 04 18 FC FF FF 00 00 00 00");  // SP: speed -1000
  run(rq::set_jog_velocity(1000));
  run(rq::begin());
  bench.advance_to(bench.at(5.0));
  expect_ack("05 9D 00 00 00 00 00 00 00 00 00", "05 1D 04 E8 03 00 00 00 00 00 00");  // JV: speed 1000
  expect_ack("05 97 00 00 00 00 00 00 00 00 00", "05 17 00 00 00 00 00 00 00 00 00");  // ST
}

TEST_F(ManualExamples, PositionsAndDesiredValues) {
  expect_ack("05 9F 04 18 FC FF FF", "05 2E 05 03 18 FC FF FF");  // PR=-1000 -> DV[3]
  run(rq::set_ptp_speed(2000));
  run(rq::begin());
  bench.settle();
  bench.take();
  expect_ack("05 9F 00 00 00 00 00 00 00 00 00", "05 1F 04 18 FC FF FF 00 00 00 00");  // PR: -1000
  expect_ack("05 A0 00 00 00 00 00 00 00 00 00", "05 20 04 18 FC FF FF 00 00 00 00");  // PA: -1000
  expect_ack("05 9F 04 E8 03 00 00 00 00 00 00", "05 2E 05 03 E8 03 00 00 00 00 00");  // PR=+1000 (§5.20, CW 9F)
  expect_ack("05 A0 04 E8 03 00 00 00 00 00 00", "05 2E 05 04 E8 03 00 00 00 00 00");  // PA=+1000
  expect_ack("05 9E 04 E8 03 00 00 00 00 00 00", "05 2E 05 02 E8 03 00 00 00 00 00");  // SP=+1000
  expect_ack("05 AE 01 02 00 00 00 00 00 00 00", "05 2E 05 02 E8 03 00 00 00 00 00");  // DV[2] (§5.25: bytes E8 03)
  expect_ack("05 A1 00 00 00 00 00 00 00 00 00", "05 21 00 00 00 00 00 00 00 00 00");  // OG
  expect_ack("05 A0 00", "05 20 04 00 00 00 00");
}

TEST_F(ManualExamples, Section25ShortPositiveValues) {
  // §2.5 sends positive 32-bit values in 2 bytes (§5.18-§5.21 define 4): zero-extended.
  expect_ack("05 9D 02 10 27", "05 2E 05 02 10 27 00 00");        // JV=10000
  expect_ack("05 9D 04 F0 D8 FF FF", "05 2E 05 02 F0 D8 FF FF");  // JV=-10000
  expect_ack("05 9F 02 80 0C", "05 2E 05 03 80 0C 00 00");        // PR=3200
  expect_ack("05 9F 04 80 F3 FF FF", "05 2E 05 03 80 F3 FF FF");  // PR=-3200
  expect_ack("05 A0 02 80 0C", "05 2E 05 04 80 0C 00 00");        // PA=3200
  expect_ack("05 A0 04 80 F3 FF FF", "05 2E 05 04 80 F3 FF FF");  // PA=-3200
  expect_ack("05 9E 02 80 0C", "05 2E 05 02 80 0C 00 00");        // SP=3200
}

TEST_F(ManualExamples, MotionStatus) {
  for (int input = 1; input <= 3; ++input)
    bench.sim->control(control(motionlcm::sim_control_t::SET_INPUT, input, 1), bench.now);
  run(rq::set_relative_position(-1000));
  run(rq::set_ptp_speed(2000));
  run(rq::begin());
  bench.settle();
  expect_ack("05 91 01 00 00 00 00 00 00 00 00", "05 11 08 00 3D 03 00 18 FC FF FF");  // PTP, in position, rel -1000
  expect_ack("05 91 02 00 00 00 00 00 00 00 00", "05 11 08 00 3D 01 00 00 00 00 00");  // MS[0]=0
  expect_ack("05 91 01 01", "05 11 08 01 00 00 00 18 FC FF FF");                       // MS[1]: speed 0, abs -1000
}

TEST_F(ManualExamples, InputLogicAndTrigger) {
  expect_ack("05 B4 03 00 06 80 00 00 00 00 00", "05 34 03 00 06 80 00 00 00 00 00");  // IL[0] set
  expect_ack("05 B4 01 00 00 00 00 00 00 00 00", "05 34 03 00 06 80 00 00 00 00 00");  // IL[0] get (§5.26: the bytes)
  expect_ack("05 B5 01 01 00 00 00 00 00 00 00",
             "05 35 03 01 00 00 00 00 00 00 00");  // TG[1] (§5.27 prints d0 = 00; echoes 01 like every sub-indexed ACK)
  expect_ack("05 B5 03 00 64 00 00 00 00 00 00", "05 35 03 00 64 00 00 00 00 00 00");  // TG[0]=100
  expect_ack("05 B4 01 10", "05 34 03 10 00 00");                                      // IL[16] stall: hold
}

TEST_F(ManualExamples, DigitalInputsAndOutput) {
  bench.sim->control(control(motionlcm::sim_control_t::SET_INPUT, 1, 1), bench.now);
  bench.sim->control(control(motionlcm::sim_control_t::SET_INPUT, 2, 1), bench.now);
  expect_ack("05 B7 00 00 00 00 00 00 00 00 00", "05 37 04 03 00 00 00 00 00 00 00");
  expect_ack("05 B7 04 01 01 00 00 00 00 00 00", "05 37 04 03 01 00 00 00 00 00 00");  // OP1 = 1 (§5.28: byte d1 = 01)
}

TEST_F(ManualExamples, SystemRebootHasNoAck) {
  EXPECT_TRUE(bench.deliver(instruction_row("05 7E 01 01 00 00 00 00 00 00 00")).empty());
  EXPECT_EQ(bench.reports_of(powered_up()).size(), 2U);  // power-up, then the reboot
}

// §2.4 notification rows, normalized (DL rule, §2.1).
TEST_F(ManualExamples, RealTimeNotifications) {
  using C = motionlcm::sim_control_t;
  for (std::uint8_t i = 0; i <= 2; ++i) run(rq::set(static_cast<u::InformationEnable>(i), true));
  run(rq::set(u::InformationEnable::kPositionReached, true));
  const auto expect_sent = [this](std::initializer_list<std::string_view> rows) {
    const auto sent = bench.take();
    ASSERT_EQ(sent.size(), rows.size());
    std::size_t i = 0;
    for (const auto row : rows) {
      EXPECT_EQ(sent[i].id, 0x0520005AU);
      EXPECT_EQ(sent[i++], reply_row(row)) << row;
    }
  };
  const std::pair<int, std::string_view> edges[] = {{1, "05 5A 01 02"}, {2, "05 5A 01 04"}, {3, "05 5A 01 06"}};
  for (const auto& [input, rising] : edges) {
    bench.sim->control(control(C::SET_INPUT, input, 1), bench.now);
    expect_sent({rising});
  }
  bench.sim->control(control(C::SET_INPUT, 1, 0), bench.now);
  expect_sent({"05 5A 01 01 00 00 00 00 00 00 00"});
  bench.sim->control(control(C::SET_INPUT, 2, 0), bench.now);
  expect_sent({"05 5A 01 03"});
  bench.sim->control(control(C::SET_INPUT, 3, 0), bench.now);
  expect_sent({"05 5A 01 05"});
  bench.sim->control(control(C::STALL), bench.now);
  expect_sent({"05 5A 05 00 1D 00 00 00 00 00 00"});
  const std::string_view alarms[] = {"05 5A 05 00 0A 00 00 00", "05 5A 05 00 19 00 00 00", "05 5A 05 00 1A 00 00 00",
                                     "05 5A 05 00 1B 00 00 00", "05 5A 05 00 1E 00 00 00", "05 5A 05 00 1F 00 00 00"};
  for (const auto row : alarms) {
    EXPECT_TRUE(bench.sim->control(control(C::ALARM, hex_bytes(row)[4]), bench.now));
    expect_sent({row});
  }
  // PTP finished with the position 0x00000BB8 = 3000, after a reboot clears the lock of alarm 0x0A.
  bench.send(rq::system(u::SystemOperation::kReboot));
  bench.send(rq::driver_on(true));
  for (std::uint8_t i = 0; i <= 2; ++i) run(rq::set(static_cast<u::InformationEnable>(i), false));
  run(rq::set(u::InformationEnable::kPositionReached, true));
  ptp_to(1000);  // the helper takes the notification of this one away
  run(rq::set_absolute_position(3000));
  run(rq::set_ptp_speed(2000));
  run(rq::begin());
  bench.settle();
  expect_sent({"05 5A 08 29 00 00 00 B8 0B 00 00"});
}

}  // namespace
}  // namespace motion::sim
