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
  EXPECT_NE(e.find("/etc/motionbus/authorized_keys:3: expected '<base64 public key> <name> <role>', got 2 fields"),
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
