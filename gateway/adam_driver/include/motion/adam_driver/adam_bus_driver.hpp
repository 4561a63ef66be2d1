// AdamBusDriver: the gateway's BusDriver for an RS485 line of ADAM Modbus RTU steppers. A thin
// poll-loop shell around MasterCore (master_core.hpp, which holds every protocol decision):
//  * opens the bus's serial port (serial:<device>, or the simserial link motion-sim publishes),
//    non-blocking; while it cannot (motion-sim not up yet, adapter unplugged) it retries every
//    `reopen_period` and reports the bus "closed";
//  * watches the port's fd, hands the bytes to the core with `now`, keeps ONE timer at the core's
//    next deadline (timeouts, t3.5 silence, polls): never a busy wait, never a blocking call;
//  * on a hang-up/read error closes the port, fails what was running (via the core) and reopens.
//
// Construction from the configuration (what gateway/app/bus_assembly.cpp does for a serial bus
// whose drives are adam-modbus):
//   AdamBusDriver::create(loop, config, bus, out)
//
// Thread contract: the loop's thread only.
#pragma once

#include <memory>
#include <string>

#include "motion/adam_driver/master_core.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/gateway/bus_driver.hpp"
#include "motion/serial/serial_port.hpp"

namespace motion::adam_driver {

class AdamBusDriver final : public gateway::BusDriver {
 public:
  AdamBusDriver(EventLoop& loop, MasterSettings settings, std::string device_path, serial::SerialSettings line,
                gateway::GatewayOutput& out);
  static std::unique_ptr<AdamBusDriver> create(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                               gateway::GatewayOutput& out);
  ~AdamBusDriver() override;

  void start() override;
  void execute(const motionlcm::gateway_command_t& command) override;
  void fire(std::int64_t trigger_id) override;
  [[nodiscard]] std::vector<motionlcm::bus_stats_t> statistics() const override;
  [[nodiscard]] bool ready() const override;

  [[nodiscard]] bool port_open() const { return port_ != nullptr; }
  Duration reopen_period = std::chrono::milliseconds(500);

 private:
  void try_open();
  void close_port(const std::string& why);
  void on_readable();
  void pump();

  EventLoop& loop_;
  std::string device_path_;
  serial::SerialSettings line_;
  gateway::GatewayOutput& out_;
  MasterCore core_;
  std::unique_ptr<serial::SerialPort> port_;
  EventLoop::TimerId timer_ = 0;
  EventLoop::TimerId reopen_timer_ = 0;
  std::string last_open_error_;
};

}  // namespace motion::adam_driver
