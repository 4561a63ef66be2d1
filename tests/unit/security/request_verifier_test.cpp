// The verifier on a manual wall clock: every acceptance and refusal path, and who may be answered.
#include <gtest/gtest.h>

#include <chrono>
#include <limits>

#include "motion/security/request_verifier.hpp"
#include "motion/security/signed_request.hpp"

namespace motion::security {
namespace {

using motionlcm::request_t;
using motionlcm::signed_request_t;
using namespace std::chrono_literals;

constexpr std::int64_t kStart = 1'700'000'000'000'000;  // µs since the epoch
constexpr std::string_view kPrefix = "MOTION_";

class Verifier : public ::testing::Test {
 protected:
  Verifier() {
    const std::string text = operator_.authorized_line("operate") + "\n" + observer_.authorized_line("observe") + "\n";
    verifier_.emplace(std::get<AuthorizedKeys>(AuthorizedKeys::parse(text, "keys")), std::string(kPrefix), 2000ms,
                      kStart);
  }

  static request_t move(const std::string& client_id, std::int64_t request_id = 1,
                        std::int8_t kind = request_t::MOVE_ABSOLUTE) {
    request_t r{};
    r.client_id = client_id;
    r.request_id = request_id;
    r.kind = kind;
    r.axes = {"x"};
    r.values = {10.0};
    r.num_axes = 1;
    return r;
  }

  KeyPair operator_ = KeyPair::generate("op");
  KeyPair observer_ = KeyPair::generate("watch");
  RequestSigner op_signer_{operator_, std::string(kPrefix)};
  RequestSigner observe_signer_{observer_, std::string(kPrefix)};
  std::optional<RequestVerifier> verifier_;
  std::int64_t now_ = kStart + 1'000'000;
};

TEST_F(Verifier, SignedRequestOfAnAllowedKindIsAcceptedWhole) {
  const Verdict v = verifier_->verify(op_signer_.sign(move("op/ctl", 7), now_), now_ + 300);
  ASSERT_TRUE(v.accepted) << v.reason;
  ASSERT_TRUE(v.request);
  EXPECT_EQ(v.request->client_id, "op/ctl");
  EXPECT_EQ(v.request->request_id, 7);
  EXPECT_EQ(v.request->values, std::vector<double>{10.0});
}

TEST_F(Verifier, UnknownKeyIsRefusedUnanswered) {
  RequestSigner stranger(KeyPair::generate("op"), std::string(kPrefix));  // same name, other key
  const Verdict v = verifier_->verify(stranger.sign(move("op"), now_), now_);
  EXPECT_FALSE(v.accepted);
  EXPECT_FALSE(v.answerable);
  EXPECT_EQ(v.reason,
            "unknown key " + to_hex(stranger.key().id()) + " (not in authorized_keys): move request 1 of client 'op'");
}

TEST_F(Verifier, AlteredPayloadOrSignatureOrOtherPrefixIsABadSignature) {
  signed_request_t tampered = op_signer_.sign(move("op"), now_);
  tampered.payload[tampered.payload.size() - 20] ^= 0x40;
  Verdict v = verifier_->verify(tampered, now_);
  EXPECT_FALSE(v.accepted);
  EXPECT_FALSE(v.answerable);
  EXPECT_EQ(
      v.reason.rfind("bad signature from key 'op' (" + to_hex(operator_.id()) + ") (forged or altered in transit)", 0),
      0u)
      << v.reason;

  signed_request_t resigned = op_signer_.sign(move("op"), now_);
  resigned.signature[10] ^= 1;
  EXPECT_EQ(verifier_->verify(resigned, now_).reason.substr(0, 13), "bad signature");

  signed_request_t counter_moved = op_signer_.sign(move("op"), now_);
  counter_moved.counter += 1000;
  EXPECT_EQ(verifier_->verify(counter_moved, now_).reason.substr(0, 13), "bad signature");

  RequestSigner other_system(operator_, "LAB2_");
  EXPECT_EQ(verifier_->verify(other_system.sign(move("op"), now_), now_).reason.substr(0, 13), "bad signature");
}

TEST_F(Verifier, ReplayedCounterIsRefusedUnanswered) {
  const signed_request_t once = op_signer_.sign(move("op"), now_);
  ASSERT_TRUE(verifier_->verify(once, now_).accepted);
  const Verdict again = verifier_->verify(once, now_ + 1000);
  EXPECT_FALSE(again.accepted);
  EXPECT_FALSE(again.answerable);
  EXPECT_EQ(again.reason, "replayed counter " + std::to_string(once.counter) + " from key 'op' (" +
                              to_hex(operator_.id()) + ") (last accepted " + std::to_string(once.counter) +
                              "): move request 1 of client 'op'");
  // The next counter passes; counters are per key.
  EXPECT_TRUE(verifier_->verify(op_signer_.sign(move("op", 2), now_), now_).accepted);
  EXPECT_TRUE(verifier_->verify(observe_signer_.sign(move("watch", 1, request_t::STOP), now_), now_).accepted);
}

TEST_F(Verifier, TimestampOutsideTheWindowOrBeforeTheStartIsStale) {
  const Verdict old = verifier_->verify(op_signer_.sign(move("op"), now_), now_ + 2'500'000);
  EXPECT_FALSE(old.accepted);
  EXPECT_FALSE(old.answerable);
  EXPECT_NE(old.reason.find("stale timestamp from key 'op'"), std::string::npos) << old.reason;
  EXPECT_NE(old.reason.find("signed 2500 ms ago, outside the window of 2000 ms"), std::string::npos) << old.reason;
  const Verdict ahead = verifier_->verify(op_signer_.sign(move("op"), now_ + 3'000'000), now_);
  EXPECT_NE(ahead.reason.find("signed 3000 ms in the future"), std::string::npos) << ahead.reason;
  // Within the window, but signed before this verifier started: what a restart must not accept.
  const Verdict before = verifier_->verify(op_signer_.sign(move("op"), kStart - 500'000), kStart + 100'000);
  EXPECT_NE(before.reason.find("signed 500 ms before the coordinator started"), std::string::npos) << before.reason;
  // A stale request does not use up its counter's place: a fresh one still passes.
  EXPECT_TRUE(verifier_->verify(op_signer_.sign(move("op", 9), now_), now_).accepted);
}

// utime is the signer's: an authorized key may sign any int64. The extremes are stale, and their
// distance to the clock is computed without overflow (the ASan/UBSan pass of the unit tests and the
// fuzz target signed_messages would report one).
TEST_F(Verifier, ExtremeTimestampsAreStaleWithoutOverflow) {
  constexpr auto kMin = std::numeric_limits<std::int64_t>::min();
  constexpr auto kMax = std::numeric_limits<std::int64_t>::max();
  RequestSigner early(operator_, std::string(kPrefix));
  const Verdict first = verifier_->verify(early.sign(move("op"), kMin), now_);
  EXPECT_FALSE(first.accepted);
  EXPECT_NE(first.reason.find("signed 9225072036854775 ms before the coordinator started"), std::string::npos)
      << first.reason;
  RequestSigner late(operator_, std::string(kPrefix));
  const Verdict last = verifier_->verify(late.sign(move("op"), kMax), now_);
  EXPECT_FALSE(last.accepted);
  EXPECT_NE(last.reason.find("signed 9221672036853775 ms in the future"), std::string::npos) << last.reason;
}

TEST_F(Verifier, RoleTooLowIsRefusedAndAnswerable) {
  const Verdict v = verifier_->verify(observe_signer_.sign(move("watch", 3), now_), now_);
  EXPECT_FALSE(v.accepted);
  EXPECT_TRUE(v.answerable);
  ASSERT_TRUE(v.request);
  EXPECT_EQ(v.request->request_id, 3);
  EXPECT_EQ(v.reason, "role too low: key 'watch' (" + to_hex(observer_.id()) +
                          ") has role observe, a move needs operate: move request 3 of client 'watch'");
  const Verdict set = verifier_->verify(op_signer_.sign(move("op", 4, request_t::SET_POSITION), now_), now_);
  EXPECT_FALSE(set.accepted);
  EXPECT_NE(set.reason.find("has role operate, a set position needs configure"), std::string::npos) << set.reason;
  EXPECT_TRUE(verifier_->verify(observe_signer_.sign(move("watch", 5, request_t::ESTOP), now_), now_).accepted);
}

// A gateway's key (role gateway) signs what gateways publish: a request from it, even a stop, is
// refused (answerable: the ids are its own) and says why.
TEST(GatewayKey, SendsNoRequest) {
  const KeyPair gateway = KeyPair::generate("gateway");
  RequestVerifier verifier(std::get<AuthorizedKeys>(AuthorizedKeys::parse(gateway.authorized_line("gateway"), "keys")),
                           std::string(kPrefix), 2000ms, kStart);
  RequestSigner signer(gateway, std::string(kPrefix));
  request_t stop{};
  stop.client_id = "gateway/x";
  stop.request_id = 1;
  stop.kind = request_t::STOP;
  const Verdict v = verifier.verify(signer.sign(stop, kStart + 1000), kStart + 1000);
  EXPECT_FALSE(v.accepted);
  EXPECT_TRUE(v.answerable);
  EXPECT_EQ(v.reason.rfind("key 'gateway' (" + to_hex(gateway.id()) +
                               ") has role gateway: a gateway's key signs what gateways publish, no request",
                           0),
            0u)
      << v.reason;
}

TEST_F(Verifier, AnotherKeysClientIdIsRefusedUnanswered) {
  // The operator signs a stop under the observer's client id: nothing may answer the observer.
  const Verdict v = verifier_->verify(op_signer_.sign(move("watch", 1, request_t::STOP), now_), now_);
  EXPECT_FALSE(v.accepted);
  EXPECT_FALSE(v.answerable);
  EXPECT_NE(v.reason.find("client id 'watch' is not key 'op'"), std::string::npos) << v.reason;
  EXPECT_EQ(op_signer_.own_client_id("watch"), "op/watch");
  EXPECT_EQ(op_signer_.own_client_id("op/x"), "op/x");
}

TEST_F(Verifier, PayloadThatIsNoRequestIsRefused) {
  signed_request_t envelope = op_signer_.sign(move("op"), now_);
  // A correctly signed envelope around bytes that are no request_t.
  RequestSigner signer(operator_, std::string(kPrefix));
  signed_request_t odd{};
  odd = envelope;
  odd.payload = {1, 2, 3};
  odd.payload_size = 3;
  odd.counter = envelope.counter + 1;
  const Signature sig = operator_.sign(signed_bytes(kPrefix, odd));
  std::copy(sig.begin(), sig.end(), std::begin(odd.signature));
  const Verdict v = verifier_->verify(odd, now_);
  EXPECT_FALSE(v.accepted);
  EXPECT_NE(v.reason.find("malformed payload from key 'op'"), std::string::npos) << v.reason;
}

TEST_F(Verifier, CountersIncreaseAcrossSignersOfOneKey) {
  // A second run of a program with the same key starts from the wall clock, above the first.
  RequestSigner first(operator_, std::string(kPrefix));
  const auto a = first.sign(move("op", 1), now_);
  const auto b = first.sign(move("op", 2), now_);  // same microsecond: still increasing
  RequestSigner second(operator_, std::string(kPrefix));
  const auto c = second.sign(move("op", 3), now_ + 10);
  EXPECT_LT(a.counter, b.counter);
  EXPECT_LT(b.counter, c.counter);
  for (const auto* e : {&a, &b, &c}) EXPECT_TRUE(verifier_->verify(*e, now_ + 20).accepted);
}

}  // namespace
}  // namespace motion::security
