// What the simulated far end of a `simserial:` line (the ADAM RS485 slaves, a UIM2501 gateway with
// its UIM242 controllers, ...) implements to live in motion-sim's SerialLineHost.
//
// Passive core: the bytes the gateway wrote and `now` in, bytes out through the context's `send`
// (with the delay after which they go on the line: the simulated reply latency), the next
// deadline out. The host owns the pty, its fd and the one timer.
// Thread contract: the host's loop thread only.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include <motionlcm/sim_control_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"

namespace motion::sim {

struct SerialDeviceContext {
  std::string bus;
  // Bytes onto the line `delay` after now (in order of their due time, then of the calls).
  std::function<void(std::span<const std::uint8_t> bytes, Duration delay)> send;
  // Ground truth (SIM_REPORT; kind from sim_report_t, frame_utime = the triggering frame's time).
  std::function<void(const std::string& drive, std::int8_t kind, std::int64_t frame_utime, std::int64_t position,
                     std::int64_t target)>
      report;
  // Wall-clock utime of a loop time point (the frame_utime of reports); one value per time point.
  std::function<std::int64_t(TimePoint)> utime_of;
};

class SerialDeviceSim {
 public:
  virtual ~SerialDeviceSim() = default;
  // Once, when the line exists (POWERED_UP reports, greetings).
  virtual void power_up(TimePoint now) = 0;
  // Bytes from the gateway, in any pieces; `now` = their arrival. Returns the next deadline.
  virtual TimePoint receive(std::span<const std::uint8_t> bytes, TimePoint now) = 0;
  // Advances to `now` (frames closed by silence, arrivals, notifications); the next deadline or kNever.
  virtual TimePoint process(TimePoint now) = 0;
  // Fault injection for one of the device's drives (one line serves them all, so SILENCE,
  // POWER_CYCLE and REPLY_LATENCY are the device's too). False when not its drive or unsupported.
  virtual bool control(const motionlcm::sim_control_t& control, TimePoint now) = 0;
  // Whether the line has wires of its own for each direction (RS232): the gateway's bytes then
  // never wait on the line for the device's, nor the device's for the gateway's. Default: one pair
  // for both (RS485, half duplex), each direction waiting for the line.
  [[nodiscard]] virtual bool full_duplex() const { return false; }
};

// The device of one family serving `bus` (its drives of that family in the configuration).
using SerialDeviceFactory = std::function<std::unique_ptr<SerialDeviceSim>(
    const config::Config& config, const config::Bus& bus, SerialDeviceContext context)>;

}  // namespace motion::sim
