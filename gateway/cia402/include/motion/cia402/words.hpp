// Bits of the CiA 402 controlword (6040h) and statusword (6041h), with the ADAMPOWER UC57's own
// meanings of the manufacturer-specific statusword bits.
//
// Sources: CiA 402 (device control bits), UC57 manual §4.2.1 (bits 0-3, 5, 6, 7 of both words),
// §4.2.2 (UC57 statusword bits 7, 8, 11, 13, 14, 15), §4.2.4-§4.2.6 (mode-specific bits 4, 5, 6, 8,
// 10, 12). Statusword bits 4 and 9 are not documented by the manual and keep their CiA names.
// The conflicting meanings of statusword bits 8/12/13 for homing are resolved in uc57_units.hpp
// ("Conflicts") and implemented by uc57_homing.hpp.
//
// Thread contract: constants and pure constexpr functions only; thread-safe.
#pragma once

#include <cstdint>

namespace motion::cia402 {

// Controlword 6040h, one enumerator per bit (the enumerator's value is the bit's mask).
enum class ControlBit : std::uint16_t {
  kSwitchOn = 1U << 0,
  kEnableVoltage = 1U << 1,
  kQuickStop = 1U << 2,  // 0 = quick stop requested
  kEnableOperation = 1U << 3,
  kNewSetPoint = 1U << 4,           // PP: new set-point (rising edge); HM: homing operation start
  kChangeSetImmediately = 1U << 5,  // PP only
  kRelative = 1U << 6,              // PP only: 0 = absolute target, 1 = relative target
  kFaultReset = 1U << 7,            // acts on the 0 -> 1 edge
  kHalt = 1U << 8,                  // PP/PV/HM: decelerate to standstill
};

// Statusword 6041h, one enumerator per bit. Where the UC57 meaning differs from CiA 402, the UC57
// meaning names the bit and the CiA meaning is given in the comment.
enum class StatusBit : std::uint16_t {
  kReadyToSwitchOn = 1U << 0,
  kSwitchedOn = 1U << 1,
  kOperationEnabled = 1U << 2,
  kFault = 1U << 3,
  kVoltageEnabled = 1U << 4,  // CiA 402; not documented for the UC57
  kQuickStop = 1U << 5,       // 0 = quick stop active
  kSwitchOnDisabled = 1U << 6,
  kAlarm = 1U << 7,       // UC57 §4.2.2: driver alarm (CiA: warning)
  kHomingDone = 1U << 8,  // UC57 §4.2.2/§4.2.6: homing completed (CiA: manufacturer-specific)
  kRemote = 1U << 9,      // CiA 402; not documented for the UC57
  kTargetReached = 1U << 10,
  kNewSetPointEcho = 1U << 11,      // UC57 §4.2.2: copy of controlword bit 4 (CiA: internal limit active)
  kSetPointAcknowledge = 1U << 12,  // PP: set-point acknowledge; PV: speed is 0; HM: homing attained (§7)
  kMotorEnabled = 1U << 13,         // UC57 §4.2.2: motor energised (CiA: following error / homing error)
  kMotorRunning = 1U << 14,         // UC57 §4.2.2 (CiA: manufacturer-specific)
  kInPosition = 1U << 15,           // UC57 §4.2.2/§4.2.4 "Pend" (CiA: manufacturer-specific)
};

// PV reading of bit 12 (UC57 §4.2.5) and the appendix's homing reading (§7 MC_HOME).
inline constexpr StatusBit kSpeedIsZero = StatusBit::kSetPointAcknowledge;
inline constexpr StatusBit kHomingAttained = StatusBit::kSetPointAcknowledge;

[[nodiscard]] constexpr std::uint16_t mask(ControlBit bit) { return static_cast<std::uint16_t>(bit); }
[[nodiscard]] constexpr std::uint16_t mask(StatusBit bit) { return static_cast<std::uint16_t>(bit); }

[[nodiscard]] constexpr bool is_set(std::uint16_t statusword, StatusBit bit) { return (statusword & mask(bit)) != 0; }
[[nodiscard]] constexpr bool is_set(std::uint16_t controlword, ControlBit bit) {
  return (controlword & mask(bit)) != 0;
}

[[nodiscard]] constexpr std::uint16_t with(std::uint16_t word, ControlBit bit, bool value) {
  return static_cast<std::uint16_t>(value ? (word | mask(bit)) : (word & ~mask(bit)));
}

// True when `bit` went from 0 in `previous` to 1 in `current` (fault reset, new set-point, homing
// start): the drive side of every edge-triggered controlword bit.
[[nodiscard]] constexpr bool rising_edge(std::uint16_t previous, std::uint16_t current, ControlBit bit) {
  return !is_set(previous, bit) && is_set(current, bit);
}

}  // namespace motion::cia402
