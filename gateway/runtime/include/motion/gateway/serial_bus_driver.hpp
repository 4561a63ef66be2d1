// A serial line in the gateway (RS485 Modbus RTU, RS232 to a UIM2501/2502): the poll-loop shell
// shared by the serial families, around one passive protocol core (SerialStack: bytes and
// `now` in, bytes out through the Write it was built with, the next deadline out of process()):
//  * opens the bus's serial port (serial:<device>, or the simserial link motion-sim publishes),
//    non-blocking; while it cannot (motion-sim not up yet, adapter unplugged, no permission) it
//    retries every `reopen_period`, reports the bus state as "closed: <why>" in its statistics
//    (the gateway's heartbeat, `motionctl health`), e.g. "closed: cannot open /dev/ttyUSB0:
//    Permission denied", and raises one OFFLINE event per distinct cause;
//  * a parity the pty of a simulated line refuses is modelled, not set (serial_port.hpp);
//  * watches the port's fd and hands what it reads to the core with `now`; after EVERY call into
//    the core it calls process(now) and keeps ONE timer at the returned deadline: never a busy
//    wait, never a blocking call;
//  * on a hang-up/read error closes the port, tells the core (line_lost: it fails what was
//    running) and reopens; each (re)open starts the core again.
// A family's driver derives from it and builds its core in the constructor (AdamBusDriver,
// Uim242BusDriver); the gateway only sees a BusDriver.
// Thread contract: the loop's thread only.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "motion/core/event_loop.hpp"
#include "motion/gateway/bus_driver.hpp"
#include "motion/gateway/serial_stack.hpp"
#include "motion/serial/serial_port.hpp"

namespace motion::gateway {

class SerialBusDriver : public BusDriver {
 public:
  // How the core writes to the line: false when the port is closed or took less than the frame.
  using Write = std::function<bool(std::span<const std::uint8_t>)>;
  using CoreFactory = std::function<std::unique_ptr<SerialStack>(Write write)>;

  SerialBusDriver(EventLoop& loop, std::string bus, std::string device_path, serial::SerialSettings line,
                  GatewayOutput& out, const CoreFactory& make_core);
  ~SerialBusDriver() override;
  SerialBusDriver(const SerialBusDriver&) = delete;
  SerialBusDriver& operator=(const SerialBusDriver&) = delete;

  void start() final;
  void execute(const motionlcm::gateway_command_t& command) final;
  void fire(std::int64_t trigger_id) final;
  void prepare_fire(TimePoint at) final;
  [[nodiscard]] Duration start_wait() const final { return core_->start_wait(); }
  [[nodiscard]] Duration start_delay(std::int64_t trigger_id) const final { return core_->start_delay(trigger_id); }
  [[nodiscard]] std::vector<motionlcm::bus_stats_t> statistics() const final;
  [[nodiscard]] bool ready() const final;
  [[nodiscard]] LedgerCounters ledger_counters() const final { return core_->ledger_counters(); }

  [[nodiscard]] bool port_open() const { return port_ != nullptr; }
  [[nodiscard]] const std::string& device_path() const { return device_path_; }
  Duration reopen_period = std::chrono::milliseconds(500);

 private:
  void try_open();
  void close_port(const std::string& why);
  void on_readable();
  void pump();
  bool write(std::span<const std::uint8_t> bytes);

  EventLoop& loop_;
  std::string bus_;
  std::string device_path_;
  serial::SerialSettings line_;
  GatewayOutput& out_;
  std::unique_ptr<SerialStack> core_;
  std::unique_ptr<serial::SerialPort> port_;
  EventLoop::TimerId timer_ = 0;
  EventLoop::TimerId reopen_timer_ = 0;
  std::string last_open_error_;
  std::string closed_because_;  // why the port is not open ("" before the first attempt)
};

}  // namespace motion::gateway
