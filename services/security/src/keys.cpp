#include "motion/security/keys.hpp"

#include <fcntl.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

namespace motion::security {
namespace {

constexpr std::string_view kPrivateTag = "motionbus-ed25519-private-key";

std::string octal_mode(mode_t mode) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(mode & 07777));
  return buf;
}

std::vector<std::string> split_fields(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> fields;
  for (std::string f; in >> f;) fields.push_back(f);
  return fields;
}

// Creates `path` with `mode` and writes `text`; refuses an existing file.
std::optional<std::string> write_new_file(const std::string& path, const std::string& text, mode_t mode) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd < 0) {
    if (errno == EEXIST) return "cannot write " + path + ": it exists (a key is never overwritten; move it away first)";
    return "cannot create " + path + ": " + std::strerror(errno);
  }
  // The umask may have cleared bits but never adds any: set exactly `mode`.
  const bool ok = ::fchmod(fd, mode) == 0 && ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  const int saved = errno;
  ::close(fd);
  if (!ok) return "cannot write " + path + ": " + std::strerror(saved);
  return std::nullopt;
}

}  // namespace

bool init() {
  static const bool ok = sodium_init() >= 0;
  return ok;
}

KeyId key_id(const PublicKey& key) {
  KeyId id{};
  std::copy(key.begin(), key.begin() + kKeyIdBytes, id.begin());
  return id;
}

std::string to_hex(const KeyId& id) {
  char out[kKeyIdBytes * 2 + 1];
  sodium_bin2hex(out, sizeof out, id.data(), id.size());
  return out;
}

std::string base64_encode(std::span<const std::uint8_t> bytes) {
  init();
  std::string out(sodium_base64_ENCODED_LEN(bytes.size(), sodium_base64_VARIANT_ORIGINAL), '\0');
  sodium_bin2base64(out.data(), out.size(), bytes.data(), bytes.size(), sodium_base64_VARIANT_ORIGINAL);
  out.resize(std::strlen(out.c_str()));
  return out;
}

std::optional<std::vector<std::uint8_t>> base64_decode(std::string_view text) {
  init();
  std::vector<std::uint8_t> out(text.size() / 4 * 3 + 3);
  std::size_t length = 0;
  const char* end = nullptr;
  if (sodium_base642bin(out.data(), out.size(), text.data(), text.size(), nullptr, &length, &end,
                        sodium_base64_VARIANT_ORIGINAL) != 0 ||
      end != text.data() + text.size()) {
    return std::nullopt;
  }
  out.resize(length);
  return out;
}

bool valid_name(std::string_view name) {
  if (name.empty() || name.size() > 64) return false;
  for (const char c : name) {
    const bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

bool name_owns_client_id(std::string_view name, std::string_view client_id) {
  if (client_id == name) return true;
  return client_id.size() > name.size() && client_id.starts_with(name) && client_id[name.size()] == '/';
}

bool verify(const PublicKey& key, std::span<const std::uint8_t> message, const Signature& signature) {
  init();
  return crypto_sign_verify_detached(signature.data(), message.data(), message.size(), key.data()) == 0;
}

KeyPair KeyPair::generate(std::string name) {
  init();
  std::array<std::uint8_t, kSeedBytes> seed{};
  randombytes_buf(seed.data(), seed.size());
  KeyPair pair = from_seed(seed, std::move(name));
  sodium_memzero(seed.data(), seed.size());
  return pair;
}

KeyPair KeyPair::from_seed(std::span<const std::uint8_t, kSeedBytes> seed, std::string name) {
  init();
  KeyPair pair;
  crypto_sign_seed_keypair(pair.public_.data(), pair.secret_.data(), seed.data());
  pair.name_ = std::move(name);
  return pair;
}

KeyPair::~KeyPair() { sodium_memzero(secret_.data(), secret_.size()); }

Signature KeyPair::sign(std::span<const std::uint8_t> message) const {
  Signature signature{};
  crypto_sign_detached(signature.data(), nullptr, message.data(), message.size(), secret_.data());
  return signature;
}

std::string KeyPair::private_file_text() const {
  // The seed is the first half of libsodium's secret key.
  const std::string seed = base64_encode(std::span<const std::uint8_t>(secret_.data(), kSeedBytes));
  return "# motionbus Ed25519 private key of '" + name_ + "': keep it secret (mode 0600)\n" + std::string(kPrivateTag) +
         " " + seed + " " + name_ + "\n";
}

std::string KeyPair::authorized_line(std::string_view role, const std::vector<std::string>& buses) const {
  std::string line = base64_encode(public_) + " " + name_ + " " + std::string(role);
  for (std::size_t i = 0; i < buses.size(); ++i) line += (i == 0 ? " buses=" : ",") + buses[i];
  return line;
}

Loaded<KeyPair> load_private_key(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return "cannot read key file " + path + ": " + std::strerror(errno);
  if (!S_ISREG(st.st_mode)) return "key file " + path + " is not a regular file";
  if ((st.st_mode & 077) != 0) {
    const char* what = (st.st_mode & 044) != 0 ? "readable" : "accessible";
    return "key file " + path + " is " + what + " by group/others (mode " + octal_mode(st.st_mode) + "); chmod 600 it";
  }
  std::ifstream in(path);
  if (!in) return "cannot read key file " + path + ": " + std::strerror(errno);
  std::optional<KeyPair> found;
  int number = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    const auto fields = split_fields(line);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string where = path + ":" + std::to_string(number) + ": ";
    if (found) return where + "a second key line (a private key file holds one key)";
    if (fields.size() != 3 || fields[0] != kPrivateTag) {
      return where + "expected '" + std::string(kPrivateTag) +
             " <base64 seed> <name>' (is this a private key file? a .pub file is not)";
    }
    auto seed = base64_decode(fields[1]);
    if (!seed || seed->size() != kSeedBytes) return where + "the seed is not base64 of 32 bytes";
    if (!valid_name(fields[2])) return where + "name '" + fields[2] + "' is not 1..64 of [A-Za-z0-9._-]";
    found = KeyPair::from_seed(std::span<const std::uint8_t, kSeedBytes>(seed->data(), kSeedBytes), fields[2]);
    sodium_memzero(seed->data(), seed->size());
  }
  if (!found) return "key file " + path + " holds no key line";
  return std::move(*found);
}

std::string private_key_path(const std::string& dir, std::string_view name) {
  return dir + "/" + std::string(name) + ".key";
}
std::string public_key_path(const std::string& dir, std::string_view name) {
  return dir + "/" + std::string(name) + ".pub";
}

std::optional<std::string> write_key_pair(const KeyPair& key, const std::string& dir, std::string_view role,
                                          const std::vector<std::string>& buses) {
  if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) return "cannot create " + dir + ": " + std::strerror(errno);
  if (auto err = write_new_file(private_key_path(dir, key.name()), key.private_file_text(), 0600)) return err;
  return write_new_file(public_key_path(dir, key.name()), key.authorized_line(role, buses) + "\n", 0644);
}

}  // namespace motion::security
