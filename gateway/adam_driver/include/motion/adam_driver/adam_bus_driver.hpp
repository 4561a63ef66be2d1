// AdamBusDriver: the gateway's BusDriver for an RS485 line of ADAM Modbus RTU steppers: AdamStack
// (adam_stack.hpp, which holds every protocol decision) in the serial poll-loop shell
// gateway::SerialBusDriver (port opening and reopening, fd watch, one timer at the core's next
// deadline: timeouts, t3.5 silence, polls).
//
// Construction from the configuration (what gateway/app/bus_assembly.cpp does for a serial bus
// whose drives are adam-modbus):
//   AdamBusDriver::create(loop, config, bus, out)
//
// Thread contract: the loop's thread only.
#pragma once

#include <memory>
#include <string>

#include "motion/adam_driver/adam_stack.hpp"
#include "motion/gateway/serial_bus_driver.hpp"

namespace motion::adam_driver {

class AdamBusDriver final : public gateway::SerialBusDriver {
 public:
  AdamBusDriver(EventLoop& loop, MasterSettings settings, std::string device_path, serial::SerialSettings line,
                gateway::GatewayOutput& out);
  static std::unique_ptr<AdamBusDriver> create(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                               gateway::GatewayOutput& out);
};

}  // namespace motion::adam_driver
