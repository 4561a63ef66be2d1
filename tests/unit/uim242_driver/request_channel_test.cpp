// RequestChannel (passive, time only moves when the test says so): a request held for its
// not_before, and a line reserved for a start frame.
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "motion/uim242_driver/request_channel.hpp"

namespace motion::uim242_driver {
namespace {

using namespace std::chrono_literals;

struct Line {
  explicit Line(Duration egress = {}) : egress_latency(egress) {}
  Duration egress_latency;
  std::vector<std::string> sent;
  RequestChannel channel{[this](std::span<const std::uint8_t> b) { sent.emplace_back(b.begin(), b.end()); },
                         ChannelSettings{100ms, 0, std::chrono::microseconds(174), egress_latency}};  // 57600 baud
};

Request global_speed(std::int64_t speed) {
  Request r;
  r.drive = "gateway";
  r.instruction = uim242::Instruction{uim242::Mnemonic::kSPD, true, speed, false};
  return r;
}

// The controllers act when the instruction's last character has arrived: its characters after the
// write, and after the line's egress latency (bus key egress_latency_us) when it has one.
TEST(RequestChannel, AnInstructionIsOnTheWireAfterTheEgressLatencyAndItsCharacters) {
  for (const Duration egress : {Duration{}, Duration{900us}}) {
    Line line(egress);
    const TimePoint t0 = TimePoint{} + 10s;
    Request r = global_speed(4800);
    std::optional<TimePoint> on_wire;
    r.on_sent = [&](TimePoint t) { on_wire = t; };
    line.channel.submit(std::move(r), true);
    line.channel.process(t0);
    ASSERT_EQ(line.sent.size(), 1U);
    ASSERT_TRUE(on_wire);
    EXPECT_EQ(*on_wire, t0 + egress + 10 * 174us) << "gSPD 4800; is 10 characters";
  }
}

TEST(RequestChannel, ARequestIsNotHandedToTheLineBeforeItsNotBefore) {
  Line line;
  const TimePoint t0 = TimePoint{} + 10s;
  Request r = global_speed(4800);
  r.not_before = t0 + 174us;
  line.channel.submit(std::move(r), true);
  EXPECT_EQ(line.channel.process(t0), t0 + 174us);
  EXPECT_TRUE(line.sent.empty());
  line.channel.process(t0 + 174us);
  ASSERT_EQ(line.sent.size(), 1U);
  EXPECT_EQ(line.sent[0], "gSPD 4800;");
}

TEST(RequestChannel, AReservedLineHoldsRequestsUntilTheStartComes) {
  Line line;
  const TimePoint t0 = TimePoint{} + 10s;
  line.channel.reserve(t0 + 3ms);  // the start frame goes out then
  line.channel.submit(global_speed(100));
  line.channel.process(t0);  // it would still wait for its reply at t0 + 3 ms
  line.channel.process(t0 + 3ms);
  EXPECT_TRUE(line.sent.empty());
  line.channel.reserve(kNever);  // the start came
  line.channel.process(t0 + 3ms);
  EXPECT_EQ(line.sent.size(), 1U);
}

}  // namespace
}  // namespace motion::uim242_driver
