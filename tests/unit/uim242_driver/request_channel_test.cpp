// RequestChannel (passive, time only moves when the test says so): a request held for its
// not_before, and a line reserved for a start frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "motion/uim242_driver/request_channel.hpp"

namespace motion::uim242_driver {
namespace {

using namespace std::chrono_literals;

struct Line {
  // 57600 baud unless `character` says otherwise (10 bits per character).
  explicit Line(Duration egress = {}, Duration character = std::chrono::microseconds(174))
      : egress_latency(egress), character_time(character) {}
  Duration egress_latency;
  Duration character_time;
  std::vector<std::string> sent;
  std::vector<TimePoint> sent_at;
  TimePoint now{};
  RequestChannel channel{[this](std::span<const std::uint8_t> b) {
                           sent.emplace_back(b.begin(), b.end());
                           sent_at.push_back(now);
                         },
                         ChannelSettings{100ms, 0, character_time, egress_latency}};
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

// What holds the line when a start comes is said (the gateway logs it): the request awaiting its
// reply, and how long ago it went on the wire; nothing once the reply is in.
TEST(RequestChannel, TheExchangeUnderWayIsNamedWithItsAge) {
  Line line;
  const TimePoint t0 = TimePoint{} + 10s;
  EXPECT_EQ(line.channel.under_way(t0), "");
  Request r;
  r.drive = "u-drive";
  r.node = 5;
  r.instruction = uim242::Instruction{uim242::Mnemonic::kSPD, false, 1000, false};
  line.channel.submit(std::move(r));
  line.channel.process(t0);
  ASSERT_EQ(line.sent.size(), 1U);
  EXPECT_EQ(line.sent[0], "ADR 5;") << "the gateway selects node 5 first";
  EXPECT_EQ(line.channel.under_way(t0 + 6 * 174us + 250us),
            "u-drive (node 5): 'SPD 1000;' (its ADR selection), on the wire 250 us ago");
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

// While a move of the line awaits its trigger the line is limited to its start wait: a longer
// exchange (a speed for node 5, with its selection) does not begin, nor node 5's poll behind it;
// node 6's poll goes by; a start submitted at the front goes at once. With the limit lifted node
// 5's requests go, in their order.
TEST(RequestChannel, ALimitedLineBeginsNoLongerExchangeButLetsOtherNodesAndStartsBy) {
  Line line;
  const uim242::Instruction fbk{uim242::Mnemonic::kFBK, false, std::nullopt, false};
  const uim242::Instruction spd{uim242::Mnemonic::kSPD, false, 12000, false};
  const auto request = [](int node, const uim242::Instruction& in) {
    Request r;
    r.drive = "u" + std::to_string(node);
    r.node = node;
    r.instruction = in;
    return r;
  };
  const Duration wait = line.channel.exchange_time(fbk, 125);  // a poll of the line, selection included
  ASSERT_GT(line.channel.exchange_time(spd, 5), wait);
  line.channel.limit(wait);
  line.channel.submit(request(5, spd));
  line.channel.submit(request(5, fbk));
  line.channel.submit(request(6, fbk));
  line.now = TimePoint{} + 10s;
  line.channel.process(line.now);
  ASSERT_EQ(line.sent, (std::vector<std::string>{"ADR 6;"}));
  line.now += 5ms;
  ASSERT_TRUE(line.channel.on_frame(
      uim242::make_reply(uim242::reply_form({uim242::Mnemonic::kADR, false, 6, false}), 6, {}), line.now));
  ASSERT_EQ(line.sent, (std::vector<std::string>{"ADR 6;", "FBK;"}));
  line.now += 5ms;
  ASSERT_TRUE(line.channel.on_frame(uim242::make_status_frame(uim242::Header::kStatus, 6, uim242::Status{}), line.now));
  EXPECT_EQ(line.channel.process(line.now), kNever) << "node 5's requests wait for the start";
  EXPECT_EQ(line.sent.size(), 2U);
  line.channel.submit(global_speed(2559), true);  // the start
  line.channel.process(line.now);
  ASSERT_EQ(line.sent.size(), 3U);
  EXPECT_EQ(line.sent.back(), "gSPD 2559;");
  line.now += 200ms;  // gSPD is not answered here: it times out
  line.channel.process(line.now);
  EXPECT_EQ(line.sent.size(), 3U);
  line.channel.limit(Duration::max());
  line.channel.process(line.now);
  ASSERT_EQ(line.sent.size(), 4U);
  EXPECT_EQ(line.sent.back(), "ADR 5;");
  line.now += 5ms;
  ASSERT_TRUE(line.channel.on_frame(
      uim242::make_reply(uim242::reply_form({uim242::Mnemonic::kADR, false, 5, false}), 5, {}), line.now));
  ASSERT_EQ(line.sent.size(), 5U);
  EXPECT_EQ(line.sent.back(), "SPD 12000;");
}

// How long a reservation counts an exchange: the egress latency, the characters of the instruction
// and a reply of kReplyCharacters, those of an `ADR η;` and its reply first when it selects, and
// kReplyAllowance.
TEST(RequestChannel, AnExchangeIsItsInstructionsAndRepliesAtTheBaudRateAndTheAllowance) {
  Line line(300us, 521us);  // 19200 baud
  const uim242::Instruction fbk{uim242::Mnemonic::kFBK, false, std::nullopt, false};
  EXPECT_EQ(line.channel.exchange_time(fbk, 0), 300us + (4 + 24) * 521us + 2ms) << "FBK; is 4 characters";
  EXPECT_EQ(line.channel.exchange_time(fbk, 6), 300us + (4 + 24 + 6 + 24) * 521us + 2ms) << "ADR 6; is 6";
  EXPECT_EQ(line.channel.exchange_time(fbk, 125), 300us + (4 + 24 + 8 + 24) * 521us + 2ms) << "ADR 125; is 8";
}

// A start reserved exchange_time() before it goes out finds the line free, wherever in a poll it
// was reserved (the trigger heard as the poll began, in its middle, at its end): the poll selects
// node 6 (`ADR 6;`) and reads `FBK;` and `QEC;`, and each reply arrives whole, at the baud rate, a
// reply latency after its instruction has crossed the line. Reserved as it goes out, the start is
// left behind the poll wherever the poll is under way.
TEST(RequestChannel, AStartReservedAnExchangeAheadFindsThePollDoneWhereverItWasReserved) {
  const Duration character = 521us;  // 19200 baud
  const uim242::Instruction fbk{uim242::Mnemonic::kFBK, false, std::nullopt, false};
  const uim242::Instruction qec{uim242::Mnemonic::kQEC, false, std::nullopt, false};
  const std::map<std::string, uim242::Frame> replies{
      {"ADR 6;", uim242::make_reply(uim242::reply_form({uim242::Mnemonic::kADR, false, 6, false}), 6, {})},
      {"FBK;", uim242::make_status_frame(uim242::Header::kStatus, 6, uim242::Status{})},
      {"QEC;", uim242::make_reply(uim242::reply_form(qec), 6, std::vector<std::int64_t>{1234})},
  };
  // Whether the start goes out at `at` when reserved `margin` before it, `heard` after the poll
  // was handed to the line.
  const auto start_on_time = [&](Duration heard, Duration margin, Duration latency) {
    Line line({}, character);
    const TimePoint t0 = TimePoint{} + 10s;
    for (const auto& in : {fbk, qec}) {
      Request poll;
      poll.drive = "u2-drive";
      poll.node = 6;
      poll.instruction = in;
      line.channel.submit(std::move(poll));
    }
    const TimePoint at = t0 + heard + margin;
    std::multimap<TimePoint, std::function<void()>> events;
    std::size_t answered = 0;
    const auto answer_writes = [&] {  // each instruction's reply, once it has crossed the line
      for (; answered < line.sent.size(); ++answered) {
        const auto it = replies.find(line.sent[answered]);
        if (it == replies.end()) continue;
        const TimePoint end =
            line.sent_at[answered] +
            character * static_cast<std::int64_t>(line.sent[answered].size() + uim242::serialize(it->second).size()) +
            latency;
        events.emplace(end, [&line, frame = it->second] { line.channel.on_frame(frame, line.now); });
      }
    };
    events.emplace(t0 + heard, [&] { line.channel.reserve(at); });
    line.now = t0;
    line.channel.process(t0);
    answer_writes();
    while (!events.empty() && events.begin()->first <= at) {
      auto [when, what] = *events.begin();
      events.erase(events.begin());
      line.now = when;
      what();
      line.channel.process(when);
      answer_writes();
    }
    line.now = at;
    line.channel.process(at);
    line.channel.submit(global_speed(2559), true);
    line.channel.reserve(kNever);
    const std::size_t before = line.sent.size();
    line.channel.process(at);
    return line.sent.size() == before + 1 && line.sent.back() == "gSPD 2559;" && line.sent_at.back() == at;
  };
  Line probe({}, character);
  const Duration wait = probe.channel.exchange_time(fbk, 6);
  int late_unreserved = 0;
  for (const Duration latency : {Duration{}, Duration{1ms}}) {
    for (Duration heard{}; heard < 40ms; heard += 250us) {
      EXPECT_TRUE(start_on_time(heard, wait, latency))
          << "reserved " << heard.count() / 1000 << " us into the poll, reply latency " << latency.count() / 1000
          << " us";
      late_unreserved += start_on_time(heard, Duration{}, latency) ? 0 : 1;
    }
  }
  EXPECT_GT(late_unreserved, 0) << "a start without a margin never met the poll: the test would not see a short wait";
}

}  // namespace
}  // namespace motion::uim242_driver
