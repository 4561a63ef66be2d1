// The simulated UC57 (services/sim/uc57) on the CANopen side, frame by frame with the manual's and
// derived frames: boot-up, NMT and heartbeat, SDO with abort codes, PDO remapping and the manual's
// RO markings, synchronous start of two drives by one SYNC and its variants, synchronous TPDOs
// (bench: uc57_drive_bench.hpp).
#include "uc57_drive_bench.hpp"

namespace motion::sim::uc57_test {
namespace {

TEST(Uc57Sim, BootUpOnPowerUpThenPreOperational) {
  Drive drive;
  EXPECT_EQ(drive.take(), Texts{"701: 00"});  // D-17
  EXPECT_EQ(drive.reports_of(motionlcm::sim_report_t::POWERED_UP).size(), 1u);
  EXPECT_EQ(drive.sim().nmt_state(), canopen::NmtState::kPreOperational);
  EXPECT_EQ(drive.sim().drive_state(), cia402::State::kSwitchOnDisabled);
  EXPECT_EQ(drive.statusword(), 0x0040);  // Switch on disabled (manual §4.2.1)
}

TEST(Uc57Sim, ManualPowerOnSequenceM01ToM05) {
  Drive drive;
  drive.take();
  EXPECT_EQ(drive.deliver("00: 01 00").size(), 2u);  // M-01 -> Operational: TPDO1 and TPDO2 go out
  EXPECT_EQ(drive.sim().nmt_state(), canopen::NmtState::kOperational);
  struct Step {
    const char* request;
    std::uint16_t low_bits;  // statusword bits 3..0 in the manual's column
  };
  for (const Step& step : {Step{"601: 2B 40 60 00 00 00 00 00", 0x0}, Step{"601: 2B 40 60 00 06 00 00 00", 0x1},
                           Step{"601: 2B 40 60 00 07 00 00 00", 0x3}, Step{"601: 2B 40 60 00 0F 00 00 00", 0x7}}) {
    const Texts out = drive.deliver(step.request);
    ASSERT_FALSE(out.empty());
    EXPECT_EQ(out[0], "581: 60 40 60 00 00 00 00 00") << step.request;
    EXPECT_EQ(drive.statusword() & 0x0F, step.low_bits) << step.request;
  }
  EXPECT_EQ(drive.sim().drive_state(), cia402::State::kOperationEnabled);
  EXPECT_TRUE(bit(drive.statusword(), cia402::StatusBit::kMotorEnabled));
}

TEST(Uc57Sim, SdoReadsOfTheObjectDictionary) {
  Drive drive;
  drive.take();
  EXPECT_EQ(drive.deliver("601: 40 00 10 00 00 00 00 00"), Texts{"581: 43 00 10 00 92 01 04 00"});  // D-05
  EXPECT_EQ(drive.deliver("601: 40 18 10 01 00 00 00 00"), Texts{"581: 43 18 10 01 22 03 00 00"});  // D-06
  EXPECT_EQ(drive.deliver("601: 40 06 20 00 00 00 00 00"), Texts{"581: 4B 06 20 00 0D 00 00 00"});  // D-09
  EXPECT_EQ(drive.deliver("601: 40 14 10 00 00 00 00 00"), Texts{"581: 43 14 10 00 81 00 00 00"});  // C-11
  EXPECT_EQ(drive.deliver("601: 40 41 60 00 00 00 00 00"), Texts{"581: 4B 41 60 00 40 00 00 00"});
  EXPECT_EQ(drive.deliver("601: 40 00 20 00 00 00 00 00"), Texts{"581: 4B 00 20 00 01 00 00 00"});  // node-ID
}

TEST(Uc57Sim, SdoAbortCodes) {
  Drive drive;
  drive.take();
  EXPECT_EQ(drive.deliver("601: 2B 41 60 00 00 00 00 00"), Texts{"581: 80 41 60 00 02 00 01 06"});  // D-20
  EXPECT_EQ(drive.deliver("601: 40 5A 60 00 00 00 00 00"), Texts{"581: 80 5A 60 00 00 00 02 06"});  // D-21
  EXPECT_EQ(drive.deliver("601: 40 99 60 03 00 00 00 00"), Texts{"581: 80 99 60 03 11 00 09 06"});  // D-22
  EXPECT_EQ(drive.deliver("601: 23 99 60 00 78 00 00 00"), Texts{"581: 80 99 60 00 02 00 01 06"});  // D-23
  EXPECT_EQ(drive.deliver("601: 23 81 60 00 00 00 00 00"), Texts{"581: 80 81 60 00 32 00 09 06"});  // D-24
  EXPECT_EQ(drive.deliver("601: 23 40 60 00 0F 00 00 00"), Texts{"581: 80 40 60 00 10 00 07 06"});  // D-25
  EXPECT_EQ(drive.deliver("601: 23 81 60 00 E9 03 00 00"), Texts{"581: 80 81 60 00 31 00 09 06"});  // 1001 RPM
  EXPECT_EQ(drive.deliver("601: 2F 60 60 00 02 00 00 00"), Texts{"581: 80 60 60 00 30 00 09 06"});
  EXPECT_EQ(drive.deliver("601: 40 08 10 00 00 00 00 00"), Texts{"581: 80 08 10 00 00 00 02 06"});  // no 1008h
  EXPECT_EQ(drive.deliver("601: 2F 00 14 02 F5 00 00 00"), Texts{"581: 80 00 14 02 30 00 09 06"});  // type 245
  // Segmented download of 6081h (D-26) works like the expedited one.
  EXPECT_EQ(drive.deliver("601: 21 81 60 00 04 00 00 00"), Texts{"581: 60 81 60 00 00 00 00 00"});
  EXPECT_EQ(drive.deliver("601: 07 78 00 00 00 00 00 00"), Texts{"581: 20 00 00 00 00 00 00 00"});
  EXPECT_EQ(drive.deliver("601: 40 81 60 00 00 00 00 00"), Texts{"581: 43 81 60 00 78 00 00 00"});
}

TEST(Uc57Sim, NmtStatesHeartbeatAndResets) {
  Drive drive;
  drive.take();
  EXPECT_EQ(drive.deliver("601: 2B 17 10 00 E8 03 00 00"), Texts{"581: 60 17 10 00 00 00 00 00"});  // D-19
  drive.advance_to(t0 + 1000ms);
  EXPECT_EQ(drive.take(), Texts{"701: 7F"});
  drive.deliver("000: 01 01");  // D-12
  drive.take();
  drive.advance_to(t0 + 2000ms);
  EXPECT_EQ(drive.take(), Texts{"701: 05"});  // D-18
  drive.deliver("000: 02 00");                // stop: SDO is not served
  EXPECT_TRUE(drive.deliver("601: 40 41 60 00 00 00 00 00").empty());
  drive.advance_to(t0 + 3000ms);
  EXPECT_EQ(drive.take(), Texts{"701: 04"});
  EXPECT_TRUE(drive.deliver("000: 01 02").empty());  // another node
  drive.deliver("000: 82 01");                       // reset communication: boot-up, 1017h back to 0
  EXPECT_EQ(drive.take(), Texts{});
  EXPECT_EQ(drive.sim().nmt_state(), canopen::NmtState::kPreOperational);
  drive.advance_to(t0 + 5000ms);
  EXPECT_TRUE(drive.take().empty());
}

TEST(Uc57Sim, ResetCommunicationSendsBootUp) {
  Drive drive;
  drive.take();
  EXPECT_EQ(drive.deliver("000: 82 01"), Texts{"701: 00"});
  EXPECT_EQ(drive.deliver("000: 81 00"), Texts{"701: 00"});
}

TEST(Uc57Sim, TpdosOnStartAndRpdosOnlyWhenOperational) {
  Drive drive;
  drive.take();
  EXPECT_TRUE(drive.deliver("201: 06 00 00 00 00 00 01").empty());  // pre-operational: dropped
  EXPECT_EQ(drive.sim().drive_state(), cia402::State::kSwitchOnDisabled);
  EXPECT_EQ(drive.deliver("000: 01 00"), (Texts{"181: 40 00 00 00 00 00 00", "281: 00 00 00 00 00 00 00 00"}));
  // Default RPDO1 (type 255) applies at once: Shutdown; TPDO1 follows the change.
  EXPECT_EQ(drive.deliver("201: 06 00 00 00 00 00 01"), Texts{"181: 21 00 00 00 00 00 01"});
  EXPECT_EQ(drive.sim().drive_state(), cia402::State::kReadyToSwitchOn);
  // A short RPDO is not processed: EMCY 8210h.
  const Texts short_pdo = drive.deliver("201: 07 00");
  ASSERT_EQ(short_pdo.size(), 1u);
  EXPECT_EQ(short_pdo[0].substr(0, 10), "081: 10 82");
}

TEST(Uc57Sim, RemapRpdo1AsControlwordAndTargetD30ToD38) {
  Drive drive;
  drive.take();
  EXPECT_TRUE(drive.deliver("000: 80 01").empty());                                                 // D-30
  EXPECT_EQ(drive.deliver("601: 23 00 14 01 01 02 00 80"), Texts{"581: 60 00 14 01 00 00 00 00"});  // D-31
  EXPECT_EQ(drive.deliver("601: 2F 00 16 00 00 00 00 00"), Texts{"581: 60 00 16 00 00 00 00 00"});  // D-32
  EXPECT_EQ(drive.deliver("601: 23 00 16 01 10 00 40 60"), Texts{"581: 60 00 16 01 00 00 00 00"});  // D-33
  EXPECT_EQ(drive.deliver("601: 23 00 16 02 20 00 7A 60"), Texts{"581: 60 00 16 02 00 00 00 00"});  // D-34
  EXPECT_EQ(drive.deliver("601: 2F 00 16 00 02 00 00 00"), Texts{"581: 60 00 16 00 00 00 00 00"});  // D-35
  EXPECT_EQ(drive.deliver("601: 2F 00 14 02 01 00 00 00"), Texts{"581: 60 00 14 02 00 00 00 00"});  // D-36
  EXPECT_EQ(drive.deliver("601: 23 00 14 01 01 02 00 00"), Texts{"581: 60 00 14 01 00 00 00 00"});  // D-37
  // Remap errors: unmappable object, wrong length, mapping too long, entry change while active.
  EXPECT_EQ(drive.deliver("601: 23 00 16 03 20 00 41 60"), Texts{"581: 80 00 16 03 00 00 01 06"});
  drive.deliver("601: 2F 00 16 00 00 00 00 00");
  EXPECT_EQ(drive.deliver("601: 23 00 16 03 20 00 41 60"), Texts{"581: 80 00 16 03 41 00 04 06"});  // 6041h RO
  EXPECT_EQ(drive.deliver("601: 23 00 16 03 10 00 7A 60"), Texts{"581: 80 00 16 03 41 00 04 06"});  // 16 bits
  drive.deliver("601: 23 00 16 03 20 00 81 60");
  drive.deliver("601: 23 00 16 04 20 00 FF 60");
  EXPECT_EQ(drive.deliver("601: 2F 00 16 00 04 00 00 00"), Texts{"581: 80 00 16 00 42 00 04 06"});  // 112 bits
  EXPECT_EQ(drive.deliver("601: 2F 00 16 00 02 00 00 00"), Texts{"581: 60 00 16 00 00 00 00 00"});
  // A valid PDO's COB-ID cannot change without disabling it first.
  EXPECT_EQ(drive.deliver("601: 23 00 14 01 11 02 00 00"), Texts{"581: 80 00 14 01 30 00 09 06"});

  drive.deliver("000: 01 01");  // D-38
  drive.take();
  drive.sdo_ok("601: 2F 60 60 00 01 00 00 00");
  drive.enable();
  drive.deliver("201: 0F 00 10 27 00 00");
  drive.deliver("080:");
  drive.take();
  // D-29: buffered (type 1), no motion until the SYNC.
  drive.now += 5ms;
  drive.deliver("201: 1F 00 10 27 00 00");
  EXPECT_TRUE(drive.reports_of(kStarted).empty());
  drive.now += 5ms;
  drive.deliver("080:");
  const auto started = drive.reports_of(kStarted);
  ASSERT_EQ(started.size(), 1u);
  EXPECT_EQ(started[0].frame_utime, utime_of(drive.now));
  EXPECT_EQ(started[0].target, 10000);
}

TEST(Uc57Sim, ManualRoMarkingsWhenTheCiASwitchIsOff) {
  Uc57SimOptions strict;
  strict.pdo_configuration_writable = false;
  Drive drive(1, strict);
  drive.take();
  EXPECT_EQ(drive.deliver("601: 23 00 14 01 01 02 00 80"), Texts{"581: 80 00 14 01 02 00 01 06"});  // D-31 refused
  EXPECT_EQ(drive.deliver("601: 2F 00 16 00 00 00 00 00"), Texts{"581: 80 00 16 00 02 00 01 06"});  // D-32 refused
  EXPECT_EQ(drive.deliver("601: 2F 00 14 02 01 00 00 00"), Texts{"581: 60 00 14 02 00 00 00 00"});  // type is RW/S
}

// Synchronous RPDO1 (CiA 301 §7.2.2, §7.2.5), targets preloaded by RPDO2, one SYNC starts both axes;
// steps 0.x set up, 1.x start (our sequence, not the manual's).
TEST(Uc57Sim, TwoDrivesStartedByOneSync) {
  Drive a(1);
  Drive b(2);
  for (Drive* d : {&a, &b}) {
    d->take();
    d->sdo_ok(d->for_node("0: 2F 00 14 02 01 00 00 00").c_str());  // 0.2 RPDO1 type 1
    d->sdo_ok(d->for_node("0: 2F 60 60 00 01 00 00 00").c_str());  // 0.5 PP
    d->deliver("000: 01 00");                                      // 0.7
    d->enable();                                                   // 0.8
  }
  const auto both = [&](const char* text) {
    a.deliver(text);
    b.deliver(text);
  };
  a.deliver("201: 0F 00 00 00 00 00 01");  // 0.9 prime
  b.deliver("202: 0F 00 00 00 00 00 01");
  both("080:");
  a.deliver("301: 10 27 00 00 3C 00 00 00");  // 1.1: D-42 (10000 at 60 RPM)
  b.deliver("302: 80 F3 FF FF 78 00 00 00");  //       D-42b (-3200 at 120 RPM)
  a.deliver("201: 1F 00 00 00 00 00 01");     // 1.2: queued
  b.deliver("202: 1F 00 00 00 00 00 01");
  a.now = b.now = t0 + 20ms;
  EXPECT_TRUE(a.reports_of(kStarted).empty());
  EXPECT_FALSE(bit(a.statusword(), cia402::StatusBit::kSetPointAcknowledge));
  both("080:");  // 1.4
  const auto started_a = a.reports_of(kStarted);
  const auto started_b = b.reports_of(kStarted);
  ASSERT_EQ(started_a.size(), 1u);
  ASSERT_EQ(started_b.size(), 1u);
  EXPECT_EQ(started_a[0].frame_utime, utime_of(t0 + 20ms));
  EXPECT_EQ(started_b[0].frame_utime, started_a[0].frame_utime);
  EXPECT_EQ(started_a[0].target, 10000);
  EXPECT_EQ(started_b[0].target, -3200);
  // 1.5: acknowledged, echo of bit 4, running.
  const std::uint16_t status = a.statusword();
  EXPECT_TRUE(bit(status, cia402::StatusBit::kSetPointAcknowledge));
  EXPECT_TRUE(bit(status, cia402::StatusBit::kNewSetPointEcho));
  // 1.6 clears bit 4 at the next SYNC; 1.7 waits for completion.
  a.deliver("201: 0F 00 00 00 00 00 01");
  b.deliver("202: 0F 00 00 00 00 00 01");
  both("080:");
  EXPECT_FALSE(bit(a.statusword(), cia402::StatusBit::kSetPointAcknowledge));
  a.advance_to(t0 + 10s);
  b.advance_to(t0 + 10s);
  EXPECT_EQ(a.sim().position(a.now), 10000);
  EXPECT_EQ(b.sim().position(b.now), -3200);
  EXPECT_EQ(a.reports_of(kFinished).size(), 1u);
  EXPECT_TRUE(bit(b.statusword(), cia402::StatusBit::kTargetReached));
}

TEST(Uc57Sim, SyncUnsupportedSwitchAppliesRpdosAtOnce) {
  Uc57SimOptions options;
  options.rpdo_sync =
      sim::RpdoSync::kOnReception;  // the synchronous-RPDO acceptance test then fails, as on such a drive
  Drive drive(1, options);
  drive.sdo_ok("601: 2F 00 14 02 01 00 00 00");
  drive.sdo_ok("601: 2F 60 60 00 01 00 00 00");
  drive.deliver("000: 01 00");
  drive.enable();
  drive.deliver("201: 0F 00 00 00 00 00 01");
  drive.deliver("201: 1F 00 00 00 00 00 01");
  EXPECT_EQ(drive.reports_of(kStarted).size(), 1u);
}

// rpdo_sync: refused. Type 1 to 1400h:02 is aborted with 0609 0030h (value range); the manual's
// default FFh is accepted, and such an RPDO applies when it arrives.
TEST(Uc57Sim, RefusedVariantAbortsSynchronousRpdoTransmissionType) {
  Uc57SimOptions options;
  options.rpdo_sync = sim::RpdoSync::kRefused;
  Drive drive(1, options);
  drive.take();
  EXPECT_EQ(drive.deliver("601: 2F 00 14 02 01 00 00 00"), Texts{"581: 80 00 14 02 30 00 09 06"});
  drive.sdo_ok("601: 2F 00 14 02 FF 00 00 00");
  drive.sdo_ok("601: 2F 01 18 02 01 00 00 00");  // synchronous TPDOs are not affected
  drive.sdo_ok("601: 2F 60 60 00 01 00 00 00");
  drive.deliver("000: 01 00");
  drive.enable();
  drive.deliver("201: 0F 00 00 00 00 00 01");
  drive.deliver("201: 1F 00 00 00 00 00 01");
  EXPECT_EQ(drive.reports_of(kStarted).size(), 1u);
}

// rpdo_sync: honoured. A type-1 RPDO waits for the SYNC.
TEST(Uc57Sim, HonouredVariantAppliesSynchronousRpdoAtSync) {
  Drive drive(1);
  drive.sdo_ok("601: 2F 00 14 02 01 00 00 00");
  drive.sdo_ok("601: 2F 60 60 00 01 00 00 00");
  drive.deliver("000: 01 00");
  drive.enable();
  drive.deliver("201: 0F 00 00 00 00 00 01");
  drive.deliver("080:");
  drive.deliver("201: 1F 00 00 00 00 00 01");
  EXPECT_EQ(drive.reports_of(kStarted).size(), 0u);
  drive.deliver("080:");
  EXPECT_EQ(drive.reports_of(kStarted).size(), 1u);
}

TEST(Uc57Sim, SynchronousTpdoEverySync) {
  Drive drive;
  drive.take();
  drive.sdo_ok("601: 2F 00 18 02 01 00 00 00");  // TPDO1 type 1 (CiA 301 §7.5.2.37)
  drive.sdo_ok("601: 2F 00 18 02 02 00 00 00");  // then every 2nd SYNC
  drive.deliver("000: 01 00");
  drive.take();
  EXPECT_TRUE(drive.deliver("080:").empty());
  EXPECT_EQ(drive.deliver("080:"), Texts{"181: 40 00 00 00 00 00 00"});
}

// Type n sends at every n-th SYNC counted from the entry into Operational, and a written type
// restarts the count (as CANopenNode does; CiA 301 leaves it to the device): what staggered TPDOs
// set each node's slot with.
TEST(Uc57Sim, SynchronousTpdoCountsFromTheStartAndFromATypeWrite) {
  Drive drive;
  drive.take();
  drive.sdo_ok("601: 2F 00 18 02 03 00 00 00");  // TPDO1 every 3rd SYNC
  drive.deliver("080:");                         // pre-operational: not counted
  drive.deliver("000: 01 00");
  drive.take();
  EXPECT_TRUE(drive.deliver("080:").empty());
  EXPECT_TRUE(drive.deliver("080:").empty());
  EXPECT_EQ(drive.deliver("080:").size(), 1u) << "the 3rd SYNC after the NMT start";
  EXPECT_TRUE(drive.deliver("080:").empty());
  drive.sdo_ok("601: 2F 00 18 02 03 00 00 00");  // the same type again: the count restarts here
  EXPECT_TRUE(drive.deliver("080:").empty());
  EXPECT_TRUE(drive.deliver("080:").empty());
  EXPECT_EQ(drive.deliver("080:").size(), 1u) << "the 3rd SYNC after the write, not after the last send";
  // Types 241..253 (reserved, RTR-only) are refused; 0 (acyclic synchronous) and 254/255 are taken.
  for (const char* type : {"F1", "FB", "FC", "FD"}) {
    const std::string request = std::string("601: 2F 00 18 02 ") + type + " 00 00 00";
    const auto answer = drive.deliver(request.c_str());
    ASSERT_EQ(answer.size(), 1u);
    EXPECT_EQ(answer[0].substr(0, 8), "581: 80 ") << type;
  }
  drive.sdo_ok("601: 2F 00 18 02 00 00 00 00");
  drive.sdo_ok("601: 2F 00 18 02 FE 00 00 00");
}

}  // namespace
}  // namespace motion::sim::uc57_test
