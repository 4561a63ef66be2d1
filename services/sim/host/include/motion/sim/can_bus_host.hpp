// One CAN bus in motion-sim with every simulated drive of the configuration on that bus, each on
// its own endpoint (so a drive sees the other drives' frames but not its own, and arbitration and
// bus load include the drives' replies). Two kinds of bus:
//   open()            simcan:NAME   the simbus Hub (the wire, bit-timed) with a LocalEndpoint per
//                                   drive; gateways attach to the hub's socket.
//   open_socketcan()  socketcan:IF  a real SocketCAN interface (e.g. vcan0 in the test VM): one
//                                   CAN_RAW socket per drive (own echo off), the gateway opens the
//                                   interface as it would with real drives. motion-sim does this
//                                   only when told to (--simulate-socketcan).
//   open_with()       any can::Transport per drive, from a caller's EndpointFactory.
// Thread contract: the loop's thread only.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "motion/can/transport.hpp"
#include "motion/config/config.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/sim/can_drive.hpp"
#include "motion/simbus/hub.hpp"

namespace motion::sim {

class CanBusHost {
 public:
  using Reporter = std::function<void(motionlcm::sim_report_t)>;
  // A new endpoint on the bus for `drive`; nullptr with `error` set when it cannot be opened.
  using EndpointFactory =
      std::function<std::unique_ptr<can::Transport>(const config::Drive& drive, std::error_code& error)>;

  // Opens the hub for the simcan: `bus` (socket in `socket_dir`) and creates the drives with
  // `factories` (by family). Drives of a family without a factory are listed in missing().
  static std::unique_ptr<CanBusHost> open(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                          const std::map<config::Family, CanDriveFactory>& factories, Reporter reporter,
                                          std::error_code& error);
  // The drives of the socketcan: `bus` on its interface, one SocketCanTransport each. Errors as
  // SocketCanTransport::open() (they name the interface).
  static std::unique_ptr<CanBusHost> open_socketcan(EventLoop& loop, const config::Config& config,
                                                    const config::Bus& bus,
                                                    const std::map<config::Family, CanDriveFactory>& factories,
                                                    Reporter reporter, std::error_code& error);
  // The drives of `bus`, each on the endpoint `endpoints` makes for it (no hub).
  static std::unique_ptr<CanBusHost> open_with(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                               const std::map<config::Family, CanDriveFactory>& factories,
                                               Reporter reporter, const EndpointFactory& endpoints,
                                               std::error_code& error);
  ~CanBusHost();
  CanBusHost(const CanBusHost&) = delete;
  CanBusHost& operator=(const CanBusHost&) = delete;

  [[nodiscard]] const std::string& name() const { return bus_.name; }
  [[nodiscard]] const std::vector<std::string>& missing() const { return missing_; }
  [[nodiscard]] std::size_t drive_count() const { return drives_.size(); }
  // The simulated wire: only for a host made by open() (has_hub()).
  [[nodiscard]] bool has_hub() const { return hub_ != nullptr; }
  [[nodiscard]] simbus::Hub& hub() { return *hub_; }
  [[nodiscard]] bool has_drive(const std::string& name) const { return drives_.contains(name); }
  // Applies a sim_control_t addressed to one of this bus's drives (or the bus). False when unknown
  // (BUS_DROP needs the simulated wire).
  bool control(const motionlcm::sim_control_t& control);

 private:
  struct Drive {
    const config::Drive* config = nullptr;
    std::unique_ptr<can::Transport> endpoint;
    std::unique_ptr<CanDriveSim> sim;
    EventLoop::TimerId timer = 0;
    Duration latency{};
    bool silent = false;
    bool corrupt = false;      // CRC_ERRORS: what it sends fails the CAN CRC (see control())
    bool send_failed = false;  // a send error was logged already
  };
  CanBusHost(EventLoop& loop, const config::Config& config, const config::Bus& bus, Reporter reporter);
  // Creates every drive of the bus with a factory, each on endpoints(drive).
  std::error_code attach_drives(const std::map<config::Family, CanDriveFactory>& factories,
                                const EndpointFactory& endpoints);
  void create(Drive& d, const CanDriveFactory& factory);
  void transmit(Drive& d, const can::Frame& frame);
  void on_readable(Drive& d);
  void reschedule(Drive& d);

  EventLoop& loop_;
  const config::Config& config_;
  config::Bus bus_;
  Reporter reporter_;
  std::unique_ptr<simbus::Hub> hub_;
  std::vector<simbus::FaultId> drops_;  // the BUS_DROP faults given (cleared by a BUS_DROP of 0)
  std::map<std::string, Drive> drives_;
  std::map<config::Family, CanDriveFactory> factories_;
  std::vector<std::string> missing_;
};

}  // namespace motion::sim
