#include "motion/lcm/node.hpp"

#include <gtest/gtest.h>

#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>
#include <stdexcept>

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

TEST(LcmNode, MalformedMessageIsCountedAndNotDelivered) {
  EventLoop loop;
  Node node(loop, {testing::unique_lcm_url(2), "T2_"});
  ASSERT_TRUE(node.ok());
  int delivered = 0;
  std::string what;
  node.on_malformed([&](const std::string& w) { what = w; });
  node.subscribe<motionlcm::event_t>(channels::kEvent, [&](const motionlcm::event_t&, const std::string&) { ++delivered; });
  ASSERT_TRUE(node.publish_raw("T2_EVENT", {1, 2, 3}));
  run_until(loop, [&] { return node.malformed_count() > 0; });
  EXPECT_EQ(node.malformed_count(), 1u);
  EXPECT_EQ(delivered, 0);
  EXPECT_NE(what.find("T2_EVENT"), std::string::npos) << what;
  EXPECT_NE(what.find("event_t"), std::string::npos) << what;
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
  node.subscribe<motionlcm::health_t>(channels::kHealth, [&](const motionlcm::health_t& h, const std::string&) { beats.push_back(h); });
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

}  // namespace
}  // namespace motion::lcm
