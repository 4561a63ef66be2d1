// Ed25519 key pairs and their files (libsodium's crypto_sign_*; no cryptography of our own).
//
// A private key file is text: comment lines (#) and one line
//   motionbus-ed25519-private-key <base64 of the 32-byte seed> <name>
// It must not be accessible by group or others (mode 0600): loading refuses it otherwise. The
// public half is the line an administrator adds to authorized_keys ("<base64 public key> <name>
// <role>"); `write_key_pair` writes it next to the private key as <name>.pub.
//
// A key id is the first 8 bytes of the public key: what a signed message names its key by.
//
// Thread contract: value types and functions without shared state; usable from any thread once
// init() returned true (each function calls it).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace motion::security {

inline constexpr std::size_t kPublicKeyBytes = 32;
inline constexpr std::size_t kSeedBytes = 32;
inline constexpr std::size_t kSignatureBytes = 64;
inline constexpr std::size_t kKeyIdBytes = 8;

using PublicKey = std::array<std::uint8_t, kPublicKeyBytes>;
using Signature = std::array<std::uint8_t, kSignatureBytes>;
using KeyId = std::array<std::uint8_t, kKeyIdBytes>;

// A value, or the text of what went wrong (naming the file, line and cause).
template <typename T>
using Loaded = std::variant<T, std::string>;

// libsodium's sodium_init(), once; false when the library cannot run (no entropy source).
bool init();

[[nodiscard]] KeyId key_id(const PublicKey& key);
// 16 lower-case hex digits.
[[nodiscard]] std::string to_hex(const KeyId& id);

[[nodiscard]] std::string base64_encode(std::span<const std::uint8_t> bytes);
// Standard base64 with padding; nullopt when `text` is not.
[[nodiscard]] std::optional<std::vector<std::uint8_t>> base64_decode(std::string_view text);

// A principal's name: 1..64 of [A-Za-z0-9._-] (client ids of its requests start with it).
[[nodiscard]] bool valid_name(std::string_view name);
// Whether `client_id` belongs to the principal `name`: it is the name, or "<name>/...".
[[nodiscard]] bool name_owns_client_id(std::string_view name, std::string_view client_id);

// Whether `signature` is `key`'s Ed25519 signature of `message`.
[[nodiscard]] bool verify(const PublicKey& key, std::span<const std::uint8_t> message, const Signature& signature);

// A key pair with its name. The secret half is wiped when the object goes.
class KeyPair {
 public:
  // A fresh pair from the system's random source.
  [[nodiscard]] static KeyPair generate(std::string name);
  // The pair of a 32-byte seed (deterministic: test vectors).
  [[nodiscard]] static KeyPair from_seed(std::span<const std::uint8_t, kSeedBytes> seed, std::string name);

  KeyPair(const KeyPair& other) = default;
  KeyPair& operator=(const KeyPair& other) = default;
  ~KeyPair();

  [[nodiscard]] const PublicKey& public_key() const { return public_; }
  [[nodiscard]] KeyId id() const { return key_id(public_); }
  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] Signature sign(std::span<const std::uint8_t> message) const;

  // The private key file's text, and the authorized_keys line for `role` (no newline), with
  // "buses=<bus>,..." when `buses` names any (role gateway: the buses the key may speak for).
  [[nodiscard]] std::string private_file_text() const;
  [[nodiscard]] std::string authorized_line(std::string_view role, const std::vector<std::string>& buses = {}) const;

 private:
  KeyPair() = default;
  PublicKey public_{};
  std::array<std::uint8_t, 64> secret_{};  // libsodium's secret key: seed + public key
  std::string name_;
};

// Reads a private key file. Refused: a file group or others may access ("key file X is readable
// by group/others (mode 0644); chmod 600 it"), one that is not a regular file, and any other
// content than one key line (errors name file:line).
[[nodiscard]] Loaded<KeyPair> load_private_key(const std::string& path);

// Writes <dir>/<name>.key (mode 0600) and <dir>/<name>.pub (the authorized_keys line with
// `role`, and `buses`), creating `dir` (mode 0700) when missing; never overwrites a file. Returns what went
// wrong, nothing on success.
[[nodiscard]] std::optional<std::string> write_key_pair(const KeyPair& key, const std::string& dir,
                                                        std::string_view role,
                                                        const std::vector<std::string>& buses = {});
// Where write_key_pair puts the private and the public file of `name`.
[[nodiscard]] std::string private_key_path(const std::string& dir, std::string_view name);
[[nodiscard]] std::string public_key_path(const std::string& dir, std::string_view name);

}  // namespace motion::security
