// The cross-language test vector (tests/vectors/signed_request_v1.txt): a fixed key file and a
// fixed request_t signed at a fixed time must give exactly the file's payload, signed bytes,
// signature and encoded signed_request_t. The Python, Java and Lua clients check the same file, so
// the four implementations of the signed layout agree byte for byte.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "motion/security/request_verifier.hpp"
#include "motion/security/signed_request.hpp"

namespace motion::security {
namespace {

using motionlcm::request_t;
using motionlcm::signed_request_t;
namespace fs = std::filesystem;

// "name = value" lines of the vector file; # comments.
std::map<std::string, std::string> read_vector() {
  std::ifstream in(MOTION_SIGNING_VECTOR);
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

}  // namespace
}  // namespace motion::security
