// Errors of the SocketCAN classes (SocketCanTransport, SocketCanCyclic).
//
// They are plain errno values, so `ec == std::errc::no_such_device` works as usual, but their
// category knows the interface, so `ec.message()` names it:
//   "SocketCAN interface 'can7' does not exist or is not a CAN interface (ip -details link show can7)"
// Categories are interned per interface name and never destroyed, so an error_code stays valid
// after the transport that produced it is gone. Thread-safe.
#pragma once

#include <string_view>
#include <system_error>

namespace motion::can {

[[nodiscard]] std::error_code socketcan_error(std::string_view interface, int errno_value);

}  // namespace motion::can
