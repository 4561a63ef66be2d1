// Key pairs, key files (modes, content) and base64.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "motion/security/keys.hpp"

namespace motion::security {
namespace {

namespace fs = std::filesystem;

class KeyFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("motion-keys-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  void write(const fs::path& path, const std::string& text, fs::perms perms) {
    fs::create_directories(path.parent_path());
    std::ofstream(path) << text;
    fs::permissions(path, perms);
  }
  fs::path dir_;
};

template <typename T>
const std::string& error_of(const Loaded<T>& loaded) {
  static const std::string none = "(no error)";
  return std::holds_alternative<std::string>(loaded) ? std::get<std::string>(loaded) : none;
}

TEST(Keys, SignatureVerifiesAndFailsOnAnyChange) {
  ASSERT_TRUE(init());
  const KeyPair key = KeyPair::generate("alice");
  const std::vector<std::uint8_t> message{1, 2, 3, 4};
  Signature sig = key.sign(message);
  EXPECT_TRUE(verify(key.public_key(), message, sig));
  auto altered = message;
  altered[2] ^= 1;
  EXPECT_FALSE(verify(key.public_key(), altered, sig));
  sig[0] ^= 1;
  EXPECT_FALSE(verify(key.public_key(), message, sig));
  EXPECT_FALSE(verify(KeyPair::generate("bob").public_key(), message, key.sign(message)));
}

TEST(Keys, SeedGivesTheRfc8032TestVector) {
  // RFC 8032 §7.1, TEST 1: secret key 9d61b19d..., public key d75a9801...
  const std::array<std::uint8_t, 32> seed{0x9d, 0x61, 0xb1, 0x9d, 0xef, 0xfd, 0x5a, 0x60, 0xba, 0x84, 0x4a,
                                          0xf4, 0x92, 0xec, 0x2c, 0xc4, 0x44, 0x49, 0xc5, 0x69, 0x7b, 0x32,
                                          0x69, 0x19, 0x70, 0x3b, 0xac, 0x03, 0x1c, 0xae, 0x7f, 0x60};
  const KeyPair key = KeyPair::from_seed(seed, "rfc");
  EXPECT_EQ(to_hex(key.id()), "d75a980182b10ab7");
  const Signature sig = key.sign({});
  EXPECT_EQ(sig[0], 0xe5);
  EXPECT_EQ(sig[63], 0x0b);
}

TEST(Keys, Base64RoundTripsAndRefusesGarbage) {
  const std::vector<std::uint8_t> bytes{0, 1, 2, 250, 251, 252, 253};
  const std::string text = base64_encode(bytes);
  EXPECT_EQ(base64_decode(text), bytes);
  EXPECT_FALSE(base64_decode("not base64!"));
  EXPECT_FALSE(base64_decode(text + "x"));
}

TEST(Keys, NamesAndClientIds) {
  EXPECT_TRUE(valid_name("alice.ops-1_x"));
  EXPECT_FALSE(valid_name(""));
  EXPECT_FALSE(valid_name("a/b"));
  EXPECT_FALSE(valid_name(std::string(65, 'a')));
  EXPECT_TRUE(name_owns_client_id("alice", "alice"));
  EXPECT_TRUE(name_owns_client_id("alice", "alice/motionctl:12"));
  EXPECT_FALSE(name_owns_client_id("alice", "alice2"));
  EXPECT_FALSE(name_owns_client_id("alice", "bob/alice"));
  EXPECT_FALSE(name_owns_client_id("alice", "alic"));
}

TEST_F(KeyFiles, WrittenPairLoadsBackWithMode0600AndIsNeverOverwritten) {
  const KeyPair key = KeyPair::generate("alice");
  ASSERT_EQ(write_key_pair(key, dir_.string(), "operate"), std::nullopt);
  const std::string path = private_key_path(dir_.string(), "alice");
  EXPECT_EQ(path, (dir_ / "alice.key").string());
  EXPECT_EQ(fs::status(path).permissions() & fs::perms::all, fs::perms::owner_read | fs::perms::owner_write);
  const auto loaded = load_private_key(path);
  ASSERT_TRUE(std::holds_alternative<KeyPair>(loaded)) << error_of(loaded);
  EXPECT_EQ(std::get<KeyPair>(loaded).public_key(), key.public_key());
  EXPECT_EQ(std::get<KeyPair>(loaded).name(), "alice");
  std::ifstream pub(dir_ / "alice.pub");
  std::string line;
  std::getline(pub, line);
  EXPECT_EQ(line, key.authorized_line("operate"));
  const auto again = write_key_pair(KeyPair::generate("alice"), dir_.string(), "operate");
  ASSERT_TRUE(again);
  EXPECT_NE(again->find("exists"), std::string::npos) << *again;
}

TEST_F(KeyFiles, GroupOrOtherReadableKeyIsRefusedSayingHowToFixIt) {
  const KeyPair key = KeyPair::generate("alice");
  const fs::path path = dir_ / "alice.key";
  write(path, key.private_file_text(),
        fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read);
  const auto loaded = load_private_key(path.string());
  EXPECT_EQ(error_of(loaded), "key file " + path.string() + " is readable by group/others (mode 0644); chmod 600 it");
}

TEST_F(KeyFiles, BadContentNamesFileAndLine) {
  const fs::path path = dir_ / "bad.key";
  const auto rw = fs::perms::owner_read | fs::perms::owner_write;
  write(path, "# comment\n\nmotionbus-ed25519-private-key AAAA alice\n", rw);
  EXPECT_EQ(error_of(load_private_key(path.string())), path.string() + ":3: the seed is not base64 of 32 bytes");
  const KeyPair key = KeyPair::generate("alice");
  write(path, key.authorized_line("admin") + "\n", rw);
  EXPECT_NE(
      error_of(load_private_key(path.string())).find(path.string() + ":1: expected 'motionbus-ed25519-private-key"),
      std::string::npos);
  write(path, key.private_file_text() + key.private_file_text(), rw);
  EXPECT_EQ(error_of(load_private_key(path.string())),
            path.string() + ":4: a second key line (a private key file holds one key)");
  write(path, "# nothing\n", rw);
  EXPECT_EQ(error_of(load_private_key(path.string())), "key file " + path.string() + " holds no key line");
  EXPECT_NE(error_of(load_private_key((dir_ / "missing.key").string())).find("cannot read key file"),
            std::string::npos);
}

}  // namespace
}  // namespace motion::security
