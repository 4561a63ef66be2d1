// Who may do what: the authorized_keys file and the roles.
//
// One principal per line, "<base64 Ed25519 public key> <name> <role>", and for role gateway an
// optional fourth token "buses=<bus>[,<bus>...]": the buses the key may speak for (without it,
// every bus). Blank lines and lines starting with # are ignored. Roles, each including the ones before it:
//   observe    STOP and ESTOP only (every principal may stop)
//   operate    + moves (absolute, relative), jog, home, enable, disable, fault reset
//   configure  + set-position, set outputs, parameter read and write
//   admin      everything, including request kinds added later
// and, outside that ladder, `gateway`: a gateway's key (config security.gateway_key). It signs what
// gateways publish (AXIS_STATE, GW_REPLY, DRIVE_MODEL, ORPHANED_MOVES, their events and heartbeats)
// and sends no request at all.
// Names are 1..64 of [A-Za-z0-9._-]; a signed request's client_id must be the name or start
// with "<name>/" (so no key can speak under another key's client ids).
//
// Thread contract: a value type, immutable once parsed; pure functions.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "motion/security/keys.hpp"

namespace motion::security {

enum class Role : std::uint8_t { kObserve, kOperate, kConfigure, kAdmin, kGateway };

[[nodiscard]] const char* to_string(Role role);
[[nodiscard]] std::optional<Role> parse_role(std::string_view text);
// The least role that may send a request_t of `kind` (kAdmin for a kind no role lists).
[[nodiscard]] Role required_role(std::int8_t kind);
// A gateway key may send no request (it is not on the ladder).
[[nodiscard]] inline bool allows(Role role, std::int8_t kind) {
  return role != Role::kGateway && role >= required_role(kind);
}

struct Principal {
  PublicKey key{};
  std::string name;
  Role role = Role::kObserve;
  int line = 0;  // in its file
  // Role gateway: the buses it may speak for (its line's buses=...); empty: every bus.
  std::vector<std::string> buses;
  // Whether `client_id` is this principal's: the name, or "<name>/..." .
  [[nodiscard]] bool owns_client_id(std::string_view client_id) const;
  // Whether it may speak for `bus` (a gateway key bound to buses: one of them; else any).
  [[nodiscard]] bool may_speak_for(std::string_view bus) const;
};

class AuthorizedKeys {
 public:
  AuthorizedKeys() = default;
  // Every error at once, one per line: "<file>:<line>: <what was wrong>".
  [[nodiscard]] static Loaded<AuthorizedKeys> parse(std::string_view text, const std::string& file_name);
  [[nodiscard]] static Loaded<AuthorizedKeys> load(const std::string& path);

  [[nodiscard]] const Principal* find(const KeyId& id) const;
  [[nodiscard]] const std::vector<Principal>& principals() const { return principals_; }
  // The public keys of the principals with `role`, in file order.
  [[nodiscard]] std::vector<PublicKey> keys_with_role(Role role) const;
  // The principals with `role` (their names and buses too), in file order.
  [[nodiscard]] std::vector<Principal> with_role(Role role) const;

 private:
  std::vector<Principal> principals_;
};

// The gateway keys a client verifies what gateways publish with: the principals of role gateway
// (with their buses) of a file in authorized_keys' format (authorized_keys itself, or config
// security.gateway_public_keys), or what is wrong: the file cannot be read, a bad line
// (file:line), or no key of role gateway in it.
[[nodiscard]] Loaded<std::vector<Principal>> load_gateway_keys(const std::string& path);

}  // namespace motion::security
