// Which replies reach the page: under security.mode enforce with the coordinator's public key only
// its signed replies that verify, so a forged reply for a pending move is never shown as the
// move's outcome; otherwise the plain ones.
#include "motion/web/reply_gate.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <string>
#include <vector>

#include "motion/testing/temp_dir.hpp"

#include "motion/security/keys.hpp"
#include "shipped_lab.hpp"

namespace motion::web {
namespace {

using motionlcm::reply_t;
using motionlcm::request_t;
using nlohmann::json;
namespace fs = std::filesystem;

constexpr std::int64_t kStart = 1'767'225'600'000'000;

reply_t reply(std::int8_t status, std::int64_t utime, const std::string& reason = "") {
  reply_t r{};
  r.utime = utime;
  r.client_id = "web/page";
  r.request_id = 7;
  r.status = status;
  r.reason = reason;
  r.num_axes = 1;
  r.axes = {"x"};
  r.targets = {10.0};
  r.positions = {0.0};
  r.start_utime = {0};
  return r;
}

// The statuses of the page's move 7 and of the replies it was shown, from a late browser's snapshot.
struct Shown {
  std::string move_status;
  std::vector<std::string> replies;
};
Shown shown(const LabView& view) {
  Shown s;
  for (const auto& text : view.snapshot().texts) {
    const auto j = json::parse(text);
    if (j["type"] == "move") s.move_status = j["status"];
    if (j["type"] == "reply")
      s.replies.push_back(j["status"].get<std::string>() + ":" + j["reason"].get<std::string>());
  }
  return s;
}

struct ReplyGateTest : ::testing::Test {
  ReplyGateTest() {
    if (auto error = security::write_key_pair(coordinator, dir.string(), "admin")) throw std::runtime_error(*error);
    config = testing::lab();
    config.security.mode = config::SecuritySettings::Mode::kEnforce;
    config.security.coordinator_public_key = security::public_key_path(dir.string(), "coordinator");
  }
  ReplyGate gate_of(const config::Config& c) {
    auto gate = ReplyGate::from_config(c, kStart);
    if (const auto* error = std::get_if<std::string>(&gate)) throw std::runtime_error(*error);
    return std::get<ReplyGate>(std::move(gate));
  }
  LabView pending_move() {
    LabView view(testing::lab());
    request_t r{};
    r.client_id = "web/page";
    r.request_id = 7;
    r.kind = request_t::MOVE_ABSOLUTE;
    r.num_axes = 1;
    r.axes = {"x"};
    r.values = {10.0};
    view.on_request(r);
    return view;
  }

  motion::testing::TempDir tmp{"motion-web-gate"};
  fs::path dir = tmp.path();
  security::KeyPair coordinator = security::KeyPair::generate("coordinator");
  config::Config config;
};

TEST_F(ReplyGateTest, UnderEnforceAForgedReplyIsNotShownAsThePendingMovesOutcome) {
  ReplyGate gate = gate_of(config);
  ASSERT_TRUE(gate.verifies());
  LabView view = pending_move();
  security::MessageSigner signer(coordinator, config.lcm.channel_prefix);
  const std::int64_t now = kStart + 1'000'000;
  EXPECT_FALSE(gate.on_signed(view, signer.sign("REPLY", reply(reply_t::ACCEPTED, now), now), now).empty());
  EXPECT_EQ(shown(view).move_status, "accepted");

  // A plain REPLY: not shown (the coordinator sends every reply signed too).
  EXPECT_TRUE(gate.on_plain(view, reply(reply_t::DONE, now, "plain")).empty());
  // Signed with another key, altered in transit, replayed, signed before motion-web started.
  security::MessageSigner impostor(security::KeyPair::generate("coordinator"), config.lcm.channel_prefix);
  EXPECT_TRUE(gate.on_signed(view, impostor.sign("REPLY", reply(reply_t::FAILED, now, "forged"), now), now).empty());
  EXPECT_NE(gate.last_refusal().find("is not the coordinator's"), std::string::npos) << gate.last_refusal();
  auto altered = signer.sign("REPLY", reply(reply_t::REJECTED, now, "altered"), now);
  altered.message[altered.message.size() - 3] ^= 1;
  EXPECT_TRUE(gate.on_signed(view, altered, now).empty());
  EXPECT_NE(gate.last_refusal().find("bad signature"), std::string::npos) << gate.last_refusal();
  auto first = signer.sign("REPLY", reply(reply_t::ABORTED, now, "recorded"), now);
  // (signed but never delivered before the next one: its counter is then old)
  EXPECT_FALSE(gate.on_signed(view, signer.sign("REPLY", reply(reply_t::STARTED, now), now), now).empty());
  EXPECT_TRUE(gate.on_signed(view, first, now).empty());
  EXPECT_NE(gate.last_refusal().find("replayed counter"), std::string::npos) << gate.last_refusal();
  security::MessageSigner old_signer(coordinator, config.lcm.channel_prefix);
  EXPECT_TRUE(gate.on_signed(view, old_signer.sign("REPLY", reply(reply_t::FAILED, kStart - 5, "old"), kStart - 5), now)
                  .empty());
  EXPECT_NE(gate.last_refusal().find("stale timestamp"), std::string::npos) << gate.last_refusal();
  EXPECT_EQ(gate.refused(), 4U);
  EXPECT_EQ(shown(view).move_status, "started");  // still pending: none of them is its outcome
  EXPECT_EQ(shown(view).replies, (std::vector<std::string>{"accepted:", "started:"}));

  // The coordinator's own DONE ends it.
  EXPECT_FALSE(
      gate.on_signed(view, signer.sign("REPLY", reply(reply_t::DONE, now, "moved"), now + 1), now + 1).empty());
  EXPECT_EQ(shown(view).move_status, "done");
  EXPECT_EQ(shown(view).replies, (std::vector<std::string>{"accepted:", "started:", "done:moved"}));
}

TEST_F(ReplyGateTest, WithoutEnforceOrTheCoordinatorsKeyThePlainRepliesAreShown) {
  for (const bool enforce : {false, true}) {
    config::Config c = config;
    if (enforce) {
      c.security.coordinator_public_key.clear();
    } else {
      c.security.mode = config::SecuritySettings::Mode::kOff;
    }
    ReplyGate gate = gate_of(c);
    EXPECT_FALSE(gate.verifies());
    LabView view = pending_move();
    EXPECT_FALSE(gate.on_plain(view, reply(reply_t::ACCEPTED, kStart)).empty());
    EXPECT_FALSE(gate.on_plain(view, reply(reply_t::DONE, kStart, "plain")).empty());
    security::MessageSigner signer(coordinator, c.lcm.channel_prefix);
    // Its signed twin is not shown a second time.
    EXPECT_TRUE(gate.on_signed(view, signer.sign("REPLY", reply(reply_t::DONE, kStart), kStart), kStart).empty());
    EXPECT_EQ(shown(view).move_status, "done");
    EXPECT_EQ(shown(view).replies, (std::vector<std::string>{"accepted:", "done:plain"}));
  }
}

TEST_F(ReplyGateTest, AnUnreadableCoordinatorKeyIsAConfigurationError) {
  config.security.coordinator_public_key = (dir / "missing.pub").string();
  auto gate = ReplyGate::from_config(config, kStart);
  ASSERT_TRUE(std::holds_alternative<std::string>(gate));
  EXPECT_NE(std::get<std::string>(gate).find("security.coordinator_public_key: "), std::string::npos);
  EXPECT_NE(std::get<std::string>(gate).find("missing.pub"), std::string::npos) << std::get<std::string>(gate);
}

}  // namespace
}  // namespace motion::web
