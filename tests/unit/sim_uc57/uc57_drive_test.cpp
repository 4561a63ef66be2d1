// The simulated UC57 (services/sim/uc57) driven frame by frame with the manual's and derived
// frames: boot-up, NMT, SDO with abort codes, PDO remapping, synchronous start of two drives by
// one SYNC, the profile-position handshake with its exact arrival time, profile velocity,
// homing, quick stop, faults with EMCY and fault reset, inputs.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "../canopen/frame_text.hpp"
#include "motion/cia402/uc57_homing.hpp"
#include "motion/cia402/uc57_units.hpp"
#include "motion/cia402/words.hpp"
#include "motion/sim/kinematics.hpp"
#include "motion/sim/uc57_drive.hpp"

namespace motion::sim {
namespace {

using namespace std::chrono_literals;
using canopen::test::frame;
using Texts = std::vector<std::string>;
namespace od = cia402::uc57;

const TimePoint t0 = TimePoint{} + 1h;
constexpr std::int64_t kEpochUs = 1'700'000'000'000'000;  // wall time of t0

std::int64_t utime_of(TimePoint t) {
  return kEpochUs + std::chrono::duration_cast<std::chrono::microseconds>(t - t0).count();
}

struct Report {
  std::int8_t kind;
  std::int64_t frame_utime;
  std::int64_t position;
  std::int64_t target;
};

// One simulated drive with a recording context and a manual clock.
class Drive {
 public:
  explicit Drive(canopen::NodeId node = 1, Uc57SimOptions options = {}) : node_(node), sim_(node, context(), options) {
    sim_.power_up(now);
  }

  // Delivers a frame at `now` (its end-of-frame time) and returns what the drive sent.
  Texts deliver(const char* text) {
    can::Frame f = frame(text);
    f.timestamp_us = utime_of(now);
    sim_.on_frame(f, now);
    return take();
  }
  // Moves the clock, running every deadline on the way, as the host's loop does.
  void advance_to(TimePoint until) {
    for (int guard = 0; guard < 10000; ++guard) {
      const TimePoint next = sim_.process(now);
      if (next > until) break;
      now = std::max(now, next);
    }
    now = until;
    sim_.process(now);
  }
  Texts take() {
    auto texts = canopen::test::to_texts(sent_);
    sent_.clear();
    return texts;
  }
  std::uint16_t statusword() const { return sim_.statusword(now); }
  std::vector<Report> reports_of(std::int8_t kind) const {
    std::vector<Report> out;
    for (const auto& r : reports_) {
      if (r.kind == kind) out.push_back(r);
    }
    return out;
  }
  // SDO write with the manual's frame, expecting the plain confirmation.
  // TPDOs that follow the change may go out too; exactly one SDO reply must be a confirmation.
  void sdo_ok(const char* request) {
    const std::string channel = "58" + std::to_string(node_) + ":";
    Texts replies;
    for (const auto& text : deliver(request)) {
      if (text.starts_with(channel)) replies.push_back(text);
    }
    ASSERT_EQ(replies.size(), 1u) << request;
    EXPECT_EQ(replies[0].substr(0, 6), channel + " 6") << request << " -> " << replies[0];
  }
  void enable() {
    for (const char* cw : {"0: 2B 40 60 00 06 00 00 00", "0: 2B 40 60 00 07 00 00 00", "0: 2B 40 60 00 0F 00 00 00"}) {
      sdo_ok(for_node(cw).c_str());
    }
  }
  // "0: ..." -> "60n: ..." for this node.
  std::string for_node(const char* sdo_tail) const {
    return "60" + std::to_string(node_) + std::string(sdo_tail).substr(1);
  }

  TimePoint now = t0;
  Uc57DriveSim& sim() { return sim_; }

 private:
  SimDriveContext context() {
    SimDriveContext c;
    c.drive = "axis";
    c.bus = "can0";
    c.send = [this](const can::Frame& f) { sent_.push_back(f); };
    c.report = [this](std::int8_t kind, std::int64_t utime, std::int64_t position, std::int64_t target) {
      reports_.push_back({kind, utime, position, target});
    };
    return c;
  }

  canopen::NodeId node_;
  std::vector<can::Frame> sent_;
  std::vector<Report> reports_;
  Uc57DriveSim sim_;
};

constexpr auto kStarted = motionlcm::sim_report_t::MOTION_STARTED;
constexpr auto kFinished = motionlcm::sim_report_t::MOTION_FINISHED;

bool bit(std::uint16_t word, cia402::StatusBit b) { return cia402::is_set(word, b); }

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

}  // namespace
}  // namespace motion::sim
