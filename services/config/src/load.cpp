// Loading a configuration: the YAML document, its sections, then the cross-references.
#include <algorithm>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "motion/config/sim_variants.hpp"
#include "yaml_reader.hpp"

namespace motion::config {

namespace {

using detail::read_axis;
using detail::read_bus;
using detail::read_coordinator;
using detail::read_drive;
using detail::read_lcm;
using detail::read_security;
using detail::read_simulation;
using detail::Reader;

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
    if (!b.name.empty() && !buses.emplace(b.name, &b).second)
      where_error(b.where.of("name"), "buses[" + std::to_string(i) + "].name", "duplicate bus name '" + b.name + "'");
    // A gateway hands its start frames over this much before the send time a trigger names: the
    // trigger must reach it earlier still, and the coordinator sends triggers at least
    // trigger_lead_min_ms ahead.
    if (b.egress_latency_us > 0 && b.egress_latency_us <= kMaxEgressLatencyUs &&
        b.egress_latency_us >= c.coordinator.trigger_lead_min_ms * 1000)
      where_error(b.where.of("egress_latency_us"), "buses[" + std::to_string(i) + "].egress_latency_us",
                  "must be below coordinator.trigger_lead_min_ms (" +
                      std::to_string(c.coordinator.trigger_lead_min_ms) +
                      " ms): the start frames are handed over this much before the trigger's send time");
  }
  std::set<std::string> drive_names;
  // (bus, address space) -> node id -> drive. UIM342 (29-bit) and CANopen (11-bit) frames do not
  // collide on one CAN bus, so they have separate spaces; UIM342 group ids share the UIM342 space.
  std::map<std::pair<std::string, std::string>, std::map<int, std::string>> node_ids;
  for (std::size_t i = 0; i < c.drives.size(); ++i) {
    const Drive& d = c.drives[i];
    const std::string path = "drives[" + std::to_string(i) + "]";
    if (!d.name.empty() && !drive_names.insert(d.name).second)
      where_error(d.where.of("name"), path + ".name", "duplicate drive name '" + d.name + "'");
    auto bus_it = buses.find(d.bus);
    if (!d.bus.empty() && bus_it == buses.end()) {
      where_error(d.where.of("bus"), path + ".bus", "drive '" + d.name + "' is on undeclared bus '" + d.bus + "'");
      continue;
    }
    if (bus_it == buses.end()) continue;
    const bool can_family = d.family == Family::kUim342 || d.family == Family::kUc57;
    if (can_family != is_can(bus_it->second->kind)) {
      where_error(d.where.of("bus"), path + ".bus",
                  std::string(to_string(d.family)) + " drive '" + d.name + "' needs a " +
                      (can_family ? "CAN bus (simcan:, socketcan: or, for uim342, uimessage:)"
                                  : "serial bus (serial: or simserial:)") +
                      ", but bus '" + d.bus + "' is " + bus_it->second->transport);
    } else if (bus_it->second->kind == TransportKind::kUiMessage && d.family != Family::kUim342) {
      where_error(d.where.of("bus"), path + ".bus",
                  std::string(to_string(d.family)) + " drive '" + d.name +
                      "' needs a CAN adapter (simcan: or socketcan:): bus '" + d.bus +
                      "' is a UIROBOT serial gateway (" + bus_it->second->transport +
                      "), which carries SimpleCAN 3.0 (uim342) frames only");
    }
    auto& space = node_ids[{d.bus, std::string(to_string(d.family))}];
    auto [it, inserted] = space.emplace(d.node_id, d.name);
    if (!inserted)
      where_error(d.where.of("node_id"), path + ".node_id",
                  "node id " + std::to_string(d.node_id) + " on bus '" + d.bus + "' is already used by drive '" +
                      it->second + "'");
  }
  for (std::size_t i = 0; i < c.drives.size(); ++i) {
    const Drive& d = c.drives[i];
    if (d.group_id == 0) continue;
    const auto& space = node_ids[{d.bus, std::string(to_string(d.family))}];
    if (auto it = space.find(d.group_id); it != space.end()) {
      where_error(d.where.of("group_id"), "drives[" + std::to_string(i) + "].group_id",
                  "group id " + std::to_string(d.group_id) + " collides with the node id of drive '" + it->second +
                      "' (SimpleCAN §5.1: must differ)");
    }
  }
  std::set<std::string> axis_names;
  std::map<std::string, std::string> drive_users;
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    const Axis& a = c.axes[i];
    const std::string path = "axes[" + std::to_string(i) + "]";
    if (!a.name.empty() && !axis_names.insert(a.name).second)
      where_error(a.where.of("name"), path + ".name", "duplicate axis name '" + a.name + "'");
    if (!a.drive.empty() && !drive_names.contains(a.drive))
      where_error(a.where.of("drive"), path + ".drive",
                  "axis '" + a.name + "' uses undeclared drive '" + a.drive + "'");
    if (const Drive* d = c.find_drive(a.drive); d && !a.homing.method_name.empty()) {
      const HomingSupport support = homing_support(d->family);
      const std::string hpath = path + ".homing";
      if (std::find(support.methods.begin(), support.methods.end(), a.homing.method_name) == support.methods.end()) {
        std::string list;
        for (const auto m : support.methods) list += (list.empty() ? "" : ", ") + std::string(m);
        where_error(a.homing.where.of("method"), hpath + ".method",
                    "'" + a.homing.method_name + "' is not a homing method of family " +
                        std::string(to_string(d->family)) + " (" + list + ")");
      }
      if (a.homing.input < 1 || a.homing.input > support.max_input) {
        where_error(a.homing.where.of("input"), hpath + ".input",
                    "input " + std::to_string(a.homing.input) + " is not an input of family " +
                        std::string(to_string(d->family)) + " (" + std::string(support.inputs) + ")");
      }
    }
    auto [it, inserted] = drive_users.emplace(a.drive, a.name);
    if (!inserted)
      where_error(a.where.of("drive"), path + ".drive",
                  "drive '" + a.drive + "' already drives axis '" + it->second + "'");
  }
  if (c.buses.empty()) r.error(root, "buses", "at least one bus is required");
  // Simulated variants name a drive of the configuration and a key of its family, or a bus and
  // a key of its transport (a uimessage: bus's serial gateway).
  for (const auto& [name, keys] : c.simulation.variants) {
    const YAML::Node node = root["simulation"]["variants"][name];
    const Drive* d = c.find_drive(name);
    const Bus* b = d ? nullptr : c.find_bus(name);
    if (!d && !b) {
      r.error(node, "simulation.variants." + name, "names no drive (or bus) of the configuration");
      continue;
    }
    for (const auto& [key, value] : keys) {
      const auto why = d ? sim_variant_error(d->family, key, value) : sim_bus_variant_error(b->kind, key, value);
      if (!why.empty()) r.error(node[key], "simulation.variants." + name + "." + key, why);
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
