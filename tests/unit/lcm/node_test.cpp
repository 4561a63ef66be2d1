#include "motion/lcm/node.hpp"

#include <gtest/gtest.h>

#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/request_t.hpp>

#include <atomic>
#include <chrono>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "motion/lcm/channels.hpp"
#include "motion/lcm/health.hpp"
#include "motion/testing/lcm_url.hpp"

namespace motion::lcm {
namespace {

using std::chrono::milliseconds;

void run_until(EventLoop& loop, const std::function<bool()>& done, milliseconds limit = milliseconds(3000)) {
  const auto deadline = loop.now() + limit;
  while (!done() && loop.now() < deadline) loop.run_once(milliseconds(20));
}

TEST(LcmNode, PublishSubscribeWithPrefix) {
  EventLoop loop;
  Node node(loop, {testing::unique_lcm_url(1), "T1_"});
  ASSERT_TRUE(node.ok());
  EXPECT_EQ(node.channel("EVENT"), "T1_EVENT");
  int received = 0;
  std::string seen_channel;
  node.subscribe<motionlcm::event_t>(channels::kEvent, [&](const motionlcm::event_t& e, const std::string& ch) {
    EXPECT_EQ(e.text, "hello");
    seen_channel = ch;
    ++received;
  });
  motionlcm::event_t e{};
  e.text = "hello";
  ASSERT_TRUE(node.publish(channels::kEvent, e));
  run_until(loop, [&] { return received > 0; });
  EXPECT_EQ(received, 1);
  EXPECT_EQ(seen_channel, "T1_EVENT");
}

// A process that stalled (a loaded host) wakes with a backlog: every message waiting is handled
// before the timers that fell due meanwhile run, so a deadline is not judged on old news (a
// gateway's queued heartbeats behind one state were once taken for a lost gateway).
TEST(LcmNode, ABacklogIsHandledWholeBeforeTheTimersDueMeanwhile) {
  const std::string url = testing::unique_lcm_url(2);
  EventLoop sender_loop;
  EventLoop loop;
  Node sender(sender_loop, {url, "T9_"});
  Node node(loop, {url, "T9_"});
  ASSERT_TRUE(sender.ok() && node.ok());
  int received = 0;
  node.subscribe<motionlcm::event_t>(channels::kEvent,
                                     [&](const motionlcm::event_t&, const std::string&) { ++received; });
  int seen_by_timer = -1;
  loop.call_after(milliseconds(0), [&] { seen_by_timer = received; });
  motionlcm::event_t e{};
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(sender.publish(channels::kEvent, e));
  std::this_thread::sleep_for(milliseconds(200));  // "stalled": everything has arrived, nothing handled
  loop.run_once(milliseconds(0));
  EXPECT_EQ(seen_by_timer, 20);
  EXPECT_EQ(received, 20);
}

// A quiet interval (around a scheduled start): what is published meanwhile waits, in order, and
// goes out when the interval ends; a later end extends it, an earlier one does not shorten it.
TEST(LcmNode, PublicationsInAQuietIntervalGoOutInOrderAtItsEnd) {
  const std::string url = testing::unique_lcm_url(3);
  EventLoop sender_loop;
  EventLoop loop;
  Node sender(sender_loop, {url, "T10_"});
  Node node(loop, {url, "T10_"});
  ASSERT_TRUE(sender.ok() && node.ok());
  std::vector<std::string> received;
  node.subscribe<motionlcm::event_t>(
      channels::kEvent, [&](const motionlcm::event_t& e, const std::string&) { received.push_back(e.text); });
  const TimePoint end = sender_loop.now() + milliseconds(150);
  sender.quiet_until(end);
  sender.quiet_until(end - milliseconds(100));  // does not shorten it
  EXPECT_TRUE(sender.quiet());
  motionlcm::event_t e{};
  for (const char* text : {"one", "two", "three"}) {
    e.text = text;
    EXPECT_TRUE(sender.publish(channels::kEvent, e));
  }
  run_until(
      loop, [] { return false; }, milliseconds(100));
  EXPECT_TRUE(received.empty()) << "published inside the quiet interval";
  while (sender_loop.now() < end + milliseconds(20)) sender_loop.run_once(milliseconds(5));
  EXPECT_FALSE(sender.quiet());
  run_until(loop, [&] { return received.size() == 3; });
  EXPECT_EQ(received, (std::vector<std::string>{"one", "two", "three"}));
  // Once it is over, publications go straight out.
  e.text = "four";
  EXPECT_TRUE(sender.publish(channels::kEvent, e));
  run_until(loop, [&] { return received.size() == 4; });
  EXPECT_EQ(received.back(), "four");
  sender.quiet_until(sender_loop.now() - milliseconds(1));  // already past: nothing
  EXPECT_FALSE(sender.quiet());
}

// Channels published at once (a coordinator's commands and triggers) pass a quiet interval in
// their order while everything else waits for its end.
TEST(LcmNode, ChannelsPublishedAtOnceAreNeverHeld) {
  const std::string url = testing::unique_lcm_url(9);
  EventLoop sender_loop;
  EventLoop loop;
  Node sender(sender_loop, {url, "T12_"});
  Node node(loop, {url, "T12_"});
  ASSERT_TRUE(sender.ok() && node.ok());
  sender.publish_at_once(channels::gateway_command2(""));
  std::vector<std::string> received;  // channel:text, in the order heard (one socket)
  node.subscribe<motionlcm::event_t>(
      "(EVENT|GW_COMMAND2_.*|GW_COMMAND_.*)",
      [&](const motionlcm::event_t& e, const std::string& channel) { received.push_back(channel + ":" + e.text); });
  sender.quiet_until(sender_loop.now() + std::chrono::seconds(60));
  motionlcm::event_t e{};
  for (const char* text : {"a", "b"}) {
    e.text = text;
    EXPECT_TRUE(sender.publish(channels::kEvent, e));
    EXPECT_TRUE(sender.publish(channels::gateway_command2("can0"), e));
    EXPECT_TRUE(sender.publish(channels::gateway_command("can0"), e));  // not named: held
  }
  run_until(loop, [&] { return received.size() == 2; });
  run_until(
      loop, [] { return false; }, milliseconds(50));
  EXPECT_EQ(received, (std::vector<std::string>{"T12_GW_COMMAND2_can0:a", "T12_GW_COMMAND2_can0:b"}));
  EXPECT_TRUE(sender.quiet());
  sender.end_quiet();
  run_until(loop, [&] { return received.size() == 6; });
  EXPECT_EQ(received, (std::vector<std::string>{"T12_GW_COMMAND2_can0:a", "T12_GW_COMMAND2_can0:b", "T12_EVENT:a",
                                                "T12_GW_COMMAND_can0:a", "T12_EVENT:b", "T12_GW_COMMAND_can0:b"}));
}

// A quiet interval never loses a publication: past the queue's limit everything waiting goes out
// and the interval ends; what waits when the node is destroyed goes out then.
TEST(LcmNode, AQuietIntervalCutShortByItsLimitOrItsEndLosesNothing) {
  const std::string url = testing::unique_lcm_url(4);
  EventLoop loop;
  Node node(loop, {url, "T11_"});
  ASSERT_TRUE(node.ok());
  int received = 0;
  node.subscribe<motionlcm::event_t>(channels::kEvent,
                                     [&](const motionlcm::event_t&, const std::string&) { ++received; });
  {
    EventLoop sender_loop;
    Node sender(sender_loop, {url, "T11_"});
    ASSERT_TRUE(sender.ok());
    sender.quiet_until(sender_loop.now() + std::chrono::seconds(60));
    motionlcm::event_t e{};
    for (std::size_t i = 0; i < Node::kQuietQueueLimit; ++i) ASSERT_TRUE(sender.publish(channels::kEvent, e));
    EXPECT_TRUE(sender.quiet());
    run_until(
        loop, [] { return false; }, milliseconds(50));
    EXPECT_EQ(received, 0);
    ASSERT_TRUE(sender.publish(channels::kEvent, e));  // one over the limit: all go out now
    EXPECT_FALSE(sender.quiet());
    run_until(loop, [&] { return received == static_cast<int>(Node::kQuietQueueLimit) + 1; });
    EXPECT_EQ(received, static_cast<int>(Node::kQuietQueueLimit) + 1);
    sender.quiet_until(sender_loop.now() + std::chrono::seconds(60));
    ASSERT_TRUE(sender.publish(channels::kEvent, e));
  }  // destroyed inside its quiet interval
  run_until(loop, [&] { return received == static_cast<int>(Node::kQuietQueueLimit) + 2; });
  EXPECT_EQ(received, static_cast<int>(Node::kQuietQueueLimit) + 2);
}

TEST(LcmNode, MalformedMessageIsCountedAndNotDelivered) {
  EventLoop loop;
  Node node(loop, {testing::unique_lcm_url(2), "T2_"});
  ASSERT_TRUE(node.ok());
  int delivered = 0;
  std::string what;
  node.on_malformed([&](const std::string& w) { what = w; });
  node.subscribe<motionlcm::event_t>(channels::kEvent,
                                     [&](const motionlcm::event_t&, const std::string&) { ++delivered; });
  ASSERT_TRUE(node.publish_raw("T2_EVENT", {1, 2, 3}));
  run_until(loop, [&] { return node.malformed_count() > 0; });
  EXPECT_EQ(node.malformed_count(), 1u);
  EXPECT_EQ(delivered, 0);
  EXPECT_NE(what.find("T2_EVENT"), std::string::npos) << what;
  EXPECT_NE(what.find("event_t"), std::string::npos) << what;
  EXPECT_NE(what.find("3 bytes"), std::string::npos) << what;
}

// A flood of malformed messages: every one counted, at most 5 reports per second and
// subscription, the rest summed up in one "N more ... suppressed" line.
TEST(LcmNode, MalformedReportsAreRateLimitedAndSummarized) {
  EventLoop loop;
  Node node(loop, {testing::unique_lcm_url(6), "T6_"});
  ASSERT_TRUE(node.ok());
  std::vector<std::string> reports;
  node.on_malformed([&](const std::string& w) { reports.push_back(w); });
  int delivered = 0;
  node.subscribe<motionlcm::event_t>(channels::kEvent,
                                     [&](const motionlcm::event_t&, const std::string&) { ++delivered; });
  constexpr int kFlood = 200;
  for (int i = 0; i < kFlood; ++i) ASSERT_TRUE(node.publish_raw("T6_EVENT", {1, 2, 3}));
  run_until(loop, [&] { return node.malformed_count() >= kFlood; });
  ASSERT_EQ(node.malformed_count(), std::uint64_t{kFlood});
  // The summary comes when the window ends.
  run_until(loop, [&] { return !reports.empty() && reports.back().find("suppressed") != std::string::npos; });
  EXPECT_EQ(delivered, 0);
  std::uint64_t reported = 0;
  std::uint64_t suppressed = 0;
  for (const auto& r : reports) {
    if (r.find("suppressed") != std::string::npos) {
      suppressed += std::stoull(r);
      EXPECT_NE(r.find("T6_EVENT"), std::string::npos) << r;
    } else {
      ++reported;
    }
  }
  EXPECT_LE(reported, 10u) << "at most 5 per second (the flood may straddle two windows)";
  EXPECT_GE(reported, 5u);
  EXPECT_EQ(reported + suppressed, std::uint64_t{kFlood});
  EXPECT_EQ(node.malformed_suppressed(), suppressed);
}

TEST(MalformedLimiter, FivePerWindowThenOneSummaryAfterIt) {
  MalformedLimiter limiter(5, std::chrono::seconds(1));
  const TimePoint t0{};
  int admitted = 0;
  for (int i = 0; i < 12; ++i) admitted += limiter.admit(t0 + milliseconds(i)) ? 1 : 0;
  EXPECT_EQ(admitted, 5);
  EXPECT_TRUE(limiter.summary_pending());
  EXPECT_EQ(limiter.take_summary(t0 + milliseconds(999)), 0u) << "not before the window ends";
  EXPECT_EQ(limiter.window_end(), t0 + std::chrono::seconds(1));
  EXPECT_EQ(limiter.take_summary(t0 + std::chrono::seconds(1)), 7u);
  EXPECT_EQ(limiter.take_summary(t0 + std::chrono::seconds(2)), 0u) << "handed out once";
  EXPECT_TRUE(limiter.admit(t0 + std::chrono::seconds(3))) << "a new window reports again";
  EXPECT_EQ(limiter.total(), 13u);
  EXPECT_EQ(limiter.suppressed_total(), 7u);
}

TEST(LcmNode, UdpmUrlsGetAReceiveBuffer) {
  EXPECT_EQ(Node::url_with_receive_buffer("udpm://239.255.76.67:7667?ttl=0", 4096),
            "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4096");
  EXPECT_EQ(Node::url_with_receive_buffer("udpm://239.255.76.67:7667", 4096),
            "udpm://239.255.76.67:7667?recv_buf_size=4096");
  EXPECT_EQ(Node::url_with_receive_buffer("", 4096), std::string(kLcmDefaultUrl) + "&recv_buf_size=4096");
  EXPECT_EQ(Node::url_with_receive_buffer("udpm://239.255.76.67:7667?recv_buf_size=100", 4096),
            "udpm://239.255.76.67:7667?recv_buf_size=100")
      << "the URL's own setting wins";
  EXPECT_EQ(Node::url_with_receive_buffer("file:///tmp/x.log?mode=r", 4096), "file:///tmp/x.log?mode=r");
  EXPECT_GT(Node::default_receive_buffer(), 0);
  EXPECT_LE(Node::default_receive_buffer(), 8 << 20);
}

// 1000 requests from 4 senders without pacing all reach one node (LCM's default per-subscription
// queue of 30 messages and the kernel's default receive buffer lost a quarter to two thirds).
TEST(LcmNode, BurstOf1000RequestsFromFourSendersIsReceivedWhole) {
  const std::string url = testing::unique_lcm_url(7);
  EventLoop loop;
  Node node(loop, {url, "T7_"});
  ASSERT_TRUE(node.ok());
  std::set<std::pair<std::string, std::int64_t>> seen;
  node.subscribe<motionlcm::request_t>(channels::kRequest, [&](const motionlcm::request_t& r, const std::string&) {
    seen.emplace(r.client_id, r.request_id);
  });
  constexpr int kSenders = 4;
  constexpr int kEach = 250;
  std::atomic<int> ready{0};
  std::atomic<int> sent{0};
  std::vector<std::thread> senders;
  senders.reserve(std::size_t{kSenders});
  for (int s = 0; s < kSenders; ++s) {
    senders.emplace_back([&, s] {
      ::lcm::LCM lcm(url);
      ++ready;
      while (ready.load() < kSenders) std::this_thread::yield();
      motionlcm::request_t r{};
      r.client_id = "sender" + std::to_string(s);
      r.kind = motionlcm::request_t::STOP;
      for (int i = 0; i < kEach; ++i) {
        r.request_id = i;
        if (lcm.publish("T7_REQUEST", &r) == 0) ++sent;
      }
    });
  }
  run_until(
      loop, [&] { return seen.size() >= std::size_t{kSenders} * kEach; }, milliseconds(10000));
  for (auto& t : senders) t.join();
  run_until(
      loop, [&] { return seen.size() >= std::size_t{kSenders} * kEach; }, milliseconds(2000));
  EXPECT_EQ(sent.load(), kSenders * kEach);
  EXPECT_EQ(seen.size(), std::size_t{kSenders} * kEach);
  EXPECT_EQ(node.malformed_count(), 0u);
}

TEST(LcmNode, ThrowingHandlerDoesNotEscape) {
  EventLoop loop;
  Node node(loop, {testing::unique_lcm_url(3), "T3_"});
  ASSERT_TRUE(node.ok());
  node.subscribe<motionlcm::event_t>(channels::kEvent, [&](const motionlcm::event_t&, const std::string&) {
    throw std::runtime_error("handler bug");
  });
  motionlcm::event_t e{};
  ASSERT_TRUE(node.publish(channels::kEvent, e));
  run_until(loop, [&] { return node.handler_errors() > 0; });
  EXPECT_EQ(node.handler_errors(), 1u);
}

TEST(LcmNode, BadUrlIsReported) {
  EventLoop loop;
  Node node(loop, {"nosuchprovider://x", "T4_"});
  EXPECT_FALSE(node.ok());
  motionlcm::event_t e{};
  EXPECT_FALSE(node.publish(channels::kEvent, e));
}

TEST(HealthPublisher, PublishesPeriodicallyWithBusStats) {
  EventLoop loop;
  Node node(loop, {testing::unique_lcm_url(4), "T5_"});
  ASSERT_TRUE(node.ok());
  std::vector<motionlcm::health_t> beats;
  node.subscribe<motionlcm::health_t>(channels::kHealth,
                                      [&](const motionlcm::health_t& h, const std::string&) { beats.push_back(h); });
  HealthPublisher health(loop, node, "gateway:can0", "gateway", milliseconds(20));
  health.set_bus_stats([] {
    motionlcm::bus_stats_t b{};
    b.name = "can0";
    b.tx_frames = 17;
    return std::vector<motionlcm::bus_stats_t>{b};
  });
  health.set_state(motionlcm::health_t::OK, "ready");
  run_until(loop, [&] { return beats.size() >= 3; });
  ASSERT_GE(beats.size(), 3u);
  EXPECT_EQ(beats.back().process, "gateway:can0");
  EXPECT_EQ(beats.back().state, std::int8_t{motionlcm::health_t::OK});
  EXPECT_EQ(beats.back().period_ms, 20);
  ASSERT_EQ(beats.back().num_buses, 1);
  EXPECT_EQ(beats.back().buses[0].tx_frames, 17);
  EXPECT_GT(beats.back().pid, 0);
}

TEST(HealthPublisher, DetailShowsMalformedMessagesAndHandlerErrors) {
  EventLoop loop;
  Node node(loop, {testing::unique_lcm_url(8), "T8_"});
  ASSERT_TRUE(node.ok());
  node.on_malformed([](const std::string&) {});
  std::vector<motionlcm::health_t> beats;
  node.subscribe<motionlcm::health_t>(channels::kHealth,
                                      [&](const motionlcm::health_t& h, const std::string&) { beats.push_back(h); });
  node.subscribe<motionlcm::event_t>(channels::kEvent, [](const motionlcm::event_t&, const std::string&) {});
  HealthPublisher health(loop, node, "gateway:can0", "gateway", milliseconds(20));
  health.set_state(motionlcm::health_t::OK, "2 axes ready");
  ASSERT_TRUE(node.publish_raw("T8_EVENT", {9, 9, 9, 9}));
  ASSERT_TRUE(node.publish_raw("T8_EVENT", {9}));
  run_until(loop, [&] { return !beats.empty() && beats.back().detail.find("malformed") != std::string::npos; });
  ASSERT_FALSE(beats.empty());
  EXPECT_EQ(beats.back().detail, "2 axes ready; 2 malformed LCM messages dropped");
  EXPECT_EQ(HealthPublisher::detail_with_counters("", 0, 3), "3 LCM handler errors");
  EXPECT_EQ(HealthPublisher::detail_with_counters("ok", 0, 0), "ok");
}

}  // namespace
}  // namespace motion::lcm
