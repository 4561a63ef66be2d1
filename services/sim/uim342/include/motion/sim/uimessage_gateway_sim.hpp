// A simulated UIROBOT UIM2513 (RS232-CAN) / UIM2533 (USB-CAN) serial gateway with the UIM342 drives
// of its CAN bus behind it: the far end of a `uimessage:` bus in motion-sim
// (`motion-sim --simulate-uimessage`), a SerialDeviceSim on a SerialLineHost pty.
//
// From the host: 16-byte UIMessages (UIM342 manual §2.6, Appendix-1), resynchronized on SM..EM
// (uim342::UiMessageStream). The CRC is checked over the coverage of the bus's simulation variant
// `crc_bytes` (13: SM..d8, the manual's text, the default; 12: ID..d8, UIROBOT's software); a frame
// whose CRC is wrong is dropped without an answer, as a real gateway would. A good one becomes
// the host's SimpleCAN frame (producer 4, consumer = the UIMessage ID) and reaches every drive at
// once (the CAN hop, ~0.13 ms at 1 Mbit/s, is small against the 1.4 ms a UIMessage takes on the
// serial line at 115200 baud and is not modelled). What the drives send goes back as UIMessages
// with the CRC over the same coverage, `simulation.reply_latency_us` after the drive sent it.
//
// Passive core: bytes and `now` in, bytes out through the context. Thread contract: the host
// loop's thread only.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/sim/can_drive.hpp"
#include "motion/sim/serial_device_sim.hpp"
#include "motion/uim342/uimessage.hpp"
#include "motion/uim342/uimessage_stream.hpp"

namespace motion::sim {

class UiMessageGatewaySim final : public SerialDeviceSim {
 public:
  // The UIM342 drives of `bus` from `drives` (the family's CanDriveFactory); CRC over `crc`.
  UiMessageGatewaySim(const config::Config& config, const config::Bus& bus, SerialDeviceContext context,
                      const CanDriveFactory& drives, uim342::CrcCoverage crc);

  void power_up(TimePoint now) override;
  TimePoint receive(std::span<const std::uint8_t> bytes, TimePoint now) override;
  TimePoint process(TimePoint now) override;
  bool control(const motionlcm::sim_control_t& control, TimePoint now) override;

  [[nodiscard]] uim342::CrcCoverage crc() const { return crc_; }
  // Frames from the host dropped for a wrong CRC (the stream's crc_errors).
  [[nodiscard]] std::uint64_t dropped_for_crc() const { return from_host_.counters().crc_errors; }
  [[nodiscard]] std::uint64_t instructions_passed() const { return passed_; }

 private:
  struct Drive {
    std::string name;
    std::unique_ptr<CanDriveSim> sim;
  };
  void to_host(const can::Frame& frame);

  SerialDeviceContext context_;
  uim342::CrcCoverage crc_;
  Duration reply_latency_;
  uim342::UiMessageStream from_host_;
  std::vector<Drive> drives_;
  std::uint64_t passed_ = 0;
};

// The coverage of `bus`'s simulation variant crc_bytes (12: ID..d8, else SM..d8).
[[nodiscard]] uim342::CrcCoverage uimessage_sim_crc(const config::Config& config, const config::Bus& bus);
// The device of a simulated uimessage: bus: a UiMessageGatewaySim with the bus's UIM342 drives
// (uim342_factory) and its crc_bytes.
[[nodiscard]] SerialDeviceFactory uimessage_gateway_factory(const config::Config& config);

}  // namespace motion::sim
