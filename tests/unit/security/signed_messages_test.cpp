// The coordinator's own messages (triggers, ACTIVE_MOVES, replies, events) signed into
// signed_message_t and verified per channel, on a manual wall clock.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <fstream>
#include <iterator>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>

#include "motion/security/authorized_keys.hpp"
#include "motion/security/signed_messages.hpp"

namespace motion::security {
namespace {

using motionlcm::reply_t;
using motionlcm::sync_trigger2_t;
using namespace std::chrono_literals;

constexpr std::int64_t kStart = 1'700'000'000'000'000;

sync_trigger2_t trigger(std::int64_t id) {
  sync_trigger2_t t{};
  t.trigger_id = id;
  t.act_utime = kStart + 6'000'000;
  t.buses = {"can0"};
  t.send_utime = {t.act_utime - 100};
  t.lead_us = {100.0};
  t.num_buses = 1;
  return t;
}

struct SignedMessages : ::testing::Test {
  KeyPair coordinator = KeyPair::generate("coordinator");
  MessageSigner signer{coordinator, "MOTION_"};
  MessageVerifier triggers{coordinator.public_key(), "MOTION_", "SYNC_TRIGGER2", 2000ms, kStart};
  std::int64_t now = kStart + 5'000'000;
};

TEST_F(SignedMessages, SignedTriggerIsAcceptedOnceAndWhole) {
  EXPECT_EQ(signed_channel("SYNC_TRIGGER2"), "SSYNC_TRIGGER2");
  const auto envelope = signer.sign("SYNC_TRIGGER2", trigger(9), now);
  EXPECT_EQ(envelope.channel, "SYNC_TRIGGER2");
  const auto ok = triggers.verify<sync_trigger2_t>(envelope, now + 100);
  ASSERT_TRUE(ok.message) << ok.reason;
  EXPECT_EQ(ok.message->trigger_id, 9);
  EXPECT_EQ(ok.message->send_utime, trigger(9).send_utime);
  const auto again = triggers.verify<sync_trigger2_t>(envelope, now + 200);
  EXPECT_FALSE(again.message);
  EXPECT_EQ(again.reason.rfind("signed SYNC_TRIGGER2 refused: replayed counter", 0), 0u) << again.reason;
}

TEST_F(SignedMessages, AnOlderCounterIsAReplayEvenForAMessageNeverSeen) {
  const auto first = signer.sign("SYNC_TRIGGER2", trigger(1), now);
  const auto second = signer.sign("SYNC_TRIGGER2", trigger(2), now);
  ASSERT_TRUE(triggers.verify<sync_trigger2_t>(second, now).message);
  EXPECT_NE(triggers.verify<sync_trigger2_t>(first, now).reason.find("replayed counter"), std::string::npos);
}

TEST_F(SignedMessages, OtherKeyAlteredOtherChannelOtherPrefixStaleAndWrongTypeAreRefused) {
  MessageSigner impostor(KeyPair::generate("coordinator"), "MOTION_");
  EXPECT_NE(triggers.verify<sync_trigger2_t>(impostor.sign("SYNC_TRIGGER2", trigger(1), now), now)
                .reason.find("is not the coordinator's"),
            std::string::npos);
  auto altered = signer.sign("SYNC_TRIGGER2", trigger(1), now);
  altered.message[altered.message.size() - 1] ^= 1;
  EXPECT_EQ(triggers.verify<sync_trigger2_t>(altered, now).reason,
            "signed SYNC_TRIGGER2 refused: bad signature (forged or altered in transit)");
  // Signed for another channel, relabelled: the channel is covered by the signature.
  auto relabelled = signer.sign("SYNC_TRIGGER", trigger(1), now);
  EXPECT_NE(triggers.verify<sync_trigger2_t>(relabelled, now).reason.find("it was signed for channel 'SYNC_TRIGGER'"),
            std::string::npos);
  relabelled.channel = "SYNC_TRIGGER2";
  EXPECT_NE(triggers.verify<sync_trigger2_t>(relabelled, now).reason.find("bad signature"), std::string::npos);
  MessageSigner other_prefix(coordinator, "LAB2_");
  EXPECT_NE(triggers.verify<sync_trigger2_t>(other_prefix.sign("SYNC_TRIGGER2", trigger(1), now), now)
                .reason.find("bad signature"),
            std::string::npos);
  const auto old = triggers.verify<sync_trigger2_t>(signer.sign("SYNC_TRIGGER2", trigger(2), now - 3'000'000), now);
  EXPECT_NE(old.reason.find("stale timestamp: signed 3000 ms ago"), std::string::npos) << old.reason;
  const auto before =
      triggers.verify<sync_trigger2_t>(signer.sign("SYNC_TRIGGER2", trigger(2), kStart - 1000), kStart + 1000);
  EXPECT_NE(before.reason.find("before the receiver started"), std::string::npos) << before.reason;
  // Refused for freshness, but authentic (in flight when the receiver started, say): not a forgery.
  EXPECT_TRUE(before.authentic);
  EXPECT_TRUE(old.authentic);
  EXPECT_FALSE(triggers.verify<sync_trigger2_t>(altered, now).authentic);
  EXPECT_FALSE(triggers.verify<sync_trigger2_t>(impostor.sign("SYNC_TRIGGER2", trigger(3), now), now).authentic);
  // Authentic, but not a sync_trigger2_t inside.
  reply_t r{};
  r.client_id = "x";
  const auto wrong = triggers.verify<sync_trigger2_t>(signer.sign("SYNC_TRIGGER2", r, now + 10), now + 10);
  EXPECT_NE(wrong.reason.find("malformed message"), std::string::npos) << wrong.reason;
}

// The fuzz target's seed envelope was signed by Python (motionclient.signing.MessageSigner, python3-nacl) with the seed 32 x 0x03 at
// utime 1.7e15 µs: byte for byte the layout signed_message_t.lcm documents.
TEST(SignedMessageLayout, AnEnvelopeSignedOutsideCppVerifies) {
  std::ifstream in(MOTION_SIGNED_MESSAGE_SEED, std::ios::binary);
  const std::vector<std::uint8_t> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ASSERT_GT(bytes.size(), 1u);
  motionlcm::signed_message_t envelope;
  ASSERT_EQ(lcm::wire::decode_bounded(bytes.data() + 1, bytes.size() - 1, envelope),
            "");  // after the fuzz target's selector byte
  std::array<std::uint8_t, kSeedBytes> seed{};
  seed.fill(3);
  MessageVerifier verifier(KeyPair::from_seed(seed, "coordinator").public_key(), "MOTION_", "SYNC_TRIGGER2", 2000ms, 0);
  const auto v = verifier.verify<sync_trigger2_t>(envelope, 1'700'000'000'000'000);
  ASSERT_TRUE(v.message) << v.reason;
  EXPECT_EQ(v.message->trigger_id, 5);
  EXPECT_EQ(v.message->start_command_ids, std::vector<std::int64_t>{11});
}

// What gateways publish: any key of role gateway, the counter kept per signer and bus, so two
// gateways sharing one key, each counting from its own clock, are not taken for replays of each
// other; within one bus an older counter still is a replay.
TEST(GatewayMessages, AnyGatewayKeyCountersPerKeyAndBus) {
  const KeyPair gw = KeyPair::generate("gateway");
  const KeyPair other = KeyPair::generate("gateway-b");
  const KeyPair op = KeyPair::generate("op");
  const auto keys = std::get<AuthorizedKeys>(AuthorizedKeys::parse(gw.authorized_line("gateway") + "\n" +
                                                                       op.authorized_line("admin") + "\n" +
                                                                       other.authorized_line("gateway") + "\n",
                                                                   "keys"));
  EXPECT_EQ(keys.keys_with_role(Role::kGateway), (std::vector<PublicKey>{gw.public_key(), other.public_key()}));
  EXPECT_FALSE(allows(Role::kGateway, motionlcm::request_t::STOP));  // a gateway key sends no request
  MessageVerifier states(keys.keys_with_role(Role::kGateway), "a gateway key", "MOTION_", "AXIS_STATE", 2000ms, kStart);
  const auto bus = [](const motionlcm::axis_state_t& s) { return s.bus; };
  const auto state = [](const std::string& b) {
    motionlcm::axis_state_t s{};
    s.axis = "x";
    s.bus = b;
    return s;
  };
  const std::int64_t now = kStart + 5'000'000;
  MessageSigner can0(gw, "MOTION_");
  MessageSigner can1(gw, "MOTION_");  // the same key in another process, its clock 1 ms behind
  MessageSigner b(other, "MOTION_");
  ASSERT_TRUE(states.verify<motionlcm::axis_state_t>(can0.sign("AXIS_STATE", state("can0"), now), now, bus).message);
  const auto late = can1.sign("AXIS_STATE", state("can1"), now - 1000);
  const auto on_can1 = states.verify<motionlcm::axis_state_t>(late, now, bus);
  ASSERT_TRUE(on_can1.message) << on_can1.reason;
  EXPECT_EQ(on_can1.message->bus, "can1");
  EXPECT_TRUE(
      states.verify<motionlcm::axis_state_t>(b.sign("AXIS_STATE", state("can1"), now - 2000), now, bus).message);
  const auto old = can0.sign("AXIS_STATE", state("can0"), now - 5000);  // counter above can0's last
  EXPECT_TRUE(states.verify<motionlcm::axis_state_t>(old, now, bus).message);
  const auto replay = states.verify<motionlcm::axis_state_t>(late, now, bus);
  EXPECT_EQ(replay.reason.rfind("signed AXIS_STATE refused: replayed counter", 0), 0u) << replay.reason;
  EXPECT_NE(replay.reason.find("for can1"), std::string::npos) << replay.reason;
  MessageSigner admin(op, "MOTION_");
  EXPECT_EQ(states.verify<motionlcm::axis_state_t>(admin.sign("AXIS_STATE", state("can0"), now + 10), now, bus).reason,
            "signed AXIS_STATE refused: key " + to_hex(op.id()) + " is not a gateway key");
}

// A gateway key bound to buses (buses=can0 in authorized_keys) speaks for those only: what it signs
// for another bus, or naming another bus besides its own, is refused naming the key and the bus;
// a key of every bus, and the bound key on its own bus, pass.
TEST(GatewayMessages, AKeyBoundToABusSpeaksForThatBusOnly) {
  const KeyPair can0 = KeyPair::generate("gateway-can0");
  const KeyPair any = KeyPair::generate("gateway");
  const auto keys = std::get<AuthorizedKeys>(AuthorizedKeys::parse(
      can0.authorized_line("gateway", {"can0"}) + "\n" + any.authorized_line("gateway") + "\n", "keys"));
  MessageVerifier states(keys.with_role(Role::kGateway), "a gateway key", "MOTION_", "AXIS_STATE", 2000ms, kStart);
  // Its bus, and the bus of the axis it names (the receiver's configuration: here y is on rs485).
  const auto buses = [](const motionlcm::axis_state_t& s) {
    return std::vector<std::string>{s.bus, s.axis == "y" ? "rs485" : s.bus};
  };
  const auto bus = [](const motionlcm::axis_state_t& s) { return s.bus; };
  const auto state = [](const std::string& axis, const std::string& b) {
    motionlcm::axis_state_t s{};
    s.axis = axis;
    s.bus = b;
    return s;
  };
  const std::int64_t now = kStart + 5'000'000;
  MessageSigner bound(can0, "MOTION_");
  MessageSigner free(any, "MOTION_");
  const auto verify = [&](MessageSigner& by, const motionlcm::axis_state_t& s) {
    return states.verify<motionlcm::axis_state_t>(by.sign("AXIS_STATE", s, now), now, bus, buses);
  };
  EXPECT_TRUE(verify(bound, state("x", "can0")).message);
  const auto other_bus = verify(bound, state("c", "rs485"));
  EXPECT_FALSE(other_bus.message);
  EXPECT_EQ(other_bus.reason, "signed AXIS_STATE refused: key 'gateway-can0' (" + to_hex(can0.id()) +
                                  ") may speak for bus can0 only (buses= of its authorized_keys line 1), not for "
                                  "bus 'rs485'");
  const auto lying = verify(bound, state("y", "can0"));  // y is on rs485 whatever the state says
  EXPECT_FALSE(lying.message);
  EXPECT_NE(lying.reason.find("not for bus 'rs485'"), std::string::npos) << lying.reason;
  EXPECT_TRUE(verify(free, state("y", "rs485")).message);
  // The 3-argument verify takes the stream for the bus.
  EXPECT_FALSE(
      states.verify<motionlcm::axis_state_t>(bound.sign("AXIS_STATE", state("c", "rs485"), now), now, bus).message);
}

}  // namespace
}  // namespace motion::security
