// Every public type encodes and decodes to an equal value (fields filled with non-default data).
#include <gtest/gtest.h>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/can_frame_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>

#include <vector>

namespace {

template <typename Msg>
Msg round_trip(const Msg& in) {
  const int size = in.getEncodedSize();
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(size));
  EXPECT_EQ(in.encode(buf.data(), 0, size), size);
  Msg out;
  EXPECT_EQ(out.decode(buf.data(), 0, size), size);
  // A truncated buffer must not decode.
  Msg partial;
  EXPECT_LT(partial.decode(buf.data(), 0, size - 1), 0);
  return out;
}

motionlcm::param_t sample_param() {
  motionlcm::param_t p{};
  p.space = motionlcm::param_t::CANOPEN_OBJECT;
  p.index = 0x6081;
  p.subindex = 0;
  p.width = 4;
  p.is_signed = false;
  p.mnemonic = "profile velocity";
  p.value = 123456789012LL;
  return p;
}

TEST(LcmTypes, RequestRoundTrip) {
  motionlcm::request_t r{};
  r.utime = 1700000000000001;
  r.client_id = "cli";
  r.request_id = 42;
  r.kind = motionlcm::request_t::MOVE_ABSOLUTE;
  r.num_axes = 2;
  r.axes = {"x", "y"};
  r.values = {120.5, -3.25};
  r.velocity_scale = 0.5;
  r.acceleration_scale = 0.25;
  r.timeout_ms = 5000;
  r.output_mask = 3;
  r.output_value = 1;
  r.param = sample_param();
  const auto o = round_trip(r);
  EXPECT_EQ(o.client_id, "cli");
  EXPECT_EQ(o.axes, r.axes);
  EXPECT_EQ(o.values, r.values);
  EXPECT_EQ(o.param.value, r.param.value);
  EXPECT_EQ(o.param.mnemonic, r.param.mnemonic);
  EXPECT_EQ(o.output_mask, 3);
}

TEST(LcmTypes, ReplyRoundTrip) {
  motionlcm::reply_t r{};
  r.request_id = 7;
  r.status = motionlcm::reply_t::ABORTED;
  r.reason = "axis y stalled";
  r.error_code = 12;
  r.num_axes = 1;
  r.axes = {"y"};
  r.targets = {1.0};
  r.positions = {0.5};
  r.start_utime = {99};
  r.predicted_skew_us = 1.5;
  r.param = sample_param();
  const auto o = round_trip(r);
  EXPECT_EQ(o.reason, r.reason);
  EXPECT_EQ(o.start_utime, r.start_utime);
  EXPECT_EQ(o.status, std::int8_t{motionlcm::reply_t::ABORTED});
}

TEST(LcmTypes, AxisStateEventHealthRoundTrip) {
  motionlcm::axis_state_t s{};
  s.axis = "x";
  s.family = "uim342";
  s.position_counts = -123456789;
  s.position = -1.5;
  s.enabled = true;
  s.inputs = 5;
  EXPECT_EQ(round_trip(s).position_counts, s.position_counts);
  EXPECT_EQ(round_trip(s).inputs, 5);

  motionlcm::event_t e{};
  e.kind = motionlcm::event_t::STALL;
  e.text = "stall";
  e.code = 0x41;
  EXPECT_EQ(round_trip(e).code, 0x41);

  motionlcm::health_t h{};
  h.process = "gateway:can0";
  h.num_buses = 1;
  motionlcm::bus_stats_t b{};
  b.name = "can0";
  b.tx_frames = 1000;
  b.bus_load = 0.25;
  h.buses = {b};
  const auto o = round_trip(h);
  ASSERT_EQ(o.buses.size(), 1u);
  EXPECT_EQ(o.buses[0].tx_frames, 1000);
}

TEST(LcmTypes, GatewayAndTriggerAndFrameRoundTrip) {
  motionlcm::gateway_command_t c{};
  c.bus = "can0";
  c.command_id = 5;
  c.kind = motionlcm::gateway_command_t::ARM_MOVE;
  c.trigger_id = 9;
  c.num_axes = 1;
  motionlcm::axis_command_t a{};
  a.axis = "x";
  a.target_counts = 64000;
  a.velocity = 3200;
  a.acceleration = 10000;
  a.deceleration = 12000;
  c.axes = {a};
  c.param = sample_param();
  const auto oc = round_trip(c);
  ASSERT_EQ(oc.axes.size(), 1u);
  EXPECT_EQ(oc.axes[0].target_counts, 64000);
  EXPECT_EQ(oc.axes[0].deceleration, 12000);

  motionlcm::gateway_reply_t g{};
  g.command_id = 5;
  g.status = motionlcm::gateway_reply_t::STARTED;
  g.trigger_utime = 123;
  g.start_mechanism = "group-bg";
  EXPECT_EQ(round_trip(g).start_mechanism, "group-bg");

  motionlcm::sync_trigger_t t{};
  t.trigger_id = 9;
  t.fire_utime = 1700000000500000;
  t.num_buses = 2;
  t.buses = {"can0", "rs485"};
  EXPECT_EQ(round_trip(t).buses, t.buses);

  motionlcm::sync_trigger2_t t2{};
  t2.trigger_id = 9;
  t2.act_utime = 1700000000500000;
  t2.num_buses = 2;
  t2.buses = {"can0", "rs485"};
  t2.send_utime = {1700000000499930, 1700000000499306};
  t2.lead_us = {70.0, 694.4};
  t2.num_starts = 2;
  t2.start_command_ids = {4, 5};
  const auto back = round_trip(t2);
  EXPECT_EQ(back.send_utime, t2.send_utime);
  EXPECT_EQ(back.lead_us, t2.lead_us);
  EXPECT_EQ(back.start_command_ids, t2.start_command_ids);

  motionlcm::can_frame_t f{};
  f.id = 0x04280095;
  f.extended = true;
  f.dlc = 1;
  f.data = {0x01};
  EXPECT_EQ(round_trip(f).data, f.data);
}

}  // namespace
