// A configured serial bus (serial:, simserial:, uimessage:) in motion::serial's plain values, for
// the gateway's serial bus drivers and the uimessage: CAN transport:
//   serial_line_settings  baud, 'N'/'E'/'O' parity and stop bits of the bus; 8 data bits
//   serial_device_path    the path a gateway opens: the device of serial: and uimessage:, the link
//                         motion-sim publishes for simserial: (<sim_runtime_dir>/<bus>.tty,
//                         serial::simserial_link_path); empty for simcan: and socketcan:
//
// Pure: values only.
#pragma once

#include <string>

#include "motion/config/config.hpp"
#include "motion/serial/serial_port.hpp"

namespace motion::gateway {

[[nodiscard]] serial::SerialSettings serial_line_settings(const config::Bus& bus);
[[nodiscard]] std::string serial_device_path(const config::Config& config, const config::Bus& bus);

}  // namespace motion::gateway
