#include "motion/gateway/can_transport_factory.hpp"

#include "motion/can/socketcan.hpp"
#include "motion/gateway/serial_line.hpp"
#include "motion/simbus/address.hpp"
#include "motion/simbus/endpoint.hpp"
#include "motion/uimessage/uimessage_transport.hpp"

namespace motion::gateway {
namespace {

class Category final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "motion.can_transport"; }
  [[nodiscard]] std::string message(int value) const override {
    switch (static_cast<TransportError>(value)) {
      case TransportError::kNotCanBus:
        return "not a CAN bus (CAN transports: simcan:NAME, socketcan:IFACE, uimessage:DEVICE)";
    }
    return "unknown transport error " + std::to_string(value);
  }
};

std::unique_ptr<can::Transport> open_simcan(const config::Config& config, const config::Bus& bus, std::string label,
                                            std::error_code& error) {
  simbus::EndpointOptions options;
  options.socket_dir = config::sim_runtime_dir(config);
  options.label = std::move(label);
  return simbus::SocketEndpoint::connect(bus.target, std::move(options), error);
}

// SocketCAN (motion/can/socketcan.hpp). The interface's bit rate is the kernel's (`ip link set
// IFACE type can bitrate N`); the configured one only feeds the bus-load statistic. A down
// interface opens in kDisconnected and recovers by itself; a missing one, or a kernel without
// AF_CAN, is an error whose message names the interface.
std::unique_ptr<can::Transport> open_socketcan(const config::Bus& bus, std::error_code& error) {
  auto transport = std::make_unique<can::SocketCanTransport>();
  can::SocketCanOptions options;
  options.bitrate = static_cast<std::uint32_t>(bus.bitrate);
  error = transport->open(bus.target, options);
  if (error) return nullptr;
  return transport;
}

// A UIROBOT serial gateway (motion/uimessage/uimessage_transport.hpp): the port at the bus's
// baud/parity/stop bits, the CRC coverage of uimessage_crc / uimessage_crc_strict. The CAN bit
// rate is the gateway's own setting; the configured one is not sent anywhere.
std::unique_ptr<can::Transport> open_uimessage(const config::Bus& bus, std::error_code& error) {
  return uimessage::UiMessageTransport::open(bus.target, serial_line_settings(bus), uimessage::options_from(bus),
                                             error);
}

}  // namespace

const std::error_category& transport_error_category() {
  static const Category category;
  return category;
}

std::error_code make_error_code(TransportError error) { return {static_cast<int>(error), transport_error_category()}; }

std::unique_ptr<can::Transport> open_can_transport(const config::Config& config, const config::Bus& bus,
                                                   std::string label, std::error_code& error) {
  error.clear();
  switch (bus.kind) {
    case config::TransportKind::kSimCan: return open_simcan(config, bus, std::move(label), error);
    case config::TransportKind::kSocketCan: return open_socketcan(bus, error);  // label: not listed anywhere
    case config::TransportKind::kUiMessage: return open_uimessage(bus, error);
    case config::TransportKind::kSerial:
    case config::TransportKind::kSimSerial: break;
  }
  error = make_error_code(TransportError::kNotCanBus);
  return nullptr;
}

std::unique_ptr<can::SocketCanCyclic> open_cyclic_sender(const config::Bus& bus, std::error_code& error) {
  error.clear();
  if (bus.kind != config::TransportKind::kSocketCan || !bus.kernel_sync) return nullptr;
  auto cyclic = std::make_unique<can::SocketCanCyclic>();
  error = cyclic->open(bus.target);
  if (error) return nullptr;
  return cyclic;
}

std::string open_error_message(const config::Config& config, const config::Bus& bus, std::error_code error) {
  std::string out = "bus " + bus.name + " (" + bus.transport + "): ";
  if (bus.kind == config::TransportKind::kSimCan) {
    const auto path = simbus::socket_path(bus.target, config::sim_runtime_dir(config)).string();
    if (error == std::errc::no_such_file_or_directory || error == std::errc::connection_refused) {
      return out + "no simulated bus '" + bus.target + "' at " + path + ": " + error.message() +
             " (is motion-sim running with this configuration and the same MOTION_SIM_DIR?)";
    }
    if (error == std::errc::invalid_argument) return out + "'" + bus.target + "' is not a valid simulated bus name";
    return out + "cannot connect to " + path + ": " + error.message();
  }
  if (bus.kind == config::TransportKind::kSocketCan) {
    // SocketCAN's errors already name the interface and the remedy (socketcan_error.hpp).
    return out + error.message();
  }
  if (bus.kind == config::TransportKind::kUiMessage) {
    out += "cannot open serial port " + bus.target + " at " + std::to_string(bus.baud) + " baud: " + error.message();
    if (error == std::errc::no_such_file_or_directory)
      return out + " (is the UIROBOT gateway plugged in? see ls /dev/serial/by-id)";
    if (error == std::errc::permission_denied) return out + " (add the user to the dialout group)";
    if (error == std::errc::inappropriate_io_control_operation) return out + " (not a serial port)";
    return out;
  }
  return out + error.message();
}

}  // namespace motion::gateway
