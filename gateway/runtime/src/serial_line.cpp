#include "motion/gateway/serial_line.hpp"

namespace motion::gateway {

serial::SerialSettings serial_line_settings(const config::Bus& bus) {
  return serial::line_settings(bus.baud, bus.parity, bus.stop_bits);
}

std::string serial_device_path(const config::Config& config, const config::Bus& bus) {
  switch (bus.kind) {
    case config::TransportKind::kSerial:
    case config::TransportKind::kUiMessage: return bus.target;
    case config::TransportKind::kSimSerial:
      return serial::simserial_link_path(config::sim_runtime_dir(config), bus.name);
    case config::TransportKind::kSimCan:
    case config::TransportKind::kSocketCan: return {};
  }
  return {};
}

}  // namespace motion::gateway
