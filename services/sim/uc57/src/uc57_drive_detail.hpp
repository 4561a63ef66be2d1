// Private to the simulated UC57's sources (uc57_drive.cpp: CiA 301 objects, PDOs, SYNC;
// uc57_drive_cia402.cpp: CiA 402 device control, motion, status): what both use. Not installed.
#pragma once

#include <array>
#include <cstdint>

#include "motion/cia402/state_machine.hpp"

namespace motion::sim::uc57_detail {

using cia402::State;

// EMCY contents of the UC57 alarms Err1..Err6 (CiA 301 §7.2.7 codes, assumed: the manual gives none).
struct AlarmEmcy {
  std::uint16_t code;
  std::uint8_t error_register;
  bool needs_power_cycle;  // "Lock / power-off reset" (§5.1)
};
constexpr std::array<AlarmEmcy, 6> kAlarms = {{
    {0x2310, 0x03, true},   // Err1 overcurrent
    {0x3210, 0x05, false},  // Err2 overvoltage (auto reset)
    {0x5000, 0x81, true},   // Err3 hardware
    {0xFF04, 0x01, true},   // Err4 phase loss
    {0x5530, 0x81, true},   // Err5 EEPROM
    {0x3220, 0x05, false},  // Err6 undervoltage (auto reset)
}};
// A stall has no UC57 alarm code; CiA 402 following error is the closest standard code.
constexpr std::uint16_t kStallEmcyCode = 0x8611;
constexpr std::uint8_t kStallErrorRegister = 0x21;     // generic + device profile
constexpr std::uint16_t kPdoLengthErrorCode = 0x8210;  // PDO not processed: length error

inline bool motor_energised(State state) {
  return state == State::kSwitchedOn || state == State::kOperationEnabled || state == State::kQuickStopActive ||
         state == State::kFaultReactionActive;
}

constexpr double kStepAcceleration = 1e12;  // a ramp setting that means "no ramp"

}  // namespace motion::sim::uc57_detail
