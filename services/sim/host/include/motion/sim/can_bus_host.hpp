// One simulated CAN bus in motion-sim: the simbus Hub (the wire, bit-timed) plus every simulated
// drive of the configuration on that bus, each on its own local endpoint (so arbitration and bus
// load include the drives' replies).
// Thread contract: the loop's thread only.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/sim/can_drive.hpp"
#include "motion/simbus/hub.hpp"

namespace motion::sim {

class CanBusHost {
 public:
  using Reporter = std::function<void(motionlcm::sim_report_t)>;

  // Opens the hub for `bus` (socket in `socket_dir`) and creates the drives with `factories`
  // (by family). Drives of a family without a factory are listed in missing().
  static std::unique_ptr<CanBusHost> open(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                          const std::map<config::Family, CanDriveFactory>& factories, Reporter reporter,
                                          std::error_code& error);
  ~CanBusHost();

  [[nodiscard]] const std::string& name() const { return bus_.name; }
  [[nodiscard]] const std::vector<std::string>& missing() const { return missing_; }
  [[nodiscard]] simbus::Hub& hub() { return *hub_; }
  [[nodiscard]] bool has_drive(const std::string& name) const { return drives_.contains(name); }
  // Applies a sim_control_t addressed to one of this bus's drives (or the bus). False when unknown.
  bool control(const motionlcm::sim_control_t& control);

 private:
  struct Drive {
    const config::Drive* config = nullptr;
    std::unique_ptr<simbus::LocalEndpoint> endpoint;
    std::unique_ptr<CanDriveSim> sim;
    EventLoop::TimerId timer = 0;
    Duration latency{};
    bool silent = false;
  };
  CanBusHost(EventLoop& loop, const config::Config& config, const config::Bus& bus, Reporter reporter);
  void create(Drive& d, const CanDriveFactory& factory);
  void on_readable(Drive& d);
  void reschedule(Drive& d);

  EventLoop& loop_;
  const config::Config& config_;
  config::Bus bus_;
  Reporter reporter_;
  std::unique_ptr<simbus::Hub> hub_;
  std::map<std::string, Drive> drives_;
  std::map<config::Family, CanDriveFactory> factories_;
  std::vector<std::string> missing_;
};

}  // namespace motion::sim
