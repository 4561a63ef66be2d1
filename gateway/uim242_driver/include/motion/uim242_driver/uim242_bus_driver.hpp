// Uim242BusDriver: the gateway's BusDriver for an RS232 bus of UIM242 controllers behind a
// UIM2501/2502 RS232-CAN gateway: Uim242Stack (uim242_stack.hpp, which holds every protocol
// decision) in the serial poll-loop shell gateway::SerialBusDriver (port opening and reopening,
// fd watch, one timer at the core's next deadline: reply timeouts, polls, re-identification).
//
// The line settings (baud, parity, stop bits; 8 data bits) come from the bus configuration as for
// every serial bus (gateway/serial_line.hpp); the port is serial:<device> or the simserial link
// motion-sim publishes. Construction from the configuration (gateway/app/bus_assembly.cpp, for a
// serial bus whose drives are uim242):
//   Uim242BusDriver::create(loop, config, bus, out)
// `config` must outlive the driver (the core keeps its drives' and axes' entries).
//
// Thread contract: the loop's thread only.
#pragma once

#include <memory>

#include "motion/config/config.hpp"
#include "motion/gateway/serial_bus_driver.hpp"

namespace motion::uim242_driver {

class Uim242BusDriver final : public gateway::SerialBusDriver {
 public:
  // The bus's port (gateway::serial_device_path) with its line settings.
  Uim242BusDriver(EventLoop& loop, const config::Config& config, const config::Bus& bus, gateway::GatewayOutput& out);
  static std::unique_ptr<Uim242BusDriver> create(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                                 gateway::GatewayOutput& out);
};

}  // namespace motion::uim242_driver
