// CoordinatorService, the LCM shell around the core, on real multicast (its own LCM URL).
#include "coordinator_fixture.hpp"

#include "motion/coordinator/coordinator_service.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/node.hpp"
#include "motion/lcm/start_quiet.hpp"
#include "motion/security/signed_request.hpp"
#include "motion/testing/lcm_url.hpp"
#include "motion/testing/pump.hpp"

namespace motion::coordinator::test_fixture {
namespace {

// A stand-in gateway's answers over LCM on `node`: every GW_COMMAND2_<bus> of `prefix` is kept in
// `commands` and answered at once, ARMED for an ARM_MOVE, DONE for any other; answer() sends any
// reply. Lives where it was made (its subscription refers to it).
struct GatewayAnswers {
  GatewayAnswers(lcm::Node& gateway, const std::string& prefix) : node(gateway) {
    node.subscribe_raw(prefix + "GW_COMMAND2_.*", [this](const void* data, int size, const std::string&) {
      motionlcm::gateway_command2_t c{};
      if (c.decode(data, 0, size) != size) return;
      commands.push_back(c);
      answer(c, c.kind == gateway_command_t::ARM_MOVE ? gateway_reply_t::ARMED : gateway_reply_t::DONE);
    });
  }
  GatewayAnswers(const GatewayAnswers&) = delete;
  GatewayAnswers& operator=(const GatewayAnswers&) = delete;
  void answer(const motionlcm::gateway_command2_t& c, std::int8_t status) {
    gateway_reply_t r{};
    r.command_id = c.command_id;
    r.bus = c.bus;
    r.status = status;
    r.trigger_utime = wall_time_us();
    node.publish(lcm::channels::kGatewayReply, r);
  }
  lcm::Node& node;
  std::vector<motionlcm::gateway_command2_t> commands;
};

// The shell on the wire: the same core behind the LCM subscriptions and publications, driven by
// one loop timer at the deadlines it returns.
TEST(CoordinatorServiceOverLcm, ARequestTravelsOverLcmToTheGatewayAndBack) {
  const config::Config config = *config::load_string(kConfig).config;
  EventLoop loop;
  const std::string url = testing::unique_lcm_url(21);
  lcm::Node node(loop, {url, "CT_"});
  lcm::Node gateway(loop, {url, "CT_"});
  lcm::Node client(loop, {url, "CT_"});
  ASSERT_TRUE(node.ok() && gateway.ok() && client.ok());
  CoordinatorService service(loop, node, config, simple_planner);

  // The gateway of can0 with axis x: heartbeat and state every 50 ms; ARM_MOVE armed, the trigger
  // started and the axis at its target at once.
  motionlcm::axis_state_t x{};
  x.axis = "x";
  x.bus = "can0";
  x.online = x.enabled = x.in_position = true;
  const auto tick = start_gateway_ticks(
      loop, x, [&](const motionlcm::health_t& h) { gateway.publish(lcm::channels::kHealth, h); },
      [&](const motionlcm::axis_state_t& s) { gateway.publish(lcm::channels::kAxisState, s); });
  // The gateway answers the coordinator's DRIVE_MODEL_REQUEST with the model of x.
  int model_requests = 0;
  gateway.subscribe<motionlcm::drive_model_request_t>(
      lcm::channels::kDriveModelRequest, [&](const motionlcm::drive_model_request_t& r, const std::string&) {
        EXPECT_EQ(r.requester, "coordinator");
        ++model_requests;
        gateway.publish(lcm::channels::kDriveModel, test_model("x", "can0", "uim342", 20));
      });
  GatewayAnswers answers(gateway, "CT_");  // what goes out: GW_COMMAND2_<bus>
  const auto& commands = answers.commands;
  std::vector<motionlcm::sync_trigger_t> triggers;
  gateway.subscribe<motionlcm::sync_trigger_t>(
      lcm::channels::kSyncTrigger, [&](const motionlcm::sync_trigger_t& t, const std::string&) {
        triggers.push_back(t);
        for (const auto& c : commands) {
          if (c.kind != gateway_command_t::ARM_MOVE || c.trigger_id != t.trigger_id) continue;
          answers.answer(c, gateway_reply_t::STARTED);
          x.position_counts = c.axes.at(0).target_counts;
          x.position = static_cast<double>(x.position_counts) / 100.0;
        }
      });
  std::map<std::int64_t, std::vector<reply_t>> replies;
  client.subscribe<reply_t>(lcm::channels::kReply,
                            [&](const reply_t& r, const std::string&) { replies[r.request_id].push_back(r); });
  std::vector<motionlcm::active_moves_t> active;
  client.subscribe<motionlcm::active_moves_t>(
      lcm::channels::kActiveMoves,
      [&](const motionlcm::active_moves_t& m, const std::string&) { active.push_back(m); });
  const auto ended = [&](std::int64_t id) {
    return !replies[id].empty() && replies[id].back().status != reply_t::ACCEPTED &&
           replies[id].back().status != reply_t::STARTED && replies[id].back().status != reply_t::PROGRESS;
  };

  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return service.buses_without_gateway() == std::vector<std::string>{"rs485"}; }, milliseconds(3000)));
  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return model_requests > 0; }, milliseconds(3000)))
      << "no DRIVE_MODEL_REQUEST";
  testing::pump_until(
      loop, [] { return false; }, milliseconds(100));  // the model reaches the coordinator
  request_t move = test_request(1, request_t::MOVE_ABSOLUTE, {"x"}, {1.0});
  client.publish(lcm::channels::kRequest, move);
  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return ended(1); }, milliseconds(3000)));
  EXPECT_EQ(replies[1].front().status, std::int8_t{reply_t::ACCEPTED});
  EXPECT_EQ(replies[1].back().status, std::int8_t{reply_t::DONE}) << replies[1].back().reason;
  ASSERT_FALSE(commands.empty());
  EXPECT_EQ(commands.front().kind, std::int8_t{gateway_command_t::ARM_MOVE});
  EXPECT_EQ(commands.front().axes.at(0).target_counts, 100);
  ASSERT_EQ(triggers.size(), 1u);
  EXPECT_EQ(triggers[0].buses, std::vector<std::string>{"can0"});
  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return !active.empty() && active.back().num_axes == 0; }, milliseconds(3000)));
  EXPECT_TRUE(
      std::any_of(active.begin(), active.end(), [](const auto& m) { return m.num_axes == 1 && m.axes[0] == "x"; }));

  // A request that does not decode is answered when its ids are readable.
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(move.getEncodedSize()));
  move.request_id = 2;
  ASSERT_EQ(move.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  bytes.resize(bytes.size() - 10);
  client.publish_raw(client.channel(lcm::channels::kRequest), bytes);
  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return ended(2); }, milliseconds(3000)));
  EXPECT_EQ(replies[2].back().error_code, static_cast<int>(ReplyError::kMalformedRequest));
  EXPECT_EQ(service.active_requests(), 0u);
  loop.cancel(tick);
}

// Around a start across buses the coordinator keeps quiet like the gateways: a reply due from
// just before the first bus's send time until just after the act time goes out at its end, while
// a gateway command sent meanwhile (a stop) goes out at once.
TEST(CoordinatorServiceOverLcm, AroundAStartRepliesWaitWhileCommandsGoOutAtOnce) {
  const config::Config config = *config::load_string(kConfig).config;
  EventLoop loop;
  const std::string url = testing::unique_lcm_url(24);
  lcm::Node node(loop, {url, "CQ_"});
  lcm::Node gateway(loop, {url, "CQ_"});
  lcm::Node client(loop, {url, "CQ_"});
  lcm::Node observer(loop, {url, "CQ_"});  // one socket: the order things went out in
  ASSERT_TRUE(node.ok() && gateway.ok() && client.ok() && observer.ok());
  CoordinatorService service(loop, node, config, simple_planner);

  motionlcm::axis_state_t x{};
  x.axis = "x";
  x.bus = "can0";
  x.online = x.enabled = x.in_position = true;
  motionlcm::axis_state_t c = x;
  c.axis = "c";
  c.bus = "rs485";
  const auto publish_health = [&](const motionlcm::health_t& h) { gateway.publish(lcm::channels::kHealth, h); };
  const auto publish_state = [&](const motionlcm::axis_state_t& st) { gateway.publish(lcm::channels::kAxisState, st); };
  const auto tick_x = start_gateway_ticks(loop, x, publish_health, publish_state);
  const auto tick_c = start_gateway_ticks(loop, c, publish_health, publish_state);
  gateway.subscribe<motionlcm::drive_model_request_t>(
      lcm::channels::kDriveModelRequest, [&](const motionlcm::drive_model_request_t&, const std::string&) {
        gateway.publish(lcm::channels::kDriveModel, test_model("x", "can0", "uim342", 20));
        auto slow = test_model("c", "rs485", "adam-modbus");
        slow.start_wire_us.at(0) = 8'000.0;  // a slow line: the quiet interval begins 8.5 ms ahead
        gateway.publish(lcm::channels::kDriveModel, slow);
      });
  GatewayAnswers answers(gateway, "CQ_");
  // Inside the interval, 1 ms after the slow line's send time: both buses report STARTED and the
  // client asks to stop x.
  std::optional<motionlcm::sync_trigger2_t> t2;
  std::optional<lcm::QuietInterval> quiet;
  gateway.subscribe<motionlcm::sync_trigger2_t>(
      lcm::channels::kSyncTrigger2, [&](const motionlcm::sync_trigger2_t& t, const std::string&) {
        t2 = t;
        quiet = lcm::StartQuiet::interval_of(t);
        const std::int64_t inside = quiet->from_utime + 1'500;
        loop.call_after(std::chrono::microseconds(inside - wall_time_us()), [&] {
          for (const auto& cmd : answers.commands) {
            if (cmd.kind == gateway_command_t::ARM_MOVE && cmd.trigger_id == t2->trigger_id) {
              answers.answer(cmd, gateway_reply_t::STARTED);
            }
          }
          client.publish(lcm::channels::kRequest, test_request(2, request_t::STOP, {"x"}, {0.0}));
        });
      });
  struct Heard {
    std::string what;
    std::int64_t utime = 0;
  };
  std::vector<Heard> heard;  // replies and commands, in the order the observer heard them
  observer.subscribe<reply_t>(lcm::channels::kReply, [&](const reply_t& r, const std::string&) {
    heard.push_back({"reply " + std::to_string(r.request_id) + "/" + std::to_string(r.status), wall_time_us()});
  });
  observer.subscribe_raw("CQ_GW_COMMAND2_.*", [&](const void* data, int size, const std::string&) {
    motionlcm::gateway_command2_t cmd{};
    if (cmd.decode(data, 0, size) != size) return;
    heard.push_back({"command " + std::to_string(cmd.kind), wall_time_us()});
  });
  std::map<std::int64_t, std::vector<reply_t>> replies;
  client.subscribe<reply_t>(lcm::channels::kReply,
                            [&](const reply_t& r, const std::string&) { replies[r.request_id].push_back(r); });
  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return service.buses_without_gateway().empty(); }, milliseconds(3000)));
  testing::pump_until(
      loop, [] { return false; }, milliseconds(200));  // the drive models reach the coordinator
  client.publish(lcm::channels::kRequest, test_request(1, request_t::MOVE_ABSOLUTE, {"x", "c"}, {1.0, 1.0}));
  const auto ended = [&](std::int64_t id) {
    return !replies[id].empty() && replies[id].back().status != reply_t::ACCEPTED &&
           replies[id].back().status != reply_t::STARTED && replies[id].back().status != reply_t::PROGRESS;
  };
  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return ended(1) && ended(2); }, milliseconds(5000)));
  loop.cancel(tick_x);
  loop.cancel(tick_c);
  ASSERT_TRUE(t2 && quiet);
  EXPECT_EQ(quiet->until_utime, t2->act_utime + 500);
  EXPECT_GE(quiet->until_utime - quiet->from_utime, 8'500);
  std::string order;
  for (const auto& h : heard) {
    EXPECT_FALSE(h.what.starts_with("reply") && h.utime > quiet->from_utime && h.utime < quiet->until_utime)
        << h.what << " heard " << (h.utime - quiet->from_utime) << " us into the quiet interval";
    order += h.what + "; ";
  }
  // The stop went out at once, ahead of the replies held meanwhile (the STARTED of the move, the
  // ACCEPTED of the stop).
  const auto at = [&](const std::string& what) { return order.find(what + ";"); };
  ASSERT_NE(at("command 5"), std::string::npos) << order;
  ASSERT_NE(at("reply 1/" + std::to_string(reply_t::STARTED)), std::string::npos) << order;
  ASSERT_NE(at("reply 2/" + std::to_string(reply_t::ACCEPTED)), std::string::npos) << order;
  EXPECT_LT(at("command 5"), at("reply 1/" + std::to_string(reply_t::STARTED))) << order;
  EXPECT_LT(at("command 5"), at("reply 2/" + std::to_string(reply_t::ACCEPTED))) << order;
  EXPECT_FALSE(node.quiet());
}

// The shell with security enforced: what reaches the core from REQUEST and SREQUEST.
TEST(CoordinatorServiceOverLcm, EnforcedSecurityRefusesPlainMalformedAndUnauthorizedRequests) {
  config::Config config = *config::load_string(kConfig).config;
  config.security.mode = config::SecuritySettings::Mode::kEnforce;
  const security::KeyPair watch = security::KeyPair::generate("watch");
  auto keys = std::get<security::AuthorizedKeys>(
      security::AuthorizedKeys::parse(watch.authorized_line("observe") + "\n", "keys"));
  EventLoop loop;
  const std::string url = testing::unique_lcm_url(22);
  lcm::Node node(loop, {url, "CS_"});
  lcm::Node client(loop, {url, "CS_"});
  ASSERT_TRUE(node.ok() && client.ok());
  CoordinatorService::Security gate;
  gate.verifier.emplace(std::move(keys), "CS_", milliseconds(2000), wall_time_us() - 1000);
  CoordinatorService service(loop, node, config, simple_planner, std::move(gate));
  std::vector<reply_t> replies;
  std::vector<motionlcm::event_t> security_events;
  client.subscribe<reply_t>(lcm::channels::kReply, [&](const reply_t& r, const std::string&) { replies.push_back(r); });
  client.subscribe<motionlcm::event_t>(lcm::channels::kEvent, [&](const motionlcm::event_t& e, const std::string&) {
    if (e.kind == motionlcm::event_t::SECURITY) security_events.push_back(e);
  });

  request_t plain{};
  plain.client_id = "plain";
  plain.request_id = 1;
  plain.kind = request_t::MOVE_ABSOLUTE;
  plain.axes = {"x"};
  plain.values = {1.0};
  plain.num_axes = 1;
  client.publish(lcm::channels::kRequest, plain);
  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return security_events.size() == 1; }, milliseconds(3000)));
  EXPECT_EQ(security_events[0].text.rfind(
                "unsigned request refused: security is enforced (move request 1 of client 'plain'", 0),
            0u)
      << security_events[0].text;

  client.publish_raw(node.channel(lcm::channels::kSignedRequest), {1, 2, 3});
  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return security_events.size() == 2; }, milliseconds(3000)));
  EXPECT_EQ(security_events[1].text.rfind("malformed signed request refused: ", 0), 0u) << security_events[1].text;

  security::RequestSigner signer(watch, "CS_");
  request_t move = plain;
  move.client_id = "watch/ctl";
  move.request_id = 2;
  client.publish(lcm::channels::kSignedRequest, signer.sign(move, wall_time_us()));
  ASSERT_TRUE(testing::pump_until(
      loop, [&] { return !replies.empty(); }, milliseconds(3000)));
  EXPECT_EQ(replies[0].client_id, "watch/ctl");
  EXPECT_EQ(replies[0].request_id, 2);
  EXPECT_EQ(replies[0].status, std::int8_t{reply_t::REJECTED});
  EXPECT_EQ(replies[0].error_code, static_cast<int>(ReplyError::kUnauthorized));
  ASSERT_EQ(security_events.size(), 3u);
  EXPECT_EQ(replies[0].reason.rfind("signed request refused: role too low: key 'watch'", 0), 0u) << replies[0].reason;
  EXPECT_EQ(security_events[2].text, replies[0].reason);
  // The plain request and the malformed envelope got no reply.
  EXPECT_EQ(replies.size(), 1u);
  EXPECT_EQ(service.active_requests(), 0u);
}

}  // namespace
}  // namespace motion::coordinator::test_fixture
