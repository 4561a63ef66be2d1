// What a hostile LCM message costs in memory: peak bytes allocated (operator new, counted by
// this test binary's own replacement) while a node receives it, with the bounded check and with
// lcm-gen's decode alone. Own executable: the replacement counts every allocation of the binary.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <stdexcept>

#include <motionlcm/gateway_command_t.hpp>

#include "motion/lcm/channels.hpp"
#include "motion/lcm/node.hpp"
#include "motion/testing/lcm_url.hpp"

namespace {

std::atomic<std::size_t> g_current{0};
std::atomic<std::size_t> g_peak{0};
constexpr std::size_t kHeader = alignof(std::max_align_t);

void* counted_alloc(std::size_t size) {
  void* raw = std::malloc(size + kHeader);
  if (raw == nullptr) throw std::bad_alloc();
  *static_cast<std::size_t*>(raw) = size;
  const std::size_t now = g_current.fetch_add(size) + size;
  std::size_t peak = g_peak.load();
  while (now > peak && !g_peak.compare_exchange_weak(peak, now)) {}
  return static_cast<char*>(raw) + kHeader;
}

void counted_free(void* p) noexcept {
  if (p == nullptr) return;
  void* raw = static_cast<char*>(p) - kHeader;
  g_current.fetch_sub(*static_cast<std::size_t*>(raw));
  std::free(raw);
}

// Peak bytes above what was allocated when the measurement started.
struct PeakMeter {
  std::size_t base = g_current.load();
  PeakMeter() { g_peak.store(base); }
  [[nodiscard]] std::size_t peak() const { return g_peak.load() - base; }
};

}  // namespace

void* operator new(std::size_t size) { return counted_alloc(size); }
void* operator new[](std::size_t size) { return counted_alloc(size); }
void operator delete(void* p) noexcept { counted_free(p); }
void operator delete[](void* p) noexcept { counted_free(p); }
void operator delete(void* p, std::size_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::size_t) noexcept { counted_free(p); }

namespace motion::lcm {
namespace {

using std::chrono::milliseconds;

// 74 bytes: a gateway_command_t for bus "can0" whose num_axes claims `count` axis commands.
std::vector<std::uint8_t> hostile_gateway_command(std::int32_t count) {
  motionlcm::gateway_command_t c{};
  c.bus = "can0";
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(c.getEncodedSize()));
  c.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  const std::size_t num_axes_at = 8 + 8 + 9 + 8 + 8 + 1 + 8;
  const auto u = static_cast<std::uint32_t>(count);
  for (std::size_t i = 0; i < 4; ++i) bytes[num_axes_at + i] = static_cast<std::uint8_t>(u >> (24 - 8 * i));
  bytes.resize(74, 0);
  return bytes;
}

TEST(HostileMessage, LcmGenDecodeAllocatesTheClaimedCountFirst) {
  // The hazard the bounded check removes, at a count small enough for a unit test: the meter
  // sees it, so the next tests would fail on a node that decodes without checking.
  const auto bytes = hostile_gateway_command(1'000'000);
  PeakMeter meter;
  const auto t0 = std::chrono::steady_clock::now();
  {
    motionlcm::gateway_command_t msg;
    // Fails one way or the other: a negative length, or std::length_error from the string of
    // the first (zero-length) element.
    try {
      EXPECT_LT(msg.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
    } catch (const std::length_error&) {}
  }
  const auto us = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - t0).count();
  std::printf("lcm-gen decode, 74 bytes claiming 1e6 axes: peak %zu bytes, %lld us\n", meter.peak(),
              static_cast<long long>(us));
  EXPECT_GE(meter.peak(), 1'000'000 * sizeof(motionlcm::axis_command_t));
}

TEST(HostileMessage, BoundedDecodeCostsItsOwnSize) {
  const auto bytes = hostile_gateway_command(20'000'000);
  PeakMeter meter;
  const auto t0 = std::chrono::steady_clock::now();
  motionlcm::gateway_command_t msg;
  const std::string why = wire::decode_bounded(bytes.data(), bytes.size(), msg);
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count();
  std::printf("bounded decode, 74 bytes claiming 2e7 axes: peak %zu bytes, %lld ns: %s\n", meter.peak(),
              static_cast<long long>(ns), why.c_str());
  EXPECT_NE(why, "");
  EXPECT_LT(meter.peak(), 1024u);
}

TEST(HostileMessage, NodeReceivesItWithoutAllocatingTheClaim) {
  EventLoop loop;
  Node node(loop, {testing::unique_lcm_url(31), "HA_"});
  ASSERT_TRUE(node.ok());
  int delivered = 0;
  std::string report;
  node.on_malformed([&](const std::string& w) { report = w; });
  node.subscribe<motionlcm::gateway_command_t>(
      channels::gateway_command("can0"), [&](const motionlcm::gateway_command_t&, const std::string&) { ++delivered; });
  const auto bytes = hostile_gateway_command(20'000'000);
  PeakMeter meter;
  ASSERT_TRUE(node.publish_raw("HA_" + channels::gateway_command("can0"), bytes));
  const auto deadline = loop.now() + milliseconds(3000);
  while (node.malformed_count() == 0 && loop.now() < deadline) loop.run_once(milliseconds(20));
  EXPECT_EQ(node.malformed_count(), 1u);
  EXPECT_EQ(delivered, 0);
  EXPECT_EQ(node.handler_errors(), 0u);
  EXPECT_NE(report.find("count 20000000"), std::string::npos) << report;
  std::printf("node receiving it: peak %zu bytes\n", meter.peak());
  EXPECT_LT(meter.peak(), 64u * 1024u);
}

}  // namespace
}  // namespace motion::lcm
