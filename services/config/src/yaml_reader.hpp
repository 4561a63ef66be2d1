#pragma once
// Private to motion::config: the YAML tree walker that the configuration loader and its section
// readers share, and the section readers themselves. Single-threaded, non-blocking (pure parsing).

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <initializer_list>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "motion/config/config.hpp"

namespace motion::config::detail {

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
      error(node, key_path,
            std::string("expected ") + type_name<T>() + ", got a " +
                (node.IsMap()        ? "mapping"
                 : node.IsSequence() ? "sequence"
                                     : "null"));
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

  static std::string join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }

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

// Section readers (read_sections.cpp): each checks its mapping's keys and values, filling `out`
// and collecting errors in `r`; cross-references between sections are checked by the loader.
void read_lcm(Reader& r, const YAML::Node& node, LcmSettings& out);
void read_bus(Reader& r, const YAML::Node& node, const std::string& path, Bus& bus);
void read_drive(Reader& r, const YAML::Node& node, const std::string& path, Drive& drive);
void read_axis(Reader& r, const YAML::Node& node, const std::string& path, Axis& axis);
void read_coordinator(Reader& r, const YAML::Node& node, CoordinatorSettings& out);
// `file` is the configuration file's path: relative key paths are taken from its folder.
void read_security(Reader& r, const YAML::Node& node, const std::string& file, SecuritySettings& out);
void read_simulation(Reader& r, const YAML::Node& node, SimulationSettings& out);

}  // namespace motion::config::detail
