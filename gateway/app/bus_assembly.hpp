// Builds the BusDriver of one configured bus: the one place that knows which protocol stack or
// serial driver serves which drive family on which kind of bus.
//
//   CAN bus (simcan:, socketcan:)  CanBusDriver over open_can_transport(), one CanStack per family
//                                  present on the bus (UIM342 on 29-bit ids, CANopen on 11-bit)
//   serial bus (simserial:, serial:) the family's serial bus driver (one family per line):
//                                  ADAM Modbus RTU (AdamBusDriver), UIM242 via a UIM2501/2502
//                                  (Uim242BusDriver)
//
// Families without an implementation yet are listed in `unsupported` (the gateway reports them
// in its health and fails commands for their axes with that reason) instead of stopping the bus.
// Thread contract: the gateway's loop thread.
#pragma once

#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/gateway/bus_driver.hpp"

namespace motion::gateway {

struct BusAssembly {
  std::unique_ptr<BusDriver> driver;              // nullptr: the bus could not be opened (see error)
  std::vector<const config::Drive*> unsupported;  // drives no stack or driver serves yet
  std::error_code error;
  std::string error_text;  // for users: bus, transport, what failed, what to do
};

[[nodiscard]] BusAssembly assemble_bus(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                       GatewayOutput& out);

}  // namespace motion::gateway
