// authorized_keys: parsing, errors with file:line, roles per request kind.
#include <gtest/gtest.h>

#include <motionlcm/request_t.hpp>

#include "motion/security/authorized_keys.hpp"

namespace motion::security {
namespace {

using motionlcm::request_t;

TEST(AuthorizedKeys, ParsesPrincipalsAndFindsThemByKeyId) {
  const KeyPair alice = KeyPair::generate("alice");
  const KeyPair bob = KeyPair::generate("bob");
  const std::string text =
      "# lab operators\n\n" + alice.authorized_line("operate") + "\n   " + bob.authorized_line("observe") + "  \n";
  const auto parsed = AuthorizedKeys::parse(text, "keys");
  ASSERT_TRUE(std::holds_alternative<AuthorizedKeys>(parsed)) << std::get<std::string>(parsed);
  const auto& keys = std::get<AuthorizedKeys>(parsed);
  ASSERT_EQ(keys.principals().size(), 2u);
  const Principal* p = keys.find(alice.id());
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->name, "alice");
  EXPECT_EQ(p->role, Role::kOperate);
  EXPECT_EQ(p->line, 3);
  EXPECT_EQ(keys.find(bob.id())->role, Role::kObserve);
  EXPECT_EQ(keys.find(KeyPair::generate("carol").id()), nullptr);
}

// A gateway key may be bound to buses by a fourth token, buses=<bus>[,<bus>...]; without it, it
// speaks for every bus.
TEST(AuthorizedKeys, AGatewayKeyIsBoundToTheBusesOfItsLine) {
  const KeyPair can0 = KeyPair::generate("gateway-can0");
  const KeyPair two = KeyPair::generate("gateway-two");
  const KeyPair any = KeyPair::generate("gateway");
  EXPECT_EQ(two.authorized_line("gateway", {"can0", "rs485a"}),
            base64_encode(two.public_key()) + " gateway-two gateway buses=can0,rs485a");
  const auto parsed = AuthorizedKeys::parse(can0.authorized_line("gateway", {"can0"}) + "\n" +
                                                two.authorized_line("gateway", {"can0", "rs485a"}) + "\n" +
                                                any.authorized_line("gateway") + "\n",
                                            "keys");
  ASSERT_TRUE(std::holds_alternative<AuthorizedKeys>(parsed)) << std::get<std::string>(parsed);
  const auto& keys = std::get<AuthorizedKeys>(parsed);
  EXPECT_EQ(keys.find(can0.id())->buses, std::vector<std::string>{"can0"});
  EXPECT_EQ(keys.find(two.id())->buses, (std::vector<std::string>{"can0", "rs485a"}));
  EXPECT_TRUE(keys.find(any.id())->buses.empty());
  EXPECT_TRUE(keys.find(can0.id())->may_speak_for("can0"));
  EXPECT_FALSE(keys.find(can0.id())->may_speak_for("rs485a"));
  EXPECT_TRUE(keys.find(two.id())->may_speak_for("rs485a"));
  EXPECT_TRUE(keys.find(any.id())->may_speak_for("anything"));
  ASSERT_EQ(keys.with_role(Role::kGateway).size(), 3u);
  EXPECT_EQ(keys.with_role(Role::kGateway)[1].name, "gateway-two");
}

// The buses token on another role, an empty list, an empty or bad name, a name twice, or another
// token in its place: load errors naming file:line.
TEST(AuthorizedKeys, ABadBusesTokenIsALoadError) {
  int n = 0;
  const auto line = [&n](const std::string& role, const std::string& token) {
    return base64_encode(KeyPair::generate("k").public_key()) + " k" + std::to_string(++n) + " " + role + " " + token +
           "\n";
  };
  const std::string text = line("operate", "buses=can0") +   // 1
                           line("gateway", "buses=") +       // 2
                           line("gateway", "buses=can0,") +  // 3
                           line("gateway", "buses=can/0") +  // 4
                           line("gateway", "buses=a,b,a") +  // 5
                           line("gateway", "bus=can0") +     // 6
                           line("gateway", "buses=can0") +   // 7 ok
                           line("gateway", "buses=can0 x");  // 8 five fields
  const auto parsed = AuthorizedKeys::parse(text, "keys");
  ASSERT_TRUE(std::holds_alternative<std::string>(parsed));
  const std::string& e = std::get<std::string>(parsed);
  EXPECT_NE(e.find("keys:1: 'buses=can0': only a key of role gateway is bound to buses, this one has role operate"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("keys:2: 'buses=' names no bus"), std::string::npos) << e;
  EXPECT_NE(e.find("keys:3: 'buses=can0,': bus name '' is not 1..64 of [A-Za-z0-9._-]"), std::string::npos) << e;
  EXPECT_NE(e.find("keys:4: 'buses=can/0': bus name 'can/0' is not 1..64 of [A-Za-z0-9._-]"), std::string::npos) << e;
  EXPECT_NE(e.find("keys:5: 'buses=a,b,a' names bus 'a' twice"), std::string::npos) << e;
  EXPECT_NE(e.find("keys:6: expected 'buses=<bus>[,<bus>...]' after the role, got 'bus=can0'"), std::string::npos) << e;
  EXPECT_EQ(e.find("keys:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("keys:8: expected '<base64 public key> <name> <role> [buses=<bus>,...]', got 5 fields"),
            std::string::npos)
      << e;
}

TEST(AuthorizedKeys, EveryErrorNamesFileLineAndWhatWasWrong) {
  const KeyPair alice = KeyPair::generate("alice");
  const KeyPair other = KeyPair::generate("alice");
  const std::string text = alice.authorized_line("operate") + "\n" +                               // 1 ok
                           "AAAA bob operate\n" +                                                  // 2 short key
                           base64_encode(alice.public_key()) + " carol\n" +                        // 3 two fields
                           KeyPair::generate("dave").authorized_line("root") + "\n" +              // 4 role
                           alice.authorized_line("admin") + "\n" +                                 // 5 same key
                           other.authorized_line("observe") + "\n" +                               // 6 same name
                           base64_encode(KeyPair::generate("e").public_key()) + " a/b operate\n";  // 7 name
  const auto parsed = AuthorizedKeys::parse(text, "/etc/motionbus/authorized_keys");
  ASSERT_TRUE(std::holds_alternative<std::string>(parsed));
  const std::string& e = std::get<std::string>(parsed);
  EXPECT_NE(e.find("/etc/motionbus/authorized_keys:2: 'AAAA' is not a base64 Ed25519 public key (32 bytes)"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("/etc/motionbus/authorized_keys:3: expected '<base64 public key> <name> <role> [buses=<bus>,...]', "
                   "got 2 fields"),
            std::string::npos)
      << e;
  EXPECT_NE(
      e.find("/etc/motionbus/authorized_keys:4: unknown role 'root' (observe, operate, configure, admin, gateway)"),
      std::string::npos)
      << e;
  EXPECT_NE(e.find("/etc/motionbus/authorized_keys:5: key of 'alice' is already listed at line 1"), std::string::npos)
      << e;
  EXPECT_NE(e.find("/etc/motionbus/authorized_keys:6: name 'alice' is already used at line 1"), std::string::npos) << e;
  EXPECT_NE(e.find("/etc/motionbus/authorized_keys:7: name 'a/b' is not 1..64 of [A-Za-z0-9._-]"), std::string::npos)
      << e;
  EXPECT_EQ(std::count(e.begin(), e.end(), '\n'), 5) << e;
}

TEST(AuthorizedKeys, MissingFileIsNamed) {
  const auto loaded = AuthorizedKeys::load("/nonexistent/authorized_keys");
  EXPECT_EQ(std::get<std::string>(loaded), "cannot read authorized keys file /nonexistent/authorized_keys");
}

TEST(Roles, EveryoneMayStopAndEachRoleAddsItsKinds) {
  for (const auto role : {Role::kObserve, Role::kOperate, Role::kConfigure, Role::kAdmin}) {
    EXPECT_TRUE(allows(role, request_t::STOP));
    EXPECT_TRUE(allows(role, request_t::ESTOP));
  }
  for (const auto kind : {request_t::MOVE_ABSOLUTE, request_t::MOVE_RELATIVE, request_t::JOG, request_t::HOME,
                          request_t::ENABLE, request_t::DISABLE, request_t::FAULT_RESET}) {
    EXPECT_FALSE(allows(Role::kObserve, kind)) << int(kind);
    EXPECT_TRUE(allows(Role::kOperate, kind)) << int(kind);
  }
  for (const auto kind :
       {request_t::SET_POSITION, request_t::SET_OUTPUTS, request_t::PARAM_READ, request_t::PARAM_WRITE}) {
    EXPECT_FALSE(allows(Role::kOperate, kind)) << int(kind);
    EXPECT_TRUE(allows(Role::kConfigure, kind)) << int(kind);
  }
  EXPECT_FALSE(allows(Role::kConfigure, 99));
  EXPECT_TRUE(allows(Role::kAdmin, 99));
  // A gateway's key signs what gateways publish and no request, not even a stop.
  EXPECT_EQ(parse_role("gateway"), Role::kGateway);
  for (const std::int8_t kind : {request_t::STOP, request_t::ESTOP, request_t::MOVE_ABSOLUTE, std::int8_t{99}})
    EXPECT_FALSE(allows(Role::kGateway, kind)) << int(kind);
  EXPECT_EQ(parse_role("configure"), Role::kConfigure);
  EXPECT_FALSE(parse_role("Admin"));
}

}  // namespace
}  // namespace motion::security
