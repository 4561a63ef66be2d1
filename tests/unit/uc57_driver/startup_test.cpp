// Uc57Stack start-up: probe, configuration frames, fallbacks, offline nodes, heartbeat, foreign frames.
#include <algorithm>
#include <set>

#include <gtest/gtest.h>

#include "harness.hpp"

namespace motion::uc57_driver::testing {
namespace {

using Event = motionlcm::event_t;

std::vector<std::string> texts(const std::vector<can::Frame>& frames, std::uint32_t only_id) {
  std::vector<std::string> out;
  for (const auto& f : frames) {
    if (f.id == only_id) out.push_back(can::to_cansend(f));
  }
  return out;
}

std::size_t index_of(const std::vector<std::string>& frames, const std::string& frame) {
  return static_cast<std::size_t>(std::find(frames.begin(), frames.end(), frame) - frames.begin());
}

TEST(Uc57Startup, ProbesConfiguresAndStartsEveryNode) {
  Bench bench;
  bench.start_ready();
  // Node 1's SDO requests, in order: probe (D-05, D-06), setup, heartbeat, RPDO1 remap (D-31..D-37).
  const auto sdo = texts(bench.sent, 0x601);
  ASSERT_GE(sdo.size(), 10U);
  EXPECT_EQ(sdo[0], "601#4000100000000000");                     // read 1000h
  EXPECT_EQ(sdo[1], "601#4018100100000000");                     // read 1018h:01
  EXPECT_EQ(sdo[2], "601#2B06200004000000");                     // 2006h := 4 (3200 pulses/rev = 200 x 16)
  EXPECT_LT(index_of(sdo, "601#2B05200014000000"), sdo.size());  // 2005h := 20 (2.0 A)
  EXPECT_LT(index_of(sdo, "601#2B17100064000000"), sdo.size());  // 1017h := 100 ms
  const auto disable = index_of(sdo, "601#2300140101020080");    // D-31
  const auto count0 = index_of(sdo, "601#2F00160000000000");     // D-32
  const auto entry1 = index_of(sdo, "601#2300160110004060");     // D-33
  const auto entry2 = index_of(sdo, "601#2300160220007A60");     // D-34
  const auto count2 = index_of(sdo, "601#2F00160002000000");     // D-35
  const auto sync_type = index_of(sdo, "601#2F00140201000000");  // D-36
  const auto enable = index_of(sdo, "601#2300140101020000");     // D-37
  EXPECT_LT(disable, count0);
  EXPECT_LT(count0, entry1);
  EXPECT_LT(entry1, entry2);
  EXPECT_LT(entry2, count2);
  EXPECT_LT(count2, sync_type);
  EXPECT_LT(sync_type, enable);
  EXPECT_LT(enable, sdo.size());
  EXPECT_LT(index_of(sdo, "601#2F00180201000000"), sdo.size());  // TPDO1 type 1 (tpdo_mode sync)
  // NMT: pre-operational before the configuration, start after it (D-30, D-38).
  const auto nmt = texts(bench.sent, 0x000);
  EXPECT_LT(index_of(nmt, "000#8001"), index_of(nmt, "000#0101"));
  EXPECT_LT(index_of(nmt, "000#0101"), nmt.size());
  EXPECT_EQ(bench.node(1).nmt(), canopen::NmtState::kOperational);
  EXPECT_EQ(bench.node(1).value(0x2006), 4);
  EXPECT_EQ(bench.node(1).value(0x2005), 20);
  EXPECT_EQ(bench.stack->rpdo_layout("a-drive"), RpdoLayout::kControlwordTarget);
  // SYNC at the poll rate (20 Hz): about 20 in one second.
  EXPECT_GE(texts(bench.sent, 0x080).size(), 15U);
  EXPECT_TRUE(bench.has_event(Event::ONLINE));
  ASSERT_TRUE(bench.statuses.count("a"));
  EXPECT_TRUE(bench.statuses["a"].online);
  motionlcm::bus_stats_t stats{};
  bench.stack->add_statistics(stats);
  EXPECT_EQ(stats.drives_total, 2);
  EXPECT_EQ(stats.drives_online, 2);
}

TEST(Uc57Startup, FallsBackToTheManualsDefaultRpdoWhenRemapIsReadOnly) {
  Bench bench;
  bench.node(2).pdo_remap_writable = false;  // as the manual prints 1400h:01 RO
  bench.start_ready();
  EXPECT_EQ(bench.stack->rpdo_layout("a-drive"), RpdoLayout::kControlwordTarget);
  EXPECT_EQ(bench.stack->rpdo_layout("b-drive"), RpdoLayout::kManualDefault);
  EXPECT_EQ(bench.node(2).value(0x1400, 2), 1);  // the default RPDO1 made synchronous
  EXPECT_EQ(bench.node(2).value(0x1600, 0), 3);  // mapping untouched
}

// A remap step without an answer may have been applied (under load the answer comes after the SDO
// timeout): step 1 sets 1400h:01's invalid bit. Taken for a refusal, the node went on with the
// default layout and RPDO1 switched off, and no controlword ever reached it again.
TEST(Uc57Startup, RemapStepWithoutAnAnswerIsRetriedNotTakenForARefusal) {
  Bench bench;
  bench.node(1).unanswered_once.insert(FakeUc57::key(0x1400, 1));  // applied, the answer lost
  bench.start();
  bench.run_for(std::chrono::seconds(3));
  ASSERT_TRUE(bench.stack->ready());
  EXPECT_EQ(bench.stack->rpdo_layout("a-drive"), RpdoLayout::kControlwordTarget);
  EXPECT_EQ(bench.node(1).value(0x1400, 1), 0x201);  // RPDO1 valid again
  const auto enable = bench.command(motionlcm::gateway_command_t::ENABLE, {"a"});
  bench.execute(enable);
  bench.run_for(std::chrono::milliseconds(500));
  ASSERT_FALSE(bench.replies_of(enable.command_id).empty());
  const std::int8_t done = motionlcm::gateway_reply_t::DONE;  // never ODR-use the LCM constants
  EXPECT_EQ(bench.replies_of(enable.command_id).back().status, done)
      << bench.replies_of(enable.command_id).back().reason;
  EXPECT_EQ(bench.node(1).state(), cia402::State::kOperationEnabled);
}

TEST(Uc57Startup, SilentNodeIsOfflineAndRetriedWithBackOff) {
  Bench bench;
  bench.node(2).silent = true;
  bench.start();
  bench.run_for(std::chrono::seconds(3));
  EXPECT_FALSE(bench.stack->ready());
  const auto offline = std::find_if(bench.events.begin(), bench.events.end(),
                                    [](const auto& e) { return e.second.kind == Event::OFFLINE; });
  ASSERT_NE(offline, bench.events.end());
  EXPECT_EQ(offline->first, "b");
  EXPECT_NE(offline->second.text.find("b-drive (node 2): SDO read 0x1000:00 timed out"), std::string::npos)
      << offline->second.text;
  EXPECT_GT(bench.stack->counters().sdo_timeouts, 1);
  EXPECT_GT(bench.stack->counters().sdo_retries, 1);
  // Probes are spaced out: 3 attempts of 50 ms, then 0.5 s, 1 s, 2 s back-off.
  const auto probes = std::count(bench.sent.begin(), bench.sent.end(), *can::parse_cansend("602#4000100000000000"));
  EXPECT_GE(probes, 6);
  EXPECT_LE(probes, 12);
  // Powered later: it boots, the boot-up triggers a probe, it comes online.
  bench.node(2).silent = false;
  bench.deliver(bench.node(2).power_on(bench.now));
  bench.run_for(std::chrono::seconds(1));
  EXPECT_TRUE(bench.stack->ready());
  EXPECT_TRUE(bench.statuses["b"].online);
}

TEST(Uc57Startup, HeartbeatLossTakesTheNodeOfflineAndFailsItsCommand) {
  Bench bench;
  bench.start_ready();
  auto enable = bench.command(motionlcm::gateway_command_t::ENABLE, {"a"});
  bench.execute(enable);
  bench.run_for(std::chrono::milliseconds(500));
  auto jog = bench.command(motionlcm::gateway_command_t::HOME, {"a"});
  jog.axes[0].velocity = 3200;
  jog.axes[0].acceleration = 32000;
  bench.node(1).motion_syncs = 1000;  // homing that lasts
  bench.execute(jog);
  bench.run_for(std::chrono::milliseconds(300));
  bench.node(1).silent = true;
  bench.run_for(std::chrono::seconds(1));
  EXPECT_TRUE(bench.has_event(Event::HEARTBEAT_LOST));
  EXPECT_FALSE(bench.statuses["a"].online);
  EXPECT_FALSE(bench.stack->ready());
  const auto replies = bench.replies_of(jog.command_id);
  ASSERT_EQ(bench.terminal_count(jog.command_id), 1U);
  EXPECT_EQ(replies.back().status, std::int8_t{motionlcm::gateway_reply_t::FAILED});
  EXPECT_EQ(replies.back().error_code, 6);
  EXPECT_NE(replies.back().reason.find("a-drive (node 1): heartbeat lost"), std::string::npos) << replies.back().reason;
}

TEST(Uc57Startup, RebootIsReportedAndTheNodeConfiguredAgain) {
  Bench bench;
  bench.start_ready();
  bench.deliver(bench.node(1).power_on(bench.now));
  bench.run_for(std::chrono::seconds(2));
  EXPECT_TRUE(bench.has_event(Event::REBOOT));
  EXPECT_TRUE(bench.stack->ready());
  EXPECT_EQ(bench.node(1).value(0x2006), 4);  // setup applied again
}

TEST(Uc57Startup, FramesOfOtherProtocolsAndNodesAreNotClaimed) {
  Bench bench;
  bench.start_ready();
  const auto frame = [](const char* text) { return *can::parse_cansend(text); };
  EXPECT_FALSE(bench.stack->on_frame(frame("04280095#01"), bench.now));                // UIM342, 29-bit
  EXPECT_FALSE(bench.stack->on_frame(frame("00000581#4300100092010400"), bench.now));  // extended id 581h
  EXPECT_FALSE(bench.stack->on_frame(frame("589#4300100092010400"), bench.now));       // SDO reply of node 9
  EXPECT_FALSE(bench.stack->on_frame(frame("709#05"), bench.now));                     // heartbeat of node 9
  EXPECT_FALSE(bench.stack->on_frame(frame("089#1023030101000000"), bench.now));       // EMCY of node 9
  EXPECT_FALSE(bench.stack->on_frame(frame("189#2742000000000000"), bench.now));       // TPDO of node 9
  EXPECT_FALSE(bench.stack->on_frame(frame("601#4000100000000000"), bench.now));       // another master's request
  EXPECT_FALSE(bench.stack->on_frame(frame("080#"), bench.now));                       // another SYNC producer
  EXPECT_FALSE(bench.stack->on_frame(frame("000#0100"), bench.now));                   // NMT
  EXPECT_FALSE(bench.stack->on_frame(frame("181#R"), bench.now));                      // RTR
  EXPECT_TRUE(bench.stack->on_frame(frame("701#05"), bench.now));                      // our node's heartbeat
  EXPECT_EQ(bench.unclaimed, 0U);  // every frame our fakes sent was claimed
}

TEST(Uc57Startup, EventDrivenTpdosReportStatusWithoutSync) {
  std::string yaml = kLabYaml;
  for (auto at = yaml.find("tpdo_mode: sync"); at != std::string::npos; at = yaml.find("tpdo_mode: sync")) {
    yaml.replace(at, std::string("tpdo_mode: sync").size(), "tpdo_mode: event");
  }
  Bench bench(yaml);
  bench.start_ready();
  EXPECT_EQ(bench.node(1).value(0x1800, 2), 255);
  EXPECT_EQ(bench.node(2).value(0x1801, 2), 255);
  const auto enable = bench.command(motionlcm::gateway_command_t::ENABLE, {"a"});
  bench.execute(enable);
  bench.run_for(std::chrono::milliseconds(500));
  EXPECT_EQ(bench.replies_of(enable.command_id).back().status, std::int8_t{motionlcm::gateway_reply_t::DONE});
  EXPECT_TRUE(bench.statuses["a"].enabled);
}

TEST(Uc57Startup, InvalidSetupIsRefusedWithoutTouchingTheBus) {
  // The configuration loader refuses micro_steps 3 already (setup_schema); the stack checks again
  // whatever configuration it is given.
  Bench bench(kLabYaml, [](config::Config& c) {
    for (auto& d : c.drives) {
      if (d.name == "a-drive") d.setup["micro_steps"] = 3LL;
    }
  });
  bench.start();
  bench.run_for(std::chrono::seconds(1));
  EXPECT_FALSE(bench.stack->ready());
  const auto mismatch = std::find_if(bench.events.begin(), bench.events.end(), [](const auto& e) {
    return e.second.kind == Event::CONFIG_MISMATCH && e.second.severity == Event::ERROR;
  });
  ASSERT_NE(mismatch, bench.events.end());
  EXPECT_NE(mismatch->second.text.find("a-drive (node 1): cannot be set up: micro_steps: 600 pulses/rev"),
            std::string::npos)
      << mismatch->second.text;
  EXPECT_TRUE(texts(bench.sent, 0x601).empty());
}

TEST(Uc57Startup, ManyNodesAreConfiguredAFewAtATimeAndAllComeUp) {
  // 60 nodes at 1 Mbit/s, SDO timeout 50 ms: their first SDO exchanges do not all go out together
  // (a lab bench of 127 nodes timed out at the tail of that burst and reset nodes), yet every node
  // is configured and started.
  constexpr int kNodes = 60;
  std::string yaml =
      "buses:\n  - {name: can0, transport: simcan:can0, bitrate: 1000000, request_timeout_ms: 50}\n"
      "drives:\n";
  for (int id = 1; id <= kNodes; ++id) {
    yaml += "  - {name: d" + std::to_string(id) + ", family: uc57, bus: can0, node_id: " + std::to_string(id) +
            ", setup: {micro_steps: 16, tpdo_mode: sync}}\n";
  }
  Bench bench(yaml);
  for (int id = 3; id <= kNodes; ++id)
    bench.nodes.push_back(std::make_unique<FakeUc57>(static_cast<canopen::NodeId>(id)));
  bench.stack->start(bench.now);
  (void)bench.stack->process(bench.now);  // the requests go out; the fakes have not answered yet
  std::set<std::uint32_t> first;          // nodes with an SDO request out before any answer
  for (const auto& f : bench.sent) {
    if (f.id > 0x600 && f.id <= 0x600 + kNodes) first.insert(f.id);
  }
  // An expedited SDO exchange is two 8-byte frames, about 0.25 ms at 1 Mbit/s; an eighth of 50 ms
  // holds 25 of them.
  EXPECT_GE(first.size(), 16U);
  EXPECT_LE(first.size(), 25U);
  bench.run_for(std::chrono::seconds(5));
  for (int id = 1; id <= kNodes; ++id)
    EXPECT_EQ(bench.node(id).nmt(), canopen::NmtState::kOperational) << "node " << id;
  EXPECT_TRUE(bench.stack->ready());
}

}  // namespace
}  // namespace motion::uc57_driver::testing
