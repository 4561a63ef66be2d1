// The cross-language test vectors: a fixed key file and a fixed request_t signed at a fixed time
// must give exactly tests/vectors/signed_request_v1.txt's payload, signed bytes, signature and
// encoded signed_request_t (the Python, Java and Lua clients check the same file, so the four
// implementations of the signed layout agree byte for byte); a fixed reply_t signed by the
// coordinator's MessageSigner gives exactly tests/vectors/signed_reply_v1.txt's envelope, which
// the Java client verifies; a fixed axis_state_t signed by a gateway's MessageSigner gives exactly
// tests/vectors/signed_state_v1.txt's envelope, which the Python, Java and Lua clients verify.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/reply_t.hpp>

#include "motion/security/request_verifier.hpp"
#include "motion/security/signed_messages.hpp"
#include "motion/security/signed_request.hpp"

namespace motion::security {
namespace {

using motionlcm::request_t;
using motionlcm::signed_request_t;
namespace fs = std::filesystem;

// "name = value" lines of the vector file; # comments.
std::map<std::string, std::string> read_vector(const char* path = MOTION_SIGNING_VECTOR) {
  std::ifstream in(path);
  std::map<std::string, std::string> v;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const auto eq = line.find(" = ");
    if (eq != std::string::npos) v[line.substr(0, eq)] = line.substr(eq + 3);
  }
  return v;
}

std::string hex(const std::uint8_t* data, std::size_t size) {
  std::string out;
  char two[3];
  for (std::size_t i = 0; i < size; ++i) {
    std::snprintf(two, sizeof two, "%02x", data[i]);
    out += two;
  }
  return out;
}
template <typename Bytes>
std::string hex(const Bytes& bytes) {
  return hex(bytes.data(), bytes.size());
}

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

class SignedRequestVector : public ::testing::Test {
 protected:
  void SetUp() override {
    v_ = read_vector();
    ASSERT_TRUE(v_.contains("envelope_hex")) << "cannot read " << MOTION_SIGNING_VECTOR;
    // The key as motionctl keygen writes it (a file of mode 0600).
    path_ = fs::temp_directory_path() / ("motion-vector-" + std::to_string(::getpid()) + ".key");
    std::ofstream(path_) << "# the vector's key\n" << v_["key_file_line"] << "\n";
    fs::permissions(path_, fs::perms::owner_read | fs::perms::owner_write);
    auto loaded = load_private_key(path_.string());
    ASSERT_TRUE(std::holds_alternative<KeyPair>(loaded)) << std::get<std::string>(loaded);
    key_.emplace(std::get<KeyPair>(std::move(loaded)));

    request_.utime = std::stoll(v_["request.utime"]);
    request_.client_id = v_["request.client_id"];
    request_.request_id = std::stoll(v_["request.request_id"]);
    request_.kind = static_cast<std::int8_t>(std::stoi(v_["request.kind"]));
    request_.axes = words(v_["request.axes"]);
    for (const auto& w : words(v_["request.values"])) request_.values.push_back(std::stod(w));
    request_.num_axes = static_cast<std::int32_t>(request_.axes.size());
    request_.velocity_scale = std::stod(v_["request.velocity_scale"]);
    request_.acceleration_scale = std::stod(v_["request.acceleration_scale"]);
    request_.timeout_ms = std::stoi(v_["request.timeout_ms"]);
    request_.output_mask = std::stoi(v_["request.output_mask"]);
    request_.output_value = std::stoi(v_["request.output_value"]);
  }
  void TearDown() override { fs::remove(path_); }

  std::map<std::string, std::string> v_;
  fs::path path_;
  std::optional<KeyPair> key_;
  request_t request_{};
};

TEST_F(SignedRequestVector, TheKeyFileGivesTheVectorsKey) {
  EXPECT_EQ(key_->name(), v_["key_name"]);
  EXPECT_EQ(hex(key_->public_key()), v_["public_key_hex"]);
  EXPECT_EQ(hex(key_->id()), v_["key_id_hex"]);
}

TEST_F(SignedRequestVector, TheCppSignerProducesTheVectorsBytes) {
  RequestSigner signer(*key_, v_["prefix"]);
  const signed_request_t e = signer.sign(request_, std::stoll(v_["utime"]));
  EXPECT_EQ(std::to_string(e.counter), v_["counter"]);
  EXPECT_EQ(hex(e.payload), v_["payload_hex"]);
  EXPECT_EQ(hex(signed_bytes(v_["prefix"], e)), v_["signed_bytes_hex"]);
  EXPECT_EQ(hex(e.signature, kSignatureBytes), v_["signature_hex"]);
  std::vector<std::uint8_t> encoded(static_cast<std::size_t>(e.getEncodedSize()));
  ASSERT_EQ(e.encode(encoded.data(), 0, static_cast<int>(encoded.size())), static_cast<int>(encoded.size()));
  EXPECT_EQ(hex(encoded), v_["envelope_hex"]);
}

// The vector's envelope is one the coordinator accepts (and only for its prefix).
TEST_F(SignedRequestVector, TheCoordinatorsVerifierAcceptsTheVectorsEnvelope) {
  RequestSigner signer(*key_, v_["prefix"]);
  const std::int64_t at = std::stoll(v_["utime"]);
  const signed_request_t e = signer.sign(request_, at);
  const auto keys = AuthorizedKeys::parse(key_->authorized_line("operate") + "\n", "keys");
  RequestVerifier verifier(std::get<AuthorizedKeys>(keys), v_["prefix"], std::chrono::milliseconds(2000), at - 1000);
  const Verdict ok = verifier.verify(e, at + 500);
  EXPECT_TRUE(ok.accepted) << ok.reason;
  RequestVerifier other(std::get<AuthorizedKeys>(keys), "OTHER_", std::chrono::milliseconds(2000), at - 1000);
  const Verdict refused = other.verify(e, at + 500);
  EXPECT_FALSE(refused.accepted);
  EXPECT_NE(refused.reason.find("bad signature"), std::string::npos) << refused.reason;
}

std::vector<std::uint8_t> from_hex(const std::string& text) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < text.size(); i += 2) {
    out.push_back(static_cast<std::uint8_t>(std::stoi(text.substr(i, 2), nullptr, 16)));
  }
  return out;
}

// The coordinator's signed reply (signed_message_t on SREPLY) of the reply vector's reply_t.
TEST(SignedReplyVector, TheCoordinatorsSignerProducesTheVectorsEnvelope) {
  auto v = read_vector(MOTION_SIGNED_REPLY_VECTOR);
  ASSERT_TRUE(v.contains("envelope_hex")) << "cannot read " << MOTION_SIGNED_REPLY_VECTOR;
  const auto seed = from_hex("9d61b19deffd5a60ba844af492ec2cc44449c5697b326919703bac031cae7f60");
  ASSERT_EQ(seed.size(), kSeedBytes);
  const KeyPair key = KeyPair::from_seed(std::span<const std::uint8_t, kSeedBytes>(seed.data(), kSeedBytes), "vector");
  EXPECT_EQ(hex(key.public_key()), v["public_key_hex"]);

  motionlcm::reply_t r{};
  r.utime = std::stoll(v["reply.utime"]);
  r.client_id = v["reply.client_id"];
  r.request_id = std::stoll(v["reply.request_id"]);
  r.status = static_cast<std::int8_t>(std::stoi(v["reply.status"]));
  r.reason = v["reply.reason"];
  r.progress = std::stod(v["reply.progress"]);
  r.axes = words(v["reply.axes"]);
  r.num_axes = static_cast<std::int32_t>(r.axes.size());
  for (const auto& w : words(v["reply.targets"])) r.targets.push_back(std::stod(w));
  for (const auto& w : words(v["reply.positions"])) r.positions.push_back(std::stod(w));
  for (const auto& w : words(v["reply.start_utime"])) r.start_utime.push_back(std::stoll(w));
  r.predicted_duration_s = std::stod(v["reply.predicted_duration_s"]);

  MessageSigner signer(key, v["prefix"]);
  const auto e = signer.sign(v["channel"], r, std::stoll(v["utime"]));
  EXPECT_EQ(std::to_string(e.counter), v["counter"]);
  EXPECT_EQ(hex(e.message), v["message_hex"]);
  EXPECT_EQ(hex(e.signature, kSignatureBytes), v["signature_hex"]);
  std::vector<std::uint8_t> encoded(static_cast<std::size_t>(e.getEncodedSize()));
  ASSERT_EQ(e.encode(encoded.data(), 0, static_cast<int>(encoded.size())), static_cast<int>(encoded.size()));
  EXPECT_EQ(hex(encoded), v["envelope_hex"]);
  // What the signature covers, as the vector spells it out for other languages.
  Signature signature{};
  std::copy_n(e.signature, kSignatureBytes, signature.begin());
  EXPECT_TRUE(verify(key.public_key(), from_hex(v["signed_bytes_hex"]), signature));
}

// A gateway's signed axis state (signed_message_t on SAXIS_STATE) of the state vector's
// axis_state_t, and the C++ client's verifier (Client::verify_states_with) takes it.
TEST(SignedStateVector, TheGatewaysSignerProducesTheVectorsEnvelope) {
  auto v = read_vector(MOTION_SIGNED_STATE_VECTOR);
  ASSERT_TRUE(v.contains("envelope_hex")) << "cannot read " << MOTION_SIGNED_STATE_VECTOR;
  const auto seed = from_hex("9d61b19deffd5a60ba844af492ec2cc44449c5697b326919703bac031cae7f60");
  ASSERT_EQ(seed.size(), kSeedBytes);
  const KeyPair key = KeyPair::from_seed(std::span<const std::uint8_t, kSeedBytes>(seed.data(), kSeedBytes), "vector");
  EXPECT_EQ(hex(key.public_key()), v["public_key_hex"]);
  EXPECT_EQ(key.authorized_line("gateway"), v["authorized_every_bus"]);

  motionlcm::axis_state_t s{};
  s.utime = std::stoll(v["state.utime"]);
  s.sample_utime = std::stoll(v["state.sample_utime"]);
  s.axis = v["state.axis"];
  s.family = v["state.family"];
  s.bus = v["state.bus"];
  s.node_id = std::stoi(v["state.node_id"]);
  s.group_id = std::stoi(v["state.group_id"]);
  s.position = std::stod(v["state.position"]);
  s.position_counts = std::stoll(v["state.position_counts"]);
  s.velocity = std::stod(v["state.velocity"]);
  s.target_counts = std::stoll(v["state.target_counts"]);
  s.online = v["state.online"] == "1";
  s.enabled = v["state.enabled"] == "1";
  s.moving = v["state.moving"] == "1";
  s.in_position = v["state.in_position"] == "1";
  s.homed = v["state.homed"] == "1";
  s.fault = v["state.fault"] == "1";
  s.fault_code = std::stoi(v["state.fault_code"]);
  s.inputs = std::stoi(v["state.inputs"]);
  s.outputs = std::stoi(v["state.outputs"]);

  const std::int64_t at = std::stoll(v["utime"]);
  MessageSigner signer(key, v["prefix"]);
  const auto e = signer.sign(v["channel"], s, at);
  EXPECT_EQ(std::to_string(e.counter), v["counter"]);
  EXPECT_EQ(hex(e.message), v["message_hex"]);
  EXPECT_EQ(hex(e.signature, kSignatureBytes), v["signature_hex"]);
  std::vector<std::uint8_t> encoded(static_cast<std::size_t>(e.getEncodedSize()));
  ASSERT_EQ(e.encode(encoded.data(), 0, static_cast<int>(encoded.size())), static_cast<int>(encoded.size()));
  EXPECT_EQ(hex(encoded), v["envelope_hex"]);
  Signature signature{};
  std::copy_n(e.signature, kSignatureBytes, signature.begin());
  EXPECT_TRUE(verify(key.public_key(), from_hex(v["signed_bytes_hex"]), signature));

  // As the C++ client verifies states: any gateway key, counter per key and bus.
  MessageVerifier verifier({key.public_key()}, "a gateway key", v["prefix"], v["channel"],
                           std::chrono::milliseconds(2000), at - 1000);
  const auto bus = [](const motionlcm::axis_state_t& m) { return m.bus; };
  const auto taken = verifier.verify<motionlcm::axis_state_t>(e, at + 500, bus);
  ASSERT_TRUE(taken.message.has_value()) << taken.reason;
  EXPECT_EQ(taken.message->axis, v["state.axis"]);
  const auto replayed = verifier.verify<motionlcm::axis_state_t>(e, at + 600, bus);
  EXPECT_EQ(replayed.reason, v["refused_replayed"]);
}

}  // namespace
}  // namespace motion::security
