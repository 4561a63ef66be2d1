#include "motion/config/config.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

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

const char* to_string(SecuritySettings::Mode mode) {
  return mode == SecuritySettings::Mode::kEnforce ? "enforce" : "off";
}

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
  for (const auto& b : buses)
    if (b.name == name) return &b;
  return nullptr;
}
const Drive* Config::find_drive(std::string_view name) const {
  for (const auto& d : drives)
    if (d.name == name) return &d;
  return nullptr;
}
const Axis* Config::find_axis(std::string_view name) const {
  for (const auto& a : axes)
    if (a.name == name) return &a;
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
    case Family::kUc57:
      return {{"none", "switch", "current-position"}, 3, "1..3: IN1 positive limit, IN2 origin, IN3 negative limit"};
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

}  // namespace motion::config
