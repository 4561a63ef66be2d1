// The start schedule (start_schedule.hpp) from given wire times: a pure function, no clock.
#include "motion/coordinator/start_schedule.hpp"

#include <gtest/gtest.h>

#include <chrono>

#include "motion/can_frame/bit_timing.hpp"
#include "motion/canopen/sync.hpp"
#include "motion/config/config.hpp"
#include "motion/drive_model/drive_model.hpp"
#include "motion/gateway/serial_line.hpp"

namespace motion::coordinator {
namespace {

const BusStart& bus(const StartSchedule& s, const std::string& name) {
  for (const auto& b : s.buses) {
    if (b.bus == name) return b;
  }
  throw std::runtime_error("no bus " + name);
}

TEST(StartSchedule, OneFramePerBusLeadsByItsWireTimeAndLeavesNoSpread) {
  const auto s = schedule_starts({{"can0", 11, 47.0}, {"rs485", 12, 694.4}, {"rs232", 13, 2604.2}});
  ASSERT_EQ(s.buses.size(), 3U);
  EXPECT_DOUBLE_EQ(bus(s, "can0").lead_us, 47.0);
  EXPECT_DOUBLE_EQ(bus(s, "rs485").lead_us, 694.4);
  EXPECT_DOUBLE_EQ(bus(s, "rs232").lead_us, 2604.2);
  EXPECT_DOUBLE_EQ(s.max_lead_us, 2604.2);
  EXPECT_DOUBLE_EQ(s.predicted_spread_us, 0.0);
}

TEST(StartSchedule, FramesOnOneBusGoLongestFirstAndCentreTheirEndsOnTheActInstant) {
  // Two 29-bit BGs (70 us) and an 11-bit SYNC (50 us) on one CAN bus, given shortest first.
  const auto s = schedule_starts({{"can0", 3, 50.0}, {"can0", 2, 70.0}, {"can0", 1, 70.0}});
  const auto& c = bus(s, "can0");
  EXPECT_EQ(c.command_ids, (std::vector<std::int64_t>{1, 2, 3}));
  // Ends at 70, 140, 190 after the hand-over: span 120 = (k - 1) frames after the longest.
  EXPECT_DOUBLE_EQ(c.span_us, 120.0);
  EXPECT_DOUBLE_EQ(c.lead_us, 70.0 + 60.0);
  EXPECT_DOUBLE_EQ(s.predicted_spread_us, 120.0);
  // Any other order spreads further: SYNC first spans 140.
  const auto sync_first = 70.0 + 70.0;
  EXPECT_LT(c.span_us, sync_first);
}

TEST(StartSchedule, ASerialBusActsInTheMiddleOfTheCanBusSpan) {
  const auto s = schedule_starts({{"can0", 1, 70.0}, {"can0", 2, 50.0}, {"rs485", 3, 694.0}});
  // can0: ends at 70 and 120 after its hand-over, centred: lead 95 -> acts at -25 and +25.
  EXPECT_DOUBLE_EQ(bus(s, "can0").lead_us, 95.0);
  EXPECT_DOUBLE_EQ(bus(s, "rs485").lead_us, 694.0);
  EXPECT_DOUBLE_EQ(s.predicted_spread_us, 50.0);
}

// A UIM242 command whose axes crawl into their moves (docs/protocols.md UIM242 #3): the crawl
// instructions go out before its gSPD and each crawling axis starts with its own, so its drives act
// over the lead-in up to the frame's end.
TEST(StartSchedule, ALeadInIsOnTheLineBeforeTheFrameAndSpreadsItsActs) {
  const auto s = schedule_starts({{"rs232", 1, 2083.0, 3000.0}});
  const auto& r = bus(s, "rs232");
  EXPECT_DOUBLE_EQ(r.span_us, 3000.0);
  // Acts from 2083 to 5083 after the hand-over, centred: lead 3583.
  EXPECT_DOUBLE_EQ(r.lead_us, 2083.0 + 1500.0);
  EXPECT_DOUBLE_EQ(s.predicted_spread_us, 3000.0);
  // Without a lead-in: one frame, no spread (as before).
  EXPECT_DOUBLE_EQ(schedule_starts({{"rs232", 1, 2083.0}}).predicted_spread_us, 0.0);
}

TEST(StartSchedule, NegativeWireTimesCountAsZero) {
  const auto s = schedule_starts({{"can0", 1, -5.0}, {"rs485", 2, 694.0, 0.0, -40.0}});
  EXPECT_DOUBLE_EQ(bus(s, "can0").lead_us, 0.0);
  EXPECT_DOUBLE_EQ(bus(s, "rs485").start_wait_us, 0.0);
  EXPECT_DOUBLE_EQ(s.max_ahead_us, 694.0);
}

// A serial line's start wait (LINE_TIMING: the longest poll exchange that may be under way when
// the gateway hears the trigger) asks for the trigger that much earlier, and moves nothing else:
// the leads, the wire order and the spread are those without it.
TEST(StartSchedule, AStartWaitAsksForTheTriggerEarlierAndMovesNoAct) {
  const std::vector<StartFrame> without{
      {"can0", 1, 70.0}, {"can0", 2, 50.0}, {"rs485", 3, 694.0}, {"rs232", 4, 2604.2}};
  std::vector<StartFrame> with = without;
  with[2].start_wait_us = 3600.0;   // rs485: a poll read at 115200 baud
  with[3].start_wait_us = 16600.0;  // rs232: `FBK;` and its reply at 19200 baud
  const auto a = schedule_starts(without);
  const auto b = schedule_starts(with);
  ASSERT_EQ(a.buses.size(), b.buses.size());
  for (std::size_t i = 0; i < a.buses.size(); ++i) {
    EXPECT_DOUBLE_EQ(a.buses[i].lead_us, b.buses[i].lead_us) << a.buses[i].bus;
    EXPECT_DOUBLE_EQ(a.buses[i].span_us, b.buses[i].span_us) << a.buses[i].bus;
    EXPECT_EQ(a.buses[i].command_ids, b.buses[i].command_ids) << a.buses[i].bus;
  }
  EXPECT_DOUBLE_EQ(a.predicted_spread_us, b.predicted_spread_us);
  EXPECT_DOUBLE_EQ(a.max_lead_us, b.max_lead_us);
  // Without waits the first hand-over is the longest lead after the hearing; with them, rs232's
  // lead and wait: it hears the trigger 16.6 ms before its own hand-over.
  EXPECT_DOUBLE_EQ(a.max_ahead_us, 2604.2);
  EXPECT_DOUBLE_EQ(b.max_ahead_us, 2604.2 + 16600.0);
  EXPECT_DOUBLE_EQ(bus(b, "rs232").start_wait_us, 16600.0);
  EXPECT_DOUBLE_EQ(bus(b, "can0").start_wait_us, 0.0);
  // A wait shorter than the difference of leads asks for nothing more: rs485's 694 + 1000 is
  // inside rs232's 2604.
  with[2].start_wait_us = 1000.0;
  with[3].start_wait_us = 0.0;
  EXPECT_DOUBLE_EQ(schedule_starts(with).max_ahead_us, 2604.2);
}

TEST(StartSchedule, WireTimesComeFromTheDriveModels) {
  auto loaded = config::load_string(R"(
buses:
  - {name: can0, transport: simcan:can0, bitrate: 500000}
  - {name: rs485, transport: simserial:rs485, baud: 19200}
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5, group_id: 20}
  - {name: ad, family: uc57, bus: can0, node_id: 1}
  - {name: cd, family: adam-modbus, bus: rs485, node_id: 1}
axes:
  - {name: x, drive: xd, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 50, acceleration: 400}}
  - {name: a, drive: ad, steps_per_unit: 8.888888888888889, limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}}
  - {name: c, drive: cd, steps_per_unit: 320, limits: {min: -100, max: 100, velocity: 40, acceleration: 200}}
)");
  ASSERT_TRUE(loaded.ok()) << loaded.error_text();
  const config::Config& cfg = *loaded.config;
  const auto model = [&](const std::string& axis) {
    auto m = drive_model::build(cfg, *cfg.find_axis(axis));
    if (auto* why = std::get_if<std::string>(&m)) throw std::runtime_error(*why);
    return std::get<motionlcm::drive_model_t>(m);
  };
  const auto arming = [&](const std::string& axis) {
    auto t = drive_model::arming(cfg, *cfg.find_axis(axis));
    if (auto* why = std::get_if<std::string>(&t)) throw std::runtime_error(*why);
    return std::get<motionlcm::arm_timing_t>(t);
  };
  using M = motionlcm::drive_model_t;
  const auto bg = start_wire_us(model("x"), M::START_UIM342_GROUP_BG);
  // A member of a group also offers a BG of its own (to its node id), which a move holding only
  // part of its group uses: the same frame length.
  const auto own_bg = start_wire_us(model("x"), M::START_SINGLE);
  ASSERT_TRUE(own_bg);
  EXPECT_GT(*own_bg, 0.0);
  EXPECT_DOUBLE_EQ(*own_bg, *bg);
  const auto& x = model("x");
  EXPECT_EQ(x.start_addresses, (std::vector<std::int32_t>{20, 5}));
  const auto sync = start_wire_us(model("a"), M::START_CANOPEN_SYNC);
  const auto broadcast = start_wire_us(model("c"), M::START_ADAM_BROADCAST);
  ASSERT_TRUE(bg && sync && broadcast);
  EXPECT_FALSE(start_wire_us(model("a"), M::START_ADAM_BROADCAST));
  // The SYNC is CiA 301's 0-byte frame on 080h: its bits at 500 kbit/s.
  const double sync_bits_us =
      std::chrono::duration<double, std::micro>(can::frame_duration(canopen::encode_sync({}), 500000)).count();
  EXPECT_DOUBLE_EQ(*sync, sync_bits_us);
  const auto s = schedule_starts({{"can0", 1, *sync}, {"can0", 2, *bg}, {"rs485", 3, *broadcast}});
  EXPECT_EQ(bus(s, "can0").command_ids, (std::vector<std::int64_t>{2, 1}));  // the 29-bit BG before the SYNC
  EXPECT_DOUBLE_EQ(bus(s, "can0").lead_us, *bg + *sync / 2);
  EXPECT_DOUBLE_EQ(bus(s, "rs485").lead_us, *broadcast);
  EXPECT_GT(*broadcast, 10 * *bg);  // the serial broadcast is the longest lead by far
  EXPECT_DOUBLE_EQ(s.max_lead_us, *broadcast);
  // Arming's line time, ADAM only (the CAN families arm in a few frames): per transaction the
  // request and reply bytes at 10 bits each (8N1, 520.8 us at 19200 baud), 1 ms assumed reply
  // latency and t3.5 (3.5 characters) after each frame; a Save adds its 0.1 s flash erase (§8.69).
  // The axis: 0x0096..99 and 0x00D8 profile, table entry 0, 0x00AA/AB/AC, 0x009A, Save: 147 bytes
  // in 8 transactions. Another drive of the line: its entry 0, 0x00AA/AB/AC, Save: 85 bytes in 5.
  EXPECT_EQ(arming("x").arm_line_us, 0.0);
  EXPECT_EQ(arming("a").arm_bystander_us, 0.0);
  const double byte_us = 1e6 * 10 / 19200;
  const double gaps_us = 1000 + 2 * 3.5 * byte_us;
  EXPECT_NEAR(arming("c").arm_line_us, 147 * byte_us + 8 * gaps_us + 100000, 1.0);
  EXPECT_NEAR(arming("c").arm_bystander_us, 85 * byte_us + 5 * gaps_us + 100000, 1.0);
}

}  // namespace
}  // namespace motion::coordinator
