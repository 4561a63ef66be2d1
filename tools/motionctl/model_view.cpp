// `motionctl status --model`: each axis's drive model as its gateway published it.
#include "model_view.hpp"

#include <algorithm>
#include <cstdio>
#include <vector>

namespace motion::ctl {
namespace {

const char* resolution_source(std::int8_t source) {
  switch (source) {
    case motionlcm::drive_model_t::RESOLUTION_CONFIGURED: return "configured";
    case motionlcm::drive_model_t::RESOLUTION_READ_BACK: return "read back";
    default: return "unknown";
  }
}

std::string start_name(std::int8_t kind) {
  using M = motionlcm::drive_model_t;
  switch (kind) {
    case M::START_SINGLE: return "single";
    case M::START_UIM342_GROUP_BG: return "group BG";
    case M::START_CANOPEN_SYNC: return "SYNC";
    case M::START_ADAM_BROADCAST: return "broadcast";
    case M::START_UIM242_GLOBAL: return "global";
    case M::START_UIM242_CRAWL: return "crawl (before its start)";
    default: return "kind " + std::to_string(kind);
  }
}

// One bus's arming on the line, from the ARM_TIMING of its axes, summed as the coordinator sums it
// for its arming deadline (Coordinator::arming_line_time): the armed axes' arm_line_us, plus for
// each other drive of the bus the largest arm_bystander_us of the armed axes.
struct BusArming {
  // The bus's axes with their ARM_TIMING (null: none heard).
  std::vector<std::pair<std::string, const motionlcm::arm_timing_t*>> axes;
  double all_armed_us = 0;      // every axis of the bus armed together
  double one_armed_max_us = 0;  // the slowest axis armed alone
  long drives = 0;              // drives of the bus in the configuration
  [[nodiscard]] bool heard() const {
    return std::any_of(axes.begin(), axes.end(), [](const auto& a) { return a.second != nullptr; });
  }
};

std::map<std::string, BusArming> bus_arming(const config::Config& c, const HeardModels& heard) {
  std::map<std::string, BusArming> out;
  for (const auto& bus : c.buses) {
    BusArming& b = out[bus.name];
    b.drives =
        std::count_if(c.drives.begin(), c.drives.end(), [&](const config::Drive& d) { return d.bus == bus.name; });
    double line_us = 0;
    double bystander_us = 0;
    long armed = 0;
    for (const auto& a : c.axes) {
      if (c.drive_of(a)->bus != bus.name) continue;
      const auto it = heard.arming.find(a.name);
      const motionlcm::arm_timing_t* t = it == heard.arming.end() ? nullptr : &it->second;
      b.axes.emplace_back(a.name, t);
      if (t == nullptr) continue;
      ++armed;
      line_us += t->arm_line_us;
      bystander_us = std::max(bystander_us, t->arm_bystander_us);
      b.one_armed_max_us = std::max(
          b.one_armed_max_us, t->arm_line_us + static_cast<double>(std::max(0L, b.drives - 1)) * t->arm_bystander_us);
    }
    b.all_armed_us = line_us + static_cast<double>(std::max(0L, b.drives - armed)) * bystander_us;
  }
  return out;
}

void print_arming(const config::Config& c, const HeardModels& heard) {
  for (const auto& [bus, b] : bus_arming(c, heard)) {
    std::printf("arming on %s (ARM_TIMING: line time of the frames arming sends; %ld drive%s on the bus)\n",
                bus.c_str(), b.drives, b.drives == 1 ? "" : "s");
    for (const auto& [axis, t] : b.axes) {
      if (t == nullptr) {
        std::printf("  %-11s no ARM_TIMING heard\n", axis.c_str());
      } else {
        std::printf("  %-11s %.1f us loading its move, %.1f us readying each other drive\n", axis.c_str(),
                    t->arm_line_us, t->arm_bystander_us);
      }
    }
    if (b.heard()) {
      std::printf("  bus         %.1f us every axis armed together, at most %.1f us one axis armed alone\n",
                  b.all_armed_us, b.one_armed_max_us);
    }
    const auto line = heard.lines.find(bus);
    if (line == heard.lines.end()) {
      std::printf("  start wait  no LINE_TIMING heard\n");
    } else {
      std::printf("  start wait  %.1f us (LINE_TIMING: the longest exchange a start frame may find under way)\n",
                  line->second.start_wait_us);
    }
  }
}

}  // namespace

void print_models(const config::Config& c, const HeardModels& heard) {
  const auto& models = heard.models;
  for (const auto& a : c.axes) {
    const auto it = models.find(a.name);
    if (it == models.end()) {
      std::printf("%s: no drive model heard (gateway of bus %s not running, or the drive not set up)\n", a.name.c_str(),
                  c.drive_of(a)->bus.c_str());
      continue;
    }
    const auto& m = it->second;
    std::printf("%s: %s %s on %s node %d%s\n", a.name.c_str(), m.family.c_str(), m.drive.c_str(), m.bus.c_str(),
                m.node_id, m.group_id != 0 ? (" group " + std::to_string(m.group_id)).c_str() : "");
    std::string resolution =
        m.counts_per_revolution > 0 ? std::to_string(m.counts_per_revolution) + " counts/rev" : std::string("-");
    if (m.assumed_counts_per_revolution > 0 && m.assumed_counts_per_revolution != m.counts_per_revolution) {
      resolution += " (configuration implies " + std::to_string(m.assumed_counts_per_revolution) + ")";
    }
    std::printf("  resolution  %s, %s; %.9g counts/%s%s%s\n", resolution.c_str(),
                resolution_source(m.resolution_source), m.counts_per_unit, a.unit.c_str(),
                m.firmware.empty() ? "" : "; firmware ", m.firmware.c_str());
    std::printf("  grid        %s\n", m.grid.c_str());
    std::printf("  velocity    n x %.9g counts/s, n %lld..%lld\n", m.velocity_step,
                static_cast<long long>(m.velocity_min), static_cast<long long>(m.velocity_max));
    if (m.acceleration_kind == motionlcm::drive_model_t::ACCEL_RAMP_TIME) {
      std::printf("  ramps       n x %.9g s from %.9g counts/s, n %lld..%lld\n", m.acceleration_step, m.ramp_from,
                  static_cast<long long>(m.acceleration_min), static_cast<long long>(m.acceleration_max));
    } else {
      std::printf("  accel       n x %.9g counts/s^2, n %lld..%lld\n", m.acceleration_step,
                  static_cast<long long>(m.acceleration_min), static_cast<long long>(m.acceleration_max));
    }
    std::printf("  position    %lld..%lld counts\n", static_cast<long long>(m.position_min),
                static_cast<long long>(m.position_max));
    for (std::size_t i = 0; i < m.start_kinds.size(); ++i) {
      std::printf("  start       %s (address %d), %.1f us on the wire\n", start_name(m.start_kinds[i]).c_str(),
                  m.start_addresses[i], m.start_wire_us[i]);
    }
  }
  print_arming(c, heard);
}

nlohmann::json models_json(const config::Config& c, const HeardModels& heard) {
  const auto buses = bus_arming(c, heard);
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [axis, m] : heard.models) {
    nlohmann::json starts = nlohmann::json::array();
    for (std::size_t i = 0; i < m.start_kinds.size(); ++i) {
      starts.push_back(
          {{"kind", start_name(m.start_kinds[i])}, {"address", m.start_addresses[i]}, {"wire_us", m.start_wire_us[i]}});
    }
    out[axis] = {
        {"family", m.family},
        {"bus", m.bus},
        {"drive", m.drive},
        {"node", m.node_id},
        {"group", m.group_id},
        {"counts_per_revolution", m.counts_per_revolution},
        {"assumed_counts_per_revolution", m.assumed_counts_per_revolution},
        {"resolution_source", resolution_source(m.resolution_source)},
        {"counts_per_unit", m.counts_per_unit},
        {"firmware", m.firmware},
        {"grid", m.grid},
        {"velocity_step", m.velocity_step},
        {"velocity_min", m.velocity_min},
        {"velocity_max", m.velocity_max},
        {"acceleration_kind", m.acceleration_kind == motionlcm::drive_model_t::ACCEL_RAMP_TIME ? "ramp_time" : "rate"},
        {"acceleration_step", m.acceleration_step},
        {"acceleration_min", m.acceleration_min},
        {"acceleration_max", m.acceleration_max},
        {"ramp_from", m.ramp_from},
        {"position_min", m.position_min},
        {"position_max", m.position_max},
        {"starts", starts},
        {"arm_timing", nullptr},
        {"start_wait_us", nullptr}};
    if (const auto line = heard.lines.find(m.bus); line != heard.lines.end())
      out[axis]["start_wait_us"] = line->second.start_wait_us;
    const auto t = heard.arming.find(axis);
    const auto b = buses.find(m.bus);
    if (t != heard.arming.end() && b != buses.end()) {
      out[axis]["arm_timing"] = {{"arm_line_us", t->second.arm_line_us},
                                 {"arm_bystander_us", t->second.arm_bystander_us},
                                 {"bus_all_armed_us", b->second.all_armed_us},
                                 {"bus_one_armed_max_us", b->second.one_armed_max_us}};
    }
  }
  return out;
}

}  // namespace motion::ctl
