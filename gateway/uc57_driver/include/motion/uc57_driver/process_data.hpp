// The UC57's process data as this driver uses it: the RPDO that carries the controlword to the
// drive (applied at SYNC) and the TPDOs that report statusword, inputs and position.
//
// RPDO1 has two layouts (CiA 301 §7.2.2, §7.5.2.35-38; the manual's §5 comm. table):
//  - kControlwordTarget (preferred, CiA 301 remap): 6040h + 607Ah, 48 bits, transmission type 1.
//    Target and new-set-point bit arrive in one frame and are applied atomically at the SYNC
//    (type 255, on reception, where the drive refuses type 1: Uc57Stack then starts node by node).
//    Profile velocity (6081h) does not fit as well (16 + 32 + 32 = 80 bits > 64): it goes by SDO.
//  - kManualDefault (fallback): the manual's default 1600h mapping 6040h + 60FFh + 6060h, type 1,
//    used when the drive refuses the remap (the manual prints 1400h:01 and 1600h:00 as RO, C-10).
//    607Ah is then written by SDO while arming; every frame repeats 60FFh and 6060h, so the image
//    must always hold the mode in use (a 0 would switch the drive to "undefined").
// TPDOs are never remapped (manual defaults, §5 comm. table): TPDO1 = 6041h + 60FDh + 6061h,
// TPDO2 = 6064h + 606Ch (1A01h:00 printed 0, conflict C-09: read at start-up).
//
// Pure codecs. Thread contract: values and pure functions only.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/pdo.hpp"
#include "motion/canopen/pdo_config.hpp"
#include "motion/canopen/types.hpp"

namespace motion::uc57_driver {

enum class RpdoLayout : std::uint8_t { kControlwordTarget, kManualDefault };

// What the master wants the drive's RPDO-mapped objects to hold.
struct RpdoImage {
  std::uint16_t controlword = 0;
  std::int32_t target_position = 0;  // 607Ah, kControlwordTarget only
  std::int32_t target_velocity = 0;  // 60FFh RPM, kManualDefault only
  std::int8_t mode = 0;              // 6060h, kManualDefault only
  friend bool operator==(const RpdoImage&, const RpdoImage&) = default;
};

[[nodiscard]] canopen::PdoMapping rpdo1_mapping(RpdoLayout layout);
// The CiA 301 remap of RPDO1 to kControlwordTarget, synchronous (type 1) unless another
// transmission type is given (255 where the drive refuses type 1).
[[nodiscard]] canopen::PdoConfiguration rpdo1_remap(canopen::NodeId node, std::uint8_t transmission_type = 1);
[[nodiscard]] can::Frame encode_rpdo1(canopen::NodeId node, RpdoLayout layout, const RpdoImage& image);
[[nodiscard]] std::optional<RpdoImage> decode_rpdo1(RpdoLayout layout, std::span<const std::uint8_t> payload);

struct Tpdo1 {
  std::uint16_t statusword = 0;
  std::uint32_t digital_inputs = 0;  // 60FDh: bit 0 negative limit, bit 1 positive limit, bit 2 origin
  std::int8_t mode_display = 0;
};
struct Tpdo2 {
  std::int32_t position = 0;      // 6064h pulses
  std::int32_t velocity_rpm = 0;  // 606Ch
};
[[nodiscard]] canopen::PdoMapping tpdo1_mapping();
[[nodiscard]] canopen::PdoMapping tpdo2_mapping();
[[nodiscard]] std::optional<Tpdo1> decode_tpdo1(std::span<const std::uint8_t> payload);
[[nodiscard]] std::optional<Tpdo2> decode_tpdo2(std::span<const std::uint8_t> payload);
[[nodiscard]] can::Frame encode_tpdo1(canopen::NodeId node, const Tpdo1& value);
[[nodiscard]] can::Frame encode_tpdo2(canopen::NodeId node, const Tpdo2& value);

// DriveStatus.inputs numbering (bit n = input n+1) from 60FDh, with the manual's default input
// assignment (§3.1): IN1 = positive limit, IN2 = origin, IN3 = negative limit.
[[nodiscard]] std::int32_t inputs_from_60fd(std::uint32_t digital_inputs);

}  // namespace motion::uc57_driver
