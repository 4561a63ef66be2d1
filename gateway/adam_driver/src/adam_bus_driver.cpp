#include "motion/adam_driver/adam_bus_driver.hpp"

#include <utility>

#include "motion/gateway/serial_line.hpp"

namespace motion::adam_driver {

AdamBusDriver::AdamBusDriver(EventLoop& loop, MasterSettings settings, std::string device_path,
                             serial::SerialSettings line, gateway::GatewayOutput& out)
    : SerialBusDriver(loop, settings.bus, std::move(device_path), line, out, [&settings, &out](Write write) {
        return std::make_unique<AdamStack>(std::move(settings), std::move(write), out);
      }) {}

std::unique_ptr<AdamBusDriver> AdamBusDriver::create(EventLoop& loop, const config::Config& config,
                                                     const config::Bus& bus, gateway::GatewayOutput& out) {
  return std::make_unique<AdamBusDriver>(loop, settings_from_config(config, bus),
                                         gateway::serial_device_path(config, bus), gateway::serial_line_settings(bus),
                                         out);
}

}  // namespace motion::adam_driver
