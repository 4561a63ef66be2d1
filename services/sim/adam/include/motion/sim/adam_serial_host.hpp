// The simulated RS485 line of a `simserial:` bus in motion-sim: a pty pair whose slave path is
// published as <sim_runtime_dir>/<bus>.tty (motion::serial::PtyLink), and an ADAM Modbus RTU
// slave per adam-modbus drive of the bus (motion::adam::serve over an AdamDriveSim):
//  * request frames are delimited by t3.5 silence, or closed at once when their header gives the
//    length and the CRC checks; frames with a bad CRC are discarded (never answered);
//  * broadcasts (unit 0) are executed by every drive and answered by none (§5);
//  * bad registers/values get Modbus exceptions (0x02/0x03, spec 1.3);
//  * replies go out after simulation.reply_latency_us (SIM_CONTROL REPLY_LATENCY per drive);
//  * SIM_REPORT MOTION_STARTED carries frame_utime = the end of the frame that started the motion
//    (its arrival on the pty), MOTION_FINISHED when the motion ends;
//  * SIM_CONTROL: ALARM, STALL, SILENCE, CRC_ERRORS, REPLY_LATENCY, SET_INPUT, POWER_CYCLE.
// Thread contract: the loop's thread only.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include <motionlcm/sim_control_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "motion/adam/slave.hpp"
#include "motion/config/config.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/serial/pty_link.hpp"
#include "motion/serial/silence_framer.hpp"
#include "motion/sim/adam_drive_sim.hpp"

namespace motion::sim {

class AdamSerialHost {
 public:
  using Reporter = std::function<void(motionlcm::sim_report_t)>;

  // True when `bus` carries adam-modbus drives (then this host serves it).
  [[nodiscard]] static bool serves(const config::Config& config, const config::Bus& bus);
  // Drives of the bus whose family is not adam-modbus are listed in missing().
  static std::unique_ptr<AdamSerialHost> open(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                              Reporter reporter, std::error_code& error);
  ~AdamSerialHost();

  [[nodiscard]] const std::string& name() const { return bus_.name; }
  [[nodiscard]] const std::string& link_path() const { return link_->link_path(); }
  [[nodiscard]] const std::vector<std::string>& missing() const { return missing_; }
  [[nodiscard]] std::size_t drive_count() const { return drives_.size(); }
  // Applies a sim_control_t for one of this bus's drives (or the bus). False when not ours.
  bool control(const motionlcm::sim_control_t& control);

 private:
  struct Drive {
    const config::Drive* config = nullptr;
    adam::SlaveConfig slave;
    AdamDriveSim sim;
    Duration latency{};
    bool silent = false;
    bool corrupt_replies = false;
    EventLoop::TimerId finish_timer = 0;
  };
  AdamSerialHost(EventLoop& loop, const config::Config& config, const config::Bus& bus, Reporter reporter);
  void on_readable();
  void on_silence();
  void serve_frame(const std::vector<std::uint8_t>& frame, TimePoint received);
  void watch_motion(Drive& d);
  void report(const Drive& d, std::int8_t kind, std::int64_t frame_utime, TimePoint now) const;

  EventLoop& loop_;
  config::Bus bus_;
  Reporter reporter_;
  std::unique_ptr<serial::PtyLink> link_;
  serial::SilenceFramer framer_;
  EventLoop::TimerId silence_timer_ = 0;
  std::map<std::string, std::unique_ptr<Drive>> drives_;
  std::vector<std::string> missing_;
};

}  // namespace motion::sim
