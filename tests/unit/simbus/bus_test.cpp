#include "motion/simbus/bus.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "motion/can_frame/bit_timing.hpp"

namespace motion::simbus {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

// Everything the bus hands out, in order.
struct RecordingSink final : BusSink {
  struct Delivery {
    EndpointId to;
    can::Frame frame;
    bool own_echo;
  };
  struct Notice {
    EndpointId to;
    can::BusEvent event;
  };
  void deliver(EndpointId to, const can::Frame& frame, bool own_echo) override {
    deliveries.push_back({to, frame, own_echo});
  }
  void notify(EndpointId to, const can::BusEvent& event) override { notices.push_back({to, event}); }

  [[nodiscard]] std::vector<can::Frame> frames_to(EndpointId to) const {
    std::vector<can::Frame> out;
    for (const auto& d : deliveries) {
      if (d.to == to) out.push_back(d.frame);
    }
    return out;
  }
  std::vector<Delivery> deliveries;
  std::vector<Notice> notices;
};

const TimePoint kStart = TimePoint{} + std::chrono::seconds(1);

std::int64_t us_of(TimePoint t) { return std::chrono::duration_cast<microseconds>(t.time_since_epoch()).count(); }

can::Frame frame(std::uint32_t id, std::vector<std::uint8_t> payload = {}, bool extended = false) {
  return can::Frame::make(id, extended, payload).value();
}

// Three endpoints a (1), b (2), c (3) on a bus.
class BusTest : public ::testing::Test {
 protected:
  explicit BusTest(BusConfig config = {}) : bus(config) {
    a = bus.attach("a");
    b = bus.attach("b");
    c = bus.attach("c");
  }
  // Runs the bus until idle (the way the hub's timer does), returning the last time used.
  TimePoint drain(TimePoint from = kStart) {
    TimePoint now = from;
    bus.advance(now, sink);
    while (bus.next_deadline() != kNever) {
      now = bus.next_deadline();
      bus.advance(now, sink);
    }
    return now;
  }
  Bus bus;
  RecordingSink sink;
  EndpointId a = 0, b = 0, c = 0;
};

TEST_F(BusTest, EveryOtherEndpointGetsTheFrameButNotTheSender) {
  ASSERT_FALSE(bus.submit(a, frame(0x123, {1, 2}), kStart));
  drain();
  EXPECT_TRUE(sink.frames_to(a).empty());
  ASSERT_EQ(sink.frames_to(b).size(), 1u);
  ASSERT_EQ(sink.frames_to(c).size(), 1u);
  EXPECT_EQ(sink.frames_to(b)[0], frame(0x123, {1, 2}));
  EXPECT_EQ(bus.endpoint(a)->tx_frames, 1u);
  EXPECT_EQ(bus.endpoint(b)->rx_frames, 1u);
  EXPECT_EQ(bus.endpoint(a)->rx_frames, 0u);
}

TEST_F(BusTest, OwnEchoReachesTheSenderMarkedAsEcho) {
  bus.set_own_echo(a, true);
  ASSERT_FALSE(bus.submit(a, frame(0x123), kStart));
  drain();
  ASSERT_EQ(sink.deliveries.size(), 3u);
  for (const auto& d : sink.deliveries) EXPECT_EQ(d.own_echo, d.to == a);
  // Same end-of-frame timestamp for the echo as for everyone else.
  EXPECT_EQ(sink.deliveries[0].frame.timestamp_us, sink.deliveries[2].frame.timestamp_us);
}

TEST_F(BusTest, FrameArrivesAtItsEndOfFrame) {
  const can::Frame f = frame(0x000);  // 53 bits, EOF ends after 50
  ASSERT_FALSE(bus.submit(a, f, kStart));
  bus.advance(kStart, sink);
  EXPECT_TRUE(sink.deliveries.empty());
  const TimePoint eof = kStart + microseconds(50 * 2);  // 500 kbit/s: 2 us per bit
  EXPECT_EQ(bus.next_deadline(), eof);
  bus.advance(eof - microseconds(1), sink);
  EXPECT_TRUE(sink.deliveries.empty());
  bus.advance(eof, sink);
  ASSERT_EQ(sink.frames_to(b).size(), 1u);
  EXPECT_EQ(sink.frames_to(b)[0].timestamp_us, us_of(eof));
  EXPECT_EQ(bus.next_deadline(), kNever);
}

class BackToBack : public ::testing::TestWithParam<std::uint32_t> {};

TEST_P(BackToBack, EndOfFrameTimestampsAreSpacedByFrameDurations) {
  const std::uint32_t bitrate = GetParam();
  BusConfig config;
  config.bitrate = bitrate;
  Bus bus(config);
  const EndpointId tx = bus.attach("tx");
  const EndpointId rx = bus.attach("rx");
  // Same id: equal arbitration fields keep submission order. Different lengths on purpose.
  const std::vector<can::Frame> frames{frame(0x601, {0x40, 0x41, 0x60, 0, 0, 0, 0, 0}), frame(0x601),
                                       frame(0x601, {0xFF, 0xFF}), frame(0x601, std::vector<std::uint8_t>(8, 0))};
  for (const auto& f : frames) ASSERT_FALSE(bus.submit(tx, f, kStart));
  RecordingSink sink;
  for (TimePoint now = kStart; now != kNever; now = bus.next_deadline()) bus.advance(now, sink);
  const auto got = sink.frames_to(rx);
  ASSERT_EQ(got.size(), frames.size());
  const std::int64_t first_eof =
      us_of(kStart + can::bits_duration(can::frame_bits(frames[0]).to_end_of_frame(), bitrate));
  EXPECT_EQ(got[0].timestamp_us, first_eof);
  for (std::size_t i = 1; i < got.size(); ++i) {
    const auto spacing = microseconds(got[i].timestamp_us - got[i - 1].timestamp_us);
    EXPECT_EQ(spacing, can::frame_duration(frames[i], bitrate)) << "frame " << i;
  }
  // The 8-byte SDO request is 123 bits: 984 us at 125 kbit/s, 123 us at 1 Mbit/s.
  EXPECT_EQ(can::frame_duration(frames[0], bitrate), can::bits_duration(123, bitrate));
}

INSTANTIATE_TEST_SUITE_P(Bitrates, BackToBack, ::testing::Values(125'000u, 500'000u, 1'000'000u));

TEST_F(BusTest, FramesWaitingTogetherGoOutInArbitrationOrder) {
  // One frame per sender (a sender's own frames keep their order: next test); o only listens.
  const EndpointId d = bus.attach("d");
  const EndpointId e = bus.attach("e");
  const EndpointId o = bus.attach("o");
  can::Frame rtr = frame(0x100);
  rtr.rtr = true;
  ASSERT_FALSE(bus.submit(a, frame(0x300), kStart));
  ASSERT_FALSE(bus.submit(b, frame(0x123u << 18, {}, true), kStart));  // extended, base id 0x123
  ASSERT_FALSE(bus.submit(c, frame(0x123), kStart));
  ASSERT_FALSE(bus.submit(d, rtr, kStart));
  ASSERT_FALSE(bus.submit(e, frame(0x100), kStart));
  drain();
  std::vector<std::string> seen;
  for (const auto& f : sink.frames_to(o)) seen.push_back(can::to_cansend(f));
  // Data before RTR with the same id; standard before extended with the same base id.
  EXPECT_EQ(seen, (std::vector<std::string>{"100#", "100#R", "123#", "048C0000#", "300#"}));
}

TEST_F(BusTest, AnEndpointsOwnFramesKeepTheirOrderAgainstAHigherPriorityOne) {
  // a queues RPDO-like 0x201 then SYNC 0x080: the SYNC must not overtake a's earlier frame (a
  // SocketCAN interface sends its frames in order); b's 0x200 contends with a's head only.
  ASSERT_FALSE(bus.submit(a, frame(0x201), kStart));
  ASSERT_FALSE(bus.submit(a, frame(0x080), kStart));
  ASSERT_FALSE(bus.submit(b, frame(0x200), kStart));
  drain();
  std::vector<std::uint32_t> seen_by_c;
  for (const auto& f : sink.frames_to(c)) seen_by_c.push_back(f.id);
  EXPECT_EQ(seen_by_c, (std::vector<std::uint32_t>{0x200, 0x201, 0x080}));
}

TEST_F(BusTest, AFrameOnTheWireIsNotPreemptedByALowerId) {
  ASSERT_FALSE(bus.submit(a, frame(0x700), kStart));
  ASSERT_FALSE(bus.submit(b, frame(0x400), kStart + microseconds(10)));  // wire busy: waits
  ASSERT_FALSE(bus.submit(c, frame(0x001), kStart + microseconds(20)));  // waits too, wins next
  drain();
  std::vector<std::uint32_t> seen_by_a;
  for (const auto& f : sink.frames_to(a)) seen_by_a.push_back(f.id);
  EXPECT_EQ(seen_by_a, (std::vector<std::uint32_t>{0x001, 0x400}));
  EXPECT_EQ(sink.frames_to(b).front().id, 0x700u);
}

// A frame the hub read late is submitted at its sender's send time, which the bus has already run
// past: it is queued at that time, takes the wire when it was free then (right behind the frame
// that was on it), and goes before a frame queued later but submitted earlier.
TEST_F(BusTest, AFrameSubmittedInTheBusPastTakesTheWireWhenItWasFreeThen) {
  const can::Frame first = frame(0x100, {1, 2, 3, 4, 5, 6, 7, 8});
  const Duration first_time = can::frame_duration(first, 500000);
  ASSERT_FALSE(bus.submit(a, first, kStart));
  bus.advance(kStart, sink);
  // The bus runs well past the end of the first frame before a's second frame and c's frame
  // are read; c's was sent later than a's but read first.
  const TimePoint later = kStart + first_time + microseconds(400);
  bus.advance(later, sink);
  ASSERT_FALSE(bus.submit(c, frame(0x050), kStart + first_time + microseconds(300)));
  ASSERT_FALSE(bus.submit(a, frame(0x200), kStart + microseconds(50)));  // sent while the first was on the wire
  drain(later);
  const auto to_b = sink.frames_to(b);
  ASSERT_EQ(to_b.size(), 3u);
  EXPECT_EQ(to_b[1].id, 0x200u) << "the one sent first goes first, though its identifier loses arbitration";
  // Back to back behind the first frame: its end plus its own bits, not the time it was read.
  EXPECT_EQ(microseconds(to_b[1].timestamp_us - to_b[0].timestamp_us), can::frame_duration(frame(0x200), 500000));
  EXPECT_EQ(to_b[2].id, 0x050u);
}

// An endpoint's frames keep their sending order even when a later one is submitted with an
// earlier send time (the hub converts each datagram's wall-clock stamp to its loop clock on its
// own, so one batch's stamp may come out a microsecond apart): it is queued with the one before.
TEST_F(BusTest, AnEndpointsFrameSubmittedWithAnEarlierTimeStaysBehindItsPreviousOne) {
  ASSERT_FALSE(bus.submit(c, frame(0x300), kStart + microseconds(2)));  // keeps the wire busy
  ASSERT_FALSE(bus.submit(a, frame(0x200), kStart + microseconds(10)));
  ASSERT_FALSE(bus.submit(a, frame(0x100), kStart + microseconds(9)));
  ASSERT_FALSE(bus.submit(c, frame(0x150), kStart + microseconds(9)));
  drain(kStart + microseconds(10));
  const auto to_b = sink.frames_to(b);
  ASSERT_EQ(to_b.size(), 4u);
  EXPECT_EQ(to_b[0].id, 0x300u);
  EXPECT_EQ(to_b[1].id, 0x150u) << "a's head is 0x200, which loses arbitration to c's 0x150";
  EXPECT_EQ(to_b[2].id, 0x200u);
  EXPECT_EQ(to_b[3].id, 0x100u) << "a's second frame overtook its first";
}

TEST(BusTiming, TimingOffDeliversAtSubmission) {
  BusConfig config;
  config.timing = false;
  Bus bus(config);
  const EndpointId a = bus.attach("a");
  const EndpointId b = bus.attach("b");
  RecordingSink sink;
  ASSERT_FALSE(bus.submit(a, frame(0x7FF), kStart));
  ASSERT_FALSE(bus.submit(a, frame(0x001), kStart));
  bus.advance(kStart, sink);
  const auto got = sink.frames_to(b);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].id, 0x7FFu);  // no arbitration without a wire
  EXPECT_EQ(got[0].timestamp_us, us_of(kStart));
  EXPECT_EQ(bus.next_deadline(), kNever);
}

TEST_F(BusTest, RejectsInvalidFramesAndUnknownEndpoints) {
  can::Frame bad = frame(0x123);
  bad.dlc = 9;
  EXPECT_EQ(bus.submit(a, bad, kStart), std::errc::invalid_argument);
  bad = frame(0x123);
  bad.id = 0x800;  // too big for a standard frame
  EXPECT_EQ(bus.submit(a, bad, kStart), std::errc::invalid_argument);
  EXPECT_EQ(bus.submit(99, frame(0x123), kStart), std::errc::not_connected);
}

TEST_F(BusTest, QueueLimitRejectsFurtherFrames) {
  BusConfig config;
  config.max_queued = 2;
  Bus small(config);
  const EndpointId tx = small.attach("tx");
  EXPECT_FALSE(small.submit(tx, frame(1), kStart));
  EXPECT_FALSE(small.submit(tx, frame(2), kStart));
  EXPECT_EQ(small.submit(tx, frame(3), kStart), std::errc::no_buffer_space);
  EXPECT_EQ(small.statistics(kStart).rejected, 1u);
  EXPECT_EQ(small.statistics(kStart).queued, 2u);
}

TEST_F(BusTest, DropNextFramesThenExpire) {
  bus.inject(Fault::drop(2));
  for (std::uint32_t id = 1; id <= 3; ++id) ASSERT_FALSE(bus.submit(a, frame(id), kStart));
  drain();
  const auto got = sink.frames_to(b);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].id, 3u);  // lowest ids win the wire first, so 1 and 2 were the "next two"
  // A dropped frame uses no wire time: 3 arrives one frame time after the start.
  EXPECT_EQ(got[0].timestamp_us,
            us_of(kStart + can::bits_duration(can::frame_bits(frame(3)).to_end_of_frame(), 500'000)));
  EXPECT_EQ(bus.statistics(kStart).dropped, 2u);
  EXPECT_EQ(bus.statistics(kStart).frames, 1u);
}

TEST_F(BusTest, DropFramesMatchingAnIdFilterFromOneSender) {
  Fault fault = Fault::drop(Fault::kUnlimited, {can::Filter{0x180, 0x780, false, true}});  // 0x180..0x1FF
  fault.sender = a;
  const FaultId id = bus.inject(fault);
  ASSERT_FALSE(bus.submit(a, frame(0x181), kStart));
  ASSERT_FALSE(bus.submit(a, frame(0x201), kStart));
  ASSERT_FALSE(bus.submit(b, frame(0x182), kStart));
  ASSERT_FALSE(bus.submit(a, frame(0x181, {}, true), kStart));  // extended: the filter wants standard
  TimePoint t = drain();
  std::vector<std::uint32_t> seen_by_c;
  for (const auto& f : sink.frames_to(c)) seen_by_c.push_back(f.id);
  // a's frames in a's order (its standard 0x181 dropped); the last 0x181 is the extended one.
  EXPECT_EQ(seen_by_c, (std::vector<std::uint32_t>{0x182, 0x201, 0x181}));
  EXPECT_TRUE(sink.frames_to(c)[2].extended);
  EXPECT_TRUE(bus.clear_fault(id));
  EXPECT_FALSE(bus.clear_fault(id));
  ASSERT_FALSE(bus.submit(a, frame(0x181), t));
  drain(t);
  EXPECT_EQ(sink.frames_to(c).size(), 4u);
}

TEST_F(BusTest, CorruptedFrameBecomesAnErrorEventForEveryone) {
  bus.inject(Fault::corrupt(1));
  ASSERT_FALSE(bus.submit(a, frame(0x123, {1}), kStart));
  ASSERT_FALSE(bus.submit(a, frame(0x124, {2}), kStart));
  drain();
  // 0x123 was corrupted: nobody receives it, everybody (the sender too) gets an error event.
  ASSERT_EQ(sink.frames_to(b).size(), 1u);
  EXPECT_EQ(sink.frames_to(b)[0].id, 0x124u);
  ASSERT_EQ(sink.notices.size(), 3u);
  for (const auto& n : sink.notices) {
    EXPECT_EQ(n.event.error_class, kErrorProtocol);
    EXPECT_EQ(n.event.state, can::BusState::kErrorActive);
    EXPECT_NE(n.event.text.find("123#01"), std::string::npos) << n.event.text;
  }
  // It still took its wire time: 0x124 ends two frame times after the start.
  const auto duration_123 = can::frame_duration(frame(0x123, {1}), 500'000);
  EXPECT_EQ(
      sink.frames_to(b)[0].timestamp_us,
      us_of(kStart + duration_123 + can::bits_duration(can::frame_bits(frame(0x124, {2})).to_end_of_frame(), 500'000)));
  const BusStatistics s = bus.statistics(kStart);
  EXPECT_EQ(s.errors, 1u);
  EXPECT_EQ(s.frames, 2u);
  EXPECT_EQ(bus.endpoint(b)->errors, 1u);
  EXPECT_EQ(bus.endpoint(a)->tx_frames, 1u);
}

TEST_F(BusTest, DelayedFrameArrivesLaterWithALaterTimestamp) {
  bus.inject(Fault::delay_by(milliseconds(5), 1, {can::Filter{0x123, 0x7FF}}));
  ASSERT_FALSE(bus.submit(a, frame(0x123), kStart));
  ASSERT_FALSE(bus.submit(a, frame(0x124), kStart));
  drain();
  const auto got = sink.frames_to(b);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].id, 0x124u);  // overtaken while 0x123 was held back
  const TimePoint eof_123 = kStart + can::bits_duration(can::frame_bits(frame(0x123)).to_end_of_frame(), 500'000);
  EXPECT_EQ(got[1].timestamp_us, us_of(eof_123 + milliseconds(5)));
}

TEST_F(BusTest, BusOffEndpointCannotSendOrReceiveUntilRecovered) {
  ASSERT_FALSE(bus.submit(a, frame(0x111), kStart));
  ASSERT_FALSE(bus.submit(a, frame(0x222), kStart));  // still queued behind 0x111 when a goes bus-off
  bus.advance(kStart, sink);
  ASSERT_TRUE(bus.set_bus_off(a, kStart));
  EXPECT_EQ(bus.submit(a, frame(0x333), kStart), std::errc::network_down);
  ASSERT_FALSE(bus.submit(b, frame(0x444), kStart));
  TimePoint t = drain();
  EXPECT_EQ(bus.endpoint(a)->state, can::BusState::kBusOff);
  EXPECT_TRUE(sink.frames_to(a).empty());  // 0x444 did not reach a
  std::vector<std::uint32_t> seen_by_c;
  for (const auto& f : sink.frames_to(c)) seen_by_c.push_back(f.id);
  EXPECT_EQ(seen_by_c, (std::vector<std::uint32_t>{0x111, 0x444}));  // 0x222 aborted, 0x111 was on the wire
  ASSERT_EQ(sink.notices.size(), 1u);
  EXPECT_EQ(sink.notices[0].to, a);
  EXPECT_EQ(sink.notices[0].event.state, can::BusState::kBusOff);
  EXPECT_EQ(sink.notices[0].event.error_class, kErrorBusOff);
  EXPECT_EQ(bus.statistics(t).rejected, 2u);  // 0x222 aborted, 0x333 refused
  EXPECT_EQ(bus.endpoint(a)->bus_off_count, 1u);

  ASSERT_TRUE(bus.recover(a, t));
  bus.advance(t, sink);
  ASSERT_EQ(sink.notices.size(), 2u);
  EXPECT_EQ(sink.notices[1].event.state, can::BusState::kErrorActive);
  EXPECT_EQ(sink.notices[1].event.error_class, kErrorRestarted);
  EXPECT_FALSE(bus.submit(a, frame(0x555), t));
}

TEST_F(BusTest, BusOffRecoversAutomaticallyAfterTheGivenTime) {
  ASSERT_TRUE(bus.set_bus_off(b, kStart, milliseconds(50)));
  bus.advance(kStart, sink);
  EXPECT_EQ(bus.next_deadline(), kStart + milliseconds(50));
  bus.advance(kStart + milliseconds(49), sink);
  EXPECT_EQ(bus.endpoint(b)->state, can::BusState::kBusOff);
  bus.advance(kStart + milliseconds(50), sink);
  EXPECT_EQ(bus.endpoint(b)->state, can::BusState::kErrorActive);
  ASSERT_EQ(sink.notices.size(), 2u);
  EXPECT_EQ(bus.next_deadline(), kNever);
}

TEST_F(BusTest, DetachedEndpointGetsNothingAndLosesItsQueue) {
  ASSERT_FALSE(bus.submit(a, frame(0x100), kStart));
  ASSERT_FALSE(bus.submit(c, frame(0x200), kStart));
  bus.detach(c);
  bus.detach(b);
  drain();
  EXPECT_TRUE(sink.deliveries.empty());  // b and c are gone, a does not hear itself
  EXPECT_EQ(bus.statistics(kStart).frames, 1u);
  EXPECT_EQ(bus.endpoints().size(), 1u);
  EXPECT_EQ(bus.find("a"), a);
  EXPECT_FALSE(bus.find("b").has_value());
}

TEST(BusStatisticsTest, CountsFramesBytesBitsAndLoadOverTheWindow) {
  BusConfig config;
  config.bitrate = 125'000;
  config.load_window = milliseconds(10);
  Bus bus(config);
  const EndpointId tx = bus.attach("tx");
  bus.attach("rx");
  RecordingSink sink;
  // 5 frames of 127 bits at 8 us/bit: 5080 us of wire time, back to back from kStart.
  const can::Frame f = frame(0x000, std::vector<std::uint8_t>(8, 0));
  for (int i = 0; i < 5; ++i) ASSERT_FALSE(bus.submit(tx, f, kStart));
  for (TimePoint now = kStart; now != kNever; now = bus.next_deadline()) bus.advance(now, sink);
  const BusStatistics at_window_end = bus.statistics(kStart + milliseconds(10));
  EXPECT_EQ(at_window_end.frames, 5u);
  EXPECT_EQ(at_window_end.bytes, 40u);
  EXPECT_EQ(at_window_end.bits, 5u * 127u);
  EXPECT_NEAR(at_window_end.bus_load, 0.508, 1e-9);
  // Half-way through the burst the wire has been busy the whole time since kStart.
  EXPECT_NEAR(bus.statistics(kStart + microseconds(2540)).bus_load, 0.254, 1e-9);
  // The window slides: 15 ms later nothing is left in it.
  EXPECT_DOUBLE_EQ(bus.statistics(kStart + milliseconds(16)).bus_load, 0.0);
  EXPECT_EQ(bus.statistics(kStart + milliseconds(16)).frames, 5u);
}

}  // namespace
}  // namespace motion::simbus
