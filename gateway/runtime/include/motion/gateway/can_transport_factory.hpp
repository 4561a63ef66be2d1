// Opens the can::Transport of a configured CAN bus: the one place that maps a bus's `transport:`
// (simcan:NAME, socketcan:IFACE, uimessage:DEVICE) to a transport object. Gateways and motionctl
// (dump, send) use it, so both reach a bus exactly the same way.
//
//   simcan:NAME     simbus::SocketEndpoint to motion-sim's hub NAME, in config::sim_runtime_dir()
//   socketcan:IFACE can::SocketCanTransport on IFACE (bit rate set by `ip link`; the configured
//                   one feeds the bus-load statistic only)
//   uimessage:DEV   uimessage::UiMessageTransport on the serial port DEV (a UIROBOT UIM2513/UIM2533
//                   gateway; baud, parity, stop bits, uimessage_crc[_strict] from the bus)
//   anything else   error kNotCanBus (serial buses are not CAN)
//
// Thread contract: reentrant; the returned transport follows can::Transport's (one thread).
// Nothing blocks: connecting to a simulated hub is a local Unix-socket connect, opening a serial
// port is non-blocking.
#pragma once

#include <memory>
#include <string>
#include <system_error>

#include "motion/can/socketcan_cyclic.hpp"
#include "motion/can/transport.hpp"
#include "motion/config/config.hpp"

namespace motion::gateway {

// Errors of the factory itself; the transports' own failures come as errno-style codes
// (ENOENT / ECONNREFUSED: no hub for a simulated bus; ENODEV: no such interface,
// EAFNOSUPPORT: a kernel without AF_CAN, in SocketCAN's category that names the interface;
// ENOENT / EACCES / ENOTTY: the serial port of a uimessage: bus).
enum class TransportError {
  kNotCanBus = 1,  // the bus's transport is not a CAN transport (serial:, simserial:)
};
[[nodiscard]] const std::error_category& transport_error_category();
[[nodiscard]] std::error_code make_error_code(TransportError error);

// Opens `bus` of `config`. `label` names this endpoint on a simulated bus (the hub lists it, e.g.
// "gateway:can0", "motionctl dump"); empty: "pid <pid>". nullptr with `error` set on failure;
// open_error_message() turns that into a line for users.
[[nodiscard]] std::unique_ptr<can::Transport> open_can_transport(const config::Config& config, const config::Bus& bus,
                                                                 std::string label, std::error_code& error);

// The kernel's cyclic sender (CAN_BCM) for a socketcan: bus with kernel_sync on (the default);
// nullptr for other buses, with kernel_sync off, or when the BCM socket cannot be opened
// (`error` set: e.g. a kernel without the can-bcm module; the loop then sends the periodic frames).
[[nodiscard]] std::unique_ptr<can::SocketCanCyclic> open_cyclic_sender(const config::Bus& bus, std::error_code& error);

// "bus can0 (simcan:can0): no simulated bus 'can0' at /tmp/x/motion-simbus-can0.sock: No such
// file or directory (is motion-sim running with this configuration?)": the bus, its transport,
// what failed and, when known, what to do.
[[nodiscard]] std::string open_error_message(const config::Config& config, const config::Bus& bus,
                                             std::error_code error);

}  // namespace motion::gateway

template <>
struct std::is_error_code_enum<motion::gateway::TransportError> : std::true_type {};
