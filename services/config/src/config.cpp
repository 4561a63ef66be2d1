#include "motion/config/config.hpp"

#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "motion/config/setup_schema.hpp"
#include "motion/config/sim_variants.hpp"

namespace motion::config {

namespace {
const SetupValue* find_setup(const SetupMap& setup, std::string_view key) {
  const auto it = setup.find(std::string(key));
  return it == setup.end() ? nullptr : &it->second;
}
}  // namespace

std::optional<double> setup_number(const SetupMap& setup, std::string_view key) {
  const SetupValue* v = find_setup(setup, key);
  if (v == nullptr) return std::nullopt;
  if (const auto* d = std::get_if<double>(v)) return *d;
  if (const auto* i = std::get_if<long long>(v)) return static_cast<double>(*i);
  if (const auto* b = std::get_if<bool>(v)) return *b ? 1.0 : 0.0;
  return std::nullopt;
}

std::optional<long long> setup_integer(const SetupMap& setup, std::string_view key) {
  const SetupValue* v = find_setup(setup, key);
  if (v == nullptr) return std::nullopt;
  if (const auto* i = std::get_if<long long>(v)) return *i;
  if (const auto* d = std::get_if<double>(v)) return std::llround(*d);
  if (const auto* b = std::get_if<bool>(v)) return *b ? 1 : 0;
  return std::nullopt;
}

std::optional<bool> setup_flag(const SetupMap& setup, std::string_view key) {
  const SetupValue* v = find_setup(setup, key);
  if (v == nullptr) return std::nullopt;
  if (const auto* b = std::get_if<bool>(v)) return *b;
  if (const auto* i = std::get_if<long long>(v)) return *i != 0;
  return std::nullopt;
}

std::optional<std::string> setup_text(const SetupMap& setup, std::string_view key) {
  const SetupValue* v = find_setup(setup, key);
  if (v == nullptr) return std::nullopt;
  if (const auto* s = std::get_if<std::string>(v)) return *s;
  return std::nullopt;
}

std::string_view to_string(Family family) {
  switch (family) {
    case Family::kUim342: return "uim342";
    case Family::kUim242: return "uim242";
    case Family::kUc57: return "uc57";
    case Family::kAdamModbus: return "adam-modbus";
  }
  return "?";
}

const char* to_string(SecuritySettings::Mode mode) { return mode == SecuritySettings::Mode::kEnforce ? "enforce" : "off"; }

std::optional<Family> parse_family(std::string_view text) {
  for (Family f : {Family::kUim342, Family::kUim242, Family::kUc57, Family::kAdamModbus}) {
    if (to_string(f) == text) return f;
  }
  return std::nullopt;
}

IdRange node_id_range(Family family) {
  switch (family) {
    case Family::kUim342: return {5, 126};
    case Family::kUim242: return {5, 125};
    case Family::kUc57: return {1, 127};
    case Family::kAdamModbus: return {1, 64};
  }
  return {0, 0};
}

bool is_can(TransportKind kind) {
  switch (kind) {
    case TransportKind::kSimCan:
    case TransportKind::kSocketCan:
    case TransportKind::kUiMessage: return true;
    case TransportKind::kSerial:
    case TransportKind::kSimSerial: return false;
  }
  return false;
}

std::string ConfigError::message() const {
  std::ostringstream out;
  out << where.file << ':' << where.line << ':' << where.column << ": " << key << ": " << reason;
  return out.str();
}

std::string LoadResult::error_text() const {
  std::string out;
  for (const auto& e : errors) out += e.message() + "\n";
  return out;
}

const Bus* Config::find_bus(std::string_view name) const {
  for (const auto& b : buses) if (b.name == name) return &b;
  return nullptr;
}
const Drive* Config::find_drive(std::string_view name) const {
  for (const auto& d : drives) if (d.name == name) return &d;
  return nullptr;
}
const Axis* Config::find_axis(std::string_view name) const {
  for (const auto& a : axes) if (a.name == name) return &a;
  return nullptr;
}
std::vector<const Axis*> Config::axes_on_bus(std::string_view bus) const {
  std::vector<const Axis*> out;
  for (const auto& a : axes) {
    const Drive* d = find_drive(a.drive);
    if (d != nullptr && d->bus == bus) out.push_back(&a);
  }
  return out;
}

std::string default_config_path() {
  if (const char* env = std::getenv("MOTION_CONFIG")) return env;
  // An installed program (bin/ of a prefix, cmake/MotionPackage.cmake) uses its prefix's copy,
  // not the source tree it was built from.
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    auto installed = exe.parent_path().parent_path() / "share" / "motionbus" / "config" / "sim-lab.yaml";
    if (std::filesystem::exists(installed, ec)) return installed.string();
  }
#ifdef MOTION_DEFAULT_CONFIG
  return MOTION_DEFAULT_CONFIG;
#else
  return "config/sim-lab.yaml";
#endif
}

HomingSupport homing_support(Family family) {
  switch (family) {
    // UIM342: IL[i] origin action on IN1..IN3 (manual §5.26); none/current-position: OG (§5.22).
    case Family::kUim342: return {{"none", "switch", "current-position"}, 3, "1..3: IN1..IN3"};
    // UC57: homing mode 6 on IN1..IN3 (manual §4.2.6, §3.1); current-position: 2012h (§5.1).
    case Family::kUc57: return {{"none", "switch", "current-position"}, 3, "1..3: IN1 positive limit, IN2 origin, IN3 negative limit"};
    default: return {{"none", "switch", "current-position"}, 8, "1..8"};
  }
}

std::string sim_runtime_dir(const Config& config) {
  if (!config.simulation.runtime_dir.empty()) return config.simulation.runtime_dir;
  if (const char* env = std::getenv("MOTION_SIM_DIR"); env != nullptr && *env != '\0') return env;
  return "/tmp/motion-sim-" + std::to_string(::getuid());
}

std::optional<FileAccess> sim_file_access(const Config& config, std::string* why) {
  if (config.simulation.group.empty()) return FileAccess{};
  const auto gid = group_id(config.simulation.group);
  if (!gid) {
    if (why != nullptr) *why = "simulation.group: no group '" + config.simulation.group + "' on this machine";
    return std::nullopt;
  }
  return FileAccess{gid};
}

namespace {

// Walks the YAML tree, converting values and collecting errors with their location and key path.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  std::vector<ConfigError>& errors() { return errors_; }

  Location at(const YAML::Node& node) const {
    const auto mark = node.Mark();
    return {file_, mark.line + 1, mark.column + 1};
  }

  // The text of a mapping key; a key that is itself a list or mapping (`? [a, b]: 1`, `{x: 1}: 2`)
  // is an error naming where it is, and the entry is skipped.
  std::optional<std::string> key_of(const YAML::Node& key, const std::string& path) {
    if (key.IsScalar()) return key.Scalar();
    error(key, path.empty() ? "<root>" : path, "a key must be a plain name, not a list or mapping");
    return std::nullopt;
  }

  KeyLocations locations(const YAML::Node& map) const {
    KeyLocations out{at(map), {}};
    for (const auto& kv : map) {
      if (kv.first.IsScalar()) out.keys.emplace(kv.first.Scalar(), at(kv.second));
    }
    return out;
  }

  void error(const YAML::Node& node, const std::string& key, std::string reason) {
    errors_.push_back({at(node), key, std::move(reason)});
  }

  // A mapping with only `allowed` keys, each at most once. Returns false when `node` is no map.
  bool check_map(const YAML::Node& node, const std::string& path, std::initializer_list<std::string_view> allowed) {
    if (!node.IsMap()) {
      error(node, path, "expected a mapping");
      return false;
    }
    std::set<std::string> seen;
    for (const auto& kv : node) {
      const auto key_text = key_of(kv.first, path);
      if (!key_text) continue;
      const std::string& key = *key_text;
      const std::string key_path = join(path, key);
      if (!seen.insert(key).second) error(kv.first, key_path, "duplicate key");
      bool known = false;
      for (auto a : allowed) known = known || a == key;
      if (!known) {
        std::string list;
        for (auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
        error(kv.first, key_path, "unknown key (allowed: " + list + ")");
      }
    }
    return true;
  }

  template <typename T>
  std::optional<T> get(const YAML::Node& map, const std::string& path, const char* key, bool required) {
    const YAML::Node node = map[key];
    const std::string key_path = join(path, key);
    if (!node) {
      if (required) error(map, key_path, "required key is missing");
      return std::nullopt;
    }
    return convert<T>(node, key_path);
  }

  template <typename T>
  std::optional<T> convert(const YAML::Node& node, const std::string& key_path) {
    if (!node.IsScalar()) {
      error(node, key_path, std::string("expected ") + type_name<T>() + ", got a " + (node.IsMap() ? "mapping" : node.IsSequence() ? "sequence" : "null"));
      return std::nullopt;
    }
    try {
      if constexpr (std::is_same_v<T, int>) {
        // yaml-cpp accepts "1.5" as int 1 in some versions: insist on an integer literal.
        const auto d = node.as<double>();
        if (std::floor(d) != d || std::abs(d) > 2e9) throw YAML::BadConversion(node.Mark());
        return static_cast<int>(d);
      } else {
        return node.as<T>();
      }
    } catch (const YAML::Exception&) {
      error(node, key_path, std::string("expected ") + type_name<T>() + ", got '" + node.Scalar() + "'");
      return std::nullopt;
    }
  }

  static std::string join(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

 private:
  template <typename T>
  static const char* type_name() {
    if constexpr (std::is_same_v<T, int>) return "an integer";
    if constexpr (std::is_same_v<T, double>) return "a number";
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    return "a string";
  }

  std::string file_;
  std::vector<ConfigError> errors_;
};

void read_lcm(Reader& r, const YAML::Node& node, LcmSettings& out) {
  if (!r.check_map(node, "lcm", {"url", "channel_prefix"})) return;
  if (auto v = r.get<std::string>(node, "lcm", "url", false)) out.url = *v;
  if (auto v = r.get<std::string>(node, "lcm", "channel_prefix", false)) out.channel_prefix = *v;
}

void positive(Reader& r, const YAML::Node& at, const std::string& key, double value) {
  if (!(value > 0)) r.error(at, key, "must be greater than zero, got " + std::to_string(value));
}

// The UIMessage CRC keys: values, and only on uimessage: buses (elsewhere they would be ignored).
void read_uimessage_keys(Reader& r, const YAML::Node& node, const std::string& path, Bus& bus) {
  const auto only_here = [&](const char* key) {
    if (bus.kind != TransportKind::kUiMessage && !bus.transport.empty()) {
      r.error(node[key], path + "." + key, std::string("only for uimessage: buses (a UIROBOT serial gateway), but this bus is ") + bus.transport);
    }
  };
  if (auto v = r.get<std::string>(node, path, "uimessage_crc", false)) {
    if (*v == "start_to_aux") bus.uimessage_crc = UiMessageCrc::kStartToAux;
    else if (*v == "id_to_aux") bus.uimessage_crc = UiMessageCrc::kIdToAux;
    else r.error(node["uimessage_crc"], path + ".uimessage_crc", "expected start_to_aux (CRC over SM..d8, the manual) or id_to_aux (over ID..d8, UIROBOT's gateway software), got '" + *v + "'");
    only_here("uimessage_crc");
  }
  if (auto v = r.get<bool>(node, path, "uimessage_crc_strict", false)) {
    bus.uimessage_crc_strict = *v;
    only_here("uimessage_crc_strict");
  }
}

void read_bus(Reader& r, const YAML::Node& node, const std::string& path, Bus& bus) {
  if (!r.check_map(node, path, {"name", "transport", "bitrate", "bus_timing", "baud", "parity", "stop_bits",
                                "uimessage_crc", "uimessage_crc_strict", "request_timeout_ms", "retries", "poll_hz"}))
    return;
  bus.where = r.locations(node);
  if (auto v = r.get<std::string>(node, path, "name", true)) bus.name = *v;
  if (auto v = r.get<std::string>(node, path, "transport", true)) {
    bus.transport = *v;
    const auto colon = v->find(':');
    const std::string scheme = v->substr(0, colon);
    bus.target = colon == std::string::npos ? "" : v->substr(colon + 1);
    if (scheme == "simcan") bus.kind = TransportKind::kSimCan;
    else if (scheme == "socketcan") bus.kind = TransportKind::kSocketCan;
    else if (scheme == "serial") bus.kind = TransportKind::kSerial;
    else if (scheme == "simserial") bus.kind = TransportKind::kSimSerial;
    else if (scheme == "uimessage") bus.kind = TransportKind::kUiMessage;
    else r.error(node["transport"], path + ".transport", "unknown transport '" + *v + "' (use simcan:NAME, socketcan:IFACE, serial:DEVICE, simserial:NAME or uimessage:DEVICE)");
    if (colon != std::string::npos && bus.target.empty()) r.error(node["transport"], path + ".transport", "missing name after '" + scheme + ":'");
    if (colon == std::string::npos) r.error(node["transport"], path + ".transport", "expected SCHEME:NAME, got '" + *v + "'");
  }
  if (auto v = r.get<int>(node, path, "bitrate", false)) {
    bus.bitrate = *v;
    static const std::set<int> kRates = {10000, 20000, 50000, 100000, 125000, 250000, 500000, 800000, 1000000};
    if (!kRates.contains(*v)) r.error(node["bitrate"], path + ".bitrate", "not a CAN bit rate: " + std::to_string(*v));
  }
  if (auto v = r.get<bool>(node, path, "bus_timing", false)) bus.bus_timing = *v;
  if (auto v = r.get<int>(node, path, "baud", false)) {
    bus.baud = *v;
    static const std::set<int> kBauds = {9600, 19200, 38400, 57600, 115200, 230400};
    if (!kBauds.contains(*v)) r.error(node["baud"], path + ".baud", "unsupported baud rate: " + std::to_string(*v));
  }
  if (auto v = r.get<std::string>(node, path, "parity", false)) {
    if (*v == "none") bus.parity = 'N';
    else if (*v == "even") bus.parity = 'E';
    else if (*v == "odd") bus.parity = 'O';
    else r.error(node["parity"], path + ".parity", "expected none, even or odd, got '" + *v + "'");
  }
  if (auto v = r.get<int>(node, path, "stop_bits", false)) {
    bus.stop_bits = *v;
    if (*v != 1 && *v != 2) r.error(node["stop_bits"], path + ".stop_bits", "expected 1 or 2");
  }
  read_uimessage_keys(r, node, path, bus);
  if (auto v = r.get<int>(node, path, "request_timeout_ms", false)) {
    bus.request_timeout_ms = *v;
    positive(r, node["request_timeout_ms"], path + ".request_timeout_ms", *v);
  }
  if (auto v = r.get<int>(node, path, "retries", false)) {
    bus.retries = *v;
    if (*v < 0 || *v > 10) r.error(node["retries"], path + ".retries", "expected 0..10");
  }
  if (auto v = r.get<double>(node, path, "poll_hz", false)) {
    bus.poll_hz = *v;
    positive(r, node["poll_hz"], path + ".poll_hz", *v);
  }
}

void read_setup(Reader& r, const YAML::Node& node, const std::string& path, Family family, Drive& drive) {
  if (!node.IsMap()) {
    r.error(node, path, "expected a mapping of set-up keys");
    return;
  }
  std::set<std::string> seen;
  for (const auto& kv : node) {
    const auto key_text = r.key_of(kv.first, path);
    if (!key_text) continue;
    const std::string& key = *key_text;
    const std::string key_path = path + "." + key;
    if (!seen.insert(key).second) {
      r.error(kv.first, key_path, "duplicate key");
      continue;
    }
    const SetupKey* schema = find_setup_key(family, key);
    if (schema == nullptr) {
      std::string list;
      for (const auto& k : setup_schema(family)) list += (list.empty() ? "" : ", ") + std::string(k.key);
      r.error(kv.first, key_path, "unknown set-up key for " + std::string(to_string(family)) + " (allowed: " + list + ")");
      continue;
    }
    switch (schema->type) {
      case SetupType::kBool:
        if (auto v = r.convert<bool>(kv.second, key_path)) drive.setup[key] = *v;
        break;
      case SetupType::kInt:
        if (auto v = r.convert<int>(kv.second, key_path)) {
          const bool listed = schema->allowed_ints.empty() ||
                              std::find(schema->allowed_ints.begin(), schema->allowed_ints.end(), *v) != schema->allowed_ints.end();
          if (*v < schema->min || *v > schema->max || !listed) {
            std::string allowed;
            if (!schema->allowed_ints.empty()) {
              for (auto a : schema->allowed_ints) allowed += (allowed.empty() ? "" : ", ") + std::to_string(a);
            } else {
              allowed = std::to_string(static_cast<long long>(schema->min)) + ".." + std::to_string(static_cast<long long>(schema->max));
            }
            r.error(kv.second, key_path, std::to_string(*v) + " is out of range (" + allowed + ")");
          } else {
            drive.setup[key] = static_cast<long long>(*v);
          }
        }
        break;
      case SetupType::kNumber:
        if (auto v = r.convert<double>(kv.second, key_path)) {
          if (*v < schema->min || *v > schema->max) {
            std::ostringstream msg;
            msg << *v << " is out of range (" << schema->min << ".." << schema->max << ")";
            r.error(kv.second, key_path, msg.str());
          } else {
            drive.setup[key] = *v;
          }
        }
        break;
      case SetupType::kChoice:
        if (auto v = r.convert<std::string>(kv.second, key_path)) {
          if (std::find(schema->choices.begin(), schema->choices.end(), *v) == schema->choices.end()) {
            std::string list;
            for (auto c : schema->choices) list += (list.empty() ? "" : ", ") + std::string(c);
            r.error(kv.second, key_path, "'" + *v + "' is not one of " + list);
          } else {
            drive.setup[key] = *v;
          }
        }
        break;
    }
  }
}

void read_drive(Reader& r, const YAML::Node& node, const std::string& path, Drive& drive) {
  if (!r.check_map(node, path, {"name", "family", "bus", "node_id", "group_id", "request_timeout_ms", "retries", "setup"})) return;
  drive.where = r.locations(node);
  if (auto v = r.get<std::string>(node, path, "name", true)) drive.name = *v;
  std::optional<Family> family;
  if (auto v = r.get<std::string>(node, path, "family", true)) {
    family = parse_family(*v);
    if (!family) r.error(node["family"], path + ".family", "unknown family '" + *v + "' (uim342, uim242, uc57, adam-modbus)");
    else drive.family = *family;
  }
  if (auto v = r.get<std::string>(node, path, "bus", true)) drive.bus = *v;
  if (auto v = r.get<int>(node, path, "node_id", true)) {
    drive.node_id = *v;
    if (family) {
      const auto range = node_id_range(*family);
      if (*v < range.min || *v > range.max) {
        r.error(node["node_id"], path + ".node_id", "node id " + std::to_string(*v) + " is outside " +
                std::string(to_string(*family)) + "'s range " + std::to_string(range.min) + ".." + std::to_string(range.max));
      }
    }
  }
  if (auto v = r.get<int>(node, path, "group_id", false)) {
    drive.group_id = *v;
    if (family && *family != Family::kUim342) {
      r.error(node["group_id"], path + ".group_id", "group ids exist only for uim342 drives");
    } else if (*v < 5 || *v > 126) {
      r.error(node["group_id"], path + ".group_id", "group id " + std::to_string(*v) + " is outside 5..126 (SimpleCAN §5.1)");
    }
  }
  if (auto v = r.get<int>(node, path, "request_timeout_ms", false)) {
    drive.request_timeout_ms = *v;
    positive(r, node["request_timeout_ms"], path + ".request_timeout_ms", *v);
  }
  if (auto v = r.get<int>(node, path, "retries", false)) {
    drive.retries = *v;
    if (*v < 0 || *v > 10) r.error(node["retries"], path + ".retries", "expected 0..10");
  }
  if (node["setup"] && family) read_setup(r, node["setup"], path + ".setup", *family, drive);
}

void read_axis(Reader& r, const YAML::Node& node, const std::string& path, Axis& axis) {
  if (!r.check_map(node, path, {"name", "drive", "unit", "steps_per_unit", "invert", "limits", "homing"})) return;
  axis.where = r.locations(node);
  if (auto v = r.get<std::string>(node, path, "name", true)) axis.name = *v;
  if (auto v = r.get<std::string>(node, path, "drive", true)) axis.drive = *v;
  if (auto v = r.get<std::string>(node, path, "unit", false)) axis.unit = *v;
  if (auto v = r.get<double>(node, path, "steps_per_unit", true)) {
    axis.steps_per_unit = *v;
    positive(r, node["steps_per_unit"], path + ".steps_per_unit", *v);
  }
  if (auto v = r.get<bool>(node, path, "invert", false)) axis.invert = *v;

  const std::string lpath = path + ".limits";
  const YAML::Node limits = node["limits"];
  if (!limits) {
    r.error(node, lpath, "required key is missing");
  } else if (r.check_map(limits, lpath, {"min", "max", "velocity", "acceleration"})) {
    auto mn = r.get<double>(limits, lpath, "min", true);
    auto mx = r.get<double>(limits, lpath, "max", true);
    auto vel = r.get<double>(limits, lpath, "velocity", true);
    auto acc = r.get<double>(limits, lpath, "acceleration", true);
    if (mn && mx) {
      axis.limits.min_position = *mn;
      axis.limits.max_position = *mx;
      if (!(*mn < *mx)) r.error(limits["max"], lpath + ".max", "must be greater than min");
    }
    if (vel) {
      axis.limits.max_velocity = *vel;
      positive(r, limits["velocity"], lpath + ".velocity", *vel);
    }
    if (acc) {
      axis.limits.max_acceleration = *acc;
      positive(r, limits["acceleration"], lpath + ".acceleration", *acc);
    }
  }

  const std::string hpath = path + ".homing";
  const YAML::Node homing = node["homing"];
  if (homing && r.check_map(homing, hpath, {"method", "input", "edge", "velocity", "offset"})) {
    axis.homing.where = r.locations(homing);
    // The method name is checked against the drive's family in the cross-checks (homing_support).
    if (auto v = r.get<std::string>(homing, hpath, "method", true)) {
      axis.homing.method_name = *v;
      if (*v == "switch") axis.homing.method = HomingMethod::kSwitch;
      else if (*v == "current-position") axis.homing.method = HomingMethod::kCurrentPosition;
      else axis.homing.method = HomingMethod::kNone;
    }
    if (auto v = r.get<int>(homing, hpath, "input", false)) axis.homing.input = *v;
    if (auto v = r.get<std::string>(homing, hpath, "edge", false)) {
      if (*v == "falling") axis.homing.edge = HomingEdge::kFalling;
      else if (*v == "rising") axis.homing.edge = HomingEdge::kRising;
      else r.error(homing["edge"], hpath + ".edge", "expected falling or rising, got '" + *v + "'");
    }
    if (auto v = r.get<double>(homing, hpath, "velocity", false)) axis.homing.velocity = *v;
    if (auto v = r.get<double>(homing, hpath, "offset", false)) axis.homing.offset = *v;
  }
}

void read_coordinator(Reader& r, const YAML::Node& node, CoordinatorSettings& out) {
  const std::string path = "coordinator";
  if (!r.check_map(node, path, {"default_timeout_ms", "progress_period_ms", "trigger_lead_ms", "gateway_timeout_ms",
                                "arm_timeout_ms", "max_active_requests", "position_tolerance"}))
    return;
  auto positive_int = [&](const char* key, int& field) {
    if (auto v = r.get<int>(node, path, key, false)) {
      field = *v;
      positive(r, node[key], path + "." + key, *v);
    }
  };
  positive_int("default_timeout_ms", out.default_timeout_ms);
  positive_int("progress_period_ms", out.progress_period_ms);
  positive_int("trigger_lead_ms", out.trigger_lead_ms);
  positive_int("gateway_timeout_ms", out.gateway_timeout_ms);
  positive_int("arm_timeout_ms", out.arm_timeout_ms);
  positive_int("max_active_requests", out.max_active_requests);
  if (auto v = r.get<double>(node, path, "position_tolerance", false)) {
    out.position_tolerance = *v;
    if (*v < 0) r.error(node["position_tolerance"], path + ".position_tolerance", "must not be negative");
  }
}

// A path as given when absolute, else from the folder of the configuration file `file`.
std::string relative_to(const std::string& file, const std::string& path) {
  if (path.empty() || path.front() == '/') return path;
  const auto slash = file.rfind('/');
  return slash == std::string::npos ? path : file.substr(0, slash + 1) + path;
}

void read_security(Reader& r, const YAML::Node& node, const std::string& file, SecuritySettings& out) {
  const std::string path = "security";
  if (!r.check_map(node, path, {"mode", "authorized_keys", "key", "coordinator_public_key", "window_ms"})) return;
  out.where = r.locations(node);
  if (auto v = r.get<std::string>(node, path, "mode", false)) {
    if (*v == "off") {
      out.mode = SecuritySettings::Mode::kOff;
    } else if (*v == "enforce") {
      out.mode = SecuritySettings::Mode::kEnforce;
    } else {
      r.error(node["mode"], path + ".mode", "'" + *v + "' is not a security mode (off, enforce)");
    }
  }
  if (auto v = r.get<std::string>(node, path, "authorized_keys", false)) out.authorized_keys = relative_to(file, *v);
  if (auto v = r.get<std::string>(node, path, "key", false)) out.key = relative_to(file, *v);
  if (auto v = r.get<std::string>(node, path, "coordinator_public_key", false)) out.coordinator_public_key = relative_to(file, *v);
  if (auto v = r.get<int>(node, path, "window_ms", false)) {
    out.window_ms = *v;
    if (*v < 100 || *v > 600000) r.error(node["window_ms"], path + ".window_ms", std::to_string(*v) + " is outside 100..600000 ms");
  }
  if (out.mode == SecuritySettings::Mode::kEnforce) {
    if (out.authorized_keys.empty()) r.error(node, path + ".authorized_keys", "required when security.mode is enforce (who may send what)");
    if (out.key.empty()) r.error(node, path + ".key", "required when security.mode is enforce (the coordinator signs its gateway commands)");
    if (out.coordinator_public_key.empty()) {
      r.error(node, path + ".coordinator_public_key", "required when security.mode is enforce (gateways verify the coordinator's commands)");
    }
  }
}

void read_simulation(Reader& r, const YAML::Node& node, SimulationSettings& out) {
  if (!r.check_map(node, "simulation", {"runtime_dir", "group", "reply_latency_us", "home_switches", "variants"})) return;
  if (const YAML::Node switches = node["home_switches"]) {
    if (!switches.IsMap()) {
      r.error(switches, "simulation.home_switches", "expected a map of drive name to switch position (counts) or none");
    } else {
      for (const auto& entry : switches) {
        const auto drive_text = r.key_of(entry.first, "simulation.home_switches");
        if (!drive_text) continue;
        const std::string& drive = *drive_text;
        const std::string path = "simulation.home_switches." + drive;
        if (entry.second.IsScalar() && entry.second.as<std::string>() == "none") {
          out.home_switches[drive] = std::nullopt;
          continue;
        }
        try {
          out.home_switches[drive] = entry.second.as<long long>();
        } catch (const YAML::Exception&) {
          r.error(entry.second, path, "expected a position in counts or none");
        }
      }
    }
  }
  if (const YAML::Node variants = node["variants"]) {
    if (!variants.IsMap()) {
      r.error(variants, "simulation.variants", "expected a map of drive name to {key: value}");
    } else {
      for (const auto& entry : variants) {
        const auto drive = r.key_of(entry.first, "simulation.variants");
        if (!drive) continue;
        const std::string path = "simulation.variants." + *drive;
        if (!entry.second.IsMap()) {
          r.error(entry.second, path, "expected a map of variant key to value");
          continue;
        }
        for (const auto& kv : entry.second) {
          const auto key = r.key_of(kv.first, path);
          if (!key) continue;
          if (!kv.second.IsScalar()) {
            r.error(kv.second, path + "." + *key, "expected a value");
            continue;
          }
          out.variants[*drive][*key] = kv.second.as<std::string>();
        }
      }
    }
  }
  if (auto v = r.get<std::string>(node, "simulation", "runtime_dir", false)) out.runtime_dir = *v;
  if (auto v = r.get<std::string>(node, "simulation", "group", false)) out.group = *v;
  if (auto v = r.get<int>(node, "simulation", "reply_latency_us", false)) {
    out.reply_latency_us = *v;
    if (*v < 0) r.error(node["reply_latency_us"], "simulation.reply_latency_us", "must not be negative");
  }
}

template <typename T, typename ReadOne>
void read_list(Reader& r, const YAML::Node& root, const char* key, std::vector<T>& out, ReadOne read_one) {
  const YAML::Node list = root[key];
  if (!list) return;
  if (!list.IsSequence()) {
    r.error(list, key, "expected a list");
    return;
  }
  for (std::size_t i = 0; i < list.size(); ++i) {
    T item;
    read_one(r, list[i], std::string(key) + "[" + std::to_string(i) + "]", item);
    out.push_back(std::move(item));
  }
}

// Cross-references and uniqueness, once every item is read.
void check_references(Reader& r, const YAML::Node& root, Config& c) {
  auto where_error = [&](const Location& loc, std::string key, std::string reason) {
    r.errors().push_back({loc, std::move(key), std::move(reason)});
  };
  std::map<std::string, const Bus*> buses;
  for (std::size_t i = 0; i < c.buses.size(); ++i) {
    const Bus& b = c.buses[i];
    if (!b.name.empty() && !buses.emplace(b.name, &b).second) where_error(b.where.of("name"), "buses[" + std::to_string(i) + "].name", "duplicate bus name '" + b.name + "'");
  }
  std::set<std::string> drive_names;
  // (bus, address space) -> node id -> drive. UIM342 (29-bit) and CANopen (11-bit) frames do not
  // collide on one CAN bus, so they have separate spaces; UIM342 group ids share the UIM342 space.
  std::map<std::pair<std::string, std::string>, std::map<int, std::string>> node_ids;
  for (std::size_t i = 0; i < c.drives.size(); ++i) {
    const Drive& d = c.drives[i];
    const std::string path = "drives[" + std::to_string(i) + "]";
    if (!d.name.empty() && !drive_names.insert(d.name).second) where_error(d.where.of("name"), path + ".name", "duplicate drive name '" + d.name + "'");
    auto bus_it = buses.find(d.bus);
    if (!d.bus.empty() && bus_it == buses.end()) {
      where_error(d.where.of("bus"), path + ".bus", "drive '" + d.name + "' is on undeclared bus '" + d.bus + "'");
      continue;
    }
    if (bus_it == buses.end()) continue;
    const bool can_family = d.family == Family::kUim342 || d.family == Family::kUc57;
    if (can_family != is_can(bus_it->second->kind)) {
      where_error(d.where.of("bus"), path + ".bus", std::string(to_string(d.family)) + " drive '" + d.name + "' needs a " +
                  (can_family ? "CAN bus (simcan:, socketcan: or, for uim342, uimessage:)" : "serial bus (serial: or simserial:)") +
                  ", but bus '" + d.bus + "' is " + bus_it->second->transport);
    } else if (bus_it->second->kind == TransportKind::kUiMessage && d.family != Family::kUim342) {
      where_error(d.where.of("bus"), path + ".bus", std::string(to_string(d.family)) + " drive '" + d.name +
                  "' needs a CAN adapter (simcan: or socketcan:): bus '" + d.bus + "' is a UIROBOT serial gateway (" +
                  bus_it->second->transport + "), which carries SimpleCAN 3.0 (uim342) frames only");
    }
    auto& space = node_ids[{d.bus, std::string(to_string(d.family))}];
    auto [it, inserted] = space.emplace(d.node_id, d.name);
    if (!inserted) where_error(d.where.of("node_id"), path + ".node_id", "node id " + std::to_string(d.node_id) + " on bus '" + d.bus + "' is already used by drive '" + it->second + "'");
  }
  for (std::size_t i = 0; i < c.drives.size(); ++i) {
    const Drive& d = c.drives[i];
    if (d.group_id == 0) continue;
    const auto& space = node_ids[{d.bus, std::string(to_string(d.family))}];
    if (auto it = space.find(d.group_id); it != space.end()) {
      where_error(d.where.of("group_id"), "drives[" + std::to_string(i) + "].group_id", "group id " + std::to_string(d.group_id) +
                  " collides with the node id of drive '" + it->second + "' (SimpleCAN §5.1: must differ)");
    }
  }
  std::set<std::string> axis_names;
  std::map<std::string, std::string> drive_users;
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    const Axis& a = c.axes[i];
    const std::string path = "axes[" + std::to_string(i) + "]";
    if (!a.name.empty() && !axis_names.insert(a.name).second) where_error(a.where.of("name"), path + ".name", "duplicate axis name '" + a.name + "'");
    if (!a.drive.empty() && !drive_names.contains(a.drive)) where_error(a.where.of("drive"), path + ".drive", "axis '" + a.name + "' uses undeclared drive '" + a.drive + "'");
    if (const Drive* d = c.find_drive(a.drive); d && !a.homing.method_name.empty()) {
      const HomingSupport support = homing_support(d->family);
      const std::string hpath = path + ".homing";
      if (std::find(support.methods.begin(), support.methods.end(), a.homing.method_name) == support.methods.end()) {
        std::string list;
        for (const auto m : support.methods) list += (list.empty() ? "" : ", ") + std::string(m);
        where_error(a.homing.where.of("method"), hpath + ".method",
                    "'" + a.homing.method_name + "' is not a homing method of family " + std::string(to_string(d->family)) + " (" + list + ")");
      }
      if (a.homing.input < 1 || a.homing.input > support.max_input) {
        where_error(a.homing.where.of("input"), hpath + ".input",
                    "input " + std::to_string(a.homing.input) + " is not an input of family " + std::string(to_string(d->family)) + " (" +
                        std::string(support.inputs) + ")");
      }
    }
    auto [it, inserted] = drive_users.emplace(a.drive, a.name);
    if (!inserted) where_error(a.where.of("drive"), path + ".drive", "drive '" + a.drive + "' already drives axis '" + it->second + "'");
  }
  if (c.buses.empty()) r.error(root, "buses", "at least one bus is required");
  // Simulated variants name a drive of the configuration and a key of its family.
  for (const auto& [drive, keys] : c.simulation.variants) {
    const YAML::Node node = root["simulation"]["variants"][drive];
    const Drive* d = c.find_drive(drive);
    if (!d) {
      r.error(node, "simulation.variants." + drive, "names no drive of the configuration");
      continue;
    }
    for (const auto& [key, value] : keys) {
      if (auto why = sim_variant_error(d->family, key, value); !why.empty()) r.error(node[key], "simulation.variants." + drive + "." + key, why);
    }
  }
}

}  // namespace

LoadResult load_string(std::string_view yaml_text, const std::string& file_name) {
  LoadResult result;
  Reader r(file_name);
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const YAML::ParserException& e) {
    result.errors.push_back({{file_name, e.mark.line + 1, e.mark.column + 1}, "<yaml>", e.msg});
    return result;
  }
  Config c;
  c.file = file_name;
  if (!root.IsMap()) {
    r.error(root, "<root>", "expected a mapping with lcm, buses, drives, axes");
  } else if (r.check_map(root, "", {"lcm", "buses", "drives", "axes", "coordinator", "security", "simulation"})) {
    try {
      if (root["lcm"]) read_lcm(r, root["lcm"], c.lcm);
      read_list(r, root, "buses", c.buses, read_bus);
      read_list(r, root, "drives", c.drives, read_drive);
      read_list(r, root, "axes", c.axes, read_axis);
      if (root["coordinator"]) read_coordinator(r, root["coordinator"], c.coordinator);
      if (root["security"]) read_security(r, root["security"], file_name, c.security);
      if (root["simulation"]) read_simulation(r, root["simulation"], c.simulation);
      check_references(r, root, c);
    } catch (const YAML::Exception& e) {
      // Every conversion above is checked; this keeps a shape the checks missed an error, not a crash.
      result.errors.push_back({{file_name, e.mark.line + 1, e.mark.column + 1}, "<yaml>", e.msg});
    }
  }
  auto& read_errors = r.errors();
  result.errors.insert(result.errors.begin(), read_errors.begin(), read_errors.end());
  if (result.errors.empty()) result.config = std::move(c);
  return result;
}

LoadResult load_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    LoadResult result;
    // Built field by field: GCC 12 at -O3 flags the nested brace-init as maybe-uninitialized.
    ConfigError error;
    error.where.file = path;
    error.key = "<file>";
    error.reason = "cannot open the configuration file";
    result.errors.push_back(std::move(error));
    return result;
  }
  std::stringstream text;
  text << in.rdbuf();
  return load_string(text.str(), path);
}

}  // namespace motion::config
