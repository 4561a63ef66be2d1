#include "motion/uc57_driver/node_settings.hpp"

#include <algorithm>
#include <cmath>
#include <variant>

#include "motion/cia402/uc57_od.hpp"
#include "motion/cia402/uc57_units.hpp"

namespace motion::uc57_driver {
namespace {

void apply_resolution(const config::Drive& drive, NodeSettings& out) {
  using Status = cia402::uc57::SetupSubdivision::Status;
  const auto setup =
      cia402::uc57::setup_subdivision(drive.setup_integer("pulses_per_revolution"), drive.setup_integer("micro_steps"));
  const std::string source = setup.from_micro_steps ? "micro_steps" : "pulses_per_revolution";
  switch (setup.status) {
    case Status::kNotSet: return;  // leave 2006h as stored in the drive; it is read back at start-up
    case Status::kCode: out.subdivision_code = setup.code; return;
    case Status::kOutOfRange:
      out.errors.push_back(source + ": " + std::to_string(setup.pulses) + " pulses/rev is out of range");
      return;
    case Status::kNotInTable:
      // The 2006h table has 16 fixed resolutions (manual §5.1); "1-256 subdivisions" of §1.1 is not
      // what the object accepts (conflict C-14).
      out.errors.push_back(
          source + ": " + std::to_string(setup.pulses) +
          " pulses/rev is not one of the UC57's 2006h resolutions (200, 400, 800, 1600, 3200, 6400, 12800, "
          "25600, 1000, 2000, 4000, 5000, 8000, 10000, 20000, 40000)");
      return;
  }
}

void apply_current(const config::Drive& drive, NodeSettings& out) {
  const auto amperes = drive.setup_number("current_a");
  if (!amperes) return;
  const auto* entry = cia402::uc57::find_entry(cia402::uc57::index::kRunCurrent, 0);
  const auto tenths = std::llround(*amperes * 10.0);
  if (entry != nullptr && (tenths < entry->min || tenths > entry->max)) {
    out.errors.push_back("current_a: " + std::to_string(*amperes) +
                         " A is outside the UC57's 2005h range 0.1..2.5 A RMS");
    return;
  }
  out.run_current = static_cast<std::uint16_t>(tenths);
}

}  // namespace

std::string NodeSettings::label() const { return drive + " (node " + std::to_string(node) + ")"; }

NodeSettings make_node_settings(const config::Config& config, const config::Bus& bus, const config::Drive& drive,
                                std::uint16_t default_heartbeat_ms) {
  NodeSettings out;
  out.drive = drive.name;
  out.node = static_cast<canopen::NodeId>(drive.node_id);
  for (const auto& axis : config.axes) {
    if (axis.drive == drive.name) {
      out.axis = axis.name;
      out.homing = axis.homing;
      break;
    }
  }
  out.sdo_timeout = std::chrono::milliseconds(drive.request_timeout_ms.value_or(bus.request_timeout_ms));
  out.sdo_retries = static_cast<unsigned>(std::max(0, drive.retries.value_or(bus.retries)));

  apply_resolution(drive, out);
  apply_current(drive, out);
  if (const auto mode = drive.setup_text("tpdo_mode")) {
    out.tpdo_mode = *mode == "event" ? TpdoMode::kEvent : *mode == "staggered" ? TpdoMode::kStaggered : TpdoMode::kSync;
  }
  if (const auto answer = drive.setup_text("rpdo_sync")) {
    out.rpdo_sync = *answer == "honoured"       ? RpdoSyncAnswer::kHonoured
                    : *answer == "on_reception" ? RpdoSyncAnswer::kOnReception
                                                : RpdoSyncAnswer::kDetect;
  }
  const auto heartbeat = drive.setup_integer("heartbeat_ms");
  out.heartbeat_ms =
      heartbeat ? static_cast<std::uint16_t>(std::clamp<long long>(*heartbeat, 0, 0xFFFF)) : default_heartbeat_ms;
  if (out.heartbeat_ms == 0) {
    out.warnings.push_back("heartbeat_ms: 0 disables the heartbeat; a lost node is only noticed by SDO timeouts");
  }
  if (drive.setup_flag("closed_loop").value_or(false)) {
    out.warnings.push_back("closed_loop: the UC57 manual documents no closed-loop object; ignored");
  }
  if (!canopen::is_valid_node_id(out.node))
    out.errors.push_back("node_id " + std::to_string(drive.node_id) + " is outside 1..127");
  return out;
}

}  // namespace motion::uc57_driver
