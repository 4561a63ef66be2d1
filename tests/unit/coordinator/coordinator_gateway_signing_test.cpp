// What gateways publish, signed (README "Security"): with security.mode enforce the coordinator
// acts only on AXIS_STATE, GW_REPLY, DRIVE_MODEL, TRIGGER_HEARD, ORPHANED_MOVES, events and heartbeats whose signed copies verify
// against a key of role gateway in authorized_keys. A fake gateway of can0 signs with that key on
// real multicast (the test's own LCM URL); a forger publishes plain messages, messages signed with
// a key of no gateway, and replays of the gateway's own.
#include "coordinator_fixture.hpp"

#include <fstream>

#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/signed_gateway_command_t.hpp>
#include <motionlcm/signed_message_t.hpp>
#include <motionlcm/trigger_heard_t.hpp>

#include "motion/coordinator/coordinator_service.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/node.hpp"
#include "motion/security/signed_messages.hpp"
#include "motion/security/signed_request.hpp"
#include "motion/testing/lcm_url.hpp"
#include "motion/testing/pump.hpp"
#include "motion/testing/temp_dir.hpp"

namespace motion::coordinator::test_fixture {
namespace {

using motionlcm::signed_message_t;

constexpr std::string_view kPrefix = "CGS_";

template <typename Msg>
Msg unwrap(const signed_message_t& envelope) {
  Msg m{};
  EXPECT_EQ(m.decode(envelope.message.data(), 0, envelope.message_size), envelope.message_size);
  return m;
}

// The coordinator under enforce, an honest gateway of can0 (axis x) signing with the gateway key
// (bound to can0: buses=can0),
// a client signing with an operate key, and a forger's node.
class GatewaySigning : public ::testing::Test {
 protected:
  explicit GatewaySigning(int port = 23)
      : url_(testing::unique_lcm_url(port)),
        node_(loop_, {url_, std::string(kPrefix)}),
        gateway_(loop_, {url_, std::string(kPrefix)}),
        client_(loop_, {url_, std::string(kPrefix)}),
        forger_(loop_, {url_, std::string(kPrefix)}),
        gateway_signer_(gateway_key_, std::string(kPrefix)),
        request_signer_(op_key_, std::string(kPrefix)) {}

  void SetUp() override {
    ASSERT_TRUE(node_.ok() && gateway_.ok() && client_.ok() && forger_.ok());
    config_ = *config::load_string(kConfig).config;
    config_.security.mode = config::SecuritySettings::Mode::kEnforce;
    config_.coordinator.arm_timeout_ms = 5000;  // the test arms by hand
    config_.coordinator.gateway_timeout_ms = 2000;
    auto keys = std::get<security::AuthorizedKeys>(security::AuthorizedKeys::parse(
        op_key_.authorized_line("operate") + "\n" + gateway_key_.authorized_line("gateway", {"can0"}) + "\n", "keys"));
    CoordinatorService::Security gate;
    gate.gateway_keys = keys.with_role(security::Role::kGateway);
    gate.verifier.emplace(std::move(keys), std::string(kPrefix), milliseconds(2000), wall_time_us() - 1000);
    gate.command_signer.emplace(coordinator_key_, std::string(kPrefix));
    gate.message_signer.emplace(coordinator_key_, std::string(kPrefix));
    service_ = std::make_unique<CoordinatorService>(loop_, node_, config_, simple_planner, std::move(gate));

    x_.axis = "x";
    x_.bus = "can0";
    x_.online = x_.enabled = x_.in_position = true;
    // Like a gateway with a key: each heartbeat signed, then plain (for observers).
    tick_ = start_gateway_ticks(
        loop_, x_,
        [this](const motionlcm::health_t& h) {
          publish_signed(lcm::channels::kHealth, h);
          gateway_.publish(lcm::channels::kHealth, h);
        },
        [this](const motionlcm::axis_state_t& s) { publish_signed(lcm::channels::kAxisState, s); });
    gateway_.subscribe<motionlcm::drive_model_request_t>(
        lcm::channels::kDriveModelRequest, [this](const motionlcm::drive_model_request_t&, const std::string&) {
          publish_signed(lcm::channels::kDriveModel, test_model("x", "can0", "uim342", 20));
          ++models_sent_;
        });
    gateway_.subscribe<motionlcm::signed_gateway_command_t>(
        lcm::channels::signed_gateway_command("can0"),
        [this](const motionlcm::signed_gateway_command_t& e, const std::string&) {
          motionlcm::gateway_command2_t c{};  // the coordinator signs gateway_command2_t
          ASSERT_EQ(c.decode(e.command.data(), 0, e.command_size), e.command_size);
          commands_.push_back(c);
          if (c.kind == gateway_command_t::ARM_MOVE && arm_on_command_) answer(c, gateway_reply_t::ARMED);
        });
    gateway_.subscribe<signed_message_t>(
        security::signed_channel(lcm::channels::kSyncTrigger), [this](const signed_message_t& e, const std::string&) {
          const auto t = unwrap<motionlcm::sync_trigger_t>(e);
          ++triggers_;
          for (const auto& c : commands_) {
            if (c.kind == gateway_command_t::ARM_MOVE && c.trigger_id == t.trigger_id) {
              answer(c, gateway_reply_t::STARTED);
              x_.in_position = false;  // moving, and it stays so until the test lets it arrive
              x_.velocity = 1.0;
            }
          }
        });
    client_.subscribe<reply_t>(lcm::channels::kReply,
                               [this](const reply_t& r, const std::string&) { replies_[r.request_id].push_back(r); });
    client_.subscribe<motionlcm::event_t>(lcm::channels::kEvent,
                                          [this](const motionlcm::event_t& e, const std::string&) {
                                            if (e.kind == motionlcm::event_t::SECURITY) security_.push_back(e.text);
                                          });
    ASSERT_TRUE(testing::pump_until(
        loop_, [&] { return models_sent_ > 0; }, milliseconds(3000)))
        << "no DRIVE_MODEL_REQUEST";
    // The signed model and states reach the coordinator: x is ready once a move of it is accepted.
    testing::pump_until(
        loop_, [] { return false; }, milliseconds(200));
  }
  void TearDown() override {
    loop_.cancel(tick_);
    service_.reset();
  }

  template <typename Msg>
  void publish_signed(std::string_view channel, const Msg& m) {
    const signed_message_t e = gateway_signer_.sign(channel, m, wall_time_us());
    heard_[std::string(channel)].push_back(e);
    gateway_.publish(security::signed_channel(channel), e);
  }
  static gateway_reply_t reply_to(const motionlcm::gateway_command2_t& c, std::int8_t status) {
    gateway_reply_t r{};
    r.command_id = c.command_id;
    r.bus = c.bus;
    r.status = status;
    r.trigger_utime = wall_time_us();
    r.utime = wall_time_us();
    return r;
  }
  void answer(const motionlcm::gateway_command2_t& c, std::int8_t status) {
    publish_signed(lcm::channels::kGatewayReply, reply_to(c, status));
  }
  void move_x(std::int64_t request_id, double to, const std::string& axis = "x") {
    request_t move{};
    move.client_id = "op/test";
    move.request_id = request_id;
    move.kind = request_t::MOVE_ABSOLUTE;
    move.axes = {axis};
    move.values = {to};
    move.num_axes = 1;
    client_.publish(lcm::channels::kSignedRequest, request_signer_.sign(move, wall_time_us()));
  }
  [[nodiscard]] bool ended(std::int64_t id) {
    const auto& r = replies_[id];
    return !r.empty() && r.back().status != reply_t::ACCEPTED && r.back().status != reply_t::STARTED &&
           r.back().status != reply_t::PROGRESS;
  }
  [[nodiscard]] bool has_status(std::int64_t id, std::int8_t status) {
    const auto& r = replies_[id];
    return std::any_of(r.begin(), r.end(), [&](const reply_t& x) { return x.status == status; });
  }
  // Waits until the coordinator has refused `n` gateway messages in all, and a little more (the
  // messages published before the refused ones have been taken by then).
  [[nodiscard]] bool refused(std::uint64_t n) {
    const bool reached = testing::pump_until(
        loop_, [&] { return service_->refused_gateway_messages() >= n; }, milliseconds(3000));
    testing::pump_until(
        loop_, [] { return false; }, milliseconds(150));
    return reached;
  }
  [[nodiscard]] bool security_event_starts(const std::string& text) const {
    return std::any_of(security_.begin(), security_.end(), [&](const std::string& e) { return e.rfind(text, 0) == 0; });
  }

  const std::string url_;
  EventLoop loop_;
  lcm::Node node_, gateway_, client_, forger_;
  const security::KeyPair coordinator_key_ = security::KeyPair::generate("coordinator");
  const security::KeyPair gateway_key_ = security::KeyPair::generate("gateway");
  const security::KeyPair op_key_ = security::KeyPair::generate("op");
  security::MessageSigner gateway_signer_;
  security::RequestSigner request_signer_;
  config::Config config_;
  std::unique_ptr<CoordinatorService> service_;
  motionlcm::axis_state_t x_{};
  EventLoop::TimerId tick_ = 0;
  int models_sent_ = 0;
  int triggers_ = 0;
  bool arm_on_command_ = true;
  std::vector<motionlcm::gateway_command2_t> commands_;
  std::map<std::int64_t, std::vector<reply_t>> replies_;
  std::map<std::string, std::vector<signed_message_t>> heard_;  // what the gateway signed, per channel
  std::vector<std::string> security_;                           // SECURITY events' texts
};

// A forger's AXIS_STATE saying the moving axis is at rest at its target, plain or signed with a
// key that is no gateway's, and a replay of the gateway's own signed state, end nothing: the move
// ends DONE only when the gateway's own state says so.
TEST_F(GatewaySigning, AForgedAxisStateAtTheTargetDoesNotEndAMove) {
  move_x(1, 1.0);
  ASSERT_TRUE(testing::pump_until(
      loop_, [&] { return has_status(1, reply_t::STARTED) || ended(1); }, milliseconds(3000)));
  ASSERT_FALSE(ended(1)) << replies_[1].back().reason;

  motionlcm::axis_state_t forged = x_;
  forged.position_counts = forged.target_counts = 100;
  forged.position = 1.0;
  forged.in_position = true;
  forged.velocity = 0;
  forged.utime = forged.sample_utime = wall_time_us();
  forger_.publish(lcm::channels::kAxisState, forged);  // plain: not even looked at under enforce
  const security::KeyPair stranger = security::KeyPair::generate("stranger");
  security::MessageSigner stranger_signer(stranger, std::string(kPrefix));
  forger_.publish(security::signed_channel(lcm::channels::kAxisState),
                  stranger_signer.sign(lcm::channels::kAxisState, forged, wall_time_us()));
  // The gateway's own state of a moment ago, published again (its counter is not new).
  ASSERT_FALSE(heard_[std::string(lcm::channels::kAxisState)].empty());
  forger_.publish(security::signed_channel(lcm::channels::kAxisState),
                  heard_[std::string(lcm::channels::kAxisState)].front());
  ASSERT_TRUE(refused(2)) << service_->refused_gateway_messages();
  EXPECT_FALSE(ended(1)) << "a forged state ended the move: " << replies_[1].back().reason;
  EXPECT_EQ(service_->active_requests(), 1u);
  EXPECT_TRUE(security_event_starts("signed AXIS_STATE refused: key " + security::to_hex(stranger.id()) +
                                    " is not a key of role gateway in authorized_keys"));
  EXPECT_TRUE(security_event_starts("signed AXIS_STATE refused: replayed counter"));

  // The gateway's own state at the target ends it.
  x_.position_counts = x_.target_counts = 100;
  x_.position = 1.0;
  x_.in_position = true;
  x_.velocity = 0;
  ASSERT_TRUE(testing::pump_until(
      loop_, [&] { return ended(1); }, milliseconds(3000)));
  EXPECT_EQ(replies_[1].back().status, std::int8_t{reply_t::DONE}) << replies_[1].back().reason;
}

// A plain GW_REPLY ARMED, or one signed with another key, does not arm a move (no trigger goes
// out); the gateway's signed ARMED does; that signed reply sent again is refused as a replay.
TEST_F(GatewaySigning, APlainOrForeignGatewayReplyDoesNotConfirmArmingAndAReplayIsRefused) {
  arm_on_command_ = false;
  move_x(2, 1.0);
  ASSERT_TRUE(testing::pump_until(
      loop_, [&] { return !commands_.empty() || ended(2); }, milliseconds(3000)));
  ASSERT_FALSE(commands_.empty()) << replies_[2].back().reason;
  const motionlcm::gateway_command2_t arm = commands_.front();
  ASSERT_EQ(arm.kind, std::int8_t{gateway_command_t::ARM_MOVE});

  forger_.publish(lcm::channels::kGatewayReply, reply_to(arm, gateway_reply_t::ARMED));
  const security::KeyPair stranger = security::KeyPair::generate("gateway");  // a name is no key
  security::MessageSigner stranger_signer(stranger, std::string(kPrefix));
  forger_.publish(
      security::signed_channel(lcm::channels::kGatewayReply),
      stranger_signer.sign(lcm::channels::kGatewayReply, reply_to(arm, gateway_reply_t::ARMED), wall_time_us()));
  ASSERT_TRUE(refused(2)) << service_->refused_gateway_messages();
  EXPECT_EQ(triggers_, 0) << "a forged ARMED armed the move";
  EXPECT_FALSE(ended(2));
  EXPECT_TRUE(security_event_starts("unsigned GW_REPLY (reply to command " + std::to_string(arm.command_id) +
                                    " of bus can0) refused: security is enforced"));

  answer(arm, gateway_reply_t::ARMED);
  ASSERT_TRUE(testing::pump_until(
      loop_, [&] { return triggers_ > 0; }, milliseconds(3000)));
  const std::uint64_t before = service_->refused_gateway_messages();
  forger_.publish(security::signed_channel(lcm::channels::kGatewayReply),
                  heard_[std::string(lcm::channels::kGatewayReply)].front());
  ASSERT_TRUE(refused(before + 1));
  EXPECT_TRUE(security_event_starts("signed GW_REPLY refused: replayed counter"));

  x_.position_counts = x_.target_counts = 100;
  x_.position = 1.0;
  x_.in_position = true;
  x_.velocity = 0;
  ASSERT_TRUE(testing::pump_until(
      loop_, [&] { return ended(2); }, milliseconds(3000)));
  EXPECT_EQ(replies_[2].back().status, std::int8_t{reply_t::DONE}) << replies_[2].back().reason;
}

// A forged STALL event of the moving axis, plain or signed with a key of no gateway, aborts
// nothing; the gateway's own, signed with its key (GW_EVENT on SGW_EVENT), does.
TEST_F(GatewaySigning, AForgedStallEventAbortsNothing) {
  move_x(3, 1.0);
  ASSERT_TRUE(testing::pump_until(
      loop_, [&] { return has_status(3, reply_t::STARTED) || ended(3); }, milliseconds(3000)));
  ASSERT_FALSE(ended(3)) << replies_[3].back().reason;
  motionlcm::event_t stall{};
  stall.utime = wall_time_us();
  stall.source = "gateway:can0";
  stall.axis = "x";
  stall.bus = "can0";
  stall.kind = motionlcm::event_t::STALL;
  stall.severity = motionlcm::event_t::ERROR;
  stall.text = "forged stall";
  forger_.publish(lcm::channels::kEvent, stall);
  security::MessageSigner stranger(security::KeyPair::generate("gateway"), std::string(kPrefix));
  forger_.publish(security::signed_channel(lcm::channels::kGatewayEvent),
                  stranger.sign(lcm::channels::kGatewayEvent, stall, wall_time_us()));
  ASSERT_TRUE(refused(1)) << service_->refused_gateway_messages();
  EXPECT_FALSE(ended(3)) << "a forged event aborted the move: " << replies_[3].back().reason;
  EXPECT_TRUE(security_event_starts("signed GW_EVENT refused: key"));

  stall.text = "stalled";
  publish_signed(lcm::channels::kGatewayEvent, stall);
  ASSERT_TRUE(testing::pump_until(
      loop_, [&] { return ended(3); }, milliseconds(3000)));
  EXPECT_EQ(replies_[3].back().status, std::int8_t{reply_t::ABORTED}) << replies_[3].back().reason;
  EXPECT_NE(replies_[3].back().reason.find("stalled"), std::string::npos) << replies_[3].back().reason;
}

// A gateway that falls silent is lost even while a forger publishes its plain heartbeats (its host
// and pid copied): under enforce only heartbeats signed with a gateway key keep a bus alive, and
// moves of its axes are refused as offline until its signed heartbeat is heard again.
TEST_F(GatewaySigning, AForgedPlainHeartbeatKeepsNoSilentGatewayAlive) {
  const auto lost = [&](std::vector<std::string> buses) {
    return testing::pump_until(
        loop_, [&] { return service_->buses_without_gateway() == buses; }, milliseconds(4000));
  };
  ASSERT_TRUE(lost({"rs485"})) << "the signed heartbeats do not keep can0 alive";
  loop_.cancel(tick_);  // the gateway of can0 dies: no heartbeat, no state
  tick_ = loop_.call_every(milliseconds(50),
                           [this] { forger_.publish(lcm::channels::kHealth, gateway_heartbeat("can0")); });
  ASSERT_TRUE(lost({"can0", "rs485"})) << "a forged plain heartbeat keeps the silent gateway of can0 alive";
  move_x(4, 1.0);
  ASSERT_TRUE(testing::pump_until(
      loop_, [&] { return ended(4); }, milliseconds(3000)));
  EXPECT_EQ(replies_[4].back().status, std::int8_t{reply_t::REJECTED}) << replies_[4].back().reason;
  EXPECT_NE(replies_[4].back().reason.find("gateway of bus can0 (axis x) is offline"), std::string::npos)
      << replies_[4].back().reason;
  ASSERT_TRUE(refused(1));
  EXPECT_TRUE(security_event_starts(
      "unsigned HEALTH (heartbeat of gateway:can0, pid 100 on testhost) refused: security is enforced"));

  // Its heartbeat signed with the gateway key (and no axis state) brings it back.
  publish_signed(lcm::channels::kHealth, gateway_heartbeat("can0"));
  EXPECT_TRUE(lost({"rs485"})) << "a signed heartbeat does not revive can0";
}

// The gateway key is bound to can0: what it signs for rs485 (the heartbeat of its gateway, a state
// of its axis c, even one that names can0 as its bus) is refused naming the key and the bus, and
// changes nothing: rs485 stays without a gateway and a move of c is refused as offline.
TEST_F(GatewaySigning, AKeyBoundToCan0SpeaksForNoOtherBus) {
  publish_signed(lcm::channels::kHealth, gateway_heartbeat("rs485"));
  motionlcm::axis_state_t c{};
  c.axis = "c";
  c.bus = "rs485";
  c.online = c.enabled = c.in_position = true;
  c.utime = c.sample_utime = wall_time_us();
  publish_signed(lcm::channels::kAxisState, c);
  c.bus = "can0";  // the key's own bus, an axis of another
  publish_signed(lcm::channels::kAxisState, c);
  ASSERT_TRUE(refused(3)) << service_->refused_gateway_messages();
  EXPECT_EQ(service_->buses_without_gateway(), std::vector<std::string>{"rs485"});
  const std::string bound = "key 'gateway' (" + security::to_hex(gateway_key_.id()) +
                            ") may speak for bus can0 only (buses= of its authorized_keys line 2), not for bus 'rs485'";
  EXPECT_TRUE(security_event_starts("signed HEALTH refused: " + bound));
  EXPECT_TRUE(security_event_starts("signed AXIS_STATE refused: " + bound));
  move_x(6, 1.0, "c");
  ASSERT_TRUE(testing::pump_until(
      loop_, [&] { return ended(6); }, milliseconds(3000)));
  EXPECT_EQ(replies_[6].back().status, std::int8_t{reply_t::REJECTED}) << replies_[6].back().reason;
  EXPECT_NE(replies_[6].back().reason.find("gateway of bus rs485 (axis c) is offline"), std::string::npos)
      << replies_[6].back().reason;
}

// Under enforce the trigger lead adapts to the gateway's signed TRIGGER_HEARD only: plain ones (a
// forger's, 1 s late) are not looked at, and the lead falls from the configured 30 ms to the 5 ms
// minimum once can0 has 8 signed samples.
TEST_F(GatewaySigning, TheTriggerLeadAdaptsToSignedHearingsOnly) {
  std::vector<motionlcm::sync_trigger2_t> triggers;
  gateway_.subscribe<signed_message_t>(security::signed_channel(lcm::channels::kSyncTrigger2),
                                       [&](const signed_message_t& e, const std::string&) {
                                         triggers.push_back(unwrap<motionlcm::sync_trigger2_t>(e));
                                       });
  EXPECT_EQ(service_->trigger_lead_us({"can0"}), 30'000);
  for (int i = 0; i < 8; ++i) {
    const std::int64_t id = 100 + i;
    const double to = i % 2 == 0 ? 1.0 : 0.0;
    move_x(id, to);
    ASSERT_TRUE(testing::pump_until(
        loop_,
        [&] {
          return (triggers.size() == static_cast<std::size_t>(i + 1) && has_status(id, reply_t::STARTED)) || ended(id);
        },
        milliseconds(3000)));
    ASSERT_FALSE(ended(id)) << replies_[id].back().reason;
    motionlcm::trigger_heard_t heard{};
    heard.bus = "can0";
    heard.trigger_id = triggers.back().trigger_id;
    heard.trigger_utime = triggers.back().utime;
    heard.send_utime = triggers.back().send_utime.at(0);
    heard.utime = heard.trigger_utime + 1'000'000;
    forger_.publish(lcm::channels::kTriggerHeard, heard);
    heard.utime = heard.trigger_utime + 300;
    publish_signed(lcm::channels::kTriggerHeard, heard);
    x_.position_counts = x_.target_counts = std::llround(to * 100);
    x_.position = to;
    x_.in_position = true;
    x_.velocity = 0;
    ASSERT_TRUE(testing::pump_until(
        loop_, [&] { return ended(id); }, milliseconds(3000)));
    ASSERT_EQ(replies_[id].back().status, std::int8_t{reply_t::DONE}) << replies_[id].back().reason;
  }
  EXPECT_EQ(service_->trigger_lead_us({"can0"}), 5'000);
}

// Under enforce a coordinator without a gateway key in authorized_keys does not start: it would
// refuse every state.
TEST(GatewaySigningConfig, EnforceWithoutAGatewayKeyIsAConfigurationError) {
  const testing::TempDir dir("motion-gwsign");
  config::Config config = *config::load_string(kConfig).config;
  config.security.mode = config::SecuritySettings::Mode::kEnforce;
  config.security.authorized_keys = dir.str() + "/authorized_keys";
  std::ofstream(config.security.authorized_keys)
      << security::KeyPair::generate("op").authorized_line("operate") << "\n";
  const auto loaded = CoordinatorService::load_security(config);
  ASSERT_TRUE(std::holds_alternative<std::string>(loaded));
  EXPECT_NE(std::get<std::string>(loaded).find("has no key with role gateway"), std::string::npos)
      << std::get<std::string>(loaded);
}

}  // namespace
}  // namespace motion::coordinator::test_fixture
