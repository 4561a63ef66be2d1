// What a simulated CAN drive (UIM342, UC57, ...) implements to live in motion-sim.
//
// Passive core: frames and `now` in, frames out through the context's `send`, next deadline out.
// The host owns sockets, timers, reply latency, silence and power cycles.
// Thread contract: the host's loop thread only.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include <motionlcm/sim_control_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "motion/can_frame/frame.hpp"
#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"

namespace motion::sim {

struct SimDriveContext {
  std::string drive;  // drive name from the configuration
  std::string bus;
  // Transmits a frame (the host adds the configured reply latency).
  std::function<void(const can::Frame&)> send;
  // Ground-truth report (kind from sim_report_t); frame_utime = the triggering frame's timestamp.
  std::function<void(std::int8_t kind, std::int64_t frame_utime, std::int64_t position, std::int64_t target)> report;
};

class CanDriveSim {
 public:
  virtual ~CanDriveSim() = default;
  // Called once after construction (power-up: e.g. a CANopen boot-up message).
  virtual void power_up(TimePoint now) = 0;
  // Every frame another node put on the bus; `frame.timestamp_us` is its end-of-frame time.
  virtual void on_frame(const can::Frame& frame, TimePoint now) = 0;
  // Advances to `now` (notifications, motion end); returns the next deadline or kNever.
  virtual TimePoint process(TimePoint now) = 0;
  // Family-specific fault injection (STALL, ALARM, SET_INPUT, ...). SILENCE, POWER_CYCLE and
  // REPLY_LATENCY are handled by the host. Returns false when the action is not supported.
  virtual bool control(const motionlcm::sim_control_t& control, TimePoint now) = 0;
};

using CanDriveFactory =
    std::function<std::unique_ptr<CanDriveSim>(const config::Drive& drive, SimDriveContext context)>;

}  // namespace motion::sim
