// The configuration's sections, one reader each (keys, types, ranges); see yaml_reader.hpp.
#include <algorithm>
#include <sstream>

#include "motion/config/setup_schema.hpp"
#include "yaml_reader.hpp"

namespace motion::config::detail {

void read_lcm(Reader& r, const YAML::Node& node, LcmSettings& out) {
  if (!r.check_map(node, "lcm", {"url", "channel_prefix"})) return;
  if (auto v = r.get<std::string>(node, "lcm", "url", false)) out.url = *v;
  if (auto v = r.get<std::string>(node, "lcm", "channel_prefix", false)) out.channel_prefix = *v;
}

namespace {

void positive(Reader& r, const YAML::Node& at, const std::string& key, double value) {
  if (!(value > 0)) r.error(at, key, "must be greater than zero, got " + std::to_string(value));
}

// An integer key within lo..hi, read into `field`; outside, one error: "expected <expected>, got N".
void bounded_int(Reader& r, const YAML::Node& node, const std::string& path, const char* key, int lo, int hi,
                 const std::string& expected, int& field) {
  if (auto v = r.get<int>(node, path, key, false)) {
    field = *v;
    if (*v < lo || *v > hi)
      r.error(node[key], path + "." + key, "expected " + expected + ", got " + std::to_string(*v));
  }
}

// The UIMessage CRC keys: values, and only on uimessage: buses (elsewhere they would be ignored).
void read_uimessage_keys(Reader& r, const YAML::Node& node, const std::string& path, Bus& bus) {
  const auto only_here = [&](const char* key) {
    if (bus.kind != TransportKind::kUiMessage && !bus.transport.empty()) {
      r.error(node[key], path + "." + key,
              std::string("only for uimessage: buses (a UIROBOT serial gateway), but this bus is ") + bus.transport);
    }
  };
  if (auto v = r.get<std::string>(node, path, "uimessage_crc", false)) {
    if (*v == "detect")
      bus.uimessage_crc = UiMessageCrc::kDetect;
    else if (*v == "start_to_aux" || *v == "13")
      bus.uimessage_crc = UiMessageCrc::kStartToAux;
    else if (*v == "id_to_aux" || *v == "12")
      bus.uimessage_crc = UiMessageCrc::kIdToAux;
    else
      r.error(node["uimessage_crc"], path + ".uimessage_crc",
              "expected detect (follow the gateway's replies), start_to_aux or 13 (CRC over the 13 bytes SM..d8, "
              "the manual) or id_to_aux or 12 (over the 12 bytes ID..d8, UIROBOT's gateway software), got '" +
                  *v + "'");
    only_here("uimessage_crc");
  }
  if (auto v = r.get<bool>(node, path, "uimessage_crc_strict", false)) {
    bus.uimessage_crc_strict = *v;
    only_here("uimessage_crc_strict");
    if (*v && bus.uimessage_crc == UiMessageCrc::kDetect) {
      r.error(node["uimessage_crc_strict"], path + ".uimessage_crc_strict",
              "needs a configured uimessage_crc (start_to_aux/13 or id_to_aux/12): detection takes either coverage");
    }
  }
}

}  // namespace

void read_bus(Reader& r, const YAML::Node& node, const std::string& path, Bus& bus) {
  if (!r.check_map(node, path,
                   {"name", "transport", "bitrate", "bus_timing", "baud", "parity", "stop_bits", "uimessage_crc",
                    "uimessage_crc_strict", "request_timeout_ms", "retries", "poll_hz", "realtime_priority",
                    "sched_slice_us", "timer_spin_us", "cpu_latency_us", "egress_latency_us", "kernel_sync"}))
    return;
  bus.where = r.locations(node);
  if (auto v = r.get<std::string>(node, path, "name", true)) bus.name = *v;
  if (auto v = r.get<std::string>(node, path, "transport", true)) {
    bus.transport = *v;
    const auto colon = v->find(':');
    const std::string scheme = v->substr(0, colon);
    bus.target = colon == std::string::npos ? "" : v->substr(colon + 1);
    if (scheme == "simcan")
      bus.kind = TransportKind::kSimCan;
    else if (scheme == "socketcan")
      bus.kind = TransportKind::kSocketCan;
    else if (scheme == "serial")
      bus.kind = TransportKind::kSerial;
    else if (scheme == "simserial")
      bus.kind = TransportKind::kSimSerial;
    else if (scheme == "uimessage")
      bus.kind = TransportKind::kUiMessage;
    else
      r.error(node["transport"], path + ".transport",
              "unknown transport '" + *v +
                  "' (use simcan:NAME, socketcan:IFACE, serial:DEVICE, simserial:NAME or uimessage:DEVICE)");
    if (colon != std::string::npos && bus.target.empty())
      r.error(node["transport"], path + ".transport", "missing name after '" + scheme + ":'");
    if (colon == std::string::npos)
      r.error(node["transport"], path + ".transport", "expected SCHEME:NAME, got '" + *v + "'");
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
    if (*v == "none")
      bus.parity = 'N';
    else if (*v == "even")
      bus.parity = 'E';
    else if (*v == "odd")
      bus.parity = 'O';
    else
      r.error(node["parity"], path + ".parity", "expected none, even or odd, got '" + *v + "'");
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
  bounded_int(r, node, path, "realtime_priority", 0, 99, "0 (normal scheduling) or a SCHED_FIFO priority 1..99",
              bus.realtime_priority);
  bounded_int(r, node, path, "timer_spin_us", 0, 500,
              "0 (sleep to each deadline) .. 500 (wake 500 us early and wait the rest busy)", bus.timer_spin_us);
  const std::string slices = "0 (the kernel's default slice) or " + std::to_string(kMinSchedSliceUs) + ".." +
                             std::to_string(kMaxSchedSliceUs) + " us";
  bounded_int(r, node, path, "sched_slice_us", 0, kMaxSchedSliceUs, slices, bus.sched_slice_us);
  if (bus.sched_slice_us > 0 && bus.sched_slice_us < kMinSchedSliceUs)
    r.error(node["sched_slice_us"], path + ".sched_slice_us",
            "expected " + slices + ", got " + std::to_string(bus.sched_slice_us));
  bounded_int(r, node, path, "cpu_latency_us", 0, kMaxCpuLatencyUs,
              "0 (idle CPUs poll) .. " + std::to_string(kMaxCpuLatencyUs) +
                  " us (the longest wake-up from idle the gateway accepts)",
              bus.cpu_latency_us);
  bounded_int(r, node, path, "egress_latency_us", 0, kMaxEgressLatencyUs,
              "0 (frames reach the wire when handed over) .. " + std::to_string(kMaxEgressLatencyUs) + " us",
              bus.egress_latency_us);
  if (auto v = r.get<bool>(node, path, "kernel_sync", false)) {
    bus.kernel_sync = *v;
    if (bus.kind != TransportKind::kSocketCan && !bus.transport.empty()) {
      r.error(
          node["kernel_sync"], path + ".kernel_sync",
          "only for socketcan: buses (the kernel's CAN_BCM sends the periodic SYNC), but this bus is " + bus.transport);
    }
  }
}

namespace {

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
      r.error(kv.first, key_path,
              "unknown set-up key for " + std::string(to_string(family)) + " (allowed: " + list + ")");
      continue;
    }
    switch (schema->type) {
      case SetupType::kBool:
        if (auto v = r.convert<bool>(kv.second, key_path)) drive.setup[key] = *v;
        break;
      case SetupType::kInt:
        if (auto v = r.convert<int>(kv.second, key_path)) {
          const bool listed =
              schema->allowed_ints.empty() ||
              std::find(schema->allowed_ints.begin(), schema->allowed_ints.end(), *v) != schema->allowed_ints.end();
          if (*v < schema->min || *v > schema->max || !listed) {
            std::string allowed;
            if (!schema->allowed_ints.empty()) {
              for (auto a : schema->allowed_ints) allowed += (allowed.empty() ? "" : ", ") + std::to_string(a);
            } else {
              allowed = std::to_string(static_cast<long long>(schema->min)) + ".." +
                        std::to_string(static_cast<long long>(schema->max));
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

}  // namespace

void read_drive(Reader& r, const YAML::Node& node, const std::string& path, Drive& drive) {
  if (!r.check_map(node, path,
                   {"name", "family", "bus", "node_id", "group_id", "request_timeout_ms", "retries", "setup"}))
    return;
  drive.where = r.locations(node);
  if (auto v = r.get<std::string>(node, path, "name", true)) drive.name = *v;
  std::optional<Family> family;
  if (auto v = r.get<std::string>(node, path, "family", true)) {
    family = parse_family(*v);
    if (!family)
      r.error(node["family"], path + ".family", "unknown family '" + *v + "' (uim342, uim242, uc57, adam-modbus)");
    else
      drive.family = *family;
  }
  if (auto v = r.get<std::string>(node, path, "bus", true)) drive.bus = *v;
  if (auto v = r.get<int>(node, path, "node_id", true)) {
    drive.node_id = *v;
    if (family) {
      const auto range = node_id_range(*family);
      if (*v < range.min || *v > range.max) {
        r.error(node["node_id"], path + ".node_id",
                "node id " + std::to_string(*v) + " is outside " + std::string(to_string(*family)) + "'s range " +
                    std::to_string(range.min) + ".." + std::to_string(range.max));
      }
    }
  }
  if (auto v = r.get<int>(node, path, "group_id", false)) {
    drive.group_id = *v;
    if (family && *family != Family::kUim342) {
      r.error(node["group_id"], path + ".group_id", "group ids exist only for uim342 drives");
    } else if (*v < 5 || *v > 126) {
      r.error(node["group_id"], path + ".group_id",
              "group id " + std::to_string(*v) + " is outside 5..126 (SimpleCAN §5.1)");
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
      if (*v == "switch")
        axis.homing.method = HomingMethod::kSwitch;
      else if (*v == "current-position")
        axis.homing.method = HomingMethod::kCurrentPosition;
      else
        axis.homing.method = HomingMethod::kNone;
    }
    if (auto v = r.get<int>(homing, hpath, "input", false)) axis.homing.input = *v;
    if (auto v = r.get<std::string>(homing, hpath, "edge", false)) {
      if (*v == "falling")
        axis.homing.edge = HomingEdge::kFalling;
      else if (*v == "rising")
        axis.homing.edge = HomingEdge::kRising;
      else
        r.error(homing["edge"], hpath + ".edge", "expected falling or rising, got '" + *v + "'");
    }
    if (auto v = r.get<double>(homing, hpath, "velocity", false)) axis.homing.velocity = *v;
    if (auto v = r.get<double>(homing, hpath, "offset", false)) axis.homing.offset = *v;
  }
}

void read_coordinator(Reader& r, const YAML::Node& node, CoordinatorSettings& out) {
  const std::string path = "coordinator";
  if (!r.check_map(
          node, path,
          {"default_timeout_ms", "progress_period_ms", "trigger_lead_ms", "trigger_lead_min_ms", "gateway_timeout_ms",
           "arm_timeout_ms", "arm_expiry_ms", "max_active_requests", "position_tolerance"}))
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
  positive_int("trigger_lead_min_ms", out.trigger_lead_min_ms);
  if (node["trigger_lead_min_ms"] && out.trigger_lead_min_ms > out.trigger_lead_ms) {
    r.error(node["trigger_lead_min_ms"], path + ".trigger_lead_min_ms",
            "must not exceed trigger_lead_ms (" + std::to_string(out.trigger_lead_ms) +
                " ms): it is the lower bound of the adaptive trigger lead, trigger_lead_ms the upper");
  }
  positive_int("gateway_timeout_ms", out.gateway_timeout_ms);
  positive_int("arm_timeout_ms", out.arm_timeout_ms);
  positive_int("arm_expiry_ms", out.arm_expiry_ms);
  if (out.arm_expiry_ms > 0 && out.arm_expiry_ms <= out.arm_timeout_ms + out.trigger_lead_ms) {
    r.error(node["arm_expiry_ms"], path + ".arm_expiry_ms",
            "must exceed arm_timeout_ms + trigger_lead_ms (" + std::to_string(out.arm_timeout_ms) + " + " +
                std::to_string(out.trigger_lead_ms) +
                " ms): a gateway would release moves the coordinator is still about to trigger");
  }
  positive_int("max_active_requests", out.max_active_requests);
  if (auto v = r.get<double>(node, path, "position_tolerance", false)) {
    out.position_tolerance = *v;
    if (*v < 0) r.error(node["position_tolerance"], path + ".position_tolerance", "must not be negative");
  }
}

namespace {

// A path as given when absolute, else from the folder of the configuration file `file`.
std::string relative_to(const std::string& file, const std::string& path) {
  if (path.empty() || path.front() == '/') return path;
  const auto slash = file.rfind('/');
  return slash == std::string::npos ? path : file.substr(0, slash + 1) + path;
}

}  // namespace

void read_security(Reader& r, const YAML::Node& node, const std::string& file, SecuritySettings& out) {
  const std::string path = "security";
  if (!r.check_map(node, path,
                   {"mode", "authorized_keys", "key", "coordinator_public_key", "gateway_key", "gateway_public_keys",
                    "window_ms"}))
    return;
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
  if (auto v = r.get<std::string>(node, path, "coordinator_public_key", false))
    out.coordinator_public_key = relative_to(file, *v);
  if (auto v = r.get<std::string>(node, path, "gateway_key", false)) out.gateway_key = relative_to(file, *v);
  if (auto v = r.get<std::string>(node, path, "gateway_public_keys", false))
    out.gateway_public_keys = relative_to(file, *v);
  if (auto v = r.get<int>(node, path, "window_ms", false)) {
    out.window_ms = *v;
    if (*v < 100 || *v > 600000)
      r.error(node["window_ms"], path + ".window_ms", std::to_string(*v) + " is outside 100..600000 ms");
  }
  if (out.mode == SecuritySettings::Mode::kEnforce) {
    if (out.authorized_keys.empty())
      r.error(node, path + ".authorized_keys", "required when security.mode is enforce (who may send what)");
    if (out.key.empty())
      r.error(node, path + ".key",
              "required when security.mode is enforce (the coordinator signs its gateway commands)");
    if (out.coordinator_public_key.empty()) {
      r.error(node, path + ".coordinator_public_key",
              "required when security.mode is enforce (gateways verify the coordinator's commands)");
    }
    if (out.gateway_key.empty()) {
      r.error(node, path + ".gateway_key",
              "required when security.mode is enforce (gateways sign their axis states and replies; its public "
              "half goes in authorized_keys with role gateway)");
    }
  }
}

void read_simulation(Reader& r, const YAML::Node& node, SimulationSettings& out) {
  if (!r.check_map(node, "simulation",
                   {"runtime_dir", "group", "reply_latency_us", "serial_link", "home_switches", "variants"}))
    return;
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
        } catch (const YAML::Exception&) { r.error(entry.second, path, "expected a position in counts or none"); }
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
  if (auto v = r.get<std::string>(node, "simulation", "serial_link", false)) {
    if (*v == "pty") {
      out.serial_link = SimulationSettings::SerialLink::kPty;
    } else if (*v == "socket") {
      out.serial_link = SimulationSettings::SerialLink::kSocket;
    } else {
      r.error(node["serial_link"], "simulation.serial_link", "expected pty or socket, got '" + *v + "'");
    }
  }
  if (auto v = r.get<int>(node, "simulation", "reply_latency_us", false)) {
    out.reply_latency_us = *v;
    if (*v < 0) r.error(node["reply_latency_us"], "simulation.reply_latency_us", "must not be negative");
  }
}

}  // namespace motion::config::detail
