// Two simulated UIM342 drives inside a CanBusHost on a real EventLoop, commanded over the
// bit-timed simulated bus from a local endpoint: the motion-sim path end to end (factory,
// endpoints, reply latency, deadlines on loop timers, ground-truth reports).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "motion/sim/can_bus_host.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/testing/temp_dir.hpp"
#include "motion/uim342/instructions.hpp"

namespace motion::sim {
namespace {

namespace u = uim342;
namespace rq = uim342::request;

using TempDir = testing::TempDir;

bool run_until(EventLoop& loop, const std::function<bool()>& done, Duration timeout = std::chrono::seconds(5)) {
  const TimePoint deadline = SteadyClock::now() + timeout;
  while (!done()) {
    if (SteadyClock::now() > deadline) return false;
    loop.run_once(std::chrono::milliseconds(5));
  }
  return true;
}

config::Config lab(const std::filesystem::path& runtime_dir) {
  const std::string yaml = R"(
buses:
  - {name: can0, transport: simcan:uimhost)" +
                           std::to_string(::getpid()) + R"(, bitrate: 1000000, bus_timing: true}
drives:
  - {name: x-drive, family: uim342, bus: can0, node_id: 5, group_id: 20, setup: {auto_enable: true, cut_in_speed: 0}}
  - {name: y-drive, family: uim342, bus: can0, node_id: 6, group_id: 20, setup: {auto_enable: true, cut_in_speed: 0}}
simulation: {runtime_dir: ")" +
                           runtime_dir.string() + R"(", reply_latency_us: 100}
)";
  auto loaded = config::load_string(yaml);
  if (!loaded.ok()) throw std::runtime_error(loaded.error_text());
  return *loaded.config;
}

TEST(SimUim342BusHost, GroupBgOverTheSimulatedBusStartsBothDrivesOnOneFrame) {
  TempDir dir{"sim-uim342"};
  const config::Config config = lab(dir.path());
  EventLoop loop;
  std::vector<motionlcm::sim_report_t> reports;
  std::error_code error;
  auto host = CanBusHost::open(
      loop, config, config.buses.front(), {{config::Family::kUim342, uim342_factory(config)}},
      [&reports](motionlcm::sim_report_t r) { reports.push_back(std::move(r)); }, error);
  ASSERT_TRUE(host) << error.message();
  EXPECT_TRUE(host->missing().empty());
  EXPECT_EQ(reports.size(), 2U);  // POWERED_UP of each drive

  auto gateway = host->hub().attach_local("test-gateway");
  std::vector<u::AddressedReply> replies;
  loop.watch(gateway->fd(), [&] {
    while (auto frame = gateway->receive()) {
      if (auto r = u::decode_reply_frame(*frame)) replies.push_back(*r);
    }
  });
  const auto send = [&](std::uint8_t target, const u::Instruction& instruction) {
    ASSERT_FALSE(gateway->send(*u::instruction_frame(target, instruction)));
  };
  // One request at a time, as a gateway does: frames queued together are reordered by
  // arbitration (SP, CW 0x9E, would overtake PR, CW 0x9F, and fail the "#50" order rule).
  const auto request = [&](std::uint8_t target, const u::Instruction& instruction) {
    replies.clear();
    send(target, instruction);
    ASSERT_TRUE(run_until(loop, [&] { return !replies.empty(); }));
    EXPECT_NE(replies[0].reply.function, u::FunctionCode::kER) << u::to_string(replies[0].reply);
  };
  for (const std::uint8_t node : {std::uint8_t{5}, std::uint8_t{6}}) {
    request(node, rq::set_acceleration(100'000));
    request(node, rq::set_deceleration(100'000));
    request(node, rq::set_relative_position(node == std::uint8_t{5} ? 1000 : -1000));
    request(node, rq::set_ptp_speed(10'000));
  }

  replies.clear();
  send(20, rq::begin());  // one frame to the group
  ASSERT_TRUE(run_until(loop, [&] { return replies.size() == 2; }));
  EXPECT_NE(replies[0].address.producer, replies[1].address.producer);

  const auto of_kind = [&reports](std::int8_t kind) {
    std::vector<motionlcm::sim_report_t> out;
    for (const auto& r : reports) {
      if (r.kind == kind) out.push_back(r);
    }
    return out;
  };
  const std::int8_t started{motionlcm::sim_report_t::MOTION_STARTED};
  const std::int8_t finished{motionlcm::sim_report_t::MOTION_FINISHED};
  ASSERT_TRUE(run_until(loop, [&] { return of_kind(finished).size() == 2; }));
  const auto starts = of_kind(started);
  ASSERT_EQ(starts.size(), 2U);
  EXPECT_NE(starts[0].frame_utime, 0);
  EXPECT_EQ(starts[0].frame_utime, starts[1].frame_utime);  // the same BG frame started both
  for (const auto& r : of_kind(finished)) {
    EXPECT_EQ(r.position_counts, r.drive == "x-drive" ? 1000 : -1000);
    EXPECT_EQ(r.position_counts, r.target_counts);
  }

  // Fault injection through the host: a stall alarm from y-drive.
  replies.clear();
  std::vector<can::Frame> notifications;
  loop.watch(gateway->fd(), [&] {
    while (auto frame = gateway->receive()) notifications.push_back(*frame);
  });
  motionlcm::sim_control_t stall{};
  stall.drive = "y-drive";
  stall.action = motionlcm::sim_control_t::STALL;
  EXPECT_TRUE(host->control(stall));
  ASSERT_TRUE(run_until(loop, [&] { return !notifications.empty(); }));
  EXPECT_EQ(notifications[0].id, 0x0620005AU);  // RT from node 6 to the host
  motionlcm::sim_control_t unsupported{};
  unsupported.drive = "x-drive";
  unsupported.action = motionlcm::sim_control_t::LINE_NOISE;  // a serial line's
  EXPECT_FALSE(host->control(unsupported));
  motionlcm::sim_control_t crc = unsupported;  // CAN: its frames fail the CRC and never arrive
  crc.action = motionlcm::sim_control_t::CRC_ERRORS;
  crc.value = 1;
  EXPECT_TRUE(host->control(crc));
  loop.unwatch(gateway->fd());
}

// BUS_DROP N drops the bus's next N frames, however long they take to come; BUS_DROP 0 ends the
// drops still pending (a fault meant to last a while on a quiet bus).
TEST(SimUim342BusHost, ABusDropLastsItsFramesOrUntilABusDropOfZero) {
  TempDir dir{"sim-uim342-drop"};
  const config::Config config = lab(dir.path());
  EventLoop loop;
  std::error_code error;
  auto host = CanBusHost::open(
      loop, config, config.buses.front(), {{config::Family::kUim342, uim342_factory(config)}},
      [](const motionlcm::sim_report_t&) {}, error);
  ASSERT_TRUE(host) << error.message();
  auto gateway = host->hub().attach_local("test-gateway");
  int replies = 0;
  loop.watch(gateway->fd(), [&] {
    while (auto frame = gateway->receive()) replies += u::decode_reply_frame(*frame) ? 1 : 0;
  });
  const auto answered = [&] {
    replies = 0;
    EXPECT_FALSE(gateway->send(*u::instruction_frame(5, rq::set_acceleration(100'000))));
    return run_until(
        loop, [&] { return replies > 0; }, std::chrono::milliseconds(300));
  };
  ASSERT_TRUE(answered());
  motionlcm::sim_control_t drop{};
  drop.bus = "can0";
  drop.action = motionlcm::sim_control_t::BUS_DROP;
  drop.value = 3;
  ASSERT_TRUE(host->control(drop));
  EXPECT_FALSE(answered());  // 3 frames: this request, then the next two
  EXPECT_FALSE(answered());
  EXPECT_FALSE(answered());
  EXPECT_TRUE(answered());  // spent
  drop.value = 1000;
  ASSERT_TRUE(host->control(drop));
  EXPECT_FALSE(answered());
  drop.value = 0;
  ASSERT_TRUE(host->control(drop));
  EXPECT_TRUE(answered());  // ended, 999 frames early
  loop.unwatch(gateway->fd());
}

}  // namespace
}  // namespace motion::sim
