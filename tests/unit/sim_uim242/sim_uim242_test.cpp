// The simulated UIM2501 gateway + UIM242 controllers, driven byte for byte with explicit `now`.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include <motionlcm/sim_control_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "../uim242/hex.hpp"
#include "motion/sim/uim242_gateway_sim.hpp"

namespace motion::sim {
namespace {

using namespace std::chrono_literals;
using uim242::test::hex;

struct Report {
  std::string drive;
  std::int8_t kind;
  std::int64_t utime;
  std::int64_t position;
  std::int64_t target;
};

class SimUim242 : public ::testing::Test {
 protected:
  SimUim242()
      : sim_({{"u-drive", 5, 40, 1302}, {"v-drive", 6, 20, 1302}},
             Uim242SimContext{
                 "rs232", [this](std::span<const std::uint8_t> b) { wire_.insert(wire_.end(), b.begin(), b.end()); },
                 [this](const std::string& d, std::int8_t k, std::int64_t u, std::int64_t p, std::int64_t t) {
                   reports_.push_back({d, k, u, p, t});
                 },
                 [](TimePoint t) {
                   return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
                 }}) {
    sim_.power_up(now_);
    wire_.clear();
  }

  // Sends `text` and returns what the gateway wrote in reply.
  std::vector<std::uint8_t> send(std::string_view text) {
    wire_.clear();
    deadline_ = sim_.receive(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), now_);
    return take();
  }
  std::vector<std::uint8_t> take() {
    auto out = std::move(wire_);
    wire_.clear();
    return out;
  }
  void advance_to(TimePoint t) {
    now_ = t;
    deadline_ = sim_.process(now_);
  }
  std::size_t count(std::int8_t kind) const {
    std::size_t n = 0;
    for (const auto& r : reports_) n += r.kind == kind ? 1 : 0;
    return n;
  }
  void ramps(std::int64_t rate) {
    send("MAC " + std::to_string(rate) + ";MDE " + std::to_string(rate) + ";MMS 0;MMD 0;");
  }
  motionlcm::sim_control_t control(std::int8_t action, std::int32_t value = 0, std::int32_t level = 0) {
    motionlcm::sim_control_t c{};
    c.drive = "u-drive";
    c.action = action;
    c.value = value;
    c.level = level;
    return c;
  }

  TimePoint now_ = TimePoint{} + 1000s;
  TimePoint deadline_ = kNever;
  std::vector<std::uint8_t> wire_;
  std::vector<Report> reports_;
  Uim242GatewaySim sim_;
};

TEST_F(SimUim242, PowerUpGreetsAndReports) {
  std::vector<std::uint8_t> wire;
  std::vector<std::string> powered;
  Uim242GatewaySim sim(
      {{"u-drive", 5, 40, 1302}},
      Uim242SimContext{"rs232",
                       [&](std::span<const std::uint8_t> b) { wire.assign(b.begin(), b.end()); },
                       [&](const std::string& d, std::int8_t k, std::int64_t, std::int64_t, std::int64_t) {
                         if (k == motionlcm::sim_report_t::POWERED_UP) powered.push_back(d);
                       },
                       {}});
  sim.power_up(now_);
  EXPECT_EQ(wire, hex("AA AB AC 19 01 00 00 00 00 00 01 00 FF"));
  EXPECT_EQ(powered, std::vector<std::string>{"u-drive"});
}

TEST_F(SimUim242, FourInstructionsFourAcksEN23) {
  const auto out = send("CUR 20; MCS 16; SPD 5000; ENA;");
  // CUR, MCS: basic ACK; SPD: AA B5; ENA: basic ACK (enabled, running at 5000 pps desired).
  EXPECT_EQ(out, hex("AA 05 1F 14 00 00 00 00 00 00 00 00 FF "
                     "AA 05 1F 14 00 00 00 00 00 00 00 00 FF "
                     "AA 05 B5 00 27 08 FF "
                     "AA 05 3F 14 00 27 08 00 00 00 00 00 FF"));
}

TEST_F(SimUim242, MacroYieldsExactlyOneAckEN23) {
  EXPECT_EQ(send("{CUR 20; MCS 16; SPD 5000; ENA; };"), hex("AA 05 3F 14 00 27 08 00 00 00 00 00 FF"));
  EXPECT_TRUE(sim_.enabled("u-drive"));
}

TEST_F(SimUim242, MacroWithoutTrailingSemicolonYieldsNoAck) {
  EXPECT_TRUE(send("{CUR 20; MCS 16; SPD 5000; ENA; }").empty());
  EXPECT_EQ(send("FBK;").size(), 13u);  // macro mode ended
}

TEST_F(SimUim242, BytesInAnyChunking) {
  const std::string text = "MCF34611;SPD -1000;";
  for (const char c : text) sim_.receive(std::span(reinterpret_cast<const std::uint8_t*>(&c), 1), now_);
  EXPECT_EQ(take(), hex("AA 05 B0 02 0E 33 FF AA 05 B5 03 78 18 FF"));
}

TEST_F(SimUim242, ErrorsCN6) {
  EXPECT_EQ(send("CUR 81;"), hex("EE 66 FF"));
  EXPECT_EQ(send("XYZ;"), hex("EE 65 FF"));
  EXPECT_EQ(send("MCFx001;"), hex("EE 65 FF"));
  EXPECT_EQ(send(std::string(100, 'A') + ";"), hex("EE 65 FF"));
}

TEST_F(SimUim242, ErrorsInsideAMacroAreStillSent) {
  EXPECT_EQ(send("{CUR 99; };"), hex("EE 66 FF AA 05 1F 0A 00 00 00 00 00 00 00 00 FF"));
}

TEST_F(SimUim242, DerivedRepliesSpec63) {
  const std::pair<const char*, const char*> rows[] = {
      {"SPD 5000;", "AA 05 B5 00 27 08 FF"},
      {"SPD -1000;", "AA 05 B5 03 78 18 FF"},
      {"QER 500;", "AA 05 C2 00 03 74 FF"},
      {"SQT 150;", "AA 05 B8 00 00 00 01 16 FF"},
      {"ENA 1000;", "AA 05 A0 00 07 68 FF"},
      {"ENAxFFFF;", "AA 05 A0 00 07 68 FF"},
      {"MAC 300;", "AA 05 B1 00 00 00 00 02 2C FF"},
      {"ACR 30;", "AA 05 BA 1E FF"},
      {"DOU 1;", "AA 05 C1 01 FF"},
      {"STGx C8 00 00;", "AA 05 C9 00 01 48 00 00 00 00 00 00 FF"},
      {"STO2;", "AA 05 D1 FF"},
      {"MDL 5;", "CC 05 DE 18 02 28 73 00 0A 16 FF"},
      {"MDL 6;", "CC 06 DE 18 02 14 73 00 0A 16 FF"},
  };
  for (const auto& [instruction, reply] : rows) {
    SCOPED_TRACE(instruction);
    EXPECT_EQ(send(instruction), hex(reply));
  }
}

TEST_F(SimUim242, AnalogThresholdExampleEN811CN811) {
  EXPECT_EQ(send("OFF;").size(), 13u);
  EXPECT_EQ(send("MCF 32769;"), hex("AA 05 B0 02 00 01 FF"));
  EXPECT_EQ(send("MCF x0180;"), hex("AA 05 B0 02 00 01 FF"));
  send("SCF x2A0000;SCF 52419;SCF xEB0102;");
  EXPECT_EQ(send("SCF;"), hex("AA 05 C0 00 00 00 00 2A 03 6B 19 4C FF"));
}

TEST_F(SimUim242, LimitSwitchAndTtlExamplesEN810EN105) {
  send("OFF;SCF 8352;STO0;SPD 5000;STO5;SPD 5000;STO3;");
  send("MCF 8;SCF 40961;");
  EXPECT_EQ(send("SCF;"), hex("AA 05 C0 00 50 00 04 0A 00 00 00 00 FF"));
}

TEST_F(SimUim242, GatewayAddressingAndGlobals) {
  EXPECT_EQ(send("ADR 6;"), hex("AA 06 D0 FF"));
  EXPECT_EQ(send("SPD 100;"), hex("AA 06 B5 00 00 64 FF"));
  EXPECT_EQ(send("ADR 9;"), hex("AA 09 D0 FF"));
  EXPECT_TRUE(send("FBK;").empty());  // nobody at 9: the host times out
  EXPECT_EQ(send("gREG;"), hex("CC 02 D0 05 06 00 00 00 00 00 00 FF"));
  EXPECT_EQ(send("gOFF;"), hex("AA 02 AD FF"));
  EXPECT_EQ(send("gORG;"), hex("CC 02 AD FF"));
  EXPECT_EQ(send("ABC;"), hex("AA AB AC 19 01 00 00 00 00 00 01 00 FF"));
  EXPECT_EQ(send("BTR 2;"), hex("AA 02 BC FF"));
}

TEST_F(SimUim242, TrapezoidMoveEndsOnTargetWithCompletionRtcn) {
  send("MCF 1040;");  // CM + STPIE
  ramps(1000);
  send("ENA;SPD 1000;");  // VT: jogs at 1000 pps
  advance_to(now_ + 2s);
  send("SPD 0;");
  advance_to(deadline_);
  EXPECT_FALSE(sim_.moving("u-drive", now_));
  const std::int64_t start = sim_.position("u-drive", now_);
  EXPECT_EQ(start, 2000);  // 1 s up (500), 1 s at 1000 pps, 1 s down (500)
  reports_.clear();
  send("STP 2000;SPD 1000;");  // target first, then the speed starts the move
  // 1 s up (500 counts), 1000 counts at 1000 pps, 1 s down: arrival 3 s later.
  EXPECT_NEAR(std::chrono::duration<double>(deadline_ - now_).count(), 3.0, 1e-6);
  ASSERT_EQ(count(motionlcm::sim_report_t::MOTION_STARTED), 1u);
  advance_to(now_ + 1500ms);
  EXPECT_EQ(sim_.position("u-drive", now_), start + 1000);
  const auto fbk = uim242::decode_status(*uim242::parse_frame(send("FBK;")));
  EXPECT_EQ(fbk->speed, 1000);
  EXPECT_EQ(fbk->displacement, 1000);
  advance_to(deadline_);
  EXPECT_EQ(take(), hex("CC 05 A8 00 00 00 00 0F 50 FF"));  // CN form: open loop, displacement 2000
  EXPECT_EQ(sim_.position("u-drive", now_), start + 2000);
  EXPECT_EQ(count(motionlcm::sim_report_t::MOTION_FINISHED), 1u);
  EXPECT_EQ(reports_.back().position, start + 2000);
  EXPECT_EQ(deadline_, kNever);
}

TEST_F(SimUim242, PreloadedMovesStartOnOneGlobalSpeed) {
  send("MCF 1040;");
  ramps(2000);
  send("ENA;SPD 0;STP 500;ADR 6;MCF 1040;MAC 2000;MDE 2000;MMS 0;MMD 0;ENA;SPD 0;STP -300;");
  EXPECT_FALSE(sim_.moving("u-drive", now_));
  EXPECT_FALSE(sim_.moving("v-drive", now_));
  EXPECT_TRUE(reports_.size() == 2u);  // POWERED_UP only
  const TimePoint fire = now_;
  EXPECT_EQ(send("gSPD 400;"), hex("AA 02 AD FF"));
  ASSERT_EQ(count(motionlcm::sim_report_t::MOTION_STARTED), 2u);
  for (const auto& r : reports_) {
    if (r.kind == motionlcm::sim_report_t::MOTION_STARTED) { EXPECT_EQ(r.utime, fire.time_since_epoch() / 1us); }
  }
  advance_to(now_ + 10s);
  EXPECT_EQ(sim_.position("u-drive", now_), 500);
  EXPECT_EQ(sim_.position("v-drive", now_), -300);
  EXPECT_EQ(count(motionlcm::sim_report_t::MOTION_FINISHED), 2u);
}

TEST_F(SimUim242, StpZeroLeavesPositionModeWithoutCompletion) {
  send("MCF 1040;");
  ramps(1000);
  send("ENA;SPD 1000;STP 100000;");
  advance_to(now_ + 2s);
  send("STP 0;");
  advance_to(deadline_);
  EXPECT_FALSE(sim_.moving("u-drive", now_));
  EXPECT_TRUE(take().empty());  // no A8 for an aborted move (the manuals do not say: assumed)
  EXPECT_EQ(count(motionlcm::sim_report_t::MOTION_FINISHED), 1u);
  EXPECT_EQ(sim_.position("u-drive", now_), 2000);  // 500 up, 1000 cruise, 500 down
}

TEST_F(SimUim242, OffHaltsAtOnce) {
  ramps(1000);
  send("ENA;SPD 1000;STP 100000;");
  advance_to(now_ + 1s);
  send("OFF;");
  EXPECT_FALSE(sim_.moving("u-drive", now_));
  EXPECT_EQ(count(motionlcm::sim_report_t::MOTION_FINISHED), 1u);
  EXPECT_EQ(sim_.position("u-drive", now_), 500);
}

TEST_F(SimUim242, OrgSetsPositionAtRestOnly) {
  EXPECT_EQ(send("ORG 1234;"), hex("CC 05 B0 00 00 00 09 52 FF"));
  EXPECT_EQ(send("QEC;"), hex("CC 05 B1 00 00 00 09 52 FF"));
  ramps(1000);
  send("ENA;SPD 100;");
  advance_to(now_ + 100ms);
  EXPECT_EQ(send("ORG;"), hex("EE 66 FF"));
}

TEST_F(SimUim242, AbsoluteTargetByQec) {
  ramps(100000);
  send("ENA;SPD 1000;QEC -200;");
  advance_to(now_ + 5s);
  EXPECT_EQ(sim_.position("u-drive", now_), -200);
}

TEST_F(SimUim242, LimitSwitchEmergencyStopAndRtcn) {
  // S1 falling = e-stop (0100) with S1IE: the switch halts the motor and notifies.
  send("MCF 1025;SCF 64;");
  ramps(1000);
  send("ENA;SPD -500;");
  advance_to(now_ + 2s);
  take();
  EXPECT_TRUE(sim_.control(control(motionlcm::sim_control_t::SET_INPUT, 1, 0), now_));
  EXPECT_EQ(take(), hex("CC 05 A0 FF"));
  EXPECT_FALSE(sim_.moving("u-drive", now_));
  EXPECT_EQ(send("SFB;"), hex("CC 05 C1 00 01 01 00 00 FF"));
}

TEST_F(SimUim242, HomingSwitchResetsPosition) {
  send("MCF 1025;SCF 192;");  // S1 falling: reset position + emergency stop (1100)
  send("ENA;SPD -500;");
  advance_to(now_ + 2s);
  sim_.control(control(motionlcm::sim_control_t::SET_INPUT, 1, 0), now_);
  EXPECT_EQ(sim_.position("u-drive", now_), 0);
}

TEST_F(SimUim242, StallHaltsAndNotifiesWhenEnabled) {
  send("MCF 1088;SCF 262145;");  // CM + STLIE; S34CON.STALL = 0100 (0x4000 x 16 + suffix 1)
  send("ENA;SPD 500;");
  take();
  EXPECT_TRUE(sim_.control(control(motionlcm::sim_control_t::STALL), now_));
  EXPECT_EQ(take(), hex("CC 05 AA FF"));
  EXPECT_FALSE(sim_.moving("u-drive", now_));
}

TEST_F(SimUim242, SilencedControllerDoesNotAnswer) {
  EXPECT_TRUE(sim_.control(control(motionlcm::sim_control_t::SILENCE, 1), now_));
  EXPECT_TRUE(send("FBK;").empty());
  EXPECT_EQ(send("gOFF;"), hex("AA 01 AD FF"));
  sim_.control(control(motionlcm::sim_control_t::SILENCE, 0), now_);
  EXPECT_EQ(send("FBK;").size(), 13u);
  EXPECT_FALSE(sim_.control(control(motionlcm::sim_control_t::ALARM), now_));
}

TEST_F(SimUim242, PowerCycleKeepsPositionAndDisables) {
  send("ORG 77;ENA;");
  EXPECT_TRUE(sim_.control(control(motionlcm::sim_control_t::POWER_CYCLE), now_));
  EXPECT_FALSE(sim_.enabled("u-drive"));
  EXPECT_EQ(sim_.position("u-drive", now_), 77);
}

TEST(SimUim242Config, ControllersOfTheBus) {
  const auto loaded = config::load_file(config::default_config_path());
  ASSERT_TRUE(loaded.ok()) << loaded.error_text();
  const auto controllers = Uim242GatewaySim::controllers_of(*loaded.config, "rs232");
  ASSERT_EQ(controllers.size(), 1u);
  EXPECT_EQ(controllers[0].drive, "u-drive");
  EXPECT_EQ(controllers[0].node_id, 5);
}

}  // namespace
}  // namespace motion::sim
