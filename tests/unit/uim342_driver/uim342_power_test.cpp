// A UIM342 that loses power, on the bit-timed wire with simulated drives (uim342_wire_rig.hpp):
//   - powered up at rest where its counter read 0 already (never moved, or at its origin after a
//     SET_POSITION), which its answers alone cannot show: its power-on marker (MT[3] in RAM,
//     manual §5.9) is gone, so its position is reported lost once, saying how it was found;
//   - a drive that goes silent and answers again, or sits at 0 for a long time, keeps its marker:
//     no power-up is reported;
//   - a move to counter 0 that runs whole between two samples (a drive polled slowly) is that move
//     arriving, not a power-up; once the move has ended, such a jump is one again.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include <motionlcm/event_t.hpp>

#include "uim342_wire_rig.hpp"

namespace motion::gateway {
namespace {

using namespace test;  // NOLINT(google-build-using-namespace): the rig's types
using std::chrono::seconds;

constexpr std::int8_t kSetPosition = gateway_command_t::SET_POSITION;
constexpr std::int16_t kOffline = motionlcm::event_t::OFFLINE;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// One drive polled at 1 Hz, enabled, at rest: its marker is armed by then.
class PowerRig : public ::testing::Test {
 protected:
  void SetUp() override {
    rig.start();
    const auto id = rig.execute(kEnable, "a0");
    ASSERT_TRUE(rig.run_until([&] { return rig.terminal(id).has_value(); }, seconds(2)));
    ASSERT_EQ(rig.terminal(id)->status, kDone);
    rig.run_for(seconds(3));
    ASSERT_TRUE(rig.out.lost.empty()) << rig.out.lost.front().second;
  }
  WireRig rig{1, 1};
};

TEST_F(PowerRig, APowerCycleAtRestAtCounterZeroIsReportedOnceByItsMarker) {
  rig.power_cycle(5);
  rig.run_for(seconds(5));
  ASSERT_EQ(rig.out.lost.size(), 1U);
  EXPECT_EQ(rig.out.lost[0].first, "a0");
  EXPECT_TRUE(contains(rig.out.lost[0].second, "d0 (node 5) powered up, detected by its power-on marker: MT[3] reads"))
      << rig.out.lost[0].second;
  // Set up again (its RAM settings are gone) and, once enabled again, armed anew: no second report.
  EXPECT_TRUE(rig.run_until([&] { return rig.stack->ready(); }, seconds(5)));
  const auto id = rig.execute(kEnable, "a0");
  ASSERT_TRUE(rig.run_until([&] { return rig.terminal(id).has_value(); }, seconds(2)));
  rig.run_for(seconds(10));
  EXPECT_EQ(rig.out.lost.size(), 1U);
}

TEST_F(PowerRig, APowerCycleAfterSetPositionIsReportedToo) {
  // SET_POSITION zeroes the drive's counter (OG, §5.22): the drive rests at counter 0 with a
  // position of 2 mm, which a power-up leaves looking the same to the position samples.
  gateway_command_t c{};
  c.bus = "can0";
  c.command_id = 77;
  c.kind = kSetPosition;
  motionlcm::axis_command_t a{};
  a.axis = "a0";
  a.target_counts = 1280;
  c.axes.push_back(a);
  c.num_axes = 1;
  rig.stack->execute(c, rig.now);
  ASSERT_TRUE(rig.run_until([&] { return rig.terminal(77).has_value(); }, seconds(2)));
  ASSERT_EQ(rig.terminal(77)->status, kDone) << rig.terminal(77)->reason;
  rig.run_for(seconds(3));
  ASSERT_TRUE(rig.out.lost.empty());
  rig.power_cycle(5);
  rig.run_for(seconds(5));
  ASSERT_EQ(rig.out.lost.size(), 1U);
  EXPECT_TRUE(contains(rig.out.lost[0].second, "detected by its power-on marker")) << rig.out.lost[0].second;
}

// An ARM_MOVE of a0 to `counts`, started at once (trigger 0), run until its terminal reply.
gateway_reply_t move_to(WireRig& rig, std::int64_t id, std::int64_t counts) {
  gateway_command_t c{};
  c.bus = "can0";
  c.command_id = id;
  c.kind = gateway_command_t::ARM_MOVE;
  motionlcm::axis_command_t a{};
  a.axis = "a0";
  a.target_counts = counts;
  a.velocity = 3200;  // 5 mm/s: 1280 counts in about 0.4 s
  a.acceleration = 32000;
  a.deceleration = 32000;
  c.axes.push_back(a);
  c.num_axes = 1;
  rig.stack->execute(c, rig.now);
  EXPECT_TRUE(rig.run_until([&] { return rig.terminal(id).has_value(); }, seconds(5)));
  return rig.terminal(id).value_or(gateway_reply_t{});
}

TEST_F(PowerRig, AMoveToZeroRunWholeBetweenTwoSamplesIsNotAPowerUp) {
  ASSERT_EQ(move_to(rig, 81, 1280).status, kDone);
  rig.run_for(seconds(2));  // at rest at 1280, sampled
  // Polled once a second: the move back to 0 (about 0.4 s) runs between two samples, which read
  // 1280 at rest and then 0 at rest.
  const auto back = move_to(rig, 82, 0);
  EXPECT_EQ(back.status, kDone) << back.reason;
  rig.run_for(seconds(3));
  EXPECT_TRUE(rig.out.lost.empty()) << rig.out.lost.front().second;
}

// MT[3] reads the stack sent from `from` on.
std::size_t marker_reads(const WireRig& rig, TimePoint from) {
  return static_cast<std::size_t>(std::count_if(rig.wire.begin(), rig.wire.end(), [from](const OnWire& w) {
    const auto d = uim342::decode_instruction_frame(w.frame);
    return w.ours && w.end_of_frame >= from && d && d->instruction.function == FC::kMT &&
           d->instruction.operation == uim342::Operation::kGet && d->instruction.sub_index() == 3;
  }));
}

TEST_F(PowerRig, SilenceAndALongRestAtZeroAreNoPowerUp) {
  rig.silent.insert("d0");
  rig.run_for(seconds(3));  // offline: its polls time out
  EXPECT_TRUE(std::any_of(rig.out.events.begin(), rig.out.events.end(),
                          [](const auto& e) { return e.second.kind == kOffline; }));
  rig.silent.clear();
  EXPECT_TRUE(rig.run_until([&] { return rig.stack->ready(); }, seconds(10)));
  const auto back = rig.now;
  rig.run_for(seconds(20));  // at counter 0 at rest: its marker read again, found each time
  EXPECT_TRUE(rig.out.lost.empty()) << rig.out.lost.front().second;
  // Read at most once a second at rest (one poll a second here), and it was read.
  const auto reads = marker_reads(rig, back);
  EXPECT_GE(reads, 8U);
  EXPECT_LE(reads, 21U);
  std::printf("20 s at rest at counter 0, polled at 1 Hz: %zu marker reads\n", reads);
}

}  // namespace
}  // namespace motion::gateway
