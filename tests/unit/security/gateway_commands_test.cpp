// Gateway commands signed by the coordinator and verified by a gateway, on a manual wall clock.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "motion/security/gateway_commands.hpp"

namespace motion::security {
namespace {

using motionlcm::gateway_command_t;
using namespace std::chrono_literals;

constexpr std::int64_t kStart = 1'700'000'000'000'000;

gateway_command_t arm(std::int64_t id) {
  gateway_command_t c{};
  c.bus = "can0";
  c.command_id = id;
  c.request_id = 7;
  c.kind = gateway_command_t::ARM_MOVE;
  return c;
}

struct GatewayCommands : ::testing::Test {
  KeyPair coordinator = KeyPair::generate("coordinator");
  GatewayCommandSigner signer{coordinator, "MOTION_"};
  GatewayCommandVerifier verifier{coordinator.public_key(), "MOTION_", 2000ms, kStart};
  std::int64_t now = kStart + 5'000'000;
};

TEST_F(GatewayCommands, SignedCommandIsAcceptedOnceAndWhole) {
  const auto envelope = signer.sign(arm(3), now);
  const auto ok = verifier.verify(envelope, now + 100);
  ASSERT_TRUE(ok.command) << ok.reason;
  EXPECT_EQ(ok.command->command_id, 3);
  EXPECT_EQ(ok.command->bus, "can0");
  const auto again = verifier.verify(envelope, now + 200);
  EXPECT_FALSE(again.command);
  EXPECT_EQ(again.reason.rfind("signed command refused: replayed counter", 0), 0u) << again.reason;
  EXPECT_TRUE(verifier.verify(signer.sign(arm(4), now), now).command);
}

TEST_F(GatewayCommands, OtherKeyAlteredPayloadStaleTimeAndRequestDomainAreRefused) {
  GatewayCommandSigner other(KeyPair::generate("coordinator"), "MOTION_");
  EXPECT_NE(verifier.verify(other.sign(arm(1), now), now).reason.find("is not the coordinator's"), std::string::npos);
  auto altered = signer.sign(arm(1), now);
  altered.command[altered.command.size() - 1] ^= 1;
  EXPECT_EQ(verifier.verify(altered, now).reason,
            "signed command refused: bad signature (forged or altered in transit)");
  const auto old = verifier.verify(signer.sign(arm(2), now - 3'000'000), now);
  EXPECT_NE(old.reason.find("stale timestamp: signed 3000 ms ago, outside the window of 2000 ms"), std::string::npos)
      << old.reason;
  const auto before = verifier.verify(signer.sign(arm(2), kStart - 1000), kStart + 1000);
  EXPECT_NE(before.reason.find("before the gateway started"), std::string::npos) << before.reason;
  GatewayCommandSigner other_prefix(coordinator, "LAB2_");
  EXPECT_EQ(verifier.verify(other_prefix.sign(arm(5), now), now).reason,
            "signed command refused: bad signature (forged or altered in transit)");
}

// A signed gateway_command2_t (grid integers) travels in the same envelope: the verifier tells it
// from a gateway_command_t by its fingerprint and hands out the one it is.
TEST_F(GatewayCommands, EitherCommandVersionIsAcceptedAsTheTypeItIs) {
  motionlcm::gateway_command2_t c2{};
  c2.bus = "can0";
  c2.command_id = 9;
  c2.kind = gateway_command_t::ARM_MOVE;
  c2.axes.resize(1);
  c2.axes[0].axis = "x";
  c2.axes[0].velocity = 123;
  c2.axes[0].model_utime = 42;
  c2.num_axes = 1;
  const auto v2 = verifier.verify(signer.sign(c2, now), now);
  ASSERT_TRUE(v2.command2) << v2.reason;
  EXPECT_FALSE(v2.command);
  EXPECT_EQ(v2.command2->axes.at(0).velocity, 123);
  EXPECT_EQ(v2.command2->axes.at(0).model_utime, 42);
  const auto v1 = verifier.verify(signer.sign(arm(10), now), now);
  ASSERT_TRUE(v1.command) << v1.reason;
  EXPECT_FALSE(v1.command2);
}

TEST(PublicKeyFile, ReadsThePubFileAndNamesBadLines) {
  const auto dir = std::filesystem::temp_directory_path() / ("motion-pub-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const KeyPair key = KeyPair::generate("coordinator");
  ASSERT_EQ(write_key_pair(key, dir.string(), "admin"), std::nullopt);
  const auto loaded = load_public_key(public_key_path(dir.string(), "coordinator"));
  ASSERT_TRUE(std::holds_alternative<PublicKey>(loaded)) << std::get<std::string>(loaded);
  EXPECT_EQ(std::get<PublicKey>(loaded), key.public_key());
  const auto bad = dir / "bad.pub";
  std::ofstream(bad) << "# comment\nAAAA coordinator\n";
  EXPECT_EQ(std::get<std::string>(load_public_key(bad.string())),
            bad.string() + ":2: expected '<base64 public key> <name> [<role>]' (is this a .pub file?)");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace motion::security
