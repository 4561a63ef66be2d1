#include "motion/security/authorized_keys.hpp"

#include <algorithm>
#include <array>
#include <fstream>
#include <map>
#include <sstream>

#include <motionlcm/request_t.hpp>

namespace motion::security {
namespace {

using motionlcm::request_t;

constexpr std::array<std::pair<Role, const char*>, 5> kRoles{{
    {Role::kObserve, "observe"},
    {Role::kOperate, "operate"},
    {Role::kConfigure, "configure"},
    {Role::kAdmin, "admin"},
    {Role::kGateway, "gateway"},
}};

}  // namespace

const char* to_string(Role role) {
  for (const auto& [r, name] : kRoles) {
    if (r == role) return name;
  }
  return "unknown";
}

std::optional<Role> parse_role(std::string_view text) {
  for (const auto& [r, name] : kRoles) {
    if (text == name) return r;
  }
  return std::nullopt;
}

Role required_role(std::int8_t kind) {
  switch (kind) {
    case request_t::STOP:
    case request_t::ESTOP: return Role::kObserve;
    case request_t::MOVE_ABSOLUTE:
    case request_t::MOVE_RELATIVE:
    case request_t::JOG:
    case request_t::HOME:
    case request_t::ENABLE:
    case request_t::DISABLE:
    case request_t::FAULT_RESET: return Role::kOperate;
    case request_t::SET_POSITION:
    case request_t::SET_OUTPUTS:
    case request_t::PARAM_READ:
    case request_t::PARAM_WRITE: return Role::kConfigure;
    default: return Role::kAdmin;
  }
}

std::vector<PublicKey> AuthorizedKeys::keys_with_role(Role role) const {
  std::vector<PublicKey> out;
  for (const auto& p : principals_) {
    if (p.role == role) out.push_back(p.key);
  }
  return out;
}

std::vector<Principal> AuthorizedKeys::with_role(Role role) const {
  std::vector<Principal> out;
  for (const auto& p : principals_) {
    if (p.role == role) out.push_back(p);
  }
  return out;
}

bool Principal::owns_client_id(std::string_view client_id) const { return name_owns_client_id(name, client_id); }

bool Principal::may_speak_for(std::string_view bus) const {
  return buses.empty() || std::find(buses.begin(), buses.end(), bus) != buses.end();
}

namespace {

constexpr std::string_view kBusesToken = "buses=";

// The buses of a "buses=can0,rs485a" token, or what is wrong with it.
Loaded<std::vector<std::string>> parse_buses(const std::string& token) {
  if (token.rfind(kBusesToken, 0) != 0) {
    return "expected 'buses=<bus>[,<bus>...]' after the role, got '" + token.substr(0, 32) + "'";
  }
  const std::string list = token.substr(kBusesToken.size());
  if (list.empty()) return std::string("'buses=' names no bus (leave the token out for a key of every bus)");
  std::vector<std::string> buses;
  std::istringstream in(list + ",");  // every name, the last one too, ends with a comma
  for (std::string bus; std::getline(in, bus, ',');) {
    if (!valid_name(bus)) return "'" + token.substr(0, 64) + "': bus name '" + bus + "' is not 1..64 of [A-Za-z0-9._-]";
    if (std::find(buses.begin(), buses.end(), bus) != buses.end()) {
      return "'" + token.substr(0, 64) + "' names bus '" + bus + "' twice";
    }
    buses.push_back(bus);
  }
  return buses;
}

}  // namespace

Loaded<AuthorizedKeys> AuthorizedKeys::parse(std::string_view text, const std::string& file_name) {
  AuthorizedKeys out;
  std::string errors;
  std::map<KeyId, int> key_lines;
  std::map<std::string, int> name_lines;
  std::istringstream in{std::string(text)};
  int number = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    std::istringstream fields_in(line);
    std::vector<std::string> fields;
    for (std::string f; fields_in >> f;) fields.push_back(f);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string where = file_name + ":" + std::to_string(number) + ": ";
    auto fail = [&](const std::string& what) { errors += (errors.empty() ? "" : "\n") + where + what; };
    if (fields.size() != 3 && fields.size() != 4) {
      fail("expected '<base64 public key> <name> <role> [buses=<bus>,...]', got " + std::to_string(fields.size()) +
           " field" + (fields.size() == 1 ? "" : "s"));
      continue;
    }
    Principal p;
    p.line = number;
    const auto key = base64_decode(fields[0]);
    if (!key || key->size() != kPublicKeyBytes) {
      fail("'" + fields[0].substr(0, 16) + (fields[0].size() > 16 ? "...'" : "'") +
           " is not a base64 Ed25519 public key (32 bytes)");
      continue;
    }
    std::copy(key->begin(), key->end(), p.key.begin());
    p.name = fields[1];
    if (!valid_name(p.name)) {
      fail("name '" + p.name + "' is not 1..64 of [A-Za-z0-9._-]");
      continue;
    }
    const auto role = parse_role(fields[2]);
    if (!role) {
      fail("unknown role '" + fields[2] + "' (observe, operate, configure, admin, gateway)");
      continue;
    }
    p.role = *role;
    if (fields.size() == 4) {
      if (p.role != Role::kGateway) {
        fail("'" + fields[3].substr(0, 32) + "': only a key of role gateway is bound to buses, this one has role " +
             fields[2]);
        continue;
      }
      auto buses = parse_buses(fields[3]);
      if (auto* error = std::get_if<std::string>(&buses)) {
        fail(*error);
        continue;
      }
      p.buses = std::move(std::get<std::vector<std::string>>(buses));
    }
    // Key ids are 8 bytes of the key: two keys sharing them could not be told apart.
    if (auto [it, fresh] = key_lines.emplace(key_id(p.key), number); !fresh) {
      fail("key of '" + p.name + "' is already listed at line " + std::to_string(it->second) + " (same key id " +
           to_hex(key_id(p.key)) + ")");
      continue;
    }
    if (auto [it, fresh] = name_lines.emplace(p.name, number); !fresh) {
      fail("name '" + p.name + "' is already used at line " + std::to_string(it->second));
      continue;
    }
    out.principals_.push_back(std::move(p));
  }
  if (!errors.empty()) return errors;
  return out;
}

Loaded<AuthorizedKeys> AuthorizedKeys::load(const std::string& path) {
  std::ifstream in(path);
  if (!in) return "cannot read authorized keys file " + path;
  std::stringstream text;
  text << in.rdbuf();
  return parse(text.str(), path);
}

Loaded<std::vector<Principal>> load_gateway_keys(const std::string& path) {
  auto keys = AuthorizedKeys::load(path);
  if (auto* error = std::get_if<std::string>(&keys)) return *error;
  auto gateways = std::get<AuthorizedKeys>(keys).with_role(Role::kGateway);
  if (gateways.empty()) return path + " has no key of role gateway";
  return gateways;
}

const Principal* AuthorizedKeys::find(const KeyId& id) const {
  for (const auto& p : principals_) {
    if (key_id(p.key) == id) return &p;
  }
  return nullptr;
}

}  // namespace motion::security
