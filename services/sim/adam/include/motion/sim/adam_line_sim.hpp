// The simulated RS485 line of a `simserial:` bus of ADAM drives, as the device on motion-sim's
// SerialLineHost (serial_line_host.hpp: the pty <sim_runtime_dir>/<bus>.tty, its fd and timer):
// an ADAM Modbus RTU slave per adam-modbus drive of the bus (motion::adam::serve over an
// AdamDriveSim):
//  * request frames are delimited by t3.5 silence, or closed at once when their header gives the
//    length and the CRC checks; frames with a bad CRC are discarded (never answered);
//  * broadcasts (unit 0) are executed by every drive and answered by none (§5);
//  * bad registers/values get Modbus exceptions (0x02/0x03; not described in the manual's §6);
//  * replies go out after simulation.reply_latency_us (SIM_CONTROL REPLY_LATENCY per drive);
//  * SIM_REPORT MOTION_STARTED carries frame_utime = the end of the frame that started the motion
//    (its arrival on the pty), MOTION_FINISHED when the motion ends;
//  * SIM_CONTROL: ALARM, STALL, SILENCE, CRC_ERRORS, REPLY_LATENCY, SET_INPUT, POWER_CYCLE.
// Passive (bytes and `now` in, bytes and the next deadline out). Thread contract: one thread.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "motion/adam/slave.hpp"
#include "motion/config/config.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/serial/silence_framer.hpp"
#include "motion/sim/adam_drive_sim.hpp"
#include "motion/sim/serial_device_sim.hpp"
#include "motion/sim/serial_line_host.hpp"

namespace motion::sim {

class AdamLineSim final : public SerialDeviceSim {
 public:
  // The adam-modbus drives of `bus`.
  AdamLineSim(const config::Config& config, const config::Bus& bus, SerialDeviceContext context);

  void power_up(TimePoint now) override;
  TimePoint receive(std::span<const std::uint8_t> bytes, TimePoint now) override;
  TimePoint process(TimePoint now) override;
  bool control(const motionlcm::sim_control_t& control, TimePoint now) override;

  // Introspection for tests (0 for an unknown drive): position counts, Saves taken.
  [[nodiscard]] std::int64_t position(const std::string& drive, TimePoint now) const;
  [[nodiscard]] int saves(const std::string& drive) const;

 private:
  struct Drive {
    const config::Drive* config = nullptr;
    adam::SlaveConfig slave;
    AdamDriveSim sim;
    Duration latency{};
    bool silent = false;
    bool corrupt_replies = false;
    TimePoint finish_at = kNever;  // end of the motion a MOTION_FINISHED is due for
  };
  void serve_frame(const std::vector<std::uint8_t>& frame, TimePoint received);
  void report(const Drive& d, std::int8_t kind, std::int64_t frame_utime, TimePoint now) const;
  [[nodiscard]] TimePoint next_deadline() const;

  SerialDeviceContext context_;
  serial::SilenceFramer framer_;
  std::map<std::string, std::unique_ptr<Drive>> drives_;
};

// The factory motion-sim registers for adam-modbus lines.
[[nodiscard]] SerialDeviceFactory adam_line_factory();

// A SerialLineHost serving `bus` with its ADAM drives (tests, benchmarks); errors as SerialLineHost::open.
[[nodiscard]] std::unique_ptr<SerialLineHost> open_adam_line(EventLoop& loop, const config::Config& config,
                                                             const config::Bus& bus, SerialLineHost::Reporter reporter,
                                                             std::error_code& error);

}  // namespace motion::sim
