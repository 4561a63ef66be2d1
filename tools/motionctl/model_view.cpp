// `motionctl status --model`: each axis's drive model as its gateway published it.
#include "model_view.hpp"

#include <cstdio>

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
    default: return "kind " + std::to_string(kind);
  }
}

}  // namespace

void print_models(const config::Config& c, const std::map<std::string, motionlcm::drive_model_t>& models) {
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
}

nlohmann::json models_json(const std::map<std::string, motionlcm::drive_model_t>& models) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [axis, m] : models) {
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
        {"starts", starts}};
  }
  return out;
}
}  // namespace motion::ctl
